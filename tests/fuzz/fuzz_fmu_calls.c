/* fuzz_fmu_calls: random FMI 2.0 call sequences against the FMU's C layer (fmu_src/) and the core
 * behind it, linked in statically. The input is a script (fmu_script.h): an instance made with a
 * fuzzed resource location and start values file, then any fmi2 calls with NaN, infinities,
 * 1e308, denormals and huge integers, steps of any size, FMU states got, set, serialized,
 * mutated (with and without a recomputed checksum) and deserialized. Everything is freed at the
 * end of each input, so LeakSanitizer sees every leak.
 *
 * Beyond the sanitizers it checks what docs/reliability.md promises: every log message is valid
 * UTF-8 with no control character but tab and newline ("Log messages"), and fmi2GetString never
 * yields NULL. A violation aborts, which libFuzzer reports as a crash. */
#define _DEFAULT_SOURCE /* mkfifo, unlink */
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "fmi2Functions.h"
#include "fmu_script.h"
#include "fuzz_bytes.h"
#include "fuzz_files.h"
#include "fuzz_gcdb.h"
#include "model.h"
#include "variables.h" /* GearMesh's variable table: the value references by type */

/* ---- oracles ------------------------------------------------------------------------------ */

static void fail(const char* what, const char* text) {
  fprintf(stderr, "fuzz_fmu_calls: %s: %s\n", what, text ? text : "(NULL)");
  abort();
}

/* RFC 3629 UTF-8 (no overlong forms, no surrogates, at most U+10FFFF) without control
 * characters other than tab and newline: written apart from the FMU's own escaping. */
static int clean_utf8(const unsigned char* s) {
  while (*s) {
    unsigned c = *s, n, min;
    if (c < 0x80) {
      if ((c < 0x20 && c != '\t' && c != '\n') || c == 0x7F) return 0;
      s++;
      continue;
    }
    if ((c & 0xE0) == 0xC0) n = 1, min = 0x80, c &= 0x1F;
    else if ((c & 0xF0) == 0xE0) n = 2, min = 0x800, c &= 0x0F;
    else if ((c & 0xF8) == 0xF0) n = 3, min = 0x10000, c &= 0x07;
    else return 0;
    for (unsigned i = 1; i <= n; i++) {
      if ((s[i] & 0xC0) != 0x80) return 0;
      c = c << 6 | (s[i] & 0x3F);
    }
    if (c < min || c > 0x10FFFF || (c >= 0xD800 && c <= 0xDFFF)) return 0;
    s += n + 1;
  }
  return 1;
}

/* GM_FUZZ_LOG=1 prints the calls and the messages, to follow one input. */
static void trace(const char* format, ...) {
  static int print = -1;
  if (print < 0) print = getenv("GM_FUZZ_LOG") != NULL;
  if (!print) return;
  va_list args;
  va_start(args, format);
  vfprintf(stderr, format, args);
  va_end(args);
}

static void logger(fmi2ComponentEnvironment environment, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
  (void)environment;
  char text[8192];
  va_list args;
  va_start(args, message);
  vsnprintf(text, sizeof text, message, args);
  va_end(args);
  if (!name || !category || (unsigned)status > fmi2Pending) fail("logger called with a bad argument", text);
  if (!clean_utf8((const unsigned char*)text)) fail("log message is not clean UTF-8", text);
  trace("[%s] %s: %s\n", category, name, text);
}

/* ---- the resources directory -------------------------------------------------------------- */

static const char deviations_txt[] =
    "gearmesh-deviations 1\nteeth 57\nroll_mm 21.5 27.5 34.3\nface_mm -11.5 11.5\n"
    "grid 0 A -1 -1.5 1 0.5 0.5 0\npitch 5 A 3\npitch 6 A -3\n";
static const char stiffness_txt[] = "gearmesh-stiffness-table 1\n15 14\n20 15\n25 15.5\n30 14\n";
static const char te_txt[] = "gearmesh-te-table 1\n0 0\n3 1.5\n";
/* valid start values files (values.h): level 5 on set_a.gcdb; level 1 with every table */
static const char* const start_files[2] = {
    "gearmesh-start-values 1\nmodel.stiffness 5\nmodel.slices 3\n"
    "gear1.compliance \"set_a.gcdb\"\ngear2.compliance \"set_a.gcdb\"\n",
    "gearmesh-start-values 1\nmodel.stiffness 1\ngear1.deviations \"deviations.txt\"\n"
    "model.stiffness_table \"stiffness.txt\"\nmodel.te_table \"te.txt\"\nmodel.friction_coefficient 0.1\n"};

