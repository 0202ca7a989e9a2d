/* Generic FMI 2.0 co-simulation layer: every fmi2* function of the CS API, mapped onto model.h
 * and nothing else of the model (its identifier, GUID, variables and log categories come through
 * model.h), so it serves another model unchanged.
 *
 * Each function first checks the instance's mode against its mask of allowed modes (an illegal
 * call logs "Illegal call sequence" and returns fmi2Error without changing anything). Errors are
 * logged and returned; only a failed evaluation in fmi2DoStep puts the instance into the Error
 * mode, from which fmi2SetFMUstate or fmi2Reset recover. No mutable globals: everything lives in
 * the instance, so instances run in parallel threads. Memory comes from malloc
 * (canNotUseMemoryManagementFunctions="true").
 */
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "model.h"
#include "uri.h"

/* Modes of the FMI 2.0 co-simulation state machine that this FMU can be in. fmi2DoStep is
 * synchronous, so stepInProgress, stepFailed and stepCanceled never occur. */
typedef enum {
  Instantiated = 1,
  InitializationMode = 2,
  StepComplete = 4,
  Terminated = 8,
  Error = 16
} fmu_mode;

#define ANY_MODE (Instantiated | InitializationMode | StepComplete | Terminated | Error)
#define MASK_SET_VALUES (Instantiated | InitializationMode | StepComplete)
#define MASK_GET_VALUES (InitializationMode | StepComplete | Terminated)
#define MASK_GET_STATE (Instantiated | InitializationMode | StepComplete | Terminated)
#define MASK_STATUS (StepComplete | Terminated | Error)

typedef struct instance {
  fmi2CallbackLogger logger;
  fmi2ComponentEnvironment environment; /* passed back to the logger unchanged */
  char* name;                           /* own copy: the importer's string is valid only during the call */
  char* resources;                      /* local resources directory ending in '/', or NULL */
  unsigned categories;                  /* enabled log categories, bit i = category i (model.h) */
  fmu_mode mode;
  double time; /* start time, then the end of the last successful step */
  int stop_defined;
  double stop_time;
  fmu_model* model;
  void** states;     /* the FMU states this instance made and has not freed: no other pointer is */
  size_t n_states;   /* taken for one (an importer's stale or uninitialised pointer is refused) */
  size_t cap_states;
  char msg[1024]; /* message from the model layer (may hold a path in resources/) */
  /* the last fmi2DoStep was discarded and nothing has changed since (cleared by a step taken, a
   * value set to another value, fmi2SetFMUstate, fmi2Reset): its start, length and reason */
  int discarded;
  double discarded_tc, discarded_h;
  char discarded_msg[1024];
} instance;

/* Every log category enabled (model.h: fewer than 32). */
static unsigned all_categories(void) {
  return (1u << model_log_category_count()) - 1u;
}

/* ---- logging ---------------------------------------------------------------------------- */

/* Length of the well-formed UTF-8 sequence at s[0..n) (RFC 3629: no overlong forms, no
 * surrogates, at most U+10FFFF), or 0 if there is none. */
static size_t utf8_sequence(const unsigned char* s, size_t n) {
  unsigned char b = s[0];
  size_t len;
  unsigned char lo = 0x80, hi = 0xBF; /* range of the second byte */
  if (b < 0x80) return 1;
  if (b >= 0xC2 && b <= 0xDF) len = 2;
  else if (b >= 0xE0 && b <= 0xEF) len = 3, lo = b == 0xE0 ? 0xA0 : 0x80, hi = b == 0xED ? 0x9F : 0xBF;
  else if (b >= 0xF0 && b <= 0xF4) len = 4, lo = b == 0xF0 ? 0x90 : 0x80, hi = b == 0xF4 ? 0x8F : 0xBF;
  else return 0;
  if (n < len || s[1] < lo || s[1] > hi) return 0;
  for (size_t i = 2; i < len; i++)
    if (s[i] < 0x80 || s[i] > 0xBF) return 0;
  return len;
}

/* Every message goes to the logger through here: out (4 n + 1 bytes) gets text[0..n) as valid
 * UTF-8, with each byte that is not part of a well-formed sequence, and each control character
 * other than tab and newline, written as \xNN. A message may echo bytes it did not make (a
 * corrupted FMU state's GUID, a file name), and importers decode the message as UTF-8. */
static void utf8_escape(const char* text, size_t n, char* out) {
  static const char hex[] = "0123456789ABCDEF";
  const unsigned char* s = (const unsigned char*)text;
  size_t i = 0, k = 0;
  while (i < n) {
    size_t len = utf8_sequence(s + i, n - i);
    if (len == 0 || (len == 1 && ((s[i] < 0x20 && s[i] != '\t' && s[i] != '\n') || s[i] == 0x7F))) {
      out[k++] = '\\';
      out[k++] = 'x';
      out[k++] = hex[s[i] >> 4];
      out[k++] = hex[s[i] & 15];
      i++;
      continue;
    }
    memcpy(out + k, s + i, len);
    k += len;
    i += len;
  }
  out[k] = '\0';
}

