/* What the FMI 2.0 and FMI 3.0 layers share (fmi_instance.h): an instance's life, log, call
 * sequence, values, FMU states, derivatives and step over model.h. Memory comes from malloc. */
#include "fmi_instance.h"

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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
static void vlog_if(const fmi_instance* c, fmi_status status, unsigned category, int always, const char* format,
                    va_list args) {
  always = always || category == MODEL_LOG_ERROR || category == MODEL_LOG_FATAL;
  if (!c->logger || !(always || (c->categories >> category & 1u))) return;
  char text[1200];
  vsnprintf(text, sizeof text, format, args);
  size_t n = strlen(text);
  while (n && (text[n - 1] == '\n' || text[n - 1] == '\r')) text[--n] = '\0';
  char safe[4 * sizeof text]; /* every byte escaped at most to 4 */
  utf8_escape(text, n, safe);
  c->logger(c->environment, c->name, status, model_log_category_name(category), safe);
}

void fmi_log_event(const fmi_instance* c, const char* format, ...) {
  va_list args;
  va_start(args, format);
  vlog_if(c, FMI_OK, MODEL_LOG_EVENTS, 0, format, args);
  va_end(args);
}

fmi_status fmi_error(const fmi_instance* c, const char* format, ...) {
  va_list args;
  va_start(args, format);
  vlog_if(c, FMI_ERROR, MODEL_LOG_ERROR, 0, format, args);
  va_end(args);
  return FMI_ERROR;
}

void fmi_warning(const fmi_instance* c, const char* format, ...) {
  va_list args;
  va_start(args, format);
  vlog_if(c, FMI_WARNING, MODEL_LOG_WARNING, 0, format, args);
  va_end(args);
}

fmi_status fmi_discard(const fmi_instance* c, const char* format, ...) {
  va_list args;
  va_start(args, format);
  vlog_if(c, FMI_DISCARD, MODEL_LOG_WARNING, 0, format, args);
  va_end(args);
  return FMI_DISCARD;
}

/* A step refused, changing nothing (status Discard). The reason goes out whatever categories
 * are enabled, as errors do, under logStatusWarning with the message status Warning: importers
 * filter their log by that status, and some show a message of status Discard only when
 * debugging (libcosim: at its debug level), or get none while logging is off (Maestro's
 * default), so a master's "step not complete" came without its reason (docs/guide/masters.md). */
static fmi_status discard_step(const fmi_instance* c, const char* format, ...) {
  va_list args;
  va_start(args, format);
  vlog_if(c, FMI_WARNING, MODEL_LOG_WARNING, 1, format, args);
  va_end(args);
  return FMI_DISCARD;
}

static void model_log(void* context, unsigned category, const char* format, ...) {
  va_list args;
  va_start(args, format);
  vlog_if(context, FMI_OK, category, 0, format, args);
  va_end(args);
}

/* ---- call sequence ---------------------------------------------------------------------- */

static const char* mode_name(const fmi_instance* c) {
  switch (c->mode) {
    case FMI_INSTANTIATED: return "Instantiated";
    case FMI_INITIALIZATION: return "Initialization Mode";
    case FMI_STEP: return c->api->step_mode;
    case FMI_TERMINATED: return "terminated";
    case FMI_CONFIGURATION: return "Configuration Mode";
    default: return "error";
  }
}

int fmi_illegal(const fmi_instance* c, const char* function, unsigned allowed) {
  if (!c) return 1;
  if (c->mode & allowed) return 0;
  fmi_error(c, "%s: Illegal call sequence (instance is in %s)", function, mode_name(c));
  return 1;
}

/* ---- life ------------------------------------------------------------------------------- */

static char* copy_string(const char* s) {
  size_t n = strlen(s) + 1;
  char* copy = malloc(n);
  if (copy) memcpy(copy, s, n);
  return copy;
}