static char resources[600]; /* <temp dir>/resources/ */

static void make_resources(void) {
  snprintf(resources, sizeof resources, "%s", fuzz_temp_path("resources/"));
  char path[700];
  mkdir(resources, 0700);
  snprintf(path, sizeof path, "%sfolder", resources);
  mkdir(path, 0700);
  snprintf(path, sizeof path, "%sfifo", resources); /* opening it would block: the FMU must not */
  mkfifo(path, 0600);
  snprintf(path, sizeof path, "%sdeviations.txt", resources);
  fuzz_write_file(path, deviations_txt, sizeof deviations_txt - 1);
  snprintf(path, sizeof path, "%sstiffness.txt", resources);
  fuzz_write_file(path, stiffness_txt, sizeof stiffness_txt - 1);
  snprintf(path, sizeof path, "%ste.txt", resources);
  fuzz_write_file(path, te_txt, sizeof te_txt - 1);
  snprintf(path, sizeof path, "%sset_a.gcdb", resources);
  fuzz_write_set_a_gcdb(path, 6, 3, 2);
}

/* ---- value references by type ------------------------------------------------------------- */

static struct {
  unsigned vr[GM_FMU_VARIABLE_COUNT];
  unsigned n;
} typed[4]; /* indexed by gm_fmu_type */

static void sort_variables(void) {
  for (unsigned vr = 0; vr < GM_FMU_VARIABLE_COUNT; vr++) {
    const gm_fmu_variable* v = &gm_fmu_variables[vr];
    typed[v->type].vr[typed[v->type].n++] = vr;
  }
}

static fmi2ValueReference fuzz_vr(fuzz_bytes* in, gm_fmu_type type) {
  unsigned b = fuzz_u8(in);
  if (b < 240) return typed[type].vr[b % typed[type].n];
  if (b < 250) return (fmi2ValueReference)(GM_FMU_VARIABLE_COUNT - 5 + (b - 240));
  return fuzz_u32(in);
}

/* ---- one run ------------------------------------------------------------------------------ */

typedef struct run {
  fuzz_bytes in;
  fmi2Component c;
  fmi2FMUstate states[2];
  double time; /* the FMU's time as far as the script knows */
} run;

static fmi2CallbackFunctions functions;

/* A malloc'd fmuResourceLocation of the given form. */
static char* resource_uri(fuzz_bytes* in, unsigned form) {
  static const char hex[] = "0123456789abcdef0123456789ABCDEF";
  char* uri = malloc(4 * sizeof resources + 64);
  const uint8_t* raw;
  size_t n;
  switch (form) {
    case RES_NONE: free(uri); return NULL;
    case RES_FILE3: sprintf(uri, "file://%s", resources); break;
    case RES_FILE1: sprintf(uri, "file:%.*s", (int)strlen(resources) - 1, resources); break;
    case RES_LOCALHOST: sprintf(uri, "file://localhost%s", resources); break;
    case RES_PERCENT:
      n = (size_t)sprintf(uri, "file://");
      for (size_t i = 0; resources[i]; i++) {
        unsigned char ch = (unsigned char)resources[i];
        if (ch == '/') {
          uri[n++] = '/';
          continue;
        }
        uri[n++] = '%';
        uri[n++] = hex[(ch >> 4) + (i & 1) * 16];
        uri[n++] = hex[(ch & 15) + (i & 1) * 16];
      }
      uri[n] = '\0';
      break;
    case RES_RAW:
      n = fuzz_chunk(in, 255, &raw);
      memcpy(uri, raw, n);
      uri[n] = '\0';
      break;
    case RES_OTHER_HOST: sprintf(uri, "file://elsewhere%s", resources); break;
    case RES_HTTP: sprintf(uri, "http://localhost/resources/"); break;
    default: uri[0] = '\0'; break;
  }
  return uri;
}

