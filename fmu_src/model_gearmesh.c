/* GearMesh behind model.h: the variable table bound to gm_fmu_values, the core model built
 * lazily from the parameters, one gm_evaluate per call. */
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "model.h"

struct fmu_model {
  gm_fmu_values v;
  gm_model* core;      /* built from v.p; NULL until needed */
  gm_data* data;       /* evaluation memory of core */
  int params_changed;  /* v.p differs from the parameters core was built from */
  int outputs_current; /* v.y was evaluated at the current v.p and v.k */
  fmu_log_fn log;
  void* log_context;
};

const gm_fmu_variable* model_variable(unsigned vr) {
  return vr < GM_FMU_VARIABLE_COUNT ? &gm_fmu_variables[vr] : NULL;
}

static void set_start_values(fmu_model* m) {
  memset(&m->v, 0, sizeof m->v); /* inputs: nominal pose, at rest */
  gm_default_params(&m->v.p);    /* parameters: the core's defaults, as in modelDescription.xml */
  m->params_changed = 1;
  m->outputs_current = 0;
}

static void drop_core(fmu_model* m) {
  gm_data_free(m->data);
  gm_model_free(m->core);
  m->data = NULL;
  m->core = NULL;
}

fmu_model* model_new(fmu_log_fn log, void* log_context) {
  fmu_model* m = calloc(1, sizeof *m);
  if (!m) return NULL;
  m->log = log;
  m->log_context = log_context;
  set_start_values(m);
  return m;
}

void model_free(fmu_model* m) {
  if (!m) return;
  drop_core(m);
  free(m);
}

void model_reset(fmu_model* m) {
  drop_core(m);
  set_start_values(m);
}

static void* field(const fmu_model* m, const gm_fmu_variable* v) {
  return (char*)&m->v + v->offset;
}

double model_get_real(const fmu_model* m, const gm_fmu_variable* v) {
  double x;
  memcpy(&x, field(m, v), sizeof x);
  return x;
}

int model_get_int(const fmu_model* m, const gm_fmu_variable* v) {
  int x;
  memcpy(&x, field(m, v), sizeof x);
  return x;
}

static void mark_changed(fmu_model* m, const gm_fmu_variable* v) {
  if (v->causality == GM_FMU_parameter) m->params_changed = 1;
  m->outputs_current = 0;
}

void model_set_real(fmu_model* m, const gm_fmu_variable* v, double x) {
  memcpy(field(m, v), &x, sizeof x);
  mark_changed(m, v);
}

void model_set_int(fmu_model* m, const gm_fmu_variable* v, int x) {
  if (v->type == GM_FMU_Boolean) x = x != 0;
  memcpy(field(m, v), &x, sizeof x);
  mark_changed(m, v);
}

/* A new core model and data for parameters p; nothing changes in m on failure. */
static int create_core(const gm_model_params* p, gm_model** core, gm_data** data, char* msg, size_t n) {
  gm_status s = gm_model_create(p, core, msg, n);
  if (s != GM_OK) return 1;
  if (gm_data_create(*core, data) != GM_OK) {
    snprintf(msg, n, "out of memory for the contact data");
    gm_model_free(*core);
    return 1;
  }
  return 0;
}

static void install_core(fmu_model* m, gm_model* core, gm_data* data) {
  drop_core(m);
  m->core = core;
  m->data = data;
  m->v.g = *gm_model_geometry(core);
  m->params_changed = 0;
}

int model_build(fmu_model* m, char* msg, size_t n) {
  if (m->core && !m->params_changed) return 0;
  gm_model* core;
  gm_data* data;
  if (create_core(&m->v.p, &core, &data, msg, n)) return 1;
  install_core(m, core, data);
  m->outputs_current = 0;
  return 0;
}

static const char* flank_name(int flank) {
  static const char* const names[] = {"none", "flank A", "flank B", "both flanks"};
  return flank >= 0 && flank <= 3 ? names[flank] : "?";
}

int model_evaluate(fmu_model* m, int restart, double time, char* msg, size_t n) {
  if (model_build(m, msg, n)) return 1;
  if (restart) gm_data_reset(m->core, m->data);
  gm_result r;
  if (gm_evaluate(m->core, m->data, &m->v.k, &r) != GM_OK) {
    snprintf(msg, n, "%s", gm_data_message(m->data));
    return 1;
  }
  if (restart || r.pairs_in_contact != m->v.y.pairs_in_contact || r.flank != m->v.y.flank)
    m->log(m->log_context, GM_LOG_CONTACT, "t = %g s: %d tooth pairs in contact, %s", time, r.pairs_in_contact,
           flank_name(r.flank));
  m->log(m->log_context, GM_LOG_SOLVER, "t = %g s: %d iterations, residual %g m", time, r.solver_iterations,
         r.solver_residual);
  m->v.y = r;
  m->outputs_current = 1;
  return 0;
}

const char* model_warnings(const fmu_model* m) {
  return m->core ? gm_model_warnings(m->core) : "";
}

int model_outputs_current(const fmu_model* m) {
  return m->outputs_current;
}