fmi_instance* fmi_instantiate(const char* function, const fmi_instance* probe, const char* instance_name,
                              int logging_on, char* resources, const char* resources_warning) {
  fmi_instance* c = calloc(1, sizeof *c);
  if (!c) {
    fmi_error(probe, "%s: out of memory", function);
    free(resources);
    return NULL;
  }
  *c = *probe;
  c->name = copy_string(instance_name);
  c->model = model_new(model_log, c);
  c->resources = resources;
  if (!c->name || !c->model) {
    fmi_error(probe, "%s: out of memory", function);
    free(c->name);
    model_free(c->model);
    free(c->resources);
    free(c);
    return NULL;
  }
  c->categories = logging_on ? all_categories() : 0u;
  c->mode = FMI_INSTANTIATED;
  if (resources_warning) fmi_warning(c, "%s: %s", function, resources_warning);
  fmi_log_event(c, "%s: resources at %s", function, c->resources ? c->resources : "(none)");
  /* a model may read data files and start values from resources/ (model_set_resources) */
  if (model_set_resources(c->model, c->resources, c->msg, sizeof c->msg)) {
    fmi_error(c, "%s: %s", function, c->msg);
    fmi_free(c);
    return NULL;
  }
  return c;
}

void fmi_free(fmi_instance* c) {
  if (!c) return;
  for (size_t i = 0; i < c->n_states; i++) free(c->states[i]); /* states not freed by the importer */
  free(c->states);
  model_free(c->model);
  free(c->resources);
  free(c->name);
  free(c);
}

fmi_status fmi_set_debug_logging(fmi_instance* c, const char* function, int logging_on, size_t n,
                                 const char* const categories[]) {
  if (n == 0) {
    c->categories = logging_on ? all_categories() : 0u;
    return FMI_OK;
  }
  if (!categories) return fmi_error(c, "%s: argument categories must not be NULL", function);
  unsigned bits = 0;
  for (size_t i = 0; i < n; i++) {
    unsigned bit = 0;
    for (unsigned k = 0; k < model_log_category_count(); k++)
      if (categories[i] && strcmp(categories[i], model_log_category_name(k)) == 0) bit = 1u << k;
    if (!bit)
      return fmi_error(c, "%s: unknown log category '%s'", function, categories[i] ? categories[i] : "(NULL)");
    bits |= bit == 1u << MODEL_LOG_ALL ? all_categories() : bit;
  }
  c->categories = logging_on ? c->categories | bits : c->categories & ~bits;
  return FMI_OK;
}

fmi_status fmi_setup(fmi_instance* c, const char* function, double start, int stop_defined, double stop) {
  if (!isfinite(start)) return fmi_error(c, "%s: startTime = %g is not finite", function, start);
  if (stop_defined && !(stop >= start))
    return fmi_error(c, "%s: stopTime = %g is before startTime = %g", function, stop, start);
  c->time = start;
  c->stop_defined = stop_defined != 0;
  c->stop_time = stop;
  return FMI_OK;
}

fmi_status fmi_enter_initialization(fmi_instance* c, const char* function) {
  c->mode = FMI_INITIALIZATION;
  fmi_log_event(c, "%s at t = %g s", function, c->time);
  return FMI_OK;
}

fmi_status fmi_exit_initialization(fmi_instance* c, const char* function) {
  /* outputs at the start time; on a parameter or input error the instance stays in
   * Initialization Mode so that the value can be corrected */
  if (!model_outputs_current(c->model) && model_evaluate(c->model, 1, c->time, 0.0, c->msg, sizeof c->msg))
    return fmi_error(c, "%s: %s", function, c->msg);
  c->mode = FMI_STEP;
  fmi_log_event(c, "%s: %s at t = %g s", function, c->api->step_mode, c->time);
  /* the model's warnings about its parameters are never silent: status Warning */
  const char* warnings = model_warnings(c->model);
  if (warnings[0]) {
    fmi_warning(c, "%s: %s", function, warnings);
    return FMI_WARNING;
  }
  return FMI_OK;
}

fmi_status fmi_terminate(fmi_instance* c, const char* function) {
  c->mode = FMI_TERMINATED;
  fmi_log_event(c, "%s at t = %g s", function, c->time);
  return FMI_OK;
}

fmi_status fmi_reset(fmi_instance* c, const char* function) {
  if (model_reset(c->model)) {
    c->mode = FMI_ERROR_MODE;
    return fmi_error(c, "%s: out of memory for the start values", function);
  }
  c->mode = FMI_INSTANTIATED;
  c->time = 0.0;
  c->stop_defined = 0;
  c->discarded = 0;
  fmi_log_event(c, "%s: start values, Instantiated", function);
  return FMI_OK;
}

/* ---- values ----------------------------------------------------------------------------- */