static void instantiate(run* r) {
  char* uri = resource_uri(&r->in, fuzz_pick(&r->in, RES_COUNT));
  char path[700];
  snprintf(path, sizeof path, "%sgearmesh-start-values.txt", resources);
  const uint8_t* bytes;
  size_t n;
  switch (fuzz_pick(&r->in, 4)) {
    case 0: unlink(path); break;
    case 1: n = fuzz_chunk(&r->in, 255, &bytes); fuzz_write_file(path, bytes, n); break;
    default: {
      const char* text = start_files[fuzz_u8(&r->in) & 1];
      fuzz_write_file(path, text, strlen(text));
    }
  }
  const unsigned flags = fuzz_u8(&r->in);
  n = fuzz_chunk(&r->in, 255, &bytes);
  snprintf(path, sizeof path, "%sfuzz.bin", resources);
  fuzz_write_file(path, bytes, n);
  functions.logger = flags & 4 ? NULL : logger;
  r->c = fmi2Instantiate(flags & 8 ? "" : "fuzz", fmi2CoSimulation, flags & 2 ? "{not-this-fmu}" : GM_FMU_GUID,
                         uri, &functions, fmi2False, (flags & 1) ? fmi2True : fmi2False);
  r->time = 0.0;
  free(uri);
}

static void free_instance(run* r) {
  for (int i = 0; i < 2; i++)
    if (r->states[i]) fmi2FreeFMUstate(r->c, &r->states[i]);
  fmi2FreeInstance(r->c);
  r->c = NULL;
}

/* 64-bit FNV-1a over the blob without its checksum field, as fmu_src/fmi2_functions.c computes
 * it (state_checksum; layout: docs/reliability.md, "FMU state blobs"). */
enum { CHECKSUM_OFFSET = 60, HEADER_SIZE = 68 };
static void restamp(unsigned char* b, size_t n) {
  if (n < HEADER_SIZE) return;
  uint64_t h = 14695981039346656037ull;
  for (size_t i = 0; i < n; i++) {
    if (i == CHECKSUM_OFFSET) i += 8;
    if (i >= n) break;
    h = (h ^ b[i]) * 1099511628211ull;
  }
  memcpy(b + CHECKSUM_OFFSET, &h, 8);
}

static void serialize_mutate(run* r) {
  fmi2FMUstate* slot = &r->states[fuzz_u8(&r->in) & 1];
  const int short_buffer = fuzz_u8(&r->in) & 1;
  size_t n;
  if (!*slot || fmi2SerializedFMUstateSize(r->c, *slot, &n) != fmi2OK || n == 0) return;
  unsigned char* b = malloc(n + 1);
  if (fmi2SerializeFMUstate(r->c, *slot, (fmi2Byte*)b, short_buffer ? n - 1 : n) != fmi2OK) {
    free(b);
    return;
  }
  for (unsigned k = fuzz_pick(&r->in, 4); k; k--) {
    const uint32_t pos = fuzz_u32(&r->in);
    b[pos % n] ^= (unsigned char)fuzz_u8(&r->in);
  }
  switch (fuzz_pick(&r->in, 3)) {
    case 1: n--; break;
    case 2: b[n++] = (unsigned char)fuzz_u8(&r->in); break;
    default: break;
  }
  if (fuzz_u8(&r->in) & 1) restamp(b, n);
  fmi2DeSerializeFMUstate(r->c, (const fmi2Byte*)b, n, slot);
  free(b);
}

/* A blob with a valid header (magic, format 3, this build's GUID, size, checksum) around a fuzzed
 * payload: the payload checks behind the header are reached at once. */
static void deserialize_payload(run* r) {
  fmi2FMUstate* slot = &r->states[fuzz_u8(&r->in) & 1];
  const uint8_t* payload;
  const size_t n = fuzz_chunk(&r->in, 255, &payload);
  unsigned char b[HEADER_SIZE + 255];
  const uint32_t format = 3;
  const uint64_t size = n;
  char guid[40] = GM_FMU_GUID;
  memcpy(b, "GearMesh", 8);
  memcpy(b + 8, &format, 4);
  memcpy(b + 12, guid, 40);
  memcpy(b + 52, &size, 8);
  memcpy(b + HEADER_SIZE, payload, n);
  restamp(b, HEADER_SIZE + n);
  if (fmi2DeSerializeFMUstate(r->c, (const fmi2Byte*)b, HEADER_SIZE + n, slot) == fmi2OK)
    fmi2SetFMUstate(r->c, *slot);
}

static const char* const string_values[] = {
#define S(text) text,
    STRING_VALUES(S)
#undef S
};
enum { STRING_COUNT = sizeof string_values / sizeof string_values[0] };

