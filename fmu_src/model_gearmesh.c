/* GearMesh behind model.h: the variable table (modelDescription/variables.h) bound to
 * gm_fmu_values, the core model built lazily from the parameters, one gm_evaluate per call. All
 * that the generic FMI layer (fmi2_functions.c) may know of GearMesh comes through here. */
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "model.h"
#include "core_params.h"
#include "values.h"

struct fmu_model {
  gm_fmu_values v;
  gm_fmu_values start; /* start values: the core's defaults, or a scene FMU's */
  char* resources;     /* local resources directory ending in '/', or NULL */
  gm_model* core;      /* built from v.p; NULL until needed */
  gm_data* data;       /* evaluation memory of core */
  gm_data* scratch;    /* model_feedthrough's: NULL until the first one */
  int params_changed;  /* v.p differs from the parameters core was built from */
  int outputs_current; /* v.y and v.ds belong to the current v.p and v.k */
  int evaluated;       /* k_eval holds the inputs of the last model_evaluate */
  gm_kinematics k_eval; /* those inputs (held over the last step): the TE jump check's reference */
  int unloaded_points;  /* large-step: communication points in a row with both gears loaded and no contact */
  double unloaded_since; /* the time of the first of them, s */
  int warned_unloaded;  /* the warning that the mesh carries nothing was given */
  /* dynamics.step_sensitivities: the last fmi2DoStep's sensitivity, its duration (s); valid once
   * a step made it, forgotten by a restart, a state set and new parameters */
  gm_step_sensitivity sens;
  double sens_step;
  int sens_valid;
  /* model_set_intermediate's hook, and the time the step in progress started and ends at, s */
  model_intermediate_fn intermediate;
  void* intermediate_context;
  double step_start, step_end;
  gm_fmu_load saved_load; /* the arrays before that step, which a failed step restores */
  fmu_log_fn log;
  void* log_context;
};

const char model_identifier[] = "GearMesh";
const char model_guid[] = GM_FMU_GUID;
_Static_assert(sizeof GM_FMU_GUID <= MODEL_GUID_SIZE, "the GUID does not fit an FMU state's header");

/* The table's FMI attributes, as model.h gives them to the generic layer. */
static const model_variable_info variable_info[] = {
#define INFO(name, type, causality, variability, ...) {name, MODEL_##type, MODEL_##causality, MODEL_##variability},
    GM_FMU_VARIABLES(INFO)
#undef INFO
};

static const model_variable_info array_info[] = {
#define INFO(name, causality, variability, ...) {name, MODEL_Real, MODEL_##causality, MODEL_##variability},
    GM_FMU_ARRAYS(INFO)
#undef INFO
};

/* An array element's value reference (model.h, MODEL_ELEMENT_VR) within the largest its array
 * can be; model_array_length bounds it at the current structural parameters. */
static int element_vr(unsigned vr) {
  return vr >= MODEL_ELEMENT_VR_BASE && MODEL_ELEMENT_ARRAY(vr) < GM_FMU_ARRAY_COUNT &&
         MODEL_ELEMENT_INDEX(vr) < gm_fmu_arrays[MODEL_ELEMENT_ARRAY(vr)].capacity;
}

const model_variable_info* model_variable(unsigned vr) {
  if (element_vr(vr)) return &array_info[MODEL_ELEMENT_ARRAY(vr)];
  return vr < GM_FMU_VARIABLE_COUNT ? &variable_info[vr] : NULL;
}

int model_variable_structural(unsigned vr) {
  return vr < GM_FMU_VARIABLE_COUNT && gm_fmu_structural(gm_fmu_variables[vr].name);
}

unsigned model_array_count(void) {
  return (unsigned)GM_FMU_ARRAY_COUNT;
}

size_t model_array_length(const fmu_model* m, unsigned a) {
  return a < GM_FMU_ARRAY_COUNT ? gm_fmu_array_length(&gm_fmu_arrays[a], &m->v) : 0;
}

unsigned model_variable_count(void) {
  return (unsigned)GM_FMU_VARIABLE_COUNT;
}

int model_variable_intermediate(unsigned vr) {
  if (element_vr(vr)) return gm_fmu_array_intermediate(&gm_fmu_arrays[MODEL_ELEMENT_ARRAY(vr)]);
  return vr < GM_FMU_VARIABLE_COUNT && gm_fmu_follows_spins(&gm_fmu_variables[vr]);
}

static const char* const log_category_names[] = {
#define L(id, name, description) name,
    GM_FMU_LOG_CATEGORIES(L)
#undef L
};
_Static_assert((int)GM_LOG_EVENTS == MODEL_LOG_EVENTS && (int)GM_LOG_WARNING == MODEL_LOG_WARNING &&
                   (int)GM_LOG_ERROR == MODEL_LOG_ERROR && (int)GM_LOG_FATAL == MODEL_LOG_FATAL &&
                   (int)GM_LOG_ALL == MODEL_LOG_ALL && GM_LOG_COUNT < 32,
               "the generic layer's log categories come first, in model.h's order");

unsigned model_log_category_count(void) {
  return GM_LOG_COUNT;
}

const char* model_log_category_name(unsigned category) {
  return log_category_names[category];
}