static const char* const type_names[] = {"Real", "Integer", "Boolean", "String"};
static const char* const causality_names[] = {"parameter", "calculatedParameter", "input", "output"};

/* The variable of value reference vr if it has the given type, else NULL (logged). */
static const model_variable_info* variable(const fmi_instance* c, const char* function, unsigned vr,
                                           model_type type) {
  const model_variable_info* v = model_variable(vr);
  if (v && v->type == type && vr >= MODEL_ELEMENT_VR_BASE) { /* an array's element: within its length now */
    const size_t length = model_array_length(c->model, MODEL_ELEMENT_ARRAY(vr));
    if (MODEL_ELEMENT_INDEX(vr) < length) return v;
    fmi_error(c, "%s: value reference %u is element %u of %s, which has %zu elements; allowed: 0 to %zu", function,
              vr, MODEL_ELEMENT_INDEX(vr), v->name, length, length ? length - 1 : 0);
    return NULL;
  }
  if (v && v->type == type) return v;
  fmi_error(c, "%s: value reference %u is not a variable of type %s", function, vr, type_names[type]);
  return NULL;
}

static int get_bool(const void* values, size_t i, size_t bool_size) {
  if (bool_size == 1) return ((const unsigned char*)values)[i] != 0;
  return ((const int*)values)[i];
}

fmi_status fmi_get_values(fmi_instance* c, const char* function, model_type type, const unsigned vr[], size_t nvr,
                          void* values, size_t bool_size) {
  if (nvr == 0) return FMI_OK;
  if (!vr || !values) return fmi_error(c, "%s: vr[] and value[] must not be NULL", function);
  int outputs = 0, calculated = 0;
  for (size_t i = 0; i < nvr; i++) {
    const model_variable_info* v = variable(c, function, vr[i], type);
    if (!v) return FMI_ERROR;
    outputs |= v->causality == MODEL_output;
    calculated |= v->causality == MODEL_calculatedParameter;
  }
  /* Set/get iteration: outputs read after inputs were set are evaluated at the current values,
   * from scratch in Initialization Mode, else at the communication point (direct feedthrough,
   * docs/fmi.md "Feedthrough"). */
  if (outputs && !model_outputs_current(c->model) &&
      (c->mode == FMI_INITIALIZATION ? model_evaluate(c->model, 1, c->time, 0.0, c->msg, sizeof c->msg)
                                     : model_feedthrough(c->model, c->time, c->msg, sizeof c->msg)))
    return fmi_error(c, "%s: %s", function, c->msg);
  if (calculated && c->mode == FMI_INITIALIZATION && model_build(c->model, c->msg, sizeof c->msg))
    return fmi_error(c, "%s: %s", function, c->msg);
  for (size_t i = 0; i < nvr; i++) {
    if (type == MODEL_Real) ((double*)values)[i] = model_get_real(c->model, vr[i]);
    else if (type == MODEL_String) ((const char**)values)[i] = model_get_string(c->model, vr[i]);
    else if (type == MODEL_Boolean && bool_size == 1) ((unsigned char*)values)[i] = model_get_int(c->model, vr[i]) != 0;
    else ((int*)values)[i] = model_get_int(c->model, vr[i]);
  }
  return FMI_OK;
}

/* All values are checked (and strings copied) before any is set, so a refused call changes
 * nothing. The instance owns a copy of every string it is given. */