/* The arguments of one fmi2Set or fmi2Get call: 1 to 4 value references and their values. */
typedef struct value_list {
  unsigned n;
  fmi2ValueReference vr[4];
  fmi2Real reals[4];
  fmi2Integer ints[4];
  fmi2String strings[4];
} value_list;

static void set_values(run* r, gm_fmu_type type) {
  value_list v = {.n = 1 + fuzz_u8(&r->in) % 4};
  char* owned[4] = {NULL, NULL, NULL, NULL};
  for (unsigned i = 0; i < v.n; i++) {
    v.vr[i] = fuzz_vr(&r->in, type);
    if (type == GM_FMU_Real) {
      v.reals[i] = fuzz_real(&r->in);
    } else if (type == GM_FMU_String) {
      const unsigned k = fuzz_u8(&r->in);
      if (k < STRING_COUNT) {
        v.strings[i] = string_values[k];
      } else {
        const uint8_t* bytes;
        const size_t len = fuzz_chunk(&r->in, 255, &bytes);
        owned[i] = malloc(len + 1);
        memcpy(owned[i], bytes, len);
        owned[i][len] = '\0';
        v.strings[i] = owned[i];
      }
    } else {
      v.ints[i] = fuzz_int(&r->in);
    }
  }
  if (type == GM_FMU_Real) fmi2SetReal(r->c, v.vr, v.n, v.reals);
  else if (type == GM_FMU_Integer) fmi2SetInteger(r->c, v.vr, v.n, v.ints);
  else if (type == GM_FMU_Boolean) fmi2SetBoolean(r->c, v.vr, v.n, v.ints);
  else fmi2SetString(r->c, v.vr, v.n, v.strings);
  for (unsigned i = 0; i < v.n; i++) free(owned[i]);
}

static void get_values(run* r, gm_fmu_type type) {
  value_list v = {.n = 1 + fuzz_u8(&r->in) % 4};
  for (unsigned i = 0; i < v.n; i++) v.vr[i] = fuzz_vr(&r->in, type);
  if (type == GM_FMU_Real) fmi2GetReal(r->c, v.vr, v.n, v.reals);
  else if (type == GM_FMU_Integer) fmi2GetInteger(r->c, v.vr, v.n, v.ints);
  else if (type == GM_FMU_Boolean) fmi2GetBoolean(r->c, v.vr, v.n, v.ints);
  else if (fmi2GetString(r->c, v.vr, v.n, v.strings) == fmi2OK)
    for (unsigned i = 0; i < v.n; i++)
      if (!v.strings[i] || strlen(v.strings[i]) > (1u << 20)) fail("fmi2GetString", "NULL or unterminated value");
}

static void do_step(run* r) {
  const unsigned form = fuzz_pick(&r->in, 3);
  double tc = r->time;
  if (form == 1) tc = fuzz_real(&r->in);
  if (form == 2) tc += fuzz_real(&r->in);
  const double h = fuzz_real(&r->in);
  trace("fmi2DoStep(%.17g, %.17g)\n", tc, h);
  if (fmi2DoStep(r->c, tc, h, fmi2True) == fmi2OK) r->time = tc + h;
}

static void derivative(run* r) {
  const unsigned nu = fuzz_pick(&r->in, 5), nk = fuzz_pick(&r->in, 5);
  fmi2ValueReference unknown[4], known[4];
  fmi2Real dv_known[4], dv_unknown[4];
  for (unsigned i = 0; i < nu; i++) unknown[i] = fuzz_vr(&r->in, GM_FMU_Real);
  for (unsigned i = 0; i < nk; i++) {
    known[i] = fuzz_vr(&r->in, GM_FMU_Real);
    dv_known[i] = fuzz_real(&r->in);
  }
  fmi2GetDirectionalDerivative(r->c, unknown, nu, known, nk, dv_known, dv_unknown);
}

static void status(run* r) {
  const unsigned which = fuzz_pick(&r->in, 5);
  const fmi2StatusKind kind = (fmi2StatusKind)fuzz_pick(&r->in, 6);
  fmi2Status s;
  fmi2Real x;
  fmi2Integer i;
  fmi2Boolean b;
  fmi2String str;
  if (which == 0) fmi2GetStatus(r->c, kind, &s);
  else if (which == 1) fmi2GetRealStatus(r->c, kind, &x);
  else if (which == 2) fmi2GetIntegerStatus(r->c, kind, &i);
  else if (which == 3) fmi2GetBooleanStatus(r->c, kind, &b);
  else fmi2GetStringStatus(r->c, kind, &str);
}