static int set_start_values(fmu_model* m) {
  m->sens_valid = 0;
  values_free_strings(&m->v);
  int failed = values_copy(&m->v, &m->start);
  m->params_changed = 1;
  m->outputs_current = 0;
  m->evaluated = 0;
  return failed;
}

static void drop_core(fmu_model* m) {
  gm_data_free(m->scratch);
  gm_data_free(m->data);
  gm_model_free(m->core);
  m->scratch = NULL;
  m->data = NULL;
  m->core = NULL;
}

/* GearMesh's start values: the core's defaults (parameters), the nominal pose at rest (inputs). */
fmu_model* model_new(fmu_log_fn log, void* log_context) {
  fmu_model* m = calloc(1, sizeof *m);
  if (!m) return NULL;
  m->log = log;
  m->log_context = log_context;
  gm_fmu_values defaults;
  memset(&defaults, 0, sizeof defaults); /* inputs: nominal pose, at rest */
  gm_default_params(&defaults.p);        /* parameters: the core's defaults, as in modelDescription.xml */
  gm_dynamics_default_params(&defaults.dp);
  defaults.mesh_damping_ratio = GM_MESH_DAMPING_RATIO;
  /* the instance owns its strings, also the start values of String parameters */
  if (values_copy(&m->start, &defaults) || set_start_values(m)) {
    model_free(m);
    return NULL;
  }
  return m;
}

void model_free(fmu_model* m) {
  if (!m) return;
  drop_core(m);
  values_free_strings(&m->v);
  values_free_strings(&m->start);
  free(m->resources);
  free(m);
}

/* GearMesh: file names in String parameters are resolved against resources, and a scene FMU's
 * start values (values.h, FMU_START_VALUES_FILE) are read from there and become the start
 * values; a malformed file is the error. */
int model_set_resources(fmu_model* m, const char* resources, char* msg, size_t n) {
  if (resources) {
    size_t size = strlen(resources) + 1;
    if (!(m->resources = malloc(size))) return snprintf(msg, n, "out of memory"), 1;
    memcpy(m->resources, resources, size);
  }
  int count;
  if (values_read_start_file(&m->start, m->resources, &count, msg, n)) return 1;
  if (count)
    m->log(m->log_context, GM_LOG_EVENTS, "%d start values of the scene from resources/" FMU_START_VALUES_FILE,
           count);
  if (set_start_values(m)) return snprintf(msg, n, "out of memory"), 1;
  return 0;
}

/* The core model is dropped with its memory. */
int model_reset(fmu_model* m) {
  drop_core(m);
  m->unloaded_points = m->warned_unloaded = 0;
  return set_start_values(m);
}

/* The field of vr in values (model.h: vr was checked with model_variable). */
static void* field(const gm_fmu_values* values, unsigned vr) {
  return (char*)values + gm_fmu_variables[vr].offset;
}

double model_get_real(const fmu_model* m, unsigned vr) {
  double x;
  if (element_vr(vr)) {
    const gm_fmu_array* a = &gm_fmu_arrays[MODEL_ELEMENT_ARRAY(vr)];
    memcpy(&x, (const char*)&m->v + a->offset + MODEL_ELEMENT_INDEX(vr) * sizeof x, sizeof x);
    return x;
  }
  memcpy(&x, field(&m->v, vr), sizeof x);
  return x;
}

int model_get_int(const fmu_model* m, unsigned vr) {
  int x;
  memcpy(&x, field(&m->v, vr), sizeof x);
  return x;
}

static void mark_changed(fmu_model* m, unsigned vr) {
  if (gm_fmu_variables[vr].causality == GM_FMU_parameter) m->params_changed = 1;
  m->outputs_current = 0;
}

/* Setting a variable to the value it holds changes nothing: the outputs stay current. */
void model_set_real(fmu_model* m, unsigned vr, double x) {
  if (memcmp(field(&m->v, vr), &x, sizeof x) == 0) return;
  memcpy(field(&m->v, vr), &x, sizeof x);
  mark_changed(m, vr);
}

void model_set_int(fmu_model* m, unsigned vr, int x) {
  if (gm_fmu_variables[vr].type == GM_FMU_Boolean) x = x != 0;
  if (memcmp(field(&m->v, vr), &x, sizeof x) == 0) return;
  memcpy(field(&m->v, vr), &x, sizeof x);
  mark_changed(m, vr);
}

const char* model_get_string(const fmu_model* m, unsigned vr) {
  return values_get_string(&m->v, &gm_fmu_variables[vr]);
}

void model_set_string(fmu_model* m, unsigned vr, char* owned) {
  if (strcmp(model_get_string(m, vr), owned) == 0) {
    free(owned);
    return;
  }
  values_set_string(&m->v, &gm_fmu_variables[vr], owned);
  mark_changed(m, vr);
}

/* The contact damping dynamics.mesh_damping_ratio adds in the large-step mode (0 elsewhere). */
static gm_status mesh_damping(const gm_fmu_values* v, double* damping, char* msg, size_t n) {
  *damping = 0;
  if (!v->dynamics || v->mesh_damping_ratio == 0) return GM_OK;
  return gm_mesh_damping_for_ratio(&v->p, v->dp.inertia, v->mesh_damping_ratio, damping, msg, n);
}

/* A new core model and data for the parameters in v (with the large-step mode's mesh damping);
 * nothing changes in m on failure. */
