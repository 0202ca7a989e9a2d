// The C API: argument checks, exception barrier, and ownership of model and data.
#include <cstdint>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <new>
#include <string>

#include "dynamics.hpp"
#include "evaluate.hpp"
#include "gearmesh/internal/geometry.hpp"
#include "microgeometry.hpp"
#include "model.hpp"
#include "params.hpp"

namespace {

void copy_message(const std::string& text, char* msg, size_t size) {
  if (!msg || size == 0) return;
  const size_t n = text.size() < size - 1 ? text.size() : size - 1;
  std::memcpy(msg, text.data(), n);
  msg[n] = '\0';
}

// Validation and geometry shared by gm_compute_geometry and gm_model_create.
gm_status build_geometry(const gm_model_params* p, gm_pair_geometry* g, std::string& text) {
  if (!p || !g) {
    text = "NULL argument";
    return GM_ERR_ARGUMENT;
  }
  gm_status st = gm::validate_params(*p, text);
  if (st != GM_OK) return st;
  return gm::compute_pair_geometry(*p, *g, text);
}

// Validated modifications and the deviation files of both gears, over their active profiles.
gm_status build_microgeometry(const gm_model_params& p, const gm_pair_geometry& g,
                              gm::GearMicrogeometry micro[2], std::string& text) {
  for (int i = 0; i < 2; ++i) {
    const gm_gear_geometry& gi = g.gear[i];
    const std::string prefix = "gear" + std::to_string(i + 1);
    const gm::ActiveFlank active{0.5 * std::sqrt(std::max(0.0, gi.d_sap * gi.d_sap - gi.d_b * gi.d_b)),
                                 gi.rho_a, p.gear[i].face_width};
    for (const gm_flank_modification& f : p.gear[i].flank) {
      gm_status st = gm::validate_modification(prefix.c_str(), f, active, text);
      if (st != GM_OK) return st;
    }
    gm::DeviationTable table;
    const char* path = p.gear[i].deviations;
    if (path && *path) {
      gm_status st = gm::load_deviations(path, p.gear[i].teeth, p.gear[i].face_width, table, text);
      if (st == GM_OK) st = gm::validate_deviation_coverage(prefix.c_str(), table, active, text);
      if (st != GM_OK) {
        if (text.rfind(prefix + ".deviations", 0) != 0) text = prefix + ".deviations: " + text;
        if (text.find("allowed") == std::string::npos)
          text += "; allowed: a readable GearMesh deviation file (format 1)";
        return st;
      }
    }
    micro[i] = gm::make_microgeometry(p.gear[i], active, std::move(table));
  }
  return GM_OK;
}

// The user tables (user_tables.hpp): level 1's stiffness table and the TE excitation table,
// each message prefixed with its parameter's name.
gm_status build_user_tables(const gm_model_params& p, const gm_pair_geometry& g,
                            gm::StiffnessTable& stiffness, gm::TeTable& te, std::string& text) {
  const auto named = [&](const char* name, const char* format, gm_status st) {
    const std::string prefix = std::string(name) + ": ";
    if (text.rfind(prefix, 0) != 0) text = prefix + text;
    if (text.find("allowed") == std::string::npos)
      text += std::string("; allowed: a readable GearMesh ") + format + " (format 1)";
    return st;
  };
  const char* path = p.stiffness_table;
  if (path && *path) {
    if (p.stiffness_level != GM_STIFFNESS_USER_VARIABLE) {
      text = "model.stiffness_table = \"" + std::string(path) + "\": a stiffness table is used at "
             "model.stiffness = 1 (user tables) only, this model has model.stiffness = " +
             std::to_string(p.stiffness_level) + "; allowed: \"\" (none) at this level";
      return GM_ERR_PARAMETER;
    }
    gm_status st = gm::load_stiffness_table(path, stiffness, text);
    if (st != GM_OK) return named("model.stiffness_table", "stiffness table", st);
    // A table in another convention (radians, the roll angle of gear 2, a diameter) would be
    // held at one end value everywhere: its roll angles must reach gear 1's active profile.
    const gm_gear_geometry& g1 = g.gear[0];
    const double lo = std::sqrt(std::max(0.0, g1.d_sap * g1.d_sap - g1.d_b * g1.d_b)) / g1.d_b;
    const double hi = 2 * g1.rho_a / g1.d_b;
    if (stiffness.roll_angle.back() < std::min(lo, hi) || stiffness.roll_angle.front() > std::max(lo, hi)) {
      char buf[400];
      constexpr double deg = 180 / 3.14159265358979323846;
      std::snprintf(buf, sizeof buf,
                    "model.stiffness_table: %s: its roll angles %.6g .. %.6g deg miss gear 1's "
                    "active profile, %.6g .. %.6g deg; allowed: a table over gear 1's roll angle "
                    "(roll distance on gear 1's flank / r_b1, deg) that overlaps its active profile",
                    path, stiffness.roll_angle.front() * deg, stiffness.roll_angle.back() * deg,
                    std::min(lo, hi) * deg, std::max(lo, hi) * deg);
      text = buf;
      return GM_ERR_PARAMETER;
    }
  }
  path = p.te_table;
  if (path && *path) {
    gm_status st = gm::load_te_table(path, p.gear[0].teeth, te, text);
    if (st != GM_OK) return named("model.te_table", "TE table", st);
  }
  return GM_OK;
}

// Design facts that do not stop the model but that a user must hear of (docs/physics.md §1).
std::string design_warnings(const gm_pair_geometry& g) {
  std::string w;
  const auto add = [&](const std::string& text) { w += (w.empty() ? "" : "; ") + text; };
  char buf[200];
  for (int i = 0; i < 2; ++i) {
    const gm_gear_geometry& gi = g.gear[i];
    if (gi.undercut) {
      std::snprintf(buf, sizeof buf, "gear%d: the basic rack undercuts the tooth root", i + 1);
      add(buf);
    }
    if (gi.interference) {
      std::snprintf(buf, sizeof buf,
                    "gear%d: involute interference: the mate's tip reaches beyond the form "
                    "diameter %.6g mm (start of active profile %.6g mm)",
                    i + 1, gi.d_Ff * 1e3, gi.d_sap * 1e3);
      add(buf);
    }
  }
  if (g.eps_alpha < 1) {
    std::snprintf(buf, sizeof buf,
                  "transverse contact ratio %.4g < 1: spur teeth lose contact between pairs",
                  g.eps_alpha);
    add(buf);
  }
  return w;
}

constexpr uint32_t kStateMagic = 0x53444d47u;  // "GMDS"
constexpr uint32_t kStateVersion = 2;
struct StateHeader {
  uint32_t magic;
  uint32_t version;
  uint64_t capacity;   // the model's slice capacity: a cheap fingerprint of the model
  double te_estimate;  // quasi-static warm start, m
};

}  // namespace