fmi_status fmi_set_values(fmi_instance* c, const char* function, model_type type, const unsigned vr[], size_t nvr,
                          const void* values, size_t bool_size) {
  if (nvr == 0) return FMI_OK;
  if (!vr || !values) return fmi_error(c, "%s: vr[] and value[] must not be NULL", function);
  char** copies = NULL;
  for (size_t i = 0; i < nvr; i++) {
    const model_variable_info* v = variable(c, function, vr[i], type);
    if (!v) return FMI_ERROR;
    if (v->causality == MODEL_parameter && v->variability == MODEL_fixed &&
        !(c->mode & (FMI_INSTANTIATED | FMI_INITIALIZATION | FMI_CONFIGURATION)))
      return fmi_error(c, "%s: %s is a fixed parameter, settable only before %sExitInitializationMode", function,
                       v->name, c->api->prefix);
    if (v->causality != MODEL_parameter && v->causality != MODEL_input)
      return fmi_error(c, "%s: %s is %s and cannot be set", function, v->name,
                       v->causality == MODEL_output ? "an output" : "a calculated parameter");
    if (type == MODEL_Real && !isfinite(((const double*)values)[i]))
      return fmi_error(c, "%s: %s = %g is not finite; it keeps %g", function, v->name, ((const double*)values)[i],
                       model_get_real(c->model, vr[i]));
    if (type == MODEL_String && !((const char* const*)values)[i])
      return fmi_error(c, "%s: %s = NULL: a String value must not be NULL (\"\" for none); it keeps \"%s\"",
                       function, v->name, model_get_string(c->model, vr[i]));
  }
  if (type == MODEL_String) {
    copies = calloc(nvr, sizeof *copies);
    for (size_t i = 0; copies && i < nvr; i++) {
      if ((copies[i] = copy_string(((const char* const*)values)[i]))) continue;
      while (i) free(copies[--i]);
      free(copies);
      copies = NULL;
    }
    if (!copies) return fmi_error(c, "%s: out of memory for the strings", function);
  }
  for (size_t i = 0; i < nvr && c->discarded; i++) /* a discarded step may succeed now */
    if (type == MODEL_Real) {
      const double now = model_get_real(c->model, vr[i]), x = ((const double*)values)[i];
      c->discarded = memcmp(&now, &x, sizeof x) == 0;
    } else if (type == MODEL_String) {
      c->discarded = strcmp(model_get_string(c->model, vr[i]), ((const char* const*)values)[i]) == 0;
    } else if (type == MODEL_Boolean) {
      c->discarded = (model_get_int(c->model, vr[i]) != 0) == get_bool(values, i, bool_size);
    } else {
      c->discarded = model_get_int(c->model, vr[i]) == ((const int*)values)[i];
    }
  for (size_t i = 0; i < nvr; i++) {
    if (type == MODEL_Real) model_set_real(c->model, vr[i], ((const double*)values)[i]);
    else if (type == MODEL_String) model_set_string(c->model, vr[i], copies[i]);
    else if (type == MODEL_Boolean) model_set_int(c->model, vr[i], get_bool(values, i, bool_size));
    else model_set_int(c->model, vr[i], ((const int*)values)[i]);
  }
  free(copies);
  return FMI_OK;
}

/* ---- FMU state -------------------------------------------------------------------------- */

/* Serialized FMU state, native byte order (the binary is per platform):
 *   modelIdentifier, cut or NUL-padded to 8 bytes | u32 format version |
 *   GUID, NUL-padded to 40 bytes | u64 payload size |
 *   u64 checksum | payload
 *   payload = f64 time | u32 mode | model payload (model_state_save)
 * Format 3: the checksum, 64-bit FNV-1a over every byte of the blob except the checksum field
 * itself (header and payload); format 2 had none, format 1 no String values either.
 * An FMU state holds exactly these bytes: taking, copying and serializing a state are one
 * path, and a state owns all its data (no pointer into the instance). Setting and
 * deserializing a state check magic, format, size, checksum and GUID before anything is
 * applied; a corrupted blob is refused with an error and the instance is unchanged
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
static size_t check_state(const fmi_instance* c, const char* function, const unsigned char* bytes, size_t size) {
  unsigned char own[12 + STATE_GUID_SIZE];
  state_identity(own);
  uint32_t format;
  uint64_t payload, stored;
  if (size < 12 || memcmp(bytes, own, 8) != 0) {
    fmi_error(c, "%s: not a %s FMU state (%zu bytes; it must start with \"%.8s\")", function, model_identifier, size,
              model_identifier);
    return 0;
  }
  memcpy(&format, bytes + 8, sizeof format);
  if (format != STATE_FORMAT) {
    fmi_error(c, "%s: FMU state format %u, this FMU reads format %u only", function, (unsigned)format, STATE_FORMAT);
    return 0;
  }
  if (size < STATE_HEADER_SIZE) {
    fmi_error(c, "%s: FMU state is truncated (%zu bytes, the header alone has %d)", function, size, STATE_HEADER_SIZE);
    return 0;
  }
  memcpy(&payload, bytes + STATE_SIZE_OFFSET, sizeof payload);
  if (payload != size - STATE_HEADER_SIZE || payload < STATE_PAYLOAD_OFFSET) {
    fmi_error(c, "%s: FMU state is truncated or padded (%zu bytes, header says %llu)", function, size,
              (unsigned long long)(payload + STATE_HEADER_SIZE));
    return 0;
  }
  memcpy(&stored, bytes + STATE_CHECKSUM_OFFSET, sizeof stored);
  const uint64_t computed = state_checksum(bytes, size);
  if (stored != computed) {
    fmi_error(c, "%s: FMU state is corrupted: checksum 0x%016llx, the %zu bytes give 0x%016llx; nothing was restored",
              function, (unsigned long long)stored, size, (unsigned long long)computed);
    return 0;
  }
  if (memcmp(bytes + 12, own + 12, STATE_GUID_SIZE) != 0) {
    fmi_error(c, "%s: FMU state is from another %s build (GUID %.*s, this build's %s)", function, model_identifier,
              STATE_GUID_SIZE, (const char*)bytes + 12, model_guid);
    return 0;
  }
  return (size_t)payload;
}

/* The index of state s among the instance's, or n_states if it is not one of them. */
static size_t state_index(const fmi_instance* c, const void* s) {
  size_t i = 0;
  while (i < c->n_states && c->states[i] != s) i++;
  return i;
}