static int create_core(const fmu_model* m, const gm_fmu_values* v, gm_model** core, gm_data** data, double* added,
                       char* msg, size_t n) {
  gm_model_params q;
  char* paths[CORE_PARAMS_FILES];
  gm_status s = core_params(m->resources, &v->p, &q, paths, msg, n) ? GM_ERR_PARAMETER : mesh_damping(v, added, msg, n);
  q.damping += *added;
  if (s == GM_OK) s = gm_model_create(&q, core, msg, n);
  for (int k = 0; k < CORE_PARAMS_FILES; k++) free(paths[k]);
  if (s != GM_OK) return 1;
  if (gm_data_create(*core, data) != GM_OK) {
    snprintf(msg, n, "out of memory for the contact data");
    gm_model_free(*core);
    return 1;
  }
  return 0;
}

/* core and data, built with the mesh damping `added`, become m's. */
static void install_core(fmu_model* m, gm_model* core, gm_data* data, double added) {
  drop_core(m);
  m->sens_valid = 0;
  m->core = core;
  m->data = data;
  m->v.g = *gm_model_geometry(core);
  memset(m->v.load.slice_position, 0, sizeof m->v.load.slice_position);
  gm_model_slice_positions(core, m->v.load.slice_position);
  m->v.mesh_damping = added;
  m->params_changed = 0;
}

/* Every parameter with a static range (gearmesh/parameters.h, modelDescription.xml's min and
 * max) inside it, whether or not the current mode uses it. */
static int check_ranges(const fmu_model* m, char* msg, size_t n) {
  for (unsigned vr = 0; vr < GM_FMU_VARIABLE_COUNT; vr++) {
    const gm_fmu_variable* v = &gm_fmu_variables[vr];
    const gm_param_range* r = v->causality == GM_FMU_parameter ? gm_param_range_find(v->name) : NULL;
    if (!r) continue;
    const double x = v->type == GM_FMU_Real ? model_get_real(m, vr) : model_get_int(m, vr);
    if (gm_param_range_check(r, x, msg, n) != GM_OK) return 1;
  }
  return 0;
}

/* GearMesh: (re)builds the core model if the parameters changed since the last build; the
 * calculated parameters are its geometry. */
int model_build(fmu_model* m, char* msg, size_t n) {
  if (m->core && !m->params_changed) return 0;
  gm_model* core;
  gm_data* data;
  double added;
  if (check_ranges(m, msg, n) || create_core(m, &m->v, &core, &data, &added, msg, n)) return 1;
  if (m->v.dynamics && gm_dynamics_check(core, &m->v.dp, msg, n) != GM_OK) {
    gm_data_free(data);
    gm_model_free(core);
    return 1;
  }
  install_core(m, core, data, added);
  m->outputs_current = 0;
  return 0;
}

/* GearMesh: the ranges as model_build checks them, then gm_model_check on the core's parameters
 * (file names as names) and the held inputs, as model_build and the first evaluation would refuse
 * them. Not checked: what reads a file, the large-step mode's dynamics and mesh damping. */
int model_check(fmu_model* m, char* msg, size_t n) {
  gm_model_params q;
  msg[0] = '\0';
  if (check_ranges(m, msg, n) || core_params_unresolved(&m->v.p, &q, msg, n)) return 1;
  return gm_model_check(&q, &m->v.k, msg, n) != GM_OK;
}

static const char* flank_name(int flank) {
  static const char* const names[] = {"none", "flank A", "flank B", "both flanks"};
  return flank >= 0 && flank <= 3 ? names[flank] : "?";
}

/* TE of prescribed spins, r_b1 phi_1 + s r_b2 phi_2, as gm_evaluate reports it (mesh.te). */
static double te_of(const fmu_model* m, const gm_kinematics* k) {
  const double s = m->v.p.pair.internal ? -1.0 : 1.0;
  return 0.5 * m->v.g.gear[0].d_b * k->phi[0] + s * 0.5 * m->v.g.gear[1].d_b * k->phi[1];
}

/* The sense of gear i's own rotation about the housing's +z (gm_fmu_ports): +1 for gear 1 and an
 * internal gear 2, -1 for an external gear 2 (it turns the other way). */
static double own_sense(const fmu_model* m, int i) {
  return i == 0 || m->v.p.pair.internal ? 1.0 : -1.0;
}

/* The large-step inputs the core integrates with: the housing-frame ones plus the ports'. */
static gm_dynamics_inputs dynamics_inputs(const fmu_model* m) {
  gm_dynamics_inputs in = m->v.di;
  for (int i = 0; i < 2; i++) {
    const double s = own_sense(m, i);
    in.torque[i] += s * m->v.port.torque[i];
    in.shaft_phi[i] += s * m->v.port.shaft_phi[i];
    in.shaft_omega[i] += s * m->v.port.shaft_omega[i];
  }
  return in;
}

/* The ports' outputs: the spin state in each gear's own sense. */
static void publish_ports(fmu_model* m) {
  for (int i = 0; i < 2; i++) {
    const double s = own_sense(m, i);
    m->v.port.angle[i] = s * m->v.ds.phi[i];
    m->v.port.speed[i] = s * m->v.ds.omega[i];
    m->v.port.shaft_torque[i] = s * m->v.ds.shaft_torque[i];
    m->v.port.shaft_torque_mean[i] = s * m->v.ds.step_aggregates.shaft_torque_mean[i];
  }
}

