/* Writes the hand-made seeds of fuzz_fmu_calls into <corpus>/fuzz_fmu_calls/ (the rest of the
 * committed corpus is what libFuzzer's -merge kept from longer runs):
 *   make_fmu_seeds tests/fuzz/corpus
 * Each seed is a call sequence in the language of fmu_script.h: a run of each mode (plain,
 * level 5 and level 1 from start values files, user tables set as Strings, quasi-static,
 * large-step), and one of refusals (bad resource location, non-finite values, time travel,
 * corrupted states). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmu_script.h"
#include "variables.h"

static unsigned char buf[4096];
static size_t len;

static void u8(unsigned v) { buf[len++] = (unsigned char)v; }
static void u32(unsigned v) {
  for (int i = 0; i < 4; i++) u8(v >> (8 * i));
}

/* fuzz_real's forms (fuzz_bytes.h): special value k, m 10^e, raw */
static void special(unsigned k) { u8(k); }
static void scaled(int m, int e) { u8(48 + (unsigned)(e + 16)), u8((unsigned)(m & 0xFF)); }
static void raw(double x) {
  unsigned char b[8];
  memcpy(b, &x, 8);
  u8(224);
  for (int i = 0; i < 8; i++) u8(b[i]);
}
enum { ZERO = 0, ONE = 2, NAN_ = 5, INF = 7, BIG = 11, DENORMAL = 14, MS = 23 /* 1e-3 */ };

/* vr:T of the named variable: its index among the variables of its type */
static void vr(const char* name) {
  unsigned index[4] = {0, 0, 0, 0};
  for (size_t i = 0; i < GM_FMU_VARIABLE_COUNT; i++) {
    const gm_fmu_variable* v = &gm_fmu_variables[i];
    if (strcmp(v->name, name) == 0) {
      u8(index[v->type]);
      return;
    }
    index[v->type]++;
  }
  fprintf(stderr, "make_fmu_seeds: no variable %s\n", name);
  exit(1);
}

static void chunk(const char* bytes) {
  u8((unsigned)strlen(bytes));
  for (const char* c = bytes; *c; c++) u8((unsigned char)*c);
}

/* the instance: resource form (raw_uri for RES_RAW), start values (0 none, 1 start_text, 2 the
 * valid file valid_file), flags, an empty resources/fuzz.bin */
static void prologue(unsigned resources, const char* raw_uri, unsigned start_values, unsigned valid_file,
                     const char* start_text, unsigned flags) {
  u8(resources);
  if (resources == RES_RAW) chunk(raw_uri);
  u8(start_values);
  if (start_values == 1) chunk(start_text);
  if (start_values >= 2) u8(valid_file);
  u8(flags);
  chunk("");
}

static void start(void) {
  u8(OP_SETUP), u8(0), special(ZERO), special(ZERO), special(ZERO);
  u8(OP_ENTER_INIT);
  u8(OP_EXIT_INIT);
}

static void set_real(const char* name, int m, int e) { u8(OP_SET_REAL), u8(0), vr(name), scaled(m, e); }
static void set_int(int op, const char* name, int value) { u8((unsigned)op), u8(0), vr(name), u8(16), u8((unsigned)value); }
static void step(void) { u8(OP_DO_STEP), u8(0), special(MS); }
static void outputs(void) {
  u8(OP_GET_REAL), u8(3), vr("mesh.te"), vr("mesh.normal_force"), vr("gear1.fy"), vr("gear2.mz");
  u8(OP_GET_INTEGER), u8(1), vr("mesh.pairs_in_contact"), vr("mesh.flank");
}
/* initialization, then one step with the given input set, and the outputs */
static void loaded_step(const char* input, int m, int e) {
  start();
  set_real(input, m, e);
  step();
  outputs();
}
/* get a state, serialize it with one flipped bit (checksum recomputed if restamp), restore */
static void state_roundtrip(unsigned restamp) {
  u8(OP_GET_STATE), u8(0);
  u8(OP_SERIALIZE), u8(0), u8(0), u8(1), u32(200), u8(1), u8(0), u8(restamp);
  u8(OP_SET_STATE), u8(0);
  u8(OP_FREE_STATE), u8(0);
}

static void save(const char* dir, const char* name) {
  char path[1024];
  snprintf(path, sizeof path, "%s/fuzz_fmu_calls/%s", dir, name);
  FILE* f = fopen(path, "wb");
  if (!f || fwrite(buf, 1, len, f) != len || fclose(f)) {
    perror(path);
    exit(1);
  }
  len = 0;
}