/* 0 if s is a state of this instance, else FMI_ERROR naming the function and the pointer. */
static int foreign_state(const fmi_instance* c, const char* function, const void* s) {
  if (state_index(c, s) < c->n_states) return 0;
  fmi_error(c, "%s: FMU state %p was not made by this instance (%sGet%s or %sDeSerialize%s) or was freed", function,
            s, c->api->prefix, c->api->state, c->api->prefix, c->api->state);
  return 1;
}

/* *slot: NULL or a state of this instance, reallocated to hold `bytes` more than the header (a
 * previous state of ours is reused). NULL (nothing changed) on an unknown pointer or no memory. */
static fmu_state* state_for(fmi_instance* c, const char* function, void** slot, size_t bytes) {
  const size_t i = *slot ? state_index(c, *slot) : c->n_states;
  if (*slot && i == c->n_states) {
    fmi_error(c, "%s: *%s = %p was not made by this instance; allowed: NULL (a new state) or a state "
                 "this instance made",
              function, c->api->state, *slot);
    return NULL;
  }
  if (!*slot && c->n_states == c->cap_states) {
    const size_t cap = c->cap_states ? 2 * c->cap_states : 4;
    void** grown = realloc(c->states, cap * sizeof *grown);
    if (!grown) return fmi_error(c, "%s: out of memory", function), NULL;
    c->states = grown;
    c->cap_states = cap;
  }
  fmu_state* s = realloc(*slot, sizeof *s + bytes);
  if (!s) return fmi_error(c, "%s: out of memory", function), NULL;
  if (*slot) c->states[i] = s;
  else c->states[c->n_states++] = s;
  *slot = s;
  return s;
}

fmi_status fmi_get_state(fmi_instance* c, const char* function, void** state) {
  if (!state) return fmi_error(c, "%s: argument %s must not be NULL", function, c->api->state);
  uint64_t payload = STATE_PAYLOAD_OFFSET + model_state_size(c->model);
  size_t size = STATE_HEADER_SIZE + (size_t)payload;
  fmu_state* s = state_for(c, function, state, size);
  if (!s) return FMI_ERROR;
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
  return FMI_OK;
}

fmi_status fmi_set_state(fmi_instance* c, const char* function, void* state) {
  if (!state) return fmi_error(c, "%s: argument %s must not be NULL", function, c->api->state);
  if (foreign_state(c, function, state)) return FMI_ERROR;
  const fmu_state* s = state;
  size_t payload = check_state(c, function, s->bytes, s->size);
  if (!payload) return FMI_ERROR;
  const unsigned char* b = s->bytes + STATE_HEADER_SIZE;
  double time;
  uint32_t mode;
  memcpy(&time, b, 8);
  memcpy(&mode, b + 8, 4);
  if (!(mode & FMI_MASK_GET_STATE) || (mode & (mode - 1)) || !isfinite(time))
    return fmi_error(c, "%s: FMU state has an invalid mode or time", function);
  if (model_state_load(c->model, b + STATE_PAYLOAD_OFFSET, payload - STATE_PAYLOAD_OFFSET, c->msg, sizeof c->msg))
    return fmi_error(c, "%s: %s", function, c->msg);
  c->time = time;
  c->mode = (fmi_mode)mode;
  c->discarded = 0;
  return FMI_OK;
}