/* Large-step mode: a warning, once, when both gears have been driven or braked (a torque or a
 * shaft) for UNLOADED_POINTS communication points and UNLOADED_TIME in a row without contact:
 * the usual sign slip (a brake on an external gear 2 as a negative gear2.torque: both gears run
 * up in the same sense), which no error catches. A rattle through the backlash is back in
 * contact within milliseconds. */
enum { UNLOADED_POINTS = 5 };
#define UNLOADED_TIME 0.05
static void check_unloaded(fmu_model* m, double time, const gm_result* r) {
  if (!m->v.dynamics || m->warned_unloaded) return;
  const gm_dynamics_inputs in = dynamics_inputs(m);
  int loaded = 1;
  for (int i = 0; i < 2; i++)
    loaded = loaded && (in.torque[i] != 0 || (m->v.dp.shaft_stiffness[i] > 0 && m->v.ds.shaft_torque[i] != 0));
  if (!loaded || r->normal_force > 0) {
    m->unloaded_points = 0;
    return;
  }
  if (m->unloaded_points++ == 0) m->unloaded_since = time;
  if (m->unloaded_points < UNLOADED_POINTS || time - m->unloaded_since < UNLOADED_TIME) return;
  m->warned_unloaded = 1;
  m->log(m->log_context, GM_LOG_WARNING,
         "t = %g s: both gears are driven or braked (torques %g and %g N.m about the housing's +z, shaft torques %g "
         "and %g N.m) but the mesh has carried nothing since t = %g s, gear speeds %g and %g rad/s: check the signs. "
         "About +z an external gear 2 turns against gear 1, so a brake on it is a positive gear2.torque; "
         "load.torque and drive.torque are in each gear's own sense (a brake -T against a drive +T)",
         time, in.torque[0], in.torque[1], m->v.ds.shaft_torque[0], m->v.ds.shaft_torque[1], m->unloaded_since,
         m->v.ds.omega[0], m->v.ds.omega[1]);
}

/* The spin state outputs of the prescribed-motion mode: the inputs, no shafts, no account. */
static void prescribed_state(fmu_model* m) {
  gm_dynamics_state s;
  memset(&s, 0, sizeof s);
  for (int i = 0; i < 2; i++) {
    s.phi[i] = m->v.k.phi[i];
    s.omega[i] = m->v.k.omega[i];
  }
  m->v.ds = s;
}

/* The load across the face of d's last evaluation becomes the arrays' (GM_FMU_ARRAYS). */
static void publish_load(fmu_model* m, const gm_data* d) {
  gm_fmu_load* load = &m->v.load;
  gm_pair_load pairs[GM_FMU_LOAD_PAIRS];
  gm_data_load_distribution(m->core, d, GM_FMU_LOAD_PAIRS, pairs, load->line_load);
  for (int k = 0; k < GM_FMU_LOAD_PAIRS; k++) {
    load->pair_force[k] = pairs[k].force;
    load->pair_share[k] = pairs[k].share;
    load->pair_position[k] = pairs[k].path_position;
    load->pair_approach[k] = pairs[k].approach;
  }
}

/* r, the result of an evaluation on d, becomes the published outputs (logged); with prescribed
 * spins the spin outputs are the inputs. */
static void publish(fmu_model* m, const gm_data* d, int restart, double time, const gm_result* r) {
  if (restart || r->pairs_in_contact != m->v.y.pairs_in_contact || r->flank != m->v.y.flank)
    m->log(m->log_context, GM_LOG_CONTACT, "t = %g s: %d tooth pairs in contact, %s", time, r->pairs_in_contact,
           flank_name(r->flank));
  m->log(m->log_context, GM_LOG_SOLVER, "t = %g s: %d iterations, residual %g m", time, r->solver_iterations,
         r->solver_residual);
  if (!m->v.dynamics) {
    prescribed_state(m);
    gm_point_aggregates(r, NULL, &m->v.ds.step_aggregates); /* the step is one evaluation */
  }
  publish_ports(m);
  m->v.y = *r;
  publish_load(m, d);
  m->outputs_current = 1;
}

/* An internal step of the large-step mode (gm_advance_options.observer): its contact, spins and
 * shaft torques become the outputs, and the model's user reads them (model_set_intermediate). */
static void on_internal_step(void* context, const gm_internal_point* point) {
  fmu_model* m = context;
  m->v.y = *point->res;
  publish_load(m, m->data); /* the internal step ends at the core's last evaluation */
  for (int i = 0; i < 2; i++) {
    m->v.ds.phi[i] = point->phi[i];
    m->v.ds.omega[i] = point->omega[i];
    m->v.ds.shaft_torque[i] = point->shaft_torque[i];
  }
  publish_ports(m);
  m->outputs_current = 1;
  m->intermediate(m->intermediate_context, m->step_start + point->time);
}

void model_set_intermediate(fmu_model* m, model_intermediate_fn fn, void* context) {
  m->intermediate = fn;
  m->intermediate_context = context;
}

/* The core's step: one evaluation at the held inputs, or in large-step mode the dynamics started
 * (restart) or advanced by step. */