/* A message goes out if its category is enabled, or always (errors, the reason of a discard). */
static void vlog_if(const instance* c, fmi2Status status, unsigned category, int always, const char* format,
                    va_list args) {
  always = always || category == MODEL_LOG_ERROR || category == MODEL_LOG_FATAL;
  if (!c->logger || !(always || (c->categories >> category & 1u))) return;
  char text[1200];
  vsnprintf(text, sizeof text, format, args);
  size_t n = strlen(text);
  while (n && (text[n - 1] == '\n' || text[n - 1] == '\r')) text[--n] = '\0';
  char safe[4 * sizeof text]; /* every byte escaped at most to 4 */
  utf8_escape(text, n, safe);
  /* through "%s": a '%' in the message or instance name is never read as a conversion */
  c->logger(c->environment, c->name, status, model_log_category_name(category), "%s", safe);
}

static void vlog(const instance* c, fmi2Status status, unsigned category, const char* format, va_list args) {
  vlog_if(c, status, category, 0, format, args);
}

static void log_event(const instance* c, const char* format, ...) {
  va_list args;
  va_start(args, format);
  vlog(c, fmi2OK, MODEL_LOG_EVENTS, format, args);
  va_end(args);
}

static fmi2Status error(const instance* c, const char* format, ...) {
  va_list args;
  va_start(args, format);
  vlog(c, fmi2Error, MODEL_LOG_ERROR, format, args);
  va_end(args);
  return fmi2Error;
}

static void warning(const instance* c, const char* format, ...) {
  va_list args;
  va_start(args, format);
  vlog(c, fmi2Warning, MODEL_LOG_WARNING, format, args);
  va_end(args);
}

static fmi2Status discard(const instance* c, const char* format, ...) {
  va_list args;
  va_start(args, format);
  vlog(c, fmi2Discard, MODEL_LOG_WARNING, format, args);
  va_end(args);
  return fmi2Discard;
}

/* fmi2DoStep refused a step, changing nothing (fmi2Discard). The reason goes out whatever
 * categories are enabled, as errors do, under logStatusWarning with the message status
 * fmi2Warning: importers filter their log by that status, and some show a message of status
 * fmi2Discard only when debugging (libcosim: at its debug level), or get none while logging is
 * off (Maestro's default), so a master's "step not complete" came without its reason
 * (docs/guide/masters.md). */
static fmi2Status discard_step(const instance* c, const char* format, ...) {
  va_list args;
  va_start(args, format);
  vlog_if(c, fmi2Warning, MODEL_LOG_WARNING, 1, format, args);
  va_end(args);
  return fmi2Discard;
}

static void model_log(void* context, unsigned category, const char* format, ...) {
  va_list args;
  va_start(args, format);
  vlog(context, fmi2OK, category, format, args);
  va_end(args);
}

/* ---- call sequence ---------------------------------------------------------------------- */

static const char* mode_name(fmu_mode mode) {
  switch (mode) {
    case Instantiated: return "Instantiated";
    case InitializationMode: return "Initialization Mode";
    case StepComplete: return "stepComplete";
    case Terminated: return "terminated";
    default: return "error";
  }
}

static int illegal(const instance* c, const char* function, unsigned allowed) {
  if (!c) return 1;
  if (c->mode & allowed) return 0;
  error(c, "%s: Illegal call sequence (instance is in %s)", function, mode_name(c->mode));
  return 1;
}

#define CHECK_MODE(allowed)                                              \
  instance* c = (instance*)component;                                   \
  if (illegal(c, __func__, (allowed))) return fmi2Error

