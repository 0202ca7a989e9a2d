/* A minimal FMI 2.0 co-simulation importer for the platform tests (docs/platforms.md): loads a
 * GearMesh binary (LoadLibrary on Windows, dlopen elsewhere) and runs a call script, printing
 * every value it reads with 17 significant digits, so that two platforms' runs of one script can
 * be compared number by number. Cross-compiled for win64 and run under wine by
 * tests/python/test_platforms.py, which writes the scripts.
 *
 * Usage: run_calls <library> <script>
 * Script: one call per line, tokens separated by spaces; '#' starts a comment line.
 *   instantiate <guid> <resource location URI, or - for none>
 *   setup <start time>
 *   init                               enter and exit Initialization Mode
 *   real <vr> <value>                  fmi2SetReal of one variable
 *   integer <vr> <value>               fmi2SetInteger
 *   step <h>                           fmi2DoStep from the current time
 *   get r<vr>|i<vr>...                 fmi2GetReal (r) or fmi2GetInteger (i) of each; prints
 *                                      "get <values>"
 *   terminate
 * Exit status 0 when every call returned fmi2OK, else 1 with the failing line on stderr. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

#ifdef _WIN32
#include <windows.h>
#define LOAD(path) ((void*)LoadLibraryA(path))
#define SYMBOL(lib, name) ((void*)GetProcAddress((HMODULE)(lib), name))
#else
#include <dlfcn.h>
#define LOAD(path) dlopen(path, RTLD_NOW | RTLD_LOCAL)
#define SYMBOL(lib, name) dlsym(lib, name)
#endif

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
  (void)env;
  va_list args;
  va_start(args, message);
  fprintf(stderr, "[%s] %s (status %d): ", category, instance, (int)status);
  vfprintf(stderr, message, args);
  fputc('\n', stderr);
  va_end(args);
}

static void* need(void* lib, const char* name) {
  void* f = SYMBOL(lib, name);
  if (!f) {
    fprintf(stderr, "run_calls: the library exports no %s\n", name);
    exit(1);
  }
  return f;
}

#define FN(name) ((name##TYPE*)need(lib, #name))

int main(int argc, char** argv) {
  if (argc != 3) {
    fprintf(stderr, "usage: run_calls <library> <script>\n");
    return 2;
  }
  void* lib = LOAD(argv[1]);
  if (!lib) {
    fprintf(stderr, "run_calls: cannot load %s\n", argv[1]);
    return 1;
  }
  FILE* script = fopen(argv[2], "r");
  if (!script) {
    fprintf(stderr, "run_calls: cannot open %s\n", argv[2]);
    return 1;
  }
  fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
  fmi2Component c = NULL;
  double time = 0.0;
  char line[4096];
  int lineno = 0;
  while (fgets(line, sizeof line, script)) {
    lineno++;
    line[strcspn(line, "\r\n")] = '\0';
    char* op = strtok(line, " ");
    if (!op || op[0] == '#') continue;
    fmi2Status status = fmi2OK;
    if (strcmp(op, "instantiate") == 0) {
      char* guid = strtok(NULL, " ");
      char* uri = strtok(NULL, " ");
      c = FN(fmi2Instantiate)("run_calls", fmi2CoSimulation, guid, uri && strcmp(uri, "-") ? uri : NULL,
                              &callbacks, fmi2False, fmi2False);
      if (!c) status = fmi2Error;
    } else if (strcmp(op, "setup") == 0) {
      time = strtod(strtok(NULL, " "), NULL);
      status = FN(fmi2SetupExperiment)(c, fmi2False, 0.0, time, fmi2False, 0.0);
    } else if (strcmp(op, "init") == 0) {
      status = FN(fmi2EnterInitializationMode)(c);
      if (status == fmi2OK) status = FN(fmi2ExitInitializationMode)(c);
    } else if (strcmp(op, "real") == 0 || strcmp(op, "integer") == 0) {
      fmi2ValueReference vr = (fmi2ValueReference)strtoul(strtok(NULL, " "), NULL, 10);
      char* value = strtok(NULL, " ");
      if (op[0] == 'r') {
        fmi2Real x = strtod(value, NULL);
        status = FN(fmi2SetReal)(c, &vr, 1, &x);
      } else {
        fmi2Integer i = (fmi2Integer)strtol(value, NULL, 10);
        status = FN(fmi2SetInteger)(c, &vr, 1, &i);
      }
    } else if (strcmp(op, "step") == 0) {
      double h = strtod(strtok(NULL, " "), NULL);
      status = FN(fmi2DoStep)(c, time, h, fmi2True);
      time += h;
    } else if (strcmp(op, "get") == 0) {
      fputs("get", stdout);
      for (char* t; status == fmi2OK && (t = strtok(NULL, " "));) {
        fmi2ValueReference vr = (fmi2ValueReference)strtoul(t + 1, NULL, 10);
        if (t[0] == 'i') {
          fmi2Integer i = 0;
          status = FN(fmi2GetInteger)(c, &vr, 1, &i);
          printf(" %d", (int)i);
        } else {
          fmi2Real x = 0.0;
          status = FN(fmi2GetReal)(c, &vr, 1, &x);
          printf(" %.17g", x);
        }
      }
      fputc('\n', stdout);
    } else if (strcmp(op, "terminate") == 0) {
      status = FN(fmi2Terminate)(c);
    } else {
      fprintf(stderr, "run_calls: line %d: unknown call %s\n", lineno, op);
      return 1;
    }
    if (status != fmi2OK) {
      fprintf(stderr, "run_calls: line %d (%s) returned status %d\n", lineno, op, (int)status);
      return 1;
    }
  }
  if (c) FN(fmi2FreeInstance)(c);
  fclose(script);
  return 0;
}