static gm_status core_step(fmu_model* m, int restart, double step, gm_result* r) {
  if (!m->v.dynamics) return gm_evaluate(m->core, m->data, &m->v.k, r);
  const gm_dynamics_inputs in = dynamics_inputs(m);
  if (restart) {
    m->sens_valid = 0;
    return gm_dynamics_start(m->core, m->data, &m->v.dp, &m->v.k, &in, &m->v.ds, r);
  }
  gm_advance_options extra = {NULL, NULL, NULL};
  if (m->v.step_sensitivities) extra.sensitivity = &m->sens;
  /* the outputs at the internal steps (model_set_intermediate); a failed step takes them back */
  const gm_dynamics_state saved_ds = m->v.ds;
  const gm_result saved_y = m->v.y;
  const gm_fmu_ports saved_port = m->v.port;
  if (m->intermediate) m->saved_load = m->v.load;
  const int saved_current = m->outputs_current;
  if (m->intermediate) {
    extra.observer = on_internal_step;
    extra.observer_context = m;
    m->step_start = m->step_end - step;
  }
  const gm_status status =
      gm_dynamics_advance_with(m->core, m->data, &m->v.dp, &m->v.k, &in, step, &m->v.ds, r, &extra);
  if (status != GM_OK && m->intermediate) {
    m->v.ds = saved_ds;
    m->v.y = saved_y;
    m->v.port = saved_port;
    m->v.load = m->saved_load;
    m->outputs_current = saved_current;
  }
  if (status == GM_OK && m->v.step_sensitivities) { /* a failed step changed nothing: the last one's stays */
    m->sens_valid = 1;
    m->sens_step = step;
  }
  return status;
}

/* 1 (msg set) if the step's TE jumps by half a base pitch or more from the last accepted
 * evaluation's: a tooth skipped, whose forces would look normal (they repeat every base pitch).
 * Quasi-static mode solves the TE near the last one instead (detection's quarter-pitch range
 * bounds it); the large-step mode integrates the spins itself; spins out of range are
 * gm_evaluate's error. */
static int skipped_tooth(const fmu_model* m, char* msg, size_t n) {
  if (!m->evaluated || m->v.p.quasi_static || m->v.dynamics || !(fabs(m->v.k.phi[0]) <= GM_MAX_SPIN_ANGLE) ||
      !(fabs(m->v.k.phi[1]) <= GM_MAX_SPIN_ANGLE))
    return 0;
  const double from = te_of(m, &m->k_eval), to = te_of(m, &m->v.k), bound = 0.5 * m->v.g.p_bt;
  if (fabs(to - from) < bound) return 0;
  snprintf(msg, n,
           "mesh.te would jump by %g m (%.4g base pitches) in one step, from %g m to %g m "
           "(gear1.phi = %.17g rad, gear2.phi = %.17g rad): a tooth skipped; allowed |jump| < "
           "%g m (half a base pitch); roll back or retry a smaller step",
           to - from, (to - from) / m->v.g.p_bt, from, to, m->v.k.phi[0], m->v.k.phi[1], bound);
  return 1;
}

/* GearMesh: restart forgets the warm start and friction memory, and with model.dynamics = 1
 * starts the spin state from the inputs gear<i>.phi/.omega; otherwise the spins are integrated
 * over step. Returns 2 if the large-step integration failed (a shorter step may succeed) or if,
 * with prescribed spins, the step skipped a tooth (skipped_tooth): nothing changes. */
int model_evaluate(fmu_model* m, int restart, double time, double step, char* msg, size_t n) {
  if (model_build(m, msg, n)) return 1;
  if (!restart && skipped_tooth(m, msg, n)) return 2;
  if (restart) gm_data_reset(m->core, m->data);
  gm_result r;
  m->step_end = time;
  const gm_status status = core_step(m, restart, step, &r);
  if (status != GM_OK) {
    snprintf(msg, n, "%s", gm_data_message(m->data));
    return m->v.dynamics && status == GM_ERR_SOLVER ? 2 : 1;
  }
  publish(m, m->data, restart, time, &r);
  if (restart) m->unloaded_points = 0;
  else check_unloaded(m, time, &r);
  if (m->v.dynamics)
    m->log(m->log_context, GM_LOG_SOLVER, "t = %g s: %d internal steps, %d rejected", time, m->v.ds.steps,
           m->v.ds.rejected);
  m->k_eval = m->v.k;
  m->evaluated = 1;
  return 0;
}

/* The memory of the last evaluation in m->scratch (created on first use): the quasi-static warm
 * start; level 5's coupled solve starts cold there (gearmesh.h, gm_data_state_load). */
static int load_scratch(fmu_model* m, char* msg, size_t n) {
  if (!m->scratch && gm_data_create(m->core, &m->scratch) != GM_OK) {
    snprintf(msg, n, "out of memory for the contact data");
    return 1;
  }
  const size_t size = gm_data_state_size(m->core, m->data);
  unsigned char* blob = malloc(size);
  int failed = !blob || gm_data_state_save(m->core, m->data, blob, size) != GM_OK ||
               gm_data_state_load(m->core, m->scratch, blob, size) != GM_OK;
  free(blob);
  if (failed) snprintf(msg, n, "out of memory for the contact data");
  return failed;
}