fmi_status fmi_free_state(fmi_instance* c, const char* function, void** state) {
  if (!state || !*state) return FMI_OK;
  if (foreign_state(c, function, *state)) return FMI_ERROR;
  const size_t i = state_index(c, *state);
  c->states[i] = c->states[--c->n_states];
  free(*state);
  *state = NULL;
  return FMI_OK;
}

fmi_status fmi_state_size(fmi_instance* c, const char* function, void* state, size_t* size) {
  if (!state) return fmi_error(c, "%s: argument %s must not be NULL", function, c->api->state);
  if (!size) return fmi_error(c, "%s: argument size must not be NULL", function);
  if (foreign_state(c, function, state)) return FMI_ERROR;
  *size = ((const fmu_state*)state)->size;
  return FMI_OK;
}

fmi_status fmi_serialize_state(fmi_instance* c, const char* function, void* state, unsigned char* buffer,
                               size_t size) {
  if (!state) return fmi_error(c, "%s: argument %s must not be NULL", function, c->api->state);
  if (!buffer) return fmi_error(c, "%s: argument serializedState must not be NULL", function);
  if (foreign_state(c, function, state)) return FMI_ERROR;
  const fmu_state* s = state;
  if (size < s->size) return fmi_error(c, "%s: buffer of %zu bytes, the state needs %zu", function, size, s->size);
  memcpy(buffer, s->bytes, s->size);
  return FMI_OK;
}

fmi_status fmi_deserialize_state(fmi_instance* c, const char* function, const unsigned char* buffer, size_t size,
                                 void** state) {
  if (!buffer) return fmi_error(c, "%s: argument serializedState must not be NULL", function);
  if (!state) return fmi_error(c, "%s: argument %s must not be NULL", function, c->api->state);
  if (!check_state(c, function, buffer, size)) return FMI_ERROR;
  fmu_state* s = state_for(c, function, state, size);
  if (!s) return FMI_ERROR;
  s->size = size;
  memcpy(s->bytes, buffer, size);
  return FMI_OK;
}

/* ---- directional derivatives ------------------------------------------------------------ */

/* 1 if refs[i] is a Real variable of the given causality, else 0 (logged, naming the role the
 * knowns or unknowns play). */
static int derivative_variable(const fmi_instance* c, const char* function, const char* role, const char* array,
                               const unsigned refs[], size_t i, model_causality causality) {
  const model_variable_info* v = model_variable(refs[i]);
  if (!v) {
    fmi_error(c, "%s: %s[%zu] = %u is not a value reference of this FMU", function, array, i, refs[i]);
    return 0;
  }
  if (v->type == MODEL_Real && v->causality == causality) return 1;
  fmi_error(c, "%s: %s %s (value reference %u) is a %s %s; the %ss must be Real %ss%s", function, role, v->name,
            refs[i], causality_names[v->causality], type_names[v->type], role, causality_names[causality],
            causality == MODEL_input ? " (parameters as knowns, for initial unknowns in Initialization Mode, are not "
                                       "supported)"
                                     : "");
  return 0;
}

fmi_status fmi_directional_derivative(fmi_instance* c, const char* function, const unsigned unknown[],
                                      size_t n_unknown, const unsigned known[], size_t n_known, const double seed[],
                                      double sensitivity[]) {
  if (n_unknown == 0) return FMI_OK;
  if (!unknown || !sensitivity)
    return fmi_error(c, "%s: the unknowns' value references and the result must not be NULL", function);
  if (n_known && (!known || !seed))
    return fmi_error(c, "%s: the knowns' value references and the seed must not be NULL", function);
  for (size_t i = 0; i < n_known; ++i) {
    if (!derivative_variable(c, function, "known", "vKnown_ref", known, i, MODEL_input)) return FMI_ERROR;
    if (!isfinite(seed[i]))
      return fmi_error(c, "%s: dvKnown[%zu] = %g for %s must be finite", function, i, seed[i],
                       model_variable(known[i])->name);
  }
  for (size_t i = 0; i < n_unknown; ++i)
    if (!derivative_variable(c, function, "unknown", "vUnknown_ref", unknown, i, MODEL_output)) return FMI_ERROR;
  if (model_directional_derivative(c->model, known, seed, n_known, unknown, sensitivity, n_unknown, c->msg,
                                   sizeof c->msg))
    return fmi_error(c, "%s: %s", function, c->msg);
  return FMI_OK;
}