extern "C" {

gm_status gm_compute_geometry(const gm_model_params* p, gm_pair_geometry* out, char* msg,
                              size_t msg_size) {
  try {
    std::string text;
    gm_status st = build_geometry(p, out, text);
    copy_message(text, msg, msg_size);
    return st;
  } catch (const std::exception& e) {
    copy_message(e.what(), msg, msg_size);
    return GM_ERR_MEMORY;
  }
}

gm_status gm_model_create(const gm_model_params* p, gm_model** out, char* msg, size_t msg_size) {
  if (!out) return GM_ERR_ARGUMENT;
  *out = nullptr;
  try {
    std::string text;
    gm_pair_geometry g{};
    // What this build cannot do is said before the geometry, which may fail for other reasons.
    gm_status st = p ? gm::validate_params(*p, text) : GM_ERR_ARGUMENT;
    if (st == GM_OK) st = gm::check_capabilities(*p, text);
    if (st == GM_OK) st = build_geometry(p, &g, text);
    if (st != GM_OK) {
      copy_message(text, msg, msg_size);
      return st;
    }
    gm::GearMicrogeometry micro[2];
    st = build_microgeometry(*p, g, micro, text);
    if (st != GM_OK) {
      copy_message(text, msg, msg_size);
      return st;
    }
    gm::StiffnessTable stiffness_table;
    gm::TeTable te_table;
    st = build_user_tables(*p, g, stiffness_table, te_table, text);
    if (st != GM_OK) {
      copy_message(text, msg, msg_size);
      return st;
    }
    // Stiffness data of the level (docs/physics.md §5).
    gm::IsoStiffness iso{};
    gm::ToothSection tooth[2];
    gm::ToothCoupling coupling;
    std::string coupling_warning;
    if (p->stiffness_level == GM_STIFFNESS_ISO6336 || p->stiffness_level == GM_STIFFNESS_TIME_VARYING) {
      st = gm::iso_stiffness(*p, g, gm::IsoGearBlank{}, iso, text);
    } else if (p->stiffness_level == GM_STIFFNESS_ANALYTICAL) {
      for (int i = 0; i < 2 && st == GM_OK; ++i)
        st = gm::build_tooth_section(*p, g, i, gm::ToothSectionOptions{}, tooth[i], text);
      if (st != GM_OK) text = "model.stiffness = 4 (analytical): " + text;
      if (st == GM_OK) st = gm::build_tooth_coupling(*p, g, coupling, coupling_warning, text);
    }
    gm::ComplianceDb compliance[2];
    if (p->stiffness_level == GM_STIFFNESS_FE) {
      for (int i = 0; i < 2 && st == GM_OK; ++i) {
        const std::string name = "gear" + std::to_string(i + 1) + ".compliance";
        st = gm::read_compliance_db(p->compliance[i], compliance[i], text);
        if (st != GM_OK) text = name + ": " + text;
        if (st == GM_OK) st = gm::check_db_matches(compliance[i], *p, i, text);
        if (st == GM_OK) st = gm::check_db_values(compliance[i], i, text);
      }
    }
    if (st != GM_OK) {
      copy_message(text, msg, msg_size);
      return st;
    }
    gm_model* m = new gm_model;
    m->params = *p;
    m->iso_c_prime = gm::iso_single_stiffness_at(iso, p->rated_line_load);
    m->iso_c_gamma = gm::iso_mesh_stiffness_at(iso, p->rated_line_load);
    // level 2: pair stiffness c'(1 - kappa (2u - 1)^2) over the path; its mean over the mesh,
    // c' (1 - kappa/3) eps_alpha, equals ISO's c_gamma_alpha = c'(0.75 eps_alpha + 0.25)
    m->iso_shape = 0.75 * (1 - 1 / g.eps_alpha);
    m->tooth[0] = std::move(tooth[0]);
    m->tooth[1] = std::move(tooth[1]);
    m->coupling = coupling;
    m->stiffness_table = std::move(stiffness_table);
    m->te_table = std::move(te_table);
    m->compliance[0] = std::move(compliance[0]);
    m->compliance[1] = std::move(compliance[1]);
    m->params.compliance[0] = m->params.compliance[1] = nullptr;
    m->params.gear[0].deviations = m->params.gear[1].deviations = nullptr;  // read, not kept
    m->params.stiffness_table = m->params.te_table = nullptr;
    m->geometry = g;
    m->layout = gm::make_mesh_layout(*p, g, std::move(micro[0]), std::move(micro[1]));
    m->slice_capacity = gm::slice_capacity(m->layout);
    m->warnings = design_warnings(g);
    if (!coupling_warning.empty())
      m->warnings += (m->warnings.empty() ? "" : "; ") + coupling_warning;
    *out = m;
    copy_message("", msg, msg_size);
    return GM_OK;
  } catch (const std::bad_alloc&) {
    copy_message("out of memory creating the model", msg, msg_size);
    return GM_ERR_MEMORY;
  } catch (const std::exception& e) {
    copy_message(e.what(), msg, msg_size);
    return GM_ERR_ARGUMENT;
  }
}

void gm_model_free(gm_model* m) { delete m; }

const gm_model_params* gm_model_parameters(const gm_model* m) { return m ? &m->params : nullptr; }

const gm_pair_geometry* gm_model_geometry(const gm_model* m) { return m ? &m->geometry : nullptr; }

const char* gm_model_warnings(const gm_model* m) { return m ? m->warnings.c_str() : ""; }

gm_status gm_data_create(const gm_model* m, gm_data** out) {
  if (!m || !out) return GM_ERR_ARGUMENT;
  *out = nullptr;
  try {
    gm_data* d = new gm_data;
    d->slices.resize(m->slice_capacity);
    d->forces.resize(m->slice_capacity);
    d->laws.resize(m->slice_capacity);
    d->approach.resize(m->slice_capacity);
    d->balance.resize(m->slice_capacity);
    d->slice_stiffness.resize(m->slice_capacity);
    d->dual_slices.resize(m->slice_capacity);
    d->dual_laws.resize(m->slice_capacity);
    d->dual_forces.resize(m->slice_capacity);
    d->dual_stiffness.resize(m->slice_capacity);
    d->dual_balance.resize(m->slice_capacity);
    if (gm::coupled_solve(*m)) {
      const int c = m->slice_capacity;
      d->nlcp = std::make_unique<gm::NlcpSolver>(c);
      d->fe_compliance.resize(c, c);
      d->fe_tangent.resize(c, c);
      d->fe_delta.resize(c);
      d->fe_force.resize(c);
      d->fe_weights.resize(c);
      d->fe_work.resize(c);
      d->fe_laws.resize(c);
      d->fe_index.resize(c);
      d->fe_height.resize(2 * std::size_t(c));
      d->coupled.reserve(c);
      d->fe_key.resize(c);
      d->fe_prev_key.resize(c);
      d->fe_dual_c.resize(c, c);
      d->fe_saved_force.resize(c);
      d->fe_saved_key.resize(c);
      if (m->params.stiffness_level == GM_STIFFNESS_FE)
        d->fe_assembly.reserve(gm::fe_view(*m), c);  // gm_evaluate then allocates nothing
    }
    d->message.reserve(256);
    *out = d;
    return GM_OK;
  } catch (...) {
    return GM_ERR_MEMORY;
  }
}

void gm_data_free(gm_data* d) { delete d; }

void gm_data_reset(const gm_model* m, gm_data* d) {
  if (!m || !d) return;
  d->message.clear();
  d->te_estimate = 0;
  d->fe_prev_n = -1;
  d->fe_assembly.invalidate();
}

gm_status gm_evaluate(const gm_model* m, gm_data* d, const gm_kinematics* kin, gm_result* res) {
  if (!m || !d || !kin || !res) return GM_ERR_ARGUMENT;
  try {
    return gm::evaluate(*m, *d, *kin, *res);
  } catch (const std::exception& e) {
    d->message = e.what();
    return GM_ERR_ARGUMENT;
  }
}

gm_status gm_directional_derivative(const gm_model* m, gm_data* d, const gm_kinematics* at,
                                    const gm_kinematics* seed, gm_result* derivative) {
  if (!m || !d || !at || !seed || !derivative) return GM_ERR_ARGUMENT;
  try {
    return gm::directional_derivative(*m, *d, *at, *seed, *derivative);
  } catch (const std::exception& e) {
    d->message = e.what();
    return GM_ERR_ARGUMENT;
  }
}

void gm_dynamics_default_params(gm_dynamics_params* p) {
  if (!p) return;
  *p = gm_dynamics_params{};
  p->inertia[0] = p->inertia[1] = 0.02;
  p->tolerance = 1e-8;
  p->max_step = 1e-3;
  p->min_step = 1e-9;
}

gm_status gm_dynamics_check(const gm_model* m, const gm_dynamics_params* p, char* msg, size_t msg_size) {
  if (!m || !p) return GM_ERR_ARGUMENT;
  const std::string text = gm::check_dynamics(*m, *p);
  copy_message(text, msg, msg_size);
  return text.empty() ? GM_OK : GM_ERR_PARAMETER;
}

gm_status gm_dynamics_start(const gm_model* m, gm_data* d, const gm_dynamics_params* p,
                            const gm_kinematics* pose, const gm_dynamics_inputs* in,
                            gm_dynamics_state* s, gm_result* res) {
  if (!m || !d || !p || !pose || !in || !s || !res) return GM_ERR_ARGUMENT;
  try {
    return gm::dynamics_start(*m, *d, *p, *pose, *in, *s, *res);
  } catch (const std::exception& e) {
    d->message = e.what();
    return GM_ERR_ARGUMENT;
  }
}

gm_status gm_dynamics_advance(const gm_model* m, gm_data* d, const gm_dynamics_params* p,
                              const gm_kinematics* pose, const gm_dynamics_inputs* in, double duration,
                              gm_dynamics_state* s, gm_result* res) {
  if (!m || !d || !p || !pose || !in || !s || !res) return GM_ERR_ARGUMENT;
  try {
    return gm::dynamics_advance(*m, *d, *p, *pose, *in, duration, *s, *res);
  } catch (const std::exception& e) {
    d->message = e.what();
    return GM_ERR_ARGUMENT;
  }
}

size_t gm_data_state_size(const gm_model* m, const gm_data* d) {
  return (m && d) ? sizeof(StateHeader) : 0;
}

gm_status gm_data_state_save(const gm_model* m, const gm_data* d, void* buf, size_t size) {
  if (!m || !d || !buf || size != sizeof(StateHeader)) return GM_ERR_ARGUMENT;
  const StateHeader h{kStateMagic, kStateVersion, static_cast<uint64_t>(m->slice_capacity),
                      d->te_estimate};
  std::memcpy(buf, &h, sizeof h);
  return GM_OK;
}

gm_status gm_data_state_load(const gm_model* m, gm_data* d, const void* buf, size_t size) {
  if (!m || !d || !buf) return GM_ERR_ARGUMENT;
  StateHeader h{};
  if (size != sizeof h) {
    d->message = "core state blob has the wrong size";
    return GM_ERR_ARGUMENT;
  }
  std::memcpy(&h, buf, sizeof h);
  if (h.magic != kStateMagic || h.version != kStateVersion ||
      h.capacity != static_cast<uint64_t>(m->slice_capacity)) {
    d->message = "core state blob belongs to another model or format version";
    return GM_ERR_ARGUMENT;
  }
  d->te_estimate = h.te_estimate;
  d->fe_prev_n = -1;  // level 5: the next solve starts cold
  d->fe_assembly.invalidate();  // derived caches: rebuilt by the next call
  d->message.clear();
  return GM_OK;
}

const char* gm_data_message(const gm_data* d) { return d ? d->message.c_str() : ""; }

const char* gm_version(void) { return GM_VERSION_STRING; }

}  // extern "C"