/* GearMesh: one gm_evaluate on m->scratch, so that m->data (where the next model_evaluate starts)
 * and k_eval (its TE jump reference) stay as the last step left them; with model.dynamics = 1 at
 * the integrated spin state and the current pose, the spin state itself unchanged. */
int model_feedthrough(fmu_model* m, double time, char* msg, size_t n) {
  if (model_build(m, msg, n) || load_scratch(m, msg, n)) return 1;
  gm_kinematics k = m->v.k;
  for (int i = 0; m->v.dynamics && i < 2; i++) { /* the spin state, not the initial one */
    k.phi[i] = m->v.ds.phi[i];
    k.omega[i] = m->v.ds.omega[i];
  }
  gm_result r;
  if (gm_evaluate(m->core, m->scratch, &k, &r) != GM_OK) {
    snprintf(msg, n, "%s", gm_data_message(m->scratch));
    return 1;
  }
  publish(m, m->scratch, 0, time, &r);
  return 0;
}

/* The outputs' derivative along the input increments in seed, into out, at the communication
 * point (docs/fmi.md, "Feedthrough"): the contact's from gm_directional_derivative (solver.residual's
 * is 0) on m->scratch, as model_feedthrough (level 5 keeps its coupled solve's tangent in the
 * data). Plain and quasi-static: the spin outputs are the spin inputs. With model.dynamics = 1 the
 * contact is taken at the integrated spin state, which no input moves at the point (the spin
 * inputs are the initial state only; torques and shaft ends act over the next step): only the
 * pose inputs feed through, and the spin state, shaft torques and energy account do not respond. */
static int derivative_along(fmu_model* m, const gm_fmu_values* seed, gm_fmu_values* out, char* msg, size_t n) {
  if (model_build(m, msg, n) || load_scratch(m, msg, n)) return 1;
  gm_kinematics at = m->v.k, along = seed->k;
  for (int i = 0; m->v.dynamics && i < 2; i++) {
    at.phi[i] = m->v.ds.phi[i];
    at.omega[i] = m->v.ds.omega[i];
    along.phi[i] = along.omega[i] = 0;
  }
  if (gm_directional_derivative(m->core, m->scratch, &at, &along, &out->y) != GM_OK) {
    snprintf(msg, n, "%s", gm_data_message(m->scratch));
    return 1;
  }
  for (int i = 0; !m->v.dynamics && i < 2; i++) {
    out->ds.phi[i] = seed->k.phi[i];
    out->ds.omega[i] = seed->k.omega[i];
    out->port.angle[i] = own_sense(m, i) * seed->k.phi[i];
    out->port.speed[i] = own_sense(m, i) * seed->k.omega[i];
  }
  if (!m->v.dynamics) { /* the step means are the point values: their derivative (|te|' = sign(te) te') */
    gm_point_aggregates(&out->y, NULL, &out->ds.step_aggregates);
    out->ds.step_aggregates.te_rms = (m->v.y.te < 0 ? -1.0 : 1.0) * out->y.te;
  }
  return 0;
}

/* dynamics.step_sensitivities: a known is an input held over the step (the core's columns). */
static int step_known(unsigned vr) {
  const gm_fmu_variable* v = &gm_fmu_variables[vr];
  return GM_FMU_IN(v, di) || GM_FMU_IN(v, port.torque) || GM_FMU_IN(v, port.shaft_phi) ||
         GM_FMU_IN(v, port.shaft_omega);
}

/* ... and an unknown a value at the step's end that follows from its spins and inputs. */
static int step_unknown(unsigned vr) {
  return gm_fmu_follows_spins(&gm_fmu_variables[vr]);
}

/* The last step's derivative along the inputs in seed, into out: the spins' from the core's step
 * sensitivity (gm_dynamics_advance_with), the contact's at the end state by the chain rule
 * through gm_directional_derivative, the shafts' from their law at the step's end. */
static int step_derivative_along(fmu_model* m, const gm_fmu_values* seed, gm_fmu_values* out, char* msg, size_t n) {
  if (model_build(m, msg, n) || load_scratch(m, msg, n)) return 1;
  gm_dynamics_inputs du = seed->di;
  for (int i = 0; i < 2; i++) {
    const double s = own_sense(m, i);
    du.torque[i] += s * seed->port.torque[i];
    du.shaft_phi[i] += s * seed->port.shaft_phi[i];
    du.shaft_omega[i] += s * seed->port.shaft_omega[i];
  }
  gm_kinematics at = m->v.k, along;
  memset(&along, 0, sizeof along);
  for (int i = 0; i < 2; i++) {
    at.phi[i] = m->v.ds.phi[i];
    at.omega[i] = m->v.ds.omega[i];
    for (int j = 0; j < 2; j++) {
      along.phi[i] += m->sens.phi[i][GM_SENS_TORQUE1 + j] * du.torque[j] +
                      m->sens.phi[i][GM_SENS_SHAFT_PHI1 + j] * du.shaft_phi[j] +
                      m->sens.phi[i][GM_SENS_SHAFT_OMEGA1 + j] * du.shaft_omega[j];
      along.omega[i] += m->sens.omega[i][GM_SENS_TORQUE1 + j] * du.torque[j] +
                        m->sens.omega[i][GM_SENS_SHAFT_PHI1 + j] * du.shaft_phi[j] +
                        m->sens.omega[i][GM_SENS_SHAFT_OMEGA1 + j] * du.shaft_omega[j];
    }
  }
  if (gm_directional_derivative(m->core, m->scratch, &at, &along, &out->y) != GM_OK) {
    snprintf(msg, n, "%s", gm_data_message(m->scratch));
    return 1;
  }
  for (int i = 0; i < 2; i++) {
    const double s = own_sense(m, i);
    out->ds.phi[i] = along.phi[i];
    out->ds.omega[i] = along.omega[i];
    out->ds.shaft_torque[i] =
        m->v.dp.shaft_stiffness[i] * (du.shaft_phi[i] + du.shaft_omega[i] * m->sens_step - along.phi[i]) +
        m->v.dp.shaft_damping[i] * (du.shaft_omega[i] - along.omega[i]);
    out->port.angle[i] = s * along.phi[i];
    out->port.speed[i] = s * along.omega[i];
    out->port.shaft_torque[i] = s * out->ds.shaft_torque[i];
  }
  return 0;
}

