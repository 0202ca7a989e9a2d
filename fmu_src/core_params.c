/* The core's parameters from an FMU's (core_params.h): shared by the pair FMU (model_gearmesh.c)
 * and the train FMU (model_train.c). */
#include "core_params.h"

#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static const char* file_kind(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO (named pipe)";
#ifdef S_ISSOCK /* not on Windows */
  if (S_ISSOCK(mode)) return "a socket";
#endif
  if (S_ISCHR(mode) || S_ISBLK(mode)) return "a device";
  return "not a regular file";
}

/* 1 if a '/'-separated component of path is "..". */
static int has_parent_component(const char* path) {
  for (const char* s = path;; s++) {
    if (s[0] == '.' && s[1] == '.' && (s[2] == '/' || s[2] == '\0')) return 1;
    if (!(s = strchr(s, '/'))) return 0;
  }
}

/* The absolute path of a String parameter that names a file inside resources/ (its value
 * `name`) in *path (NULL for ""), or nonzero with msg naming the parameter if the name would
 * leave resources/ or there is no resources directory. */
/* Nonzero with msg naming the parameter if the file name `name` would leave resources/. */
static int name_refused(const char* parameter, const char* name, char* msg, size_t n) {
  const char* why = NULL;
  if (name[0] == '/') why = "is an absolute path";
  else if (strchr(name, '\\')) why = "contains a backslash";
  else if (has_parent_component(name)) why = "has a \"..\" component";
  if (why)
    snprintf(msg, n,
             "%s = \"%s\" %s; allowed: the name of a file inside the FMU's resources/ folder "
             "(relative, '/' separators, no \"..\")",
             parameter, name, why);
  return why != NULL;
}

static int resolve_resource(const char* resources, const char* parameter, const char* name, char** path, char* msg,
                            size_t n) {
  *path = NULL;
  if (!name || !name[0]) return 0;
  if (name_refused(parameter, name, msg, n)) return 1;
  if (!resources) {
    snprintf(msg, n,
             "%s = \"%s\" names a file in resources/, but the FMU was instantiated without a local "
             "resource location (fmuResourceLocation NULL or not a file URI); set it to \"\" or give the location",
             parameter, name);
    return 1;
  }
  size_t dir = strlen(resources), size = strlen(name) + 1;
  if (!(*path = malloc(dir + size))) return snprintf(msg, n, "out of memory"), 1;
  memcpy(*path, resources, dir);
  memcpy(*path + dir, name, size);
  /* Only regular files: opening a FIFO would block until a writer comes (forever), a device or
   * a directory is no table. A name that does not exist is left to the core's message. */
  struct stat st;
  if (stat(*path, &st) == 0 && !S_ISREG(st.st_mode)) {
    snprintf(msg, n,
             "%s = \"%s\" is %s (%s); allowed: the name of a regular file inside the FMU's resources/ folder",
             parameter, name, file_kind(st.st_mode), *path);
    free(*path);
    *path = NULL;
    return 1;
  }
  return 0;
}

/* The String parameters that name a file inside resources/ (GM_PARAM_FILE rows): FMU name and the
 * field of the core's parameters that gets the file's path. */
#define RESOURCE_ROW(_, name, kind, type, where, field, unit, dunit, lo, hi, bounds, levels, modes, group, flags, \
                     desc)                                                                                    \
  RESOURCE_ROW_##where(name, field, flags)
#define RESOURCE_ROW_MODEL(name, field, flags) \
  {((flags) & GM_PARAM_FILE) ? name : NULL, offsetof(gm_model_params, field)},
#define RESOURCE_ROW_DYNAMICS(name, field, flags)
#define RESOURCE_ROW_HOST(name, field, flags)
static const struct {
  const char* name; /* NULL: not a file */
  size_t offset;
} parameter_rows[] = {GM_PARAMETERS(RESOURCE_ROW, _)};

/* The core's parameters for the FMU's p: the FMU has one micro-geometry per gear (bound to
 * flank A), which flank B gets too; each String parameter naming a file inside resources/
 * becomes an absolute path in paths[k] (the caller frees them). */
int core_params(const char* resources, const gm_model_params* p, gm_model_params* q,
                char* paths[CORE_PARAMS_FILES], char* msg, size_t n) {
  *q = *p;
  for (int k = 0; k < CORE_PARAMS_FILES; k++) paths[k] = NULL;
  for (int i = 0; i < 2; i++) q->gear[i].flank[1] = q->gear[i].flank[0];
  int k = 0;
  for (size_t r = 0; r < sizeof parameter_rows / sizeof parameter_rows[0]; r++) {
    if (!parameter_rows[r].name) continue;
    const char** field = (const char**)((char*)q + parameter_rows[r].offset);
    if (resolve_resource(resources, parameter_rows[r].name, *field, &paths[k], msg, n)) return 1;
    *field = paths[k++];
  }
  return 0;
}


int core_params_unresolved(const gm_model_params* p, gm_model_params* q, char* msg, size_t n) {
  *q = *p;
  for (int i = 0; i < 2; i++) q->gear[i].flank[1] = q->gear[i].flank[0];
  for (size_t r = 0; r < sizeof parameter_rows / sizeof parameter_rows[0]; r++) {
    if (!parameter_rows[r].name) continue;
    const char* name = *(const char**)((const char*)q + parameter_rows[r].offset);
    if (name && name[0] && name_refused(parameter_rows[r].name, name, msg, n)) return 1;
  }
  return 0;
}