#define CHECK_POINTER(p)                                                      \
  if (!(p)) return error(c, "%s: argument %s must not be NULL", __func__, #p)

/* ---- common functions ------------------------------------------------------------------- */

const char* fmi2GetTypesPlatform(void) {
  return fmi2TypesPlatform;
}

const char* fmi2GetVersion(void) {
  return fmi2Version;
}

static char* copy_string(const char* s) {
  size_t n = strlen(s) + 1;
  char* copy = malloc(n);
  if (copy) memcpy(copy, s, n);
  return copy;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions* functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
  (void)visible;
  if (!functions) return NULL;
  /* stands in for the instance while refusing, so that the refusal is logged */
  instance probe = {.logger = functions->logger,
                    .environment = functions->componentEnvironment,
                    .name = (char*)(instanceName && instanceName[0] ? instanceName : model_identifier)};
  if (!instanceName || !instanceName[0]) {
    error(&probe, "fmi2Instantiate: instanceName must be a non-empty string");
    return NULL;
  }
  if (fmuType != fmi2CoSimulation) {
    error(&probe, "fmi2Instantiate: %s is a co-simulation FMU (fmuType = %d)", model_identifier, (int)fmuType);
    return NULL;
  }
  if (!fmuGUID || strcmp(fmuGUID, model_guid) != 0) {
    error(&probe, "fmi2Instantiate: GUID %s does not match this binary's %s (modelDescription.xml is from another build)",
          fmuGUID ? fmuGUID : "(NULL)", model_guid);
    return NULL;
  }
  instance* c = calloc(1, sizeof *c);
  if (!c) {
    error(&probe, "fmi2Instantiate: out of memory");
    return NULL;
  }
  *c = probe;
  c->name = copy_string(instanceName);
  c->model = model_new(model_log, c);
  if (!c->name || !c->model) {
    error(&probe, "fmi2Instantiate: out of memory");
    free(c->name);
    model_free(c->model);
    free(c);
    return NULL;
  }
  c->categories = loggingOn ? all_categories() : 0u;
  c->mode = Instantiated;
  /* a model may read data files and start values from resources/ (model_set_resources) */
  c->resources = fmu_uri_to_path(fmuResourceLocation);
  if (fmuResourceLocation && !c->resources)
    warning(c, "fmi2Instantiate: resource location is not a local file URI: %s", fmuResourceLocation);
  log_event(c, "fmi2Instantiate: resources at %s", c->resources ? c->resources : "(none)");
  if (model_set_resources(c->model, c->resources, c->msg, sizeof c->msg)) {
    error(c, "fmi2Instantiate: %s", c->msg);
    fmi2FreeInstance(c);
    return NULL;
  }
  return c;
}

void fmi2FreeInstance(fmi2Component component) {
  instance* c = (instance*)component;
  if (!c) return;
  for (size_t i = 0; i < c->n_states; i++) free(c->states[i]); /* states not freed by the importer */
  free(c->states);
  model_free(c->model);
  free(c->resources);
  free(c->name);
  free(c);
}

fmi2Status fmi2SetDebugLogging(fmi2Component component, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
  CHECK_MODE(ANY_MODE);
  if (nCategories == 0) {
    c->categories = loggingOn ? all_categories() : 0u;
    return fmi2OK;
  }
  CHECK_POINTER(categories);
  unsigned bits = 0;
  for (size_t i = 0; i < nCategories; i++) {
    unsigned bit = 0;
    for (unsigned k = 0; k < model_log_category_count(); k++)
      if (categories[i] && strcmp(categories[i], model_log_category_name(k)) == 0) bit = 1u << k;
    if (!bit) return error(c, "fmi2SetDebugLogging: unknown log category '%s'", categories[i] ? categories[i] : "(NULL)");
    bits |= bit == 1u << MODEL_LOG_ALL ? all_categories() : bit;
  }
  c->categories = loggingOn ? c->categories | bits : c->categories & ~bits;
  return fmi2OK;
}

fmi2Status fmi2SetupExperiment(fmi2Component component, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
  (void)toleranceDefined; /* a model's solvers have their own tolerance parameters */
  (void)tolerance;
  CHECK_MODE(Instantiated);
  if (!isfinite(startTime)) return error(c, "fmi2SetupExperiment: startTime = %g is not finite", startTime);
  if (stopTimeDefined && !(stopTime >= startTime))
    return error(c, "fmi2SetupExperiment: stopTime = %g is before startTime = %g", stopTime, startTime);
  c->time = startTime;
  c->stop_defined = stopTimeDefined != fmi2False;
  c->stop_time = stopTime;
  return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component component) {
  CHECK_MODE(Instantiated);
  c->mode = InitializationMode;
  log_event(c, "fmi2EnterInitializationMode at t = %g s", c->time);
  return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component component) {
  CHECK_MODE(InitializationMode);
  /* outputs at the start time; on a parameter or input error the instance stays in
   * Initialization Mode so that the value can be corrected */
  if (!model_outputs_current(c->model) && model_evaluate(c->model, 1, c->time, 0.0, c->msg, sizeof c->msg))
    return error(c, "fmi2ExitInitializationMode: %s", c->msg);
  c->mode = StepComplete;
  log_event(c, "fmi2ExitInitializationMode: stepComplete at t = %g s", c->time);
  /* the model's warnings about its parameters are never silent: status Warning */
  const char* warnings = model_warnings(c->model);
  if (warnings[0]) {
    warning(c, "fmi2ExitInitializationMode: %s", warnings);
    return fmi2Warning;
  }
  return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component component) {
  CHECK_MODE(StepComplete);
  c->mode = Terminated;
  log_event(c, "fmi2Terminate at t = %g s", c->time);
  return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component component) {
  CHECK_MODE(ANY_MODE);
  if (model_reset(c->model)) {
    c->mode = Error;
    return error(c, "fmi2Reset: out of memory for the start values");
  }
  c->mode = Instantiated;
  c->time = 0.0;
  c->stop_defined = 0;
  c->discarded = 0;
  log_event(c, "fmi2Reset: start values, Instantiated");
  return fmi2OK;
}

/* ---- values ----------------------------------------------------------------------------- */

static const char* const type_names[] = {"Real", "Integer", "Boolean", "String"};
static const char* const causality_names[] = {"parameter", "calculatedParameter", "input", "output"};

/* The variable of value reference vr if it has the given type, else NULL (logged). */
static const model_variable_info* variable(const instance* c, const char* function, fmi2ValueReference vr,
                                           model_type type) {
  const model_variable_info* v = model_variable(vr);
  if (v && v->type == type) return v;
  error(c, "%s: value reference %u is not a variable of type %s", function, (unsigned)vr, type_names[type]);
  return NULL;
}

static fmi2Status get_values(instance* c, const char* function, model_type type, const fmi2ValueReference vr[],
                             size_t nvr, void* values) {
  if (nvr == 0) return fmi2OK;
  if (!vr || !values) return error(c, "%s: vr[] and value[] must not be NULL", function);
  int outputs = 0, calculated = 0;
  for (size_t i = 0; i < nvr; i++) {
    const model_variable_info* v = variable(c, function, vr[i], type);
    if (!v) return fmi2Error;
    outputs |= v->causality == MODEL_output;
    calculated |= v->causality == MODEL_calculatedParameter;
  }
  /* Set/get iteration: outputs read after inputs were set are evaluated at the current values,
   * from scratch in Initialization Mode, else at the communication point (direct feedthrough,
   * docs/fmi.md "Feedthrough"). */
  if (outputs && !model_outputs_current(c->model) &&
      (c->mode == InitializationMode ? model_evaluate(c->model, 1, c->time, 0.0, c->msg, sizeof c->msg)
                                     : model_feedthrough(c->model, c->time, c->msg, sizeof c->msg)))
    return error(c, "%s: %s", function, c->msg);
  if (calculated && c->mode == InitializationMode && model_build(c->model, c->msg, sizeof c->msg))
    return error(c, "%s: %s", function, c->msg);
  for (size_t i = 0; i < nvr; i++) {
    if (type == MODEL_Real) ((fmi2Real*)values)[i] = model_get_real(c->model, vr[i]);
    else if (type == MODEL_String) ((fmi2String*)values)[i] = model_get_string(c->model, vr[i]);
    else ((fmi2Integer*)values)[i] = model_get_int(c->model, vr[i]); /* fmi2Boolean is an int too */
  }
  return fmi2OK;
}

/* All values are checked (and strings copied) before any is set, so a refused call changes
 * nothing. The instance owns a copy of every string it is given. */
static fmi2Status set_values(instance* c, const char* function, model_type type, const fmi2ValueReference vr[],
                             size_t nvr, const void* values) {
  if (nvr == 0) return fmi2OK;
  if (!vr || !values) return error(c, "%s: vr[] and value[] must not be NULL", function);
  char** copies = NULL;
  for (size_t i = 0; i < nvr; i++) {
    const model_variable_info* v = variable(c, function, vr[i], type);
    if (!v) return fmi2Error;
    if (v->causality == MODEL_parameter && v->variability == MODEL_fixed &&
        !(c->mode & (Instantiated | InitializationMode)))
      return error(c, "%s: %s is a fixed parameter, settable only before fmi2ExitInitializationMode",
                   function, v->name);
    if (v->causality != MODEL_parameter && v->causality != MODEL_input)
      return error(c, "%s: %s is %s and cannot be set", function, v->name,
                   v->causality == MODEL_output ? "an output" : "a calculated parameter");
    if (type == MODEL_Real && !isfinite(((const fmi2Real*)values)[i]))
      return error(c, "%s: %s = %g is not finite; it keeps %g", function, v->name, ((const fmi2Real*)values)[i],
                   model_get_real(c->model, vr[i]));
    if (type == MODEL_String && !((const fmi2String*)values)[i])
      return error(c, "%s: %s = NULL: a String value must not be NULL (\"\" for none); it keeps \"%s\"", function,
                   v->name, model_get_string(c->model, vr[i]));
  }
  if (type == MODEL_String) {
    copies = calloc(nvr, sizeof *copies);
    for (size_t i = 0; copies && i < nvr; i++) {
      if ((copies[i] = copy_string(((const fmi2String*)values)[i]))) continue;
      while (i) free(copies[--i]);
      free(copies);
      copies = NULL;
    }
    if (!copies) return error(c, "%s: out of memory for the strings", function);
  }
  for (size_t i = 0; i < nvr && c->discarded; i++) /* a discarded step may succeed now */
    if (type == MODEL_Real) {
      const double now = model_get_real(c->model, vr[i]), x = ((const fmi2Real*)values)[i];
      c->discarded = memcmp(&now, &x, sizeof x) == 0;
    } else if (type == MODEL_String) {
      c->discarded = strcmp(model_get_string(c->model, vr[i]), ((const fmi2String*)values)[i]) == 0;
    } else {
      c->discarded = model_get_int(c->model, vr[i]) == ((const fmi2Integer*)values)[i];
    }
  for (size_t i = 0; i < nvr; i++) {
    if (type == MODEL_Real) model_set_real(c->model, vr[i], ((const fmi2Real*)values)[i]);
    else if (type == MODEL_String) model_set_string(c->model, vr[i], copies[i]);
    else model_set_int(c->model, vr[i], ((const fmi2Integer*)values)[i]);
  }
  free(copies);
  return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component component, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
  CHECK_MODE(MASK_GET_VALUES);
  return get_values(c, __func__, MODEL_Real, vr, nvr, value);
}

fmi2Status fmi2GetInteger(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[]) {
  CHECK_MODE(MASK_GET_VALUES);
  return get_values(c, __func__, MODEL_Integer, vr, nvr, value);
}

fmi2Status fmi2GetBoolean(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[]) {
  CHECK_MODE(MASK_GET_VALUES);
  return get_values(c, __func__, MODEL_Boolean, vr, nvr, value);
}

fmi2Status fmi2GetString(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[]) {
  CHECK_MODE(MASK_GET_VALUES);
  return get_values(c, __func__, MODEL_String, vr, nvr, value);
}

fmi2Status fmi2SetReal(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
  CHECK_MODE(MASK_SET_VALUES);
  return set_values(c, __func__, MODEL_Real, vr, nvr, value);
}

fmi2Status fmi2SetInteger(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[]) {
  CHECK_MODE(MASK_SET_VALUES);
  return set_values(c, __func__, MODEL_Integer, vr, nvr, value);
}

fmi2Status fmi2SetBoolean(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[]) {
  CHECK_MODE(MASK_SET_VALUES);
  return set_values(c, __func__, MODEL_Boolean, vr, nvr, value);
}

fmi2Status fmi2SetString(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[]) {
  CHECK_MODE(MASK_SET_VALUES);
  return set_values(c, __func__, MODEL_String, vr, nvr, value);
}

/* ---- FMU state -------------------------------------------------------------------------- */

/* Serialized FMU state, native byte order (the binary is per platform):
 *   modelIdentifier, cut or NUL-padded to 8 bytes | u32 format version |
 *   GUID, NUL-padded to 40 bytes | u64 payload size |
 *   u64 checksum | payload
 *   payload = f64 time | u32 mode | model payload (model_state_save)
 * Format 3: the checksum, 64-bit FNV-1a over every byte of the blob except the checksum field
 * itself (header and payload); format 2 had none, format 1 no String values either.
 * An fmi2FMUstate holds exactly these bytes: taking, copying and serializing a state are one
 * path, and a state owns all its data (no pointer into the instance). fmi2SetFMUstate and
 * fmi2DeSerializeFMUstate check magic, format, size, checksum and GUID before anything is
 * applied; a corrupted blob is refused with fmi2Error and the instance is unchanged
 * (docs/reliability.md). */
#define STATE_FORMAT 3u
#define STATE_GUID_SIZE MODEL_GUID_SIZE
#define STATE_SIZE_OFFSET (8 + 4 + STATE_GUID_SIZE)
#define STATE_CHECKSUM_OFFSET (STATE_SIZE_OFFSET + 8)
#define STATE_HEADER_SIZE (STATE_CHECKSUM_OFFSET + 8)
#define STATE_PAYLOAD_OFFSET (8 + 4) /* model payload after time and mode */

typedef struct fmu_state {
  size_t size;
  unsigned char bytes[];
} fmu_state;

/* The first 12 + STATE_GUID_SIZE bytes of a state of this build: magic, format, GUID. */
static void state_identity(unsigned char* b) {
  const uint32_t format = STATE_FORMAT;
  memset(b, 0, 12 + STATE_GUID_SIZE);
  memcpy(b, model_identifier, strnlen(model_identifier, 8));
  memcpy(b + 8, &format, 4);
  memcpy(b + 12, model_guid, strnlen(model_guid, STATE_GUID_SIZE - 1));
}

/* 64-bit FNV-1a of bytes[0..size) without the checksum field. Each step (xor a byte, multiply
 * by an odd constant modulo 2^64) is a bijection of the running hash, so a change confined to
 * one byte (every single-bit flip) always changes the result; other corruptions go undetected
 * with a probability of about 2^-64. */
static uint64_t state_checksum(const unsigned char* bytes, size_t size) {
  uint64_t h = 14695981039346656037ull;
  for (size_t i = 0; i < size; i++) {
    if (i == STATE_CHECKSUM_OFFSET) i += 8;
    if (i >= size) break;
    h = (h ^ bytes[i]) * 1099511628211ull;
  }
  return h;
}

/* Payload size if bytes[0..size) is an intact state of this FMU, else 0 (logged). */
static size_t check_state(const instance* c, const char* function, const unsigned char* bytes, size_t size) {
  unsigned char own[12 + STATE_GUID_SIZE];
  state_identity(own);
  uint32_t format;
  uint64_t payload, stored;
  if (size < 12 || memcmp(bytes, own, 8) != 0) {
    error(c, "%s: not a %s FMU state (%zu bytes; it must start with \"%.8s\")", function, model_identifier, size,
          model_identifier);
    return 0;
  }
  memcpy(&format, bytes + 8, sizeof format);
  if (format != STATE_FORMAT) {
    error(c, "%s: FMU state format %u, this FMU reads format %u only", function, (unsigned)format, STATE_FORMAT);
    return 0;
  }
  if (size < STATE_HEADER_SIZE) {
    error(c, "%s: FMU state is truncated (%zu bytes, the header alone has %d)", function, size, STATE_HEADER_SIZE);
    return 0;
  }
  memcpy(&payload, bytes + STATE_SIZE_OFFSET, sizeof payload);
  if (payload != size - STATE_HEADER_SIZE || payload < STATE_PAYLOAD_OFFSET) {
    error(c, "%s: FMU state is truncated or padded (%zu bytes, header says %llu)", function, size,
          (unsigned long long)(payload + STATE_HEADER_SIZE));
    return 0;
  }
  memcpy(&stored, bytes + STATE_CHECKSUM_OFFSET, sizeof stored);
  const uint64_t computed = state_checksum(bytes, size);
  if (stored != computed) {
    error(c, "%s: FMU state is corrupted: checksum 0x%016llx, the %zu bytes give 0x%016llx; nothing was restored",
          function, (unsigned long long)stored, size, (unsigned long long)computed);
    return 0;
  }
  if (memcmp(bytes + 12, own + 12, STATE_GUID_SIZE) != 0) {
    error(c, "%s: FMU state is from another %s build (GUID %.*s, this build's %s)", function, model_identifier,
          STATE_GUID_SIZE, (const char*)bytes + 12, model_guid);
    return 0;
  }
  return (size_t)payload;
}

/* The index of state s among the instance's, or n_states if it is not one of them. */
static size_t state_index(const instance* c, const void* s) {
  size_t i = 0;
  while (i < c->n_states && c->states[i] != s) i++;
  return i;
}

/* A state of this instance, or an error naming the function and the pointer. */
#define CHECK_STATE(s)                                                                                      \
  if (state_index(c, s) == c->n_states)                                                                     \
  return error(c, "%s: FMU state %p was not made by this instance (fmi2GetFMUstate or "                    \
               "fmi2DeSerializeFMUstate) or was freed", __func__, (const void*)(s))

/* *slot: NULL or a state of this instance, reallocated to hold `bytes` more than the header (a
 * previous state of ours is reused). NULL (nothing changed) on an unknown pointer or no memory. */
static fmu_state* state_for(instance* c, const char* function, fmi2FMUstate* slot, size_t bytes) {
  const size_t i = *slot ? state_index(c, *slot) : c->n_states;
  if (*slot && i == c->n_states) {
    error(c, "%s: *FMUstate = %p was not made by this instance; allowed: NULL (a new state) or a state "
          "this instance made", function, *slot);
    return NULL;
  }
  if (!*slot && c->n_states == c->cap_states) {
    const size_t cap = c->cap_states ? 2 * c->cap_states : 4;
    void** grown = realloc(c->states, cap * sizeof *grown);
    if (!grown) return error(c, "%s: out of memory", function), NULL;
    c->states = grown;
    c->cap_states = cap;
  }
  fmu_state* s = realloc(*slot, sizeof *s + bytes);
  if (!s) return error(c, "%s: out of memory", function), NULL;
  if (*slot) c->states[i] = s;
  else c->states[c->n_states++] = s;
  *slot = s;
  return s;
}

fmi2Status fmi2GetFMUstate(fmi2Component component, fmi2FMUstate* FMUstate) {
  CHECK_MODE(MASK_GET_STATE);
  CHECK_POINTER(FMUstate);
  uint64_t payload = STATE_PAYLOAD_OFFSET + model_state_size(c->model);
  size_t size = STATE_HEADER_SIZE + (size_t)payload;
  fmu_state* s = state_for(c, __func__, FMUstate, size);
  if (!s) return fmi2Error;
  uint32_t mode = (uint32_t)c->mode;
  unsigned char* b = s->bytes;
  s->size = size;
  state_identity(b);
  memcpy(b + STATE_SIZE_OFFSET, &payload, 8);
  memcpy(b + STATE_HEADER_SIZE, &c->time, 8);
  memcpy(b + STATE_HEADER_SIZE + 8, &mode, 4);
  model_state_save(c->model, b + STATE_HEADER_SIZE + STATE_PAYLOAD_OFFSET);
  const uint64_t checksum = state_checksum(b, size);
  memcpy(b + STATE_CHECKSUM_OFFSET, &checksum, 8);
  return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component component, fmi2FMUstate FMUstate) {
  CHECK_MODE(ANY_MODE);
  CHECK_POINTER(FMUstate);
  CHECK_STATE(FMUstate);
  const fmu_state* s = FMUstate;
  size_t payload = check_state(c, __func__, s->bytes, s->size);
  if (!payload) return fmi2Error;
  const unsigned char* b = s->bytes + STATE_HEADER_SIZE;
  double time;
  uint32_t mode;
  memcpy(&time, b, 8);
  memcpy(&mode, b + 8, 4);
  if (!(mode & MASK_GET_STATE) || (mode & (mode - 1)) || !isfinite(time))
    return error(c, "fmi2SetFMUstate: FMU state has an invalid mode or time");
  if (model_state_load(c->model, b + STATE_PAYLOAD_OFFSET, payload - STATE_PAYLOAD_OFFSET, c->msg, sizeof c->msg))
    return error(c, "fmi2SetFMUstate: %s", c->msg);
  c->time = time;
  c->mode = (fmu_mode)mode;
  c->discarded = 0;
  return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component component, fmi2FMUstate* FMUstate) {
  CHECK_MODE(ANY_MODE);
  if (!FMUstate || !*FMUstate) return fmi2OK;
  CHECK_STATE(*FMUstate);
  const size_t i = state_index(c, *FMUstate);
  c->states[i] = c->states[--c->n_states];
  free(*FMUstate);
  *FMUstate = NULL;
  return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component component, fmi2FMUstate FMUstate, size_t* size) {
  CHECK_MODE(ANY_MODE);
  CHECK_POINTER(FMUstate);
  CHECK_POINTER(size);
  CHECK_STATE(FMUstate);
  *size = ((const fmu_state*)FMUstate)->size;
  return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component component, fmi2FMUstate FMUstate, fmi2Byte serializedState[],
                                 size_t size) {
  CHECK_MODE(ANY_MODE);
  CHECK_POINTER(FMUstate);
  CHECK_POINTER(serializedState);
  CHECK_STATE(FMUstate);
  const fmu_state* s = FMUstate;
  if (size < s->size) return error(c, "%s: buffer of %zu bytes, the state needs %zu", __func__, size, s->size);
  memcpy(serializedState, s->bytes, s->size);
  return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component component, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate* FMUstate) {
  CHECK_MODE(ANY_MODE);
  CHECK_POINTER(serializedState);
  CHECK_POINTER(FMUstate);
  if (!check_state(c, __func__, (const unsigned char*)serializedState, size)) return fmi2Error;
  fmu_state* s = state_for(c, __func__, FMUstate, size);
  if (!s) return fmi2Error;
  s->size = size;
  memcpy(s->bytes, serializedState, size);
  return fmi2OK;
}

/* ---- directional derivatives ------------------------------------------------------------ */

/* 1 if refs[i] is a Real variable of the given causality, else 0 (logged, naming the role the
 * knowns or unknowns play). */
static int derivative_variable(const instance* c, const char* role, const char* array, const fmi2ValueReference refs[],
                               size_t i, model_causality causality) {
  const model_variable_info* v = model_variable(refs[i]);
  if (!v) {
    error(c, "fmi2GetDirectionalDerivative: %s[%zu] = %u is not a value reference of this FMU", array, i,
          (unsigned)refs[i]);
    return 0;
  }
  if (v->type == MODEL_Real && v->causality == causality) return 1;
  error(c, "fmi2GetDirectionalDerivative: %s %s (value reference %u) is a %s %s; the %ss must be Real %ss%s", role,
        v->name, (unsigned)refs[i], causality_names[v->causality], type_names[v->type], role,
        causality_names[causality],
        causality == MODEL_input ? " (parameters as knowns, for initial unknowns in Initialization Mode, are not "
                                   "supported)" : "");
  return 0;
}

/* d(outputs)/d(inputs) . dvKnown (model_directional_derivative), at the current inputs, to which
 * the outputs read belong (docs/fmi.md, "Feedthrough"). Knowns: Real inputs only (FMI 2.0 also
 * allows parameters as knowns for initial unknowns in Initialization Mode; this layer does not: a
 * parameter known is an error naming it), each with a finite dvKnown. Unknowns: Real outputs.
 * The FMU's state is not changed. */
fmi2Status fmi2GetDirectionalDerivative(fmi2Component component, const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
  CHECK_MODE(MASK_GET_VALUES);
  if (nUnknown == 0) return fmi2OK;
  CHECK_POINTER(vUnknown_ref);
  CHECK_POINTER(dvUnknown);
  if (nKnown) {
    CHECK_POINTER(vKnown_ref);
    CHECK_POINTER(dvKnown);
  }
  for (size_t i = 0; i < nKnown; ++i) {
    if (!derivative_variable(c, "known", "vKnown_ref", vKnown_ref, i, MODEL_input)) return fmi2Error;
    if (!isfinite(dvKnown[i]))
      return error(c, "%s: dvKnown[%zu] = %g for %s must be finite", __func__, i, dvKnown[i],
                   model_variable(vKnown_ref[i])->name);
  }
  for (size_t i = 0; i < nUnknown; ++i)
    if (!derivative_variable(c, "unknown", "vUnknown_ref", vUnknown_ref, i, MODEL_output)) return fmi2Error;
  if (model_directional_derivative(c->model, vKnown_ref, dvKnown, nKnown, vUnknown_ref, dvUnknown, nUnknown, c->msg,
                                   sizeof c->msg))
    return error(c, "%s: %s", __func__, c->msg);
  return fmi2OK;
}

/* ---- capabilities this FMU does not provide --------------------------------------------- */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
  (void)vr, (void)nvr, (void)order, (void)value;
  CHECK_MODE(MASK_SET_VALUES);
  return error(c, "fmi2SetRealInputDerivatives: not supported (canInterpolateInputs=\"false\")");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
  (void)vr, (void)nvr, (void)order, (void)value;
  CHECK_MODE(MASK_GET_VALUES);
  return error(c, "fmi2GetRealOutputDerivatives: not supported (maxOutputDerivativeOrder=\"0\")");
}

