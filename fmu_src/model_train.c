/* A gear train behind model.h (GearTrain.so): the topology and each mesh's element parameters
 * from the FMU's resources (train_variables.h), the bodies' spins integrated by the core's
 * train (gearmesh/train.h) over each communication step. The generic FMI layer
 * (fmi2_functions.c) is the pair FMU's. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core_params.h"
#include "gearmesh/train.h"
#include "model.h"
#include "train_variables.h"
#include "values.h"

enum { NB = TRAIN_MAX_BODIES, NS = TRAIN_MAX_SHAFTS, NM = TRAIN_MAX_MESHES, NF = TRAIN_STRIDE, NSCALAR = 32 };
enum { NAME_SIZE = 64 };

typedef struct train_values {
  double scalar[NSCALAR]; /* by the scalar fields' value reference */
  double body[NB][NF];
  double shaft[NS][NF];
  double mesh[NM][NF];
} train_values;

struct fmu_model {
  fmu_log_fn log;
  void* log_context;
  char* resources;
  /* topology (resources/train.txt) */
  int nb, ns, nm;
  char body_name[NB][NAME_SIZE], shaft_name[NS][NAME_SIZE], mesh_name[NM][NAME_SIZE];
  int fixed[NB];
  int group[NM]; /* planet group of each mesh (1..), 0: none */
  int sense[NB]; /* each body's own sense of rotation about +z: +1 or -1 */
  gm_train_shaft shaft_def[NS];
  gm_train_mesh mesh_def[NM];
  gm_model_params mesh_params[NM];
  gm_fmu_values mesh_values[NM]; /* owns mesh_params' strings */
  /* values */
  train_values v, start;
  gm_model* model[NM];
  gm_train* train;
  double static_phi[2][NB], static_angle[2]; /* quasi-static: the last two equilibria */
  int static_points;
  int built;     /* train matches the parameters */
  int evaluated; /* the outputs belong to the train's state */
};

const char model_identifier[] = "GearTrain";
const char model_guid[] = TRAIN_GUID;
_Static_assert(sizeof TRAIN_GUID <= MODEL_GUID_SIZE, "the GUID does not fit an FMU state's header");

/* ---- variables: generic names for every member the capacities allow ---------------------- */

enum { TABLE_SIZE = TRAIN_MESH_BASE + NM * NF };
_Static_assert(TABLE_SIZE == TRAIN_TIME_VR, "FMI 3.0's time follows the table (train_variables.h)");
static model_variable_info table[TABLE_SIZE];
static char names[TABLE_SIZE][40];
static int table_ready;

