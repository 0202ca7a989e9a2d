/* Files for the fuzz targets whose API reads paths (resource files, compliance databases): one
 * temporary directory per process, removed at exit. C and C++. */
#ifndef GEARMESH_FUZZ_FILES_H
#define GEARMESH_FUZZ_FILES_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The process's directory (made on the first call under /dev/shm, $TMPDIR or /tmp; ends in '/'). */
const char* fuzz_temp_dir(void);
/* fuzz_temp_dir() + name in a static buffer (valid until the next call). */
const char* fuzz_temp_path(const char* name);
/* Write n bytes to path, replacing the file; aborts if that fails (the harness is broken). */
void fuzz_write_file(const char* path, const void* data, size_t n);

#ifdef __cplusplus
}
#endif

#endif /* GEARMESH_FUZZ_FILES_H */
