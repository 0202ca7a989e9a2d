/* Benchmark of the FMU's call overhead (issue 16: fmi2DoStep and the get of every output within
 * 1.3 x gm_evaluate): the built GearMesh.so, loaded with dlopen as an importer loads it, stepped
 * at the poses of build/tests/bench_evaluate (57/57 pair, gear 1 advanced about 1/97 pitch per
 * step, TE held at 5 um) against gm_evaluate of the same model in the same process. Per FMU
 * step: fmi2SetReal of the two spin angles, fmi2DoStep, fmi2GetReal of every Real output and
 * fmi2GetInteger of every Integer output (one call each, value references from the FMU's
 * variable table). Median and interquartile range of the time per call over samples of 1000,
 * five interleaved rounds, and the ratio FMU / gm_evaluate. Prints; never asserts on time.
 *
 * Usage: bench_fmu_step [ROUNDS] */
#include <dlfcn.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "fmi2Functions.h"
#include "variables.h"

#define PER_SAMPLE 1000
#define SAMPLES 15
#define WARMUP 2

static const double kPi = 3.14159265358979323846;

typedef struct {
  const char* name;
  int level, slices;
} Case;

typedef struct {
  double median, q1, q3;
} Stats;

typedef struct {
  fmi2InstantiateTYPE* instantiate;
  fmi2SetupExperimentTYPE* setup;
  fmi2EnterInitializationModeTYPE* enter_init;
  fmi2ExitInitializationModeTYPE* exit_init;
  fmi2SetRealTYPE* set_real;
  fmi2SetIntegerTYPE* set_integer;
  fmi2DoStepTYPE* do_step;
  fmi2GetRealTYPE* get_real;
  fmi2GetIntegerTYPE* get_integer;
  fmi2FreeInstanceTYPE* free_instance;
} Fmi;

static fmi2ValueReference real_out[GM_FMU_VARIABLE_COUNT], int_out[GM_FMU_VARIABLE_COUNT];
static size_t n_real_out, n_int_out;

static double now_ns(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return 1e9 * (double)t.tv_sec + (double)t.tv_nsec;
}

static int compare(const void* a, const void* b) {
  const double x = *(const double*)a, y = *(const double*)b;
  return (x > y) - (x < y);
}

static Stats stats(double* ns, int n) {
  qsort(ns, (size_t)n, sizeof *ns, compare);
  Stats s = {ns[n / 2], ns[n / 4], ns[3 * n / 4]};
  return s;
}

static fmi2ValueReference vr_of(const char* name) {
  for (size_t i = 0; i < GM_FMU_VARIABLE_COUNT; i++)
    if (strcmp(gm_fmu_variables[i].name, name) == 0) return (fmi2ValueReference)i;
  fprintf(stderr, "bench_fmu_step: no variable %s\n", name);
  exit(2);
}

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
  (void)env, (void)instance, (void)status;
  fprintf(stderr, "[%s] %s\n", category, message);
}

static void* must(void* lib, const char* name) {
  void* f = dlsym(lib, name);
  if (!f) {
    fprintf(stderr, "bench_fmu_step: %s not exported\n", name);
    exit(2);
  }
  return f;
}

static Fmi load(const char* path) {
  void* lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
  if (!lib) {
    fprintf(stderr, "bench_fmu_step: %s\n", dlerror());
    exit(2);
  }
  Fmi f = {must(lib, "fmi2Instantiate"), must(lib, "fmi2SetupExperiment"),
           must(lib, "fmi2EnterInitializationMode"), must(lib, "fmi2ExitInitializationMode"),
           must(lib, "fmi2SetReal"), must(lib, "fmi2SetInteger"), must(lib, "fmi2DoStep"),
           must(lib, "fmi2GetReal"), must(lib, "fmi2GetInteger"), must(lib, "fmi2FreeInstance")};
  return f;
}

/* The poses of bench_evaluate: gear 1 about 1/97 pitch further, TE 5 um. */
static void pose(double* phi, double rb1, double rb2, double out[2]) {
  *phi += 2 * kPi / 57 / 97;
  out[0] = *phi;
  out[1] = (5e-6 - rb1 * *phi) / rb2;
}

static void check(fmi2Status status, const char* what) {
  if (status != fmi2OK) {
    fprintf(stderr, "bench_fmu_step: %s returned %d\n", what, (int)status);
    exit(1);
  }
}

