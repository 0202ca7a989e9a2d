/* fuzz_files.h: one temporary directory per fuzzing process. */
#define _XOPEN_SOURCE 700 /* mkdtemp, nftw */
#include "fuzz_files.h"

#include <ftw.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static char dir[512];

static int remove_entry(const char* path, const struct stat* st, int type, struct FTW* ftw) {
  (void)st, (void)type, (void)ftw;
  return remove(path);
}

static void remove_dir(void) {
  if (dir[0]) nftw(dir, remove_entry, 16, FTW_DEPTH | FTW_PHYS);
}

const char* fuzz_temp_dir(void) {
  if (dir[0]) return dir;
  /* /dev/shm (memory) when there is one: on ext4, a file truncated and written again is flushed
   * to the disk at its close (auto_da_alloc), which made a run 13 times slower */
  const char* base = getenv("TMPDIR");
  if (access("/dev/shm", W_OK | X_OK) == 0) base = "/dev/shm";
  snprintf(dir, sizeof dir, "%s/gearmesh-fuzz-XXXXXX", base && base[0] ? base : "/tmp");
  if (!mkdtemp(dir)) {
    perror("fuzz_temp_dir: mkdtemp");
    abort();
  }
  strcat(dir, "/");
  atexit(remove_dir);
  return dir;
}

const char* fuzz_temp_path(const char* name) {
  static char path[1024];
  snprintf(path, sizeof path, "%s%s", fuzz_temp_dir(), name);
  return path;
}

void fuzz_write_file(const char* path, const void* data, size_t n) {
  FILE* f = fopen(path, "wb");
  if (!f || fwrite(data, 1, n, f) != n || fclose(f) != 0) {
    perror(path);
    abort();
  }
}