/* The variables dynamics.step_sensitivities cannot take: 1 with msg naming the first. */
static int step_refused(const fmu_model* m, const unsigned known[], size_t n_known, const unsigned unknown[],
                        size_t n_unknown, char* msg, size_t n) {
  const char* const flag = GM_FMU_NAME(step_sensitivities);
  if (!m->sens_valid)
    return snprintf(msg, n,
                    "%s = true: no step to differentiate (the sensitivities are those of the last fmi2DoStep; "
                    "initialization, fmi2SetFMUstate and a new parameter value forget them)",
                    flag),
           1;
  for (size_t i = 0; i < n_known; i++)
    if (!step_known(known[i]))
      return snprintf(msg, n,
                      "%s = true: known %s is not held over the step; allowed knowns: gear<i>.torque, .shaft_phi, "
                      ".shaft_omega, drive./load.torque, .shaft_phi, .shaft_omega",
                      flag, gm_fmu_variables[known[i]].name),
             1;
  for (size_t i = 0; i < n_unknown; i++)
    if (!step_unknown(unknown[i]))
      return snprintf(msg, n,
                      "%s = true: unknown %s has no step sensitivity (the energy account, the step means and "
                      "dynamics.* are not differentiated); allowed unknowns: the contact outputs, gear<i>.angle, "
                      ".speed, .shaft_torque, drive./load.angle, .speed, .shaft_torque",
                      flag, gm_fmu_variables[unknown[i]].name),
             1;
  return 0;
}

int model_directional_derivative(fmu_model* m, const unsigned known[], const double dv_known[], size_t n_known,
                                 const unsigned unknown[], double dv_unknown[], size_t n_unknown, char* msg,
                                 size_t n) {
  for (size_t i = 0; i < n_unknown; i++)
    if (element_vr(unknown[i]))
      return snprintf(msg, n,
                      "unknown %s[%u]: the arrays have no directional derivative; allowed unknowns: the scalar "
                      "outputs (mesh.max_line_load, mesh.max_load_share for the load across the face)",
                      model_variable(unknown[i])->name, MODEL_ELEMENT_INDEX(unknown[i])),
             1;
  gm_fmu_values seed, out;
  memset(&seed, 0, sizeof seed);
  memset(&out, 0, sizeof out);
  for (size_t i = 0; i < n_known; i++) {
    double x;
    memcpy(&x, field(&seed, known[i]), sizeof x);
    x += dv_known[i];
    memcpy(field(&seed, known[i]), &x, sizeof x);
  }
  const int over_step = m->v.dynamics && m->v.step_sensitivities;
  if (over_step && step_refused(m, known, n_known, unknown, n_unknown, msg, n)) return 1;
  if (over_step ? step_derivative_along(m, &seed, &out, msg, n) : derivative_along(m, &seed, &out, msg, n)) return 1;
  for (size_t i = 0; i < n_unknown; i++) memcpy(&dv_unknown[i], field(&out, unknown[i]), sizeof(double));
  return 0;
}

const char* model_warnings(const fmu_model* m) {
  return m->core ? gm_model_warnings(m->core) : "";
}

int model_outputs_current(const fmu_model* m) {
  return m->outputs_current;
}

/* State payload, native byte order (the binary is per platform):
 *   values (values_state_save: every parameter, input, output in table order) |
 *   u8 flags (1 outputs current, 2 core built) | u64 core blob size | core blob |
 *   [gm_kinematics: the inputs of the last evaluation, flag EVAL_INPUTS] |
 *   gm_mesh_orders (the mesh orders' accumulation, which no variable holds) |
 *   gm_fmu_load (the arrays, which the table's values leave out) */
enum { OUTPUTS_CURRENT = 1, CORE_BUILT = 2, EVAL_INPUTS = 4 };

/* The core's evaluation memory belongs to the state only if the core matches the parameters. */
static int core_built(const fmu_model* m) {
  return m->core && !m->params_changed;
}

size_t model_state_size(const fmu_model* m) {
  size_t n = values_state_size(&m->v) + sizeof(uint8_t) + sizeof(uint64_t);
  return n + (core_built(m) ? gm_data_state_size(m->core, m->data) : 0) +
         (m->evaluated ? sizeof(gm_kinematics) : 0) + sizeof(gm_mesh_orders) + sizeof(gm_fmu_load);
}

