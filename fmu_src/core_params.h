/* The core's parameters for an FMU's gm_model_params (core_params.c): the FMU has one
 * micro-geometry per gear (bound to flank A), which flank B gets too; each String parameter that
 * names a file inside resources/ (deviations, tables, compliance databases) becomes an absolute
 * path, checked to stay inside resources/ and to be a regular file. */
#ifndef GEARMESH_FMU_CORE_PARAMS_H
#define GEARMESH_FMU_CORE_PARAMS_H

#include <stddef.h>

#include "gearmesh/parameters.h"

/* How many String parameters name a file (GM_PARAM_FILE rows of gearmesh/parameters.h). */
#define CORE_PARAMS_FILE_ROW(_, name, kind, type, where, field, unit, dunit, lo, hi, bounds, levels, modes, group, \
                             flags, desc)                                                                         \
  +(((flags) & GM_PARAM_FILE) != 0)
enum { CORE_PARAMS_FILES = 0 GM_PARAMETERS(CORE_PARAMS_FILE_ROW, _) };

/* q = p with flank B's micro-geometry from flank A and file names resolved against resources
 * (ending in '/', or NULL: then any file name is an error); paths[k] hold the absolute paths (the
 * caller frees them, also on error). Nonzero with msg naming the parameter on error. */
int core_params(const char* resources, const gm_model_params* p, gm_model_params* q,
                char* paths[CORE_PARAMS_FILES], char* msg, size_t n);

/* q = p with flank B's micro-geometry from flank A and the file names checked as names (as
 * core_params does) but kept as given: for a check that reads no file (gm_model_check). */
int core_params_unresolved(const gm_model_params* p, gm_model_params* q, char* msg, size_t n);

#endif /* GEARMESH_FMU_CORE_PARAMS_H */