fmi2Status fmi2CancelStep(fmi2Component component) {
  CHECK_MODE(ANY_MODE);
  return error(c, "fmi2CancelStep: not supported: fmi2DoStep is synchronous and never pending");
}

/* ---- co-simulation ---------------------------------------------------------------------- */

fmi2Status fmi2DoStep(fmi2Component component, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize, fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
  (void)noSetFMUStatePriorToCurrentPoint;
  CHECK_MODE(StepComplete);
  double tc = currentCommunicationPoint, h = communicationStepSize;
  /* Time never runs backwards and stays finite (docs/reliability.md): the step is finite and
   * positive, tc is the FMU's time (the end of the last step, or the time of the state set by
   * fmi2SetFMUstate) up to the master's rounding, and the end tc + h is finite and later than
   * the FMU's time. c->time is finite: fmi2SetupExperiment and fmi2SetFMUstate check it. */
  if (h == 0.0 && c->discarded)
    /* FMI 2.0 (4.2.2): communicationStepSize must be > 0. A master that retries a discarded step
     * with the length fmi2LastSuccessfulTime allows (Maestro rolling back every FMU) asks for 0:
     * a discarded step changes nothing, so that time is the step's start. */
    return error(c,
                 "fmi2DoStep: communicationStepSize = 0 s at t = %.17g s; allowed: > 0 s (FMI 2.0). The step from "
                 "t = %g s to %g s was discarded and changed nothing (fmi2LastSuccessfulTime = %g s, the step's "
                 "start), so the master's step up to that time is empty: retry a shorter step (or change what the "
                 "discard names). The discard: %s",
                 c->time, c->discarded_tc, c->discarded_tc + c->discarded_h, c->time, c->discarded_msg);
  if (!(h > 0.0) || !isfinite(h))
    return error(c, "fmi2DoStep: communicationStepSize = %g s; allowed: finite and > 0 s (at most %g s from t = %.17g s)",
                 h, DBL_MAX - fabs(c->time), c->time);
  /* the master's time is the sum of its steps: allow its rounding, relative to the time (or to
   * the step near t = 0), nothing more */
  const double tolerance = 1e-9 * fmax(fabs(c->time), h);
  if (!isfinite(tc) || !(fabs(tc - c->time) <= tolerance))
    return error(c,
                 "fmi2DoStep: currentCommunicationPoint = %.17g s, but the FMU is at t = %.17g s; allowed: the end "
                 "of the last step (or the time of the state set by fmi2SetFMUstate) within %g s",
                 tc, c->time, tolerance);
  double end = tc + h;
  if (!isfinite(end) || !(end > c->time))
    return error(c,
                 "fmi2DoStep: step of communicationStepSize = %g s from t = %.17g s ends at %g s; allowed: a finite "
                 "end later than t",
                 h, tc, end);
  if (c->stop_defined && !(end <= c->stop_time + 1e-9 * fmax(1.0, fabs(c->stop_time))))
    return error(c, "fmi2DoStep: step to t = %.17g goes past stopTime = %.17g", end, c->stop_time);
  /* A master that retries a discarded step unchanged (Maestro's fixed step without rollback:
   * the same step with the same inputs, for ever) is refused: it would be discarded again. */
  if (c->discarded && tc == c->discarded_tc && h == c->discarded_h)
    return error(c,
                 "fmi2DoStep: the step from t = %g s to %g s was discarded by the last fmi2DoStep and nothing has "
                 "changed since (no input or parameter set to another value, no fmi2SetFMUstate): it would be "
                 "discarded again; allowed: a shorter step, other inputs, or fmi2SetFMUstate to roll back. The "
                 "discard: %s",
                 tc, end, c->discarded_msg);
  /* inputs are held over the step; the outputs published are those at tc + h */
  const int failed = model_evaluate(c->model, 0, end, h, c->msg, sizeof c->msg);
  if (failed == 2) { /* refused by the model: nothing changed, the instance stays usable, the
                        master may roll back or retry shorter */
    c->discarded = 1;
    c->discarded_tc = tc;
    c->discarded_h = h;
    snprintf(c->discarded_msg, sizeof c->discarded_msg, "%s", c->msg);
    return discard_step(c, "fmi2DoStep: step from t = %g s to %g s discarded: %s", tc, end, c->msg);
  }
  c->discarded = 0;
  if (failed) {
    c->mode = Error; /* only fmi2SetFMUstate or fmi2Reset recover */
    return error(c, "fmi2DoStep: t = %g s: %s", end, c->msg);
  }
  c->time = end;
  return fmi2OK;
}