void model_state_save(const fmu_model* m, unsigned char* buf) {
  buf = values_state_save(&m->v, buf);
  *buf++ = (uint8_t)((m->outputs_current ? OUTPUTS_CURRENT : 0) | (core_built(m) ? CORE_BUILT : 0) |
                     (m->evaluated ? EVAL_INPUTS : 0));
  uint64_t blob = core_built(m) ? gm_data_state_size(m->core, m->data) : 0;
  memcpy(buf, &blob, sizeof blob);
  buf += sizeof blob;
  if (blob) gm_data_state_save(m->core, m->data, buf, (size_t)blob);
  buf += blob;
  if (m->evaluated) {
    memcpy(buf, &m->k_eval, sizeof m->k_eval);
    buf += sizeof m->k_eval;
  }
  memcpy(buf, &m->v.ds.orders, sizeof m->v.ds.orders);
  buf += sizeof m->v.ds.orders;
  memcpy(buf, &m->v.load, sizeof m->v.load);
}

/* Load into v (an owning copy of the values); m changes only on success. */
static int state_load(fmu_model* m, gm_fmu_values* v, const unsigned char* buf, size_t size, char* msg, size_t n) {
  const unsigned char* end = buf + size;
  if (values_state_load(v, &buf, end, msg, n)) return 1;
  if ((size_t)(end - buf) < sizeof(uint8_t) + sizeof(uint64_t)) {
    snprintf(msg, n, "FMU state is truncated");
    return 1;
  }
  unsigned flags = *buf++;
  uint64_t blob;
  memcpy(&blob, buf, sizeof blob);
  buf += sizeof blob;
  const size_t orders_size = sizeof(gm_mesh_orders), load_size = sizeof(gm_fmu_load);
  const size_t tail = ((flags & EVAL_INPUTS) ? sizeof(gm_kinematics) : 0) + orders_size + load_size;
  if ((size_t)(end - buf) < tail || blob != (uint64_t)(end - buf - tail) || (blob && !(flags & CORE_BUILT))) {
    snprintf(msg, n, "FMU state: contact memory of %llu bytes, %zu present", (unsigned long long)blob,
             (size_t)(end - buf - tail));
    return 1;
  }
  gm_kinematics k_eval;
  if (flags & EVAL_INPUTS) memcpy(&k_eval, end - tail, sizeof k_eval);
  gm_mesh_orders orders;
  memcpy(&orders, end - load_size - orders_size, orders_size);
  if (!(orders.ring_count >= 0 && orders.ring_count <= GM_ORDER_CYCLES_MAX && orders.ring_next >= 0 &&
        orders.ring_next < GM_ORDER_CYCLES_MAX && orders.cycles >= 0 && orders.cycles <= GM_ORDER_CYCLES_MAX)) {
    snprintf(msg, n, "FMU state: the mesh orders' record is corrupt");
    return 1;
  }
  gm_fmu_load* load = malloc(load_size);
  if (!load) {
    snprintf(msg, n, "out of memory");
    return 1;
  }
  memcpy(load, end - load_size, load_size);
  const double* element = (const double*)load;
  for (size_t i = 0; i < load_size / sizeof(double); i++)
    if (!isfinite(element[i])) {
      snprintf(msg, n, "FMU state: the arrays' record is corrupt (a value that is not finite)");
      free(load);
      return 1;
    }

  if (flags & CORE_BUILT) { /* restore the core's evaluation memory exactly */
    gm_model* core = m->core;
    gm_data* data = m->data;
    int fresh = !core || m->params_changed || !values_equal(v, &m->v, GM_FMU_parameter);
    double added = m->v.mesh_damping;
    if (fresh && create_core(m, v, &core, &data, &added, msg, n)) {
      free(load);
      return 1;
    }
    if (gm_data_state_load(core, data, buf, (size_t)blob) != GM_OK) {
      snprintf(msg, n, "FMU state: %s", gm_data_message(data));
      if (fresh) {
        gm_data_free(data);
        gm_model_free(core);
      }
      free(load);
      return 1;
    }
    if (fresh) install_core(m, core, data, added);
    v->g = m->v.g;
    v->mesh_damping = m->v.mesh_damping;
    m->params_changed = 0;
  } else { /* taken before the core was built: build lazily, as after setting parameters */
    m->params_changed = 1;
  }
  values_free_strings(&m->v);
  m->v = *v; /* m takes over v's strings */
  m->sens_valid = 0;
  m->outputs_current = (flags & OUTPUTS_CURRENT) && (flags & CORE_BUILT);
  m->evaluated = (flags & EVAL_INPUTS) != 0;
  if (m->evaluated) m->k_eval = k_eval;
  m->v.ds.orders = orders;
  m->v.load = *load;
  free(load);
  return 0;
}

int model_state_load(fmu_model* m, const unsigned char* buf, size_t size, char* msg, size_t n) {
  gm_fmu_values v;
  if (values_copy(&v, &m->v)) {
    values_free_strings(&v);
    snprintf(msg, n, "out of memory");
    return 1;
  }
  if (state_load(m, &v, buf, size, msg, n)) {
    values_free_strings(&v);
    return 1;
  }
  return 0;
}