/* ---- the step --------------------------------------------------------------------------- */

fmi_status fmi_do_step(fmi_instance* c, const char* function, double tc, double h) {
  /* Time never runs backwards and stays finite (docs/reliability.md): the step is finite and
   * positive, tc is the FMU's time (the end of the last step, or the time of the state set) up
   * to the master's rounding, and the end tc + h is finite and later than the FMU's time.
   * c->time is finite: the setup and setting a state check it. */
  if (h == 0.0 && c->discarded)
    /* communicationStepSize must be > 0. A master that retries a discarded step with the length
     * the last successful time allows (Maestro rolling back every FMU) asks for 0: a discarded
     * step changes nothing, so that time is the step's start. */
    return fmi_error(c,
                     "%s: communicationStepSize = 0 s at t = %.17g s; allowed: > 0 s (%s). The step from "
                     "t = %g s to %g s was discarded and changed nothing (%s = %g s, the step's "
                     "start), so the master's step up to that time is empty: retry a shorter step (or change what "
                     "the discard names). The discard: %s",
                     function, c->time, c->api->standard, c->discarded_tc, c->discarded_tc + c->discarded_h,
                     c->api->last_time, c->time, c->discarded_msg);
  if (!(h > 0.0) || !isfinite(h))
    return fmi_error(c, "%s: communicationStepSize = %g s; allowed: finite and > 0 s (at most %g s from t = %.17g s)",
                     function, h, DBL_MAX - fabs(c->time), c->time);
  /* the master's time is the sum of its steps: allow its rounding, relative to the time (or to
   * the step near t = 0), nothing more */
  const double tolerance = 1e-9 * fmax(fabs(c->time), h);
  if (!isfinite(tc) || !(fabs(tc - c->time) <= tolerance))
    return fmi_error(c,
                     "%s: currentCommunicationPoint = %.17g s, but the FMU is at t = %.17g s; allowed: the end "
                     "of the last step (or the time of the state set by %sSet%s) within %g s",
                     function, tc, c->time, c->api->prefix, c->api->state, tolerance);
  double end = tc + h;
  if (!isfinite(end) || !(end > c->time))
    return fmi_error(c,
                     "%s: step of communicationStepSize = %g s from t = %.17g s ends at %g s; allowed: a finite "
                     "end later than t",
                     function, h, tc, end);
  if (c->stop_defined && !(end <= c->stop_time + 1e-9 * fmax(1.0, fabs(c->stop_time))))
    return fmi_error(c, "%s: step to t = %.17g goes past stopTime = %.17g", function, end, c->stop_time);
  /* A master that retries a discarded step unchanged (Maestro's fixed step without rollback:
   * the same step with the same inputs, for ever) is refused: it would be discarded again. */
  if (c->discarded && tc == c->discarded_tc && h == c->discarded_h)
    return fmi_error(c,
                     "%s: the step from t = %g s to %g s was discarded by the last %sDoStep and nothing has "
                     "changed since (no input or parameter set to another value, no %sSet%s): it would be "
                     "discarded again; allowed: a shorter step, other inputs, or %sSet%s to roll back. The "
                     "discard: %s",
                     function, tc, end, c->api->prefix, c->api->prefix, c->api->state, c->api->prefix, c->api->state,
                     c->discarded_msg);
  /* inputs are held over the step; the outputs published are those at tc + h */
  const int failed = model_evaluate(c->model, 0, end, h, c->msg, sizeof c->msg);
  if (failed == 2) { /* refused by the model: nothing changed, the instance stays usable, the
                        master may roll back or retry shorter */
    c->discarded = 1;
    c->discarded_tc = tc;
    c->discarded_h = h;
    snprintf(c->discarded_msg, sizeof c->discarded_msg, "%s", c->msg);
    return discard_step(c, "%s: step from t = %g s to %g s discarded: %s", function, tc, end, c->msg);
  }
  c->discarded = 0;
  if (failed) {
    c->mode = FMI_ERROR_MODE; /* only setting a state or a reset recover */
    return fmi_error(c, "%s: t = %g s: %s", function, end, c->msg);
  }
  c->time = end;
  return FMI_OK;
}