fmi2Status fmi2GetStatus(fmi2Component component, const fmi2StatusKind s, fmi2Status* value) {
  CHECK_MODE(MASK_STATUS);
  CHECK_POINTER(value);
  return discard(c, "fmi2GetStatus(%d): not available: fmi2DoStep never returns fmi2Pending", (int)s);
}

fmi2Status fmi2GetRealStatus(fmi2Component component, const fmi2StatusKind s, fmi2Real* value) {
  CHECK_MODE(MASK_STATUS);
  CHECK_POINTER(value);
  if (s != fmi2LastSuccessfulTime) return discard(c, "fmi2GetRealStatus(%d): not available", (int)s);
  *value = c->time;
  return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component component, const fmi2StatusKind s, fmi2Integer* value) {
  CHECK_MODE(MASK_STATUS);
  CHECK_POINTER(value);
  return discard(c, "fmi2GetIntegerStatus(%d): not available", (int)s);
}

fmi2Status fmi2GetBooleanStatus(fmi2Component component, const fmi2StatusKind s, fmi2Boolean* value) {
  CHECK_MODE(MASK_STATUS);
  CHECK_POINTER(value);
  if (s != fmi2Terminated) return discard(c, "fmi2GetBooleanStatus(%d): not available", (int)s);
  *value = fmi2False; /* the FMU never asks to end the simulation */
  return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component component, const fmi2StatusKind s, fmi2String* value) {
  CHECK_MODE(MASK_STATUS);
  CHECK_POINTER(value);
  return discard(c, "fmi2GetStringStatus(%d): not available: fmi2DoStep never returns fmi2Pending", (int)s);
}