/* State payload, native byte order (the binary is per platform):
 *   u32 variable count | each parameter, input, output in table order (f64, or i32) |
 *   u8 flags (1 outputs current, 2 core built) | u64 core blob size | core blob
 * Calculated parameters are not stored: they follow from the parameters. */
static int stored(const gm_fmu_variable* v) {
  return v->causality != GM_FMU_calculatedParameter;
}

static size_t value_size(const gm_fmu_variable* v) {
  return v->type == GM_FMU_Real ? sizeof(double) : sizeof(int32_t);
}

enum { OUTPUTS_CURRENT = 1, CORE_BUILT = 2 };

/* The core's evaluation memory belongs to the state only if the core matches the parameters. */
static int core_built(const fmu_model* m) {
  return m->core && !m->params_changed;
}

size_t model_state_size(const fmu_model* m) {
  size_t n = sizeof(uint32_t) + sizeof(uint8_t) + sizeof(uint64_t);
  for (size_t i = 0; i < GM_FMU_VARIABLE_COUNT; i++)
    if (stored(&gm_fmu_variables[i])) n += value_size(&gm_fmu_variables[i]);
  return n + (core_built(m) ? gm_data_state_size(m->core, m->data) : 0);
}

void model_state_save(const fmu_model* m, unsigned char* buf) {
  uint32_t count = GM_FMU_VARIABLE_COUNT;
  memcpy(buf, &count, sizeof count);
  buf += sizeof count;
  for (size_t i = 0; i < GM_FMU_VARIABLE_COUNT; i++) {
    const gm_fmu_variable* v = &gm_fmu_variables[i];
    if (!stored(v)) continue;
    memcpy(buf, field(m, v), value_size(v)); /* int is int32_t on every FMI platform */
    buf += value_size(v);
  }
  *buf++ = (uint8_t)((m->outputs_current ? OUTPUTS_CURRENT : 0) | (core_built(m) ? CORE_BUILT : 0));
  uint64_t blob = core_built(m) ? gm_data_state_size(m->core, m->data) : 0;
  memcpy(buf, &blob, sizeof blob);
  buf += sizeof blob;
  if (blob) gm_data_state_save(m->core, m->data, buf, (size_t)blob);
}

static int same_parameters(const gm_fmu_values* a, const gm_fmu_values* b) {
  for (size_t i = 0; i < GM_FMU_VARIABLE_COUNT; i++) {
    const gm_fmu_variable* v = &gm_fmu_variables[i];
    if (v->causality == GM_FMU_parameter &&
        memcmp((const char*)a + v->offset, (const char*)b + v->offset, value_size(v)) != 0)
      return 0;
  }
  return 1;
}

int model_state_load(fmu_model* m, const unsigned char* buf, size_t size, char* msg, size_t n) {
  const unsigned char* end = buf + size;
  uint32_t count;
  size_t values = 0;
  for (size_t i = 0; i < GM_FMU_VARIABLE_COUNT; i++)
    if (stored(&gm_fmu_variables[i])) values += value_size(&gm_fmu_variables[i]);
  if (size < sizeof count + values + sizeof(uint8_t) + sizeof(uint64_t)) {
    snprintf(msg, n, "FMU state is truncated");
    return 1;
  }
  memcpy(&count, buf, sizeof count);
  buf += sizeof count;
  if (count != GM_FMU_VARIABLE_COUNT) {
    snprintf(msg, n, "FMU state holds %u variables, this FMU has %u", (unsigned)count,
             (unsigned)GM_FMU_VARIABLE_COUNT);
    return 1;
  }
  gm_fmu_values v = m->v;
  for (size_t i = 0; i < GM_FMU_VARIABLE_COUNT; i++) {
    const gm_fmu_variable* var = &gm_fmu_variables[i];
    if (!stored(var)) continue;
    memcpy((char*)&v + var->offset, buf, value_size(var));
    buf += value_size(var);
  }
  unsigned flags = *buf++;
  uint64_t blob;
  memcpy(&blob, buf, sizeof blob);
  buf += sizeof blob;
  if (blob != (uint64_t)(end - buf) || (blob && !(flags & CORE_BUILT))) {
    snprintf(msg, n, "FMU state: contact memory of %llu bytes, %zu present", (unsigned long long)blob,
             (size_t)(end - buf));
    return 1;
  }

  if (flags & CORE_BUILT) { /* restore the core's evaluation memory exactly */
    gm_model* core = m->core;
    gm_data* data = m->data;
    int fresh = !core || m->params_changed || !same_parameters(&v, &m->v);
    if (fresh && create_core(&v.p, &core, &data, msg, n)) return 1;
    if (gm_data_state_load(core, data, buf, (size_t)blob) != GM_OK) {
      snprintf(msg, n, "FMU state: %s", gm_data_message(data));
      if (fresh) {
        gm_data_free(data);
        gm_model_free(core);
      }
      return 1;
    }
    if (fresh) install_core(m, core, data);
    v.g = m->v.g;
    m->v = v;
    m->params_changed = 0;
  } else { /* taken before the core was built: build lazily, as after setting parameters */
    m->v = v;
    m->params_changed = 1;
  }
  m->outputs_current = (flags & OUTPUTS_CURRENT) && (flags & CORE_BUILT);
  return 0;
}