static void debug_logging(run* r) {
  static const char* const names[] = {
#define C(name) name,
      CATEGORY_NAMES(C)
#undef C
  };
  const fmi2Boolean on = fuzz_u8(&r->in) & 1;
  const unsigned n = fuzz_pick(&r->in, 4);
  fmi2String categories[3];
  for (unsigned i = 0; i < n; i++) {
    const unsigned k = fuzz_u8(&r->in);
    categories[i] = k < sizeof names / sizeof names[0] ? names[k] : NULL;
  }
  fmi2SetDebugLogging(r->c, on, n, categories);
}

static void unsupported(run* r) {
  const fmi2ValueReference vr = fuzz_vr(&r->in, GM_FMU_Real);
  const fmi2Integer order = 1;
  fmi2Real value = 0;
  switch (fuzz_pick(&r->in, 3)) {
    case 0: fmi2SetRealInputDerivatives(r->c, &vr, 1, &order, &value); break;
    case 1: fmi2GetRealOutputDerivatives(r->c, &vr, 1, &order, &value); break;
    default: fmi2CancelStep(r->c); break;
  }
}

static void call(run* r, unsigned op) {
  trace("op %u\n", op);
  switch (op) {
    case OP_SETUP: {
      const unsigned flags = fuzz_u8(&r->in);
      const double tolerance = fuzz_real(&r->in), start = fuzz_real(&r->in), stop = fuzz_real(&r->in);
      if (fmi2SetupExperiment(r->c, flags & 1, tolerance, start, (flags >> 1) & 1, stop) == fmi2OK) r->time = start;
      break;
    }
    case OP_ENTER_INIT: fmi2EnterInitializationMode(r->c); break;
    case OP_EXIT_INIT: fmi2ExitInitializationMode(r->c); break;
    case OP_SET_REAL: set_values(r, GM_FMU_Real); break;
    case OP_SET_INTEGER: set_values(r, GM_FMU_Integer); break;
    case OP_SET_BOOLEAN: set_values(r, GM_FMU_Boolean); break;
    case OP_SET_STRING: set_values(r, GM_FMU_String); break;
    case OP_GET_REAL: get_values(r, GM_FMU_Real); break;
    case OP_GET_INTEGER: get_values(r, GM_FMU_Integer); break;
    case OP_GET_BOOLEAN: get_values(r, GM_FMU_Boolean); break;
    case OP_GET_STRING: get_values(r, GM_FMU_String); break;
    case OP_DO_STEP: do_step(r); break;
    case OP_GET_STATE: fmi2GetFMUstate(r->c, &r->states[fuzz_u8(&r->in) & 1]); break;
    case OP_SET_STATE: {
      fmi2Real t;
      if (fmi2SetFMUstate(r->c, r->states[fuzz_u8(&r->in) & 1]) == fmi2OK &&
          fmi2GetRealStatus(r->c, fmi2LastSuccessfulTime, &t) == fmi2OK)
        r->time = t;
      break;
    }
    case OP_FREE_STATE: fmi2FreeFMUstate(r->c, &r->states[fuzz_u8(&r->in) & 1]); break;
    case OP_SERIALIZE: serialize_mutate(r); break;
    case OP_DESERIALIZE: deserialize_payload(r); break;
    case OP_DERIVATIVE: derivative(r); break;
    case OP_RESET:
      if (fmi2Reset(r->c) == fmi2OK) r->time = 0.0;
      break;
    case OP_TERMINATE: fmi2Terminate(r->c); break;
    case OP_STATUS: status(r); break;
    case OP_DEBUG_LOGGING: debug_logging(r); break;
    case OP_UNSUPPORTED: unsupported(r); break;
    case OP_REINSTANTIATE:
      free_instance(r);
      instantiate(r);
      break;
  }
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static int ready;
  if (!ready) {
    make_resources();
    sort_variables();
    ready = 1;
  }
  run r;
  memset(&r, 0, sizeof r);
  r.in = (fuzz_bytes){data, size, 0};
  instantiate(&r);
  while (fuzz_left(&r.in)) call(&r, fuzz_u8(&r.in) % OP_COUNT);
  free_instance(&r);
  return 0;
}