static Stats time_fmu(const Fmi* f, const Case* c, double rb[2]) {
  static const fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
  fmi2Component m = f->instantiate("bench", fmi2CoSimulation, GM_FMU_GUID, "file:///tmp/", &callbacks,
                                   fmi2False, fmi2False);
  if (!m) check(fmi2Error, "fmi2Instantiate");
  const fmi2ValueReference settings[2] = {vr_of("model.stiffness"), vr_of("model.slices")};
  const fmi2Integer values[2] = {c->level, c->slices};
  check(f->setup(m, fmi2False, 0, 0, fmi2False, 0), "fmi2SetupExperiment");
  check(f->set_integer(m, settings, 2, values), "fmi2SetInteger");
  check(f->enter_init(m), "fmi2EnterInitializationMode");
  check(f->exit_init(m), "fmi2ExitInitializationMode");
  const fmi2ValueReference diameters[2] = {vr_of("gear1.base_diameter"), vr_of("gear2.base_diameter")};
  fmi2Real d[2];
  check(f->get_real(m, diameters, 2, d), "fmi2GetReal");
  rb[0] = d[0] / 2, rb[1] = d[1] / 2;
  const fmi2ValueReference spins[2] = {vr_of("gear1.phi"), vr_of("gear2.phi")};
  static fmi2Real reals[GM_FMU_VARIABLE_COUNT];
  static fmi2Integer ints[GM_FMU_VARIABLE_COUNT];
  double ns[SAMPLES], phi = 0, t = 0, sink = 0, p[2];
  const double h = 1e-4;
  for (int s = 0; s < SAMPLES + WARMUP; s++) {
    const double t0 = now_ns();
    for (int i = 0; i < PER_SAMPLE; i++) {
      pose(&phi, rb[0], rb[1], p);
      f->set_real(m, spins, 2, p);
      f->do_step(m, t, h, fmi2True);
      t += h;
      f->get_real(m, real_out, n_real_out, reals);
      f->get_integer(m, int_out, n_int_out, ints);
      sink += reals[0];
    }
    if (s >= WARMUP) ns[s - WARMUP] = (now_ns() - t0) / PER_SAMPLE;
  }
  f->free_instance(m);
  if (sink == 42) printf(" ");
  return stats(ns, SAMPLES);
}

static Stats time_core(const Case* c, const double rb[2]) {
  gm_model_params prm;
  gm_default_params(&prm);
  prm.stiffness_level = c->level;
  prm.slices = c->slices;
  char msg[512];
  gm_model* m = NULL;
  gm_data* d = NULL;
  if (gm_model_create(&prm, &m, msg, sizeof msg) != GM_OK || gm_data_create(m, &d) != GM_OK) {
    fprintf(stderr, "bench_fmu_step: %s\n", msg);
    exit(1);
  }
  gm_kinematics k;
  memset(&k, 0, sizeof k);
  gm_result r;
  double ns[SAMPLES], phi = 0, sink = 0, p[2];
  for (int s = 0; s < SAMPLES + WARMUP; s++) {
    const double t0 = now_ns();
    for (int i = 0; i < PER_SAMPLE; i++) {
      pose(&phi, rb[0], rb[1], p);
      k.phi[0] = p[0], k.phi[1] = p[1];
      gm_evaluate(m, d, &k, &r);
      sink += r.normal_force;
    }
    if (s >= WARMUP) ns[s - WARMUP] = (now_ns() - t0) / PER_SAMPLE;
  }
  gm_data_free(d);
  gm_model_free(m);
  if (sink == 42) printf(" ");
  return stats(ns, SAMPLES);
}

static double median_of(double* x, int n) {
  qsort(x, (size_t)n, sizeof *x, compare);
  return x[n / 2];
}

int main(int argc, char** argv) {
  const int rounds = argc > 1 && atoi(argv[1]) > 0 ? atoi(argv[1]) : 5;
  for (size_t i = 0; i < GM_FMU_VARIABLE_COUNT; i++) {
    const gm_fmu_variable* v = &gm_fmu_variables[i];
    if (v->causality != GM_FMU_output) continue;
    if (v->type == GM_FMU_Real) real_out[n_real_out++] = (fmi2ValueReference)i;
    if (v->type == GM_FMU_Integer) int_out[n_int_out++] = (fmi2ValueReference)i;
  }
  const Fmi f = load(GM_FMU_LIBRARY);
  const Case cases[] = {{"level 0, 1 slice", 0, 1}, {"level 4, 10 slices", 4, 10}};
  enum { kCases = sizeof cases / sizeof cases[0], kMaxRounds = 64 };
  double fmu[kCases][kMaxRounds], core[kCases][kMaxRounds], ratio[kCases][kMaxRounds];
  double q1[kCases], q3[kCases];
  const int n = rounds < kMaxRounds ? rounds : kMaxRounds;
  for (int c = 0; c < kCases; c++) q1[c] = INFINITY, q3[c] = 0;
  for (int r = 0; r < n; r++)
    for (int c = 0; c < kCases; c++) {
      double rb[2];
      const Stats a = time_fmu(&f, &cases[c], rb), b = time_core(&cases[c], rb);
      fmu[c][r] = a.median, core[c][r] = b.median, ratio[c][r] = a.median / b.median;
      q1[c] = fmin(q1[c], a.q1), q3[c] = fmax(q3[c], a.q3);
    }
  printf("FMU step (set 2 spins, fmi2DoStep, get %zu Real + %zu Integer outputs) against gm_evaluate, "
         "57/57 pair at TE = 5 um; medians over %d rounds\n", n_real_out, n_int_out, n);
  printf("%-22s %12s %18s %14s %8s\n", "case", "FMU ns", "FMU IQR ns", "gm_evaluate ns", "ratio");
  for (int c = 0; c < kCases; c++)
    printf("%-22s %12.0f %8.0f..%-8.0f %14.0f %8.2f\n", cases[c].name, median_of(fmu[c], n), q1[c], q3[c],
           median_of(core[c], n), median_of(ratio[c], n));
  return 0;
}