static void fill_table(void) {
  if (table_ready) return;
#define SCALAR(f, name, type, causality, variability, unit, description) \
  table[f] = (model_variable_info){name, MODEL_##type, MODEL_##causality, MODEL_##variability};
  TRAIN_SCALAR_FIELDS(SCALAR)
#undef SCALAR
#define MEMBER(count, fields)                                                                                     \
  for (int i = 0; i < (count); ++i) {                                                                             \
    fields(ENTRY)                                                                                                 \
  }
#define ENTRY(f, name, type, causality, variability, unit, description)                                          \
  {                                                                                                               \
    const unsigned vr = (unsigned)(base_ + i * NF + (f));                                                         \
    snprintf(names[vr], sizeof names[vr], "%s%d.%s", prefix_, i + 1, name);                                       \
    table[vr] = (model_variable_info){names[vr], MODEL_##type, MODEL_##causality, MODEL_##variability};         \
  }
  {
    const int base_ = TRAIN_BODY_BASE;
    const char* prefix_ = "body";
    MEMBER(NB, TRAIN_BODY_FIELDS)
  }
  {
    const int base_ = TRAIN_SHAFT_BASE;
    const char* prefix_ = "shaft";
    MEMBER(NS, TRAIN_SHAFT_FIELDS)
  }
  {
    const int base_ = TRAIN_MESH_BASE;
    const char* prefix_ = "mesh";
    MEMBER(NM, TRAIN_MESH_FIELDS)
  }
#undef ENTRY
#undef MEMBER
  table_ready = 1;
}

const model_variable_info* model_variable(unsigned vr) {
  fill_table();
  return vr < TABLE_SIZE && table[vr].name ? &table[vr] : NULL;
}

unsigned model_variable_count(void) {
  return TABLE_SIZE;
}

int model_variable_intermediate(unsigned vr) {
  (void)vr;
  return 0;
}

/* The train FMU has no arrays and no structural parameters. */
int model_variable_structural(unsigned vr) {
  (void)vr;
  return 0;
}

unsigned model_array_count(void) {
  return 0;
}

size_t model_array_length(const fmu_model* m, unsigned a) {
  (void)m, (void)a;
  return 0;
}

/* The train FMU offers no intermediate results (FMI 2.0 only). */
void model_set_intermediate(fmu_model* m, model_intermediate_fn fn, void* context) {
  (void)m, (void)fn, (void)context;
}

static const char* const log_names[] = {"logEvents", "logStatusWarning", "logStatusError", "logStatusFatal", "logAll"};
unsigned model_log_category_count(void) { return 5; }
const char* model_log_category_name(unsigned category) { return log_names[category]; }

/* The value slot of vr (model.h: vr was checked with model_variable). */
static double* slot(train_values* v, unsigned vr) {
  if (vr < TRAIN_BODY_BASE) return &v->scalar[vr];
  if (vr < TRAIN_SHAFT_BASE) return &v->body[(vr - TRAIN_BODY_BASE) / NF][(vr - TRAIN_BODY_BASE) % NF];
  if (vr < TRAIN_MESH_BASE) return &v->shaft[(vr - TRAIN_SHAFT_BASE) / NF][(vr - TRAIN_SHAFT_BASE) % NF];
  return &v->mesh[(vr - TRAIN_MESH_BASE) / NF][(vr - TRAIN_MESH_BASE) % NF];
}

double model_get_real(const fmu_model* m, unsigned vr) { return *slot((train_values*)&m->v, vr); }
int model_get_int(const fmu_model* m, unsigned vr) { return (int)*slot((train_values*)&m->v, vr); }
const char* model_get_string(const fmu_model* m, unsigned vr) {
  (void)m;
  (void)vr;
  return "";
}

static void changed(fmu_model* m, unsigned vr) {
  if (table[vr].causality == MODEL_parameter) m->built = 0;
}
void model_set_real(fmu_model* m, unsigned vr, double x) {
  double* p = slot(&m->v, vr);
  if (*p != x) changed(m, vr);
  *p = x;
}
void model_set_int(fmu_model* m, unsigned vr, int x) { model_set_real(m, vr, (double)x); }
void model_set_string(fmu_model* m, unsigned vr, char* owned) {
  (void)m;
  (void)vr;
  free(owned);
}

/* ---- lifetime ----------------------------------------------------------------------------- */

static void drop_train(fmu_model* m) {
  gm_train_free(m->train);
  m->train = NULL;
  for (int i = 0; i < NM; ++i) {
    gm_model_free(m->model[i]);
    m->model[i] = NULL;
  }
  m->built = 0;
  m->evaluated = 0;
}

fmu_model* model_new(fmu_log_fn log, void* log_context) {
  fill_table();
  fmu_model* m = calloc(1, sizeof *m);
  if (!m) return NULL;
  m->log = log;
  m->log_context = log_context;
  m->start.scalar[1] = 1e-8;
  m->start.scalar[2] = 1e-3;
  m->start.scalar[3] = 1e-9;
  m->start.scalar[16] = 1;
  m->v = m->start;
  return m;
}

void model_free(fmu_model* m) {
  if (!m) return;
  drop_train(m);
  for (int i = 0; i < m->nm; ++i) values_free_strings(&m->mesh_values[i]);
  free(m->resources);
  free(m);
}

/* resources/train.txt, and each mesh's element parameters. */
static int read_train(fmu_model* m, char* msg, size_t n) {
  if (!m->resources) return snprintf(msg, n, "a train FMU needs its resources (" TRAIN_FILE ")"), 1;
  char path[4096];
  snprintf(path, sizeof path, "%s%s", m->resources, TRAIN_FILE);
  FILE* f = fopen(path, "r");
  if (!f) return snprintf(msg, n, "resources/" TRAIN_FILE ": cannot open"), 1;
  char line[512];
  int number = 0, ok = 1;
  while (ok && fgets(line, sizeof line, f)) {
    ++number;
    char kind[16], name[NAME_SIZE];
    if (number == 1) {
      ok = strncmp(line, "gearmesh-train 1", 16) == 0;
      continue;
    }
    if (line[0] == '#' || line[0] == '\n') continue;
    if (sscanf(line, "%15s %63s", kind, name) != 2) {
      ok = 0;
    } else if (!strcmp(kind, "body") && m->nb < NB) {
      double inertia, angle, extra[5] = {0, 0, 0, 0, 0};
      int fixed, sense = 1;
      const int got = sscanf(line, "%*s %*s %lf %d %lf %lf %lf %lf %lf %lf %d", &inertia, &fixed, &angle, &extra[0],
                             &extra[1], &extra[2], &extra[3], &extra[4], &sense);
      ok = (got == 3 || got == 8 || got == 9) && isfinite(angle) && (sense == 1 || sense == -1);
      m->sense[m->nb] = sense;
      snprintf(m->body_name[m->nb], NAME_SIZE, "%s", name);
      m->start.body[m->nb][0] = inertia;
      m->start.body[m->nb][1] = angle; /* the start of <body>.phi */
      for (int k = 0; k < 5; ++k) m->start.body[m->nb][7 + k] = extra[k];
      m->fixed[m->nb++] = fixed != 0;
    } else if (!strcmp(kind, "shaft") && m->ns < NS) {
      gm_train_shaft* s = &m->shaft_def[m->ns];
      ok = sscanf(line, "%*s %*s %d %d %lf %lf", &s->body, &s->other, &s->stiffness, &s->damping) == 4;
      snprintf(m->shaft_name[m->ns], NAME_SIZE, "%s", name);
      m->start.shaft[m->ns][0] = s->stiffness;
      m->start.shaft[m->ns][1] = s->damping;
      m->ns++;
    } else if (!strcmp(kind, "mesh") && m->nm < NM) {
      gm_train_mesh* me = &m->mesh_def[m->nm];
      int group = 0;
      const int got = sscanf(line, "%*s %*s %d %d %d %lf %d", &me->gear[0], &me->gear[1], &me->carrier,
                             &me->orientation, &group);
      ok = (got == 4 || got == 5) && group >= 0 && group <= NM;
      m->group[m->nm] = group;
      snprintf(m->mesh_name[m->nm++], NAME_SIZE, "%s", name);
    } else {
      ok = 0;
    }
  }
  fclose(f);
  if (!ok) return snprintf(msg, n, "resources/" TRAIN_FILE ", line %d: allowed: the header \"gearmesh-train 1\", "
                           "then body, shaft and mesh lines (fmu_src/train_variables.h), at most %d of each",
                           number, NB), 1;
  for (int i = 0; i < m->nm; ++i) {
    gm_fmu_values* v = &m->mesh_values[i];
    memset(v, 0, sizeof *v);
    gm_default_params(&v->p);
    char dir[4096];
    snprintf(dir, sizeof dir, "%smesh%d/", m->resources, i + 1);
    int count = 0;
    char why[512];
    if (values_read_start_file(v, dir, &count, why, sizeof why))
      return snprintf(msg, n, "mesh %s: %s", m->mesh_name[i], why), 1;
    m->mesh_params[i] = v->p;
  }
  return 0;
}

int model_set_resources(fmu_model* m, const char* resources, char* msg, size_t n) {
  if (resources) {
    size_t size = strlen(resources) + 1;
    if (!(m->resources = malloc(size))) return snprintf(msg, n, "out of memory"), 1;
    memcpy(m->resources, resources, size);
  }
  if (read_train(m, msg, n)) return 1;
  m->v = m->start;
  m->log(m->log_context, MODEL_LOG_EVENTS, "train: %d bodies, %d shafts, %d meshes from resources/" TRAIN_FILE,
         m->nb, m->ns, m->nm);
  return 0;
}

int model_reset(fmu_model* m) {
  drop_train(m);
  m->v = m->start;
  return 0;
}

/* ---- evaluation --------------------------------------------------------------------------- */

static int build(fmu_model* m, char* msg, size_t n) {
  if (m->built) return 0;
  drop_train(m);
  for (int i = 0; i < m->nm; ++i) {
    /* the mesh's files (tables, deviations, compliance databases) lie in resources/mesh<k>/ */
    char dir[4096], why[512];
    snprintf(dir, sizeof dir, "%smesh%d/", m->resources, i + 1);
    gm_model_params q;
    char* paths[CORE_PARAMS_FILES];
    gm_status st = core_params(dir, &m->mesh_params[i], &q, paths, why, sizeof why)
                       ? GM_ERR_PARAMETER
                       : gm_model_create(&q, &m->model[i], why, sizeof why);
    for (int k = 0; k < CORE_PARAMS_FILES; k++) free(paths[k]);
    if (st != GM_OK) return snprintf(msg, n, "mesh %s: %s", m->mesh_name[i], why), 1;
    m->mesh_def[i].model = m->model[i];
  }
  gm_train_body bodies[NB];
  for (int b = 0; b < m->nb; ++b)
    bodies[b] = (gm_train_body){m->v.body[b][0], m->fixed[b], m->v.body[b][7], m->v.body[b][8], m->v.body[b][9],
                                {m->v.body[b][10], m->v.body[b][11]}};
  const int held = (int)m->v.scalar[16];
  if (m->v.scalar[15] != 0 && m->v.scalar[15] != 1)
    return snprintf(msg, n, "%s = %g; allowed: 0 or 1", model_variable(15)->name, m->v.scalar[15]), 1;
  if (m->v.scalar[15] == 1 && (held < 1 || held > m->nb || m->fixed[held - 1]))
    return snprintf(msg, n, "%s = %d; allowed: a body that is not fixed, 1..%d", model_variable(16)->name, held, m->nb),
           1;
  for (int s = 0; s < m->ns; ++s) {
    m->shaft_def[s].stiffness = m->v.shaft[s][0];
    m->shaft_def[s].damping = m->v.shaft[s][1];
  }
  char why[512];
  if (gm_train_create(bodies, m->nb, m->mesh_def, m->nm, m->shaft_def, m->ns, m->v.scalar[1], m->v.scalar[2],
                      m->v.scalar[3], &m->train, why, sizeof why) != GM_OK)
    return snprintf(msg, n, "train: %s", why), 1;
  m->built = 1;
  return 0;
}

int model_build(fmu_model* m, char* msg, size_t n) { return build(m, msg, n); }

/* The train has no cheaper check than its build. */
int model_check(fmu_model* m, char* msg, size_t n) { return build(m, msg, n); }

static void inputs(const fmu_model* m, double* phi, double* omega, double* torque, double* far_phi,
                   double* far_omega) {
  for (int b = 0; b < m->nb; ++b) {
    phi[b] = m->v.body[b][1];
    omega[b] = m->v.body[b][2];
    torque[b] = m->v.body[b][3] + m->sense[b] * m->v.body[b][14]; /* about +z, and in its own sense */
  }
  for (int s = 0; s < m->ns; ++s) {
    const int sense = m->sense[m->shaft_def[s].body];
    far_phi[s] = m->v.shaft[s][2] + sense * m->v.shaft[s][5];
    far_omega[s] = m->v.shaft[s][3] + sense * m->v.shaft[s][6];
  }
}

static void publish(fmu_model* m) {
  for (int b = 0; b < m->nb; ++b) {
    gm_train_body_state(m->train, b, &m->v.body[b][4], &m->v.body[b][5], &m->v.body[b][6]);
    gm_train_body_centre(m->train, b, &m->v.body[b][12], &m->v.body[b][13]);
    m->v.body[b][15] = m->sense[b] * m->v.body[b][5];
  }
  for (int s = 0; s < m->ns; ++s) {
    gm_train_shaft_torque(m->train, s, &m->v.shaft[s][4]);
    m->v.shaft[s][7] = m->sense[m->shaft_def[s].body] * m->v.shaft[s][4];
  }
  for (int i = 0; i < m->nm; ++i) {
    const gm_result* r = gm_train_mesh_result(m->train, i);
    double* out = m->v.mesh[i];
    /* the element's TE counts whole teeth from its angles' zero; a train's gears start teeth apart */
    const double pitch = gm_model_geometry(m->model[i])->p_bt;
    out[0] = r->te - pitch * round(r->te / pitch);
    out[1] = r->normal_force;
    out[2] = r->max_load_share;
    out[3] = r->friction_power;
    out[4] = r->stiffness;
    out[5] = r->elastic_energy;
    out[6] = r->flank;
    out[7] = r->pairs_in_contact;
  }
  /* each mesh's share of its planet group's force */
  for (int i = 0; i < m->nm; ++i) {
    double total = 0;
    for (int j = 0; j < m->nm; ++j)
      if (m->group[i] && m->group[j] == m->group[i]) total += m->v.mesh[j][1];
    m->v.mesh[i][8] = !m->group[i] ? 1.0 : total > 0 ? m->v.mesh[i][1] / total : 0.0;
  }
  const gm_train_energy e = gm_train_energy_account(m->train);
  const double account[] = {e.kinetic, e.elastic, e.initial, e.work_in, e.work_out, e.friction, e.damping,
                            e.parametric, e.residual};
  for (int k = 0; k < 9; ++k) m->v.scalar[4 + k] = account[k];
  int steps, rejected;
  gm_train_steps(m->train, &steps, &rejected);
  m->v.scalar[13] = steps;
  m->v.scalar[14] = rejected;
  m->evaluated = 1;
}

int model_evaluate(fmu_model* m, int restart, double time, double step, char* msg, size_t n) {
  if (build(m, msg, n)) return 1;
  double phi[NB], omega[NB], torque[NB], far_phi[NS], far_omega[NS];
  inputs(m, phi, omega, torque, far_phi, far_omega);
  gm_status st;
  if (m->v.scalar[15] == 1) {
    /* quasi-static: from the last equilibrium moved on by its last change per unit of the held
       angle (a secant), or from the inputs' angles at the first */
    const int held = (int)m->v.scalar[16] - 1;
    const double angle = m->v.scalar[17];
    double start[NB];
    for (int b = 0; b < m->nb; ++b) start[b] = phi[b];
    if (!restart && m->evaluated) {
      const double moved = angle - m->static_angle[1];
      const double last = m->static_angle[1] - m->static_angle[0];
      for (int b = 0; b < m->nb; ++b) {
        const double rate = m->static_points > 1 && last != 0 ? (m->static_phi[1][b] - m->static_phi[0][b]) / last : 0.0;
        start[b] = m->static_phi[1][b] + rate * moved;
      }
    } else {
      m->static_points = 0;
    }
    st = gm_train_static(m->train, held, angle, start, torque, far_phi);
    if (st == GM_OK) {
      memcpy(m->static_phi[0], m->static_phi[1], sizeof m->static_phi[0]);
      m->static_angle[0] = m->static_angle[1];
      for (int b = 0; b < m->nb; ++b) gm_train_body_state(m->train, b, &m->static_phi[1][b], NULL, NULL);
      m->static_angle[1] = angle;
      ++m->static_points;
    }
  } else if (restart || !m->evaluated) {
    for (int b = 0; b < m->nb; ++b)
      if (m->fixed[b] && (phi[b] != 0 || omega[b] != 0))
        return snprintf(msg, n, "%s.phi, .omega: a fixed body starts at 0; allowed: 0", m->body_name[b]), 1;
    st = gm_train_start(m->train, phi, omega, torque, far_phi, far_omega);
  } else {
    st = gm_train_advance(m->train, torque, far_phi, far_omega, step);
  }
  if (st != GM_OK) {
    /* the core counts meshes ("mesh 3: ..."); the scene names them */
    const char* text = gm_train_message(m->train);
    int index = 0, used = 0;
    if (sscanf(text, "mesh %d: %n", &index, &used) == 1 && used > 0 && index >= 1 && index <= m->nm)
      snprintf(msg, n, "t = %g s: mesh %s: %s", time, m->mesh_name[index - 1], text + used);
    else
      snprintf(msg, n, "t = %g s: %s", time, text);
    return st == GM_ERR_SOLVER ? 2 : 1;
  }
  publish(m);
  return 0;
}

/* The outputs are the train's state: inputs set at a communication point act over the next step. */
int model_feedthrough(fmu_model* m, double time, char* msg, size_t n) {
  (void)time;
  return m->evaluated ? 0 : model_evaluate(m, 1, time, 0.0, msg, n);
}
int model_outputs_current(const fmu_model* m) { return m->built && m->evaluated; }

int model_directional_derivative(fmu_model* m, const unsigned known[], const double dv_known[], size_t n_known,
                                 const unsigned unknown[], double dv_unknown[], size_t n_unknown, char* msg,
                                 size_t n) {
  (void)m, (void)known, (void)dv_known, (void)n_known, (void)unknown, (void)dv_unknown, (void)n_unknown;
  return snprintf(msg, n, "a train FMU provides no directional derivatives (providesDirectionalDerivative = "
                  "false)"), 1;
}

const char* model_warnings(const fmu_model* m) {
  (void)m;
  return "";
}

/* ---- FMU state: the values, then the train's state ---------------------------------------- */

size_t model_state_size(const fmu_model* m) {
  return sizeof(train_values) + 2 * sizeof(uint8_t) + sizeof(uint64_t) +
         (m->built && m->evaluated ? gm_train_state_size(m->train) : 0);
}

void model_state_save(const fmu_model* m, unsigned char* buf) {
  memcpy(buf, &m->v, sizeof m->v);
  buf += sizeof m->v;
  *buf++ = (uint8_t)m->built;
  *buf++ = (uint8_t)m->evaluated;
  uint64_t blob = m->built && m->evaluated ? gm_train_state_size(m->train) : 0;
  memcpy(buf, &blob, sizeof blob);
  buf += sizeof blob;
  if (blob) gm_train_state_save(m->train, buf, (size_t)blob);
}

int model_state_load(fmu_model* m, const unsigned char* buf, size_t size, char* msg, size_t n) {
  msg[0] = '\0';
  if (size < sizeof(train_values) + 2 + sizeof(uint64_t)) return snprintf(msg, n, "FMU state is truncated"), 1;
  train_values v;
  memcpy(&v, buf, sizeof v);
  const unsigned char* p = buf + sizeof v;
  const int built = p[0], evaluated = p[1];
  uint64_t blob;
  memcpy(&blob, p + 2, sizeof blob);
  p += 2 + sizeof blob;
  if (blob != (uint64_t)(buf + size - p)) return snprintf(msg, n, "FMU state: train state of %llu bytes, %zu present",
                                                          (unsigned long long)blob, (size_t)(buf + size - p)), 1;
  const train_values old = m->v;
  m->v = v;
  if (built && evaluated) {
    m->built = 0;
    if (build(m, msg, n) || gm_train_state_load(m->train, p, (size_t)blob) != GM_OK) {
      m->v = old;
      m->built = 0;
      if (!msg[0]) snprintf(msg, n, "FMU state: not a state of this train");
      return 1;
    }
    m->evaluated = 1;
  } else {
    drop_train(m);
  }
  return 0;
}