int main(int argc, char** argv) {
  if (argc != 2) {
    fprintf(stderr, "usage: make_fmu_seeds CORPUS_DIR (tests/fuzz/corpus)\n");
    return 2;
  }
  const char* dir = argv[1];

  prologue(RES_FILE3, NULL, 0, 0, NULL, 1);
  loaded_step("gear2.phi", 72, -6); /* 5 um along the line of action */
  state_roundtrip(1);
  step();
  u8(OP_DERIVATIVE), u8(2), u8(1), vr("mesh.te"), vr("gear1.fy"), vr("gear2.phi"), special(ONE);
  u8(OP_TERMINATE);
  save(dir, "plain_level0");

  prologue(RES_FILE3, NULL, 2, 0, NULL, 1); /* level 5 on set_a.gcdb */
  loaded_step("gear2.phi", 72, -6);
  state_roundtrip(1);
  u8(OP_DERIVATIVE), u8(1), u8(2), vr("mesh.normal_force"), vr("gear2.phi"), special(ONE), vr("gear1.ux"), special(MS);
  save(dir, "level5_start_values");

  prologue(RES_LOCALHOST, NULL, 2, 1, NULL, 0); /* level 1, deviations, stiffness and TE tables */
  set_real("gear1.omega", 10, 0);
  loaded_step("gear2.phi", 72, -6);
  save(dir, "level1_tables_start_values");

  prologue(RES_PERCENT, NULL, 0, 0, NULL, 1); /* the tables set as Strings */
  set_int(OP_SET_INTEGER, "model.stiffness", 1);
  u8(OP_SET_STRING), u8(2), vr("model.stiffness_table"), u8(2), vr("model.te_table"), u8(3), vr("gear1.deviations"), u8(1);
  loaded_step("gear2.phi", 72, -6);
  save(dir, "level1_tables_strings");

  prologue(RES_FILE1, NULL, 0, 0, NULL, 1);
  set_int(OP_SET_BOOLEAN, "model.quasi_static", 1);
  loaded_step("mesh.load_torque", 100, 0);
  state_roundtrip(0);
  save(dir, "quasi_static");

  prologue(RES_NONE, NULL, 0, 0, NULL, 1);
  set_int(OP_SET_INTEGER, "model.dynamics", 1);
  loaded_step("gear1.torque", 50, 0);
  step();
  u8(OP_GET_REAL), u8(2), vr("energy.residual"), vr("gear1.speed"), vr("dynamics.step_size");
  save(dir, "large_step");

  /* a raw URI with a NUL escape and a garbage start values file, no instance name: refused */
  prologue(RES_RAW, "file:///%00", 1, 0, "x 1\n\xff", 9);
  u8(OP_REINSTANTIATE);
  prologue(RES_FILE3, NULL, 1, 0, "gearmesh-start-values 1\nmodel.slices 1e9\n", 0);
  u8(OP_REINSTANTIATE);
  prologue(RES_FILE3, NULL, 0, 0, NULL, 1);
  u8(OP_SET_STRING), u8(1), vr("gear1.deviations"), u8(9), vr("model.te_table"), u8(10); /* folder, FIFO */
  u8(OP_SET_REAL), u8(1), vr("gear1.phi"), special(NAN_), vr("pair.center_distance"), special(DENORMAL);
  u8(OP_SET_REAL), u8(0), vr("gear1.phi"), raw(1e308);
  u8(OP_SET_INTEGER), u8(0), vr("model.slices"), u8(11); /* INT32_MAX */
  start();
  u8(OP_SET_STRING), u8(1), vr("gear1.deviations"), u8(0), vr("model.te_table"), u8(0);
  u8(OP_SET_INTEGER), u8(0), vr("model.slices"), u8(1);
  u8(OP_EXIT_INIT);
  u8(OP_DO_STEP), u8(1), special(INF), special(MS);
  u8(OP_DO_STEP), u8(0), special(BIG);
  u8(OP_DO_STEP), u8(2), special(ONE), special(MS);
  u8(OP_DESERIALIZE), u8(1), chunk("\x9c");
  u8(OP_STATUS), u8(1), u8(2);
  u8(OP_DEBUG_LOGGING), u8(1), u8(2), u8(5), u8(200);
  u8(OP_UNSUPPORTED), vr("gear1.ux"), u8(2);
  u8(OP_RESET);
  save(dir, "refusals");
  return 0;
}
