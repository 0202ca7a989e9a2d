#include "evaluate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <Eigen/Geometry>

namespace gm {
namespace {

// Name the first non-finite input, using the FMU variable names.
bool inputs_finite(const gm_kinematics& k, std::string& msg) {
  static const char* const kAxes[3] = {"x", "y", "z"};
  char buf[120];
  for (int i = 0; i < 2; ++i) {
    const auto bad = [&](const char* prefix, const char* axis, double v) {
      if (std::isfinite(v)) return false;
      std::snprintf(buf, sizeof buf, "gear%d.%s%s = %g: inputs must be finite", i + 1, prefix,
                    axis, v);
      msg = buf;
      return true;
    };
    for (int a = 0; a < 3; ++a)
      if (bad("u", kAxes[a], k.u[i][a]) || bad("v", kAxes[a], k.v[i][a])) return false;
    for (int a = 0; a < 2; ++a)
      if (bad("r", kAxes[a], k.r[i][a]) || bad("w", kAxes[a], k.w[i][a])) return false;
    if (bad("phi", "", k.phi[i]) || bad("omega", "", k.omega[i])) return false;
  }
  if (!std::isfinite(k.load_torque)) {
    std::snprintf(buf, sizeof buf, "mesh.load_torque = %g: inputs must be finite", k.load_torque);
    msg = buf;
    return false;
  }
  return true;
}

// Tilts beyond this are refused: the two-step detection is first order in the tilt.
constexpr double kMaxTilt = 0.02;  // rad

bool tilts_in_range(const gm_kinematics& k, std::string& msg) {
  for (int i = 0; i < 2; ++i) {
    for (int a = 0; a < 2; ++a) {
      if (std::fabs(k.r[i][a]) > kMaxTilt) {
        char buf[200];
        std::snprintf(buf, sizeof buf,
                      "gear%d.r%c = %g rad: outside the small-tilt range of the two-step "
                      "detection; allowed range [-%g, %g] rad", i + 1, a == 0 ? 'x' : 'y',
                      k.r[i][a], kMaxTilt, kMaxTilt);
        msg = buf;
        return false;
      }
    }
  }
  return true;
}

// Transverse stiffness per unit face width of one slice's tooth pair, N/m^2 (the levels that
// have one; PHYSICS 5).
double pair_stiffness(const gm_model& m, const ContactSlice& s) {
  switch (m.params.stiffness_level) {
    case GM_STIFFNESS_ISO6336: {
      // c' at the middle of the path, falling parabolically towards its ends so that the mean
      // mesh stiffness is ISO's c_gamma_alpha = c'(0.75 eps_alpha + 0.25).
      const double u = std::clamp(s.path_position, 0.0, 1.0) * 2 - 1;
      return m.iso_c_prime * (1 - m.iso_shape * u * u);
    }
    case GM_STIFFNESS_USER_VARIABLE:
      // the user's table over gear 1's roll angle at the contact point (user_tables.hpp)
      return stiffness_at(m.stiffness_table, s.roll[0] / m.layout.base_radius[0]);
    case GM_STIFFNESS_TIME_VARYING:
      // contact-line-length model: constant per unit contact line, c_gamma_alpha / eps_alpha
      return m.iso_c_gamma / m.geometry.eps_alpha;
    default:
      return m.params.user_stiffness;
  }
}

// Per-slice compliance laws along the normal (PHYSICS 5). Linear levels: k' L / cos^2(beta_b).
// Analytical level: both teeth's Weber/Sainsot compliance (per unit face width on the
// transverse line of action) plus the exact local Hertz law of PHYSICS 4 over the contact line
// L / cos(beta_b), its approach referred to each tooth's centre line.
void build_laws(const gm_model& m, gm_data& d, int n, bool all) {
  const MeshLayout& L = m.layout;
  const double cb = L.cos_beta_b, cb2 = cb * cb;
  const bool analytical = m.params.stiffness_level == GM_STIFFNESS_ANALYTICAL;
  const double rho_floor = 1e-3 * m.params.pair.normal_module;  // degenerate curvature guard
  for (int i = 0; i < n; ++i) {
    const ContactSlice& s = d.slices[i];
    SliceLaw& law = d.laws[i];
    law.local = LocalLaw{};
    if (!all && s.approach <= 0) continue;  // an open slice carries nothing whatever its law
    if (!analytical) {
      law.compliance = cb2 / (pair_stiffness(m, s) * s.width);
      continue;
    }
    if (i > 0 && s.roll[0] == d.slices[i - 1].roll[0] && s.roll[1] == d.slices[i - 1].roll[1] &&
        s.width == d.slices[i - 1].width && (all || d.slices[i - 1].approach > 0)) {
      law = d.laws[i - 1];  // the next slice of an aligned spur pair: the same law
      continue;
    }
    const double rho1 = std::max(s.roll[0], rho_floor), rho2 = std::max(s.roll[1], rho_floor);
    law.compliance = (tooth_compliance(m.tooth[0], rho1) + tooth_compliance(m.tooth[1], rho2)) *
                     cb2 / s.width;
    law.local.width = s.width / cb;
    law.local.reduced_radius = 1 / (cb / rho1 + L.sign * cb / rho2);  // normal-plane curvatures
    for (int g = 0; g < 2; ++g) {
      law.local.body[g].youngs_modulus = m.params.gear[g].youngs_modulus;
      law.local.body[g].poisson_ratio = m.params.gear[g].poisson_ratio;
      law.local.body[g].depth = tooth_contact_depth(m.tooth[g], g == 0 ? rho1 : rho2) * cb;
    }
  }
}

}  // namespace

gm_status check_capabilities(const gm_model_params& p, std::string& msg) {
  char buf[300];
  const int level = p.stiffness_level;
  if (level == GM_STIFFNESS_FE) {
    std::snprintf(buf, sizeof buf,
                  "model.stiffness = %d: this build has levels 0 (user constant), 1 (user tables), "
                  "2 (ISO 6336-1 method B), 3 (contact-line-length model) and 4 (analytical: "
                  "Weber/Sainsot teeth with local Hertz); allowed values 0, 1, 2, 3, 4", level);
    msg = buf;
    return GM_ERR_PARAMETER;
  }
  if (level == GM_STIFFNESS_USER_VARIABLE && !(p.stiffness_table && *p.stiffness_table)) {
    msg = "model.stiffness_table = \"\": model.stiffness = 1 (user tables) takes the pair "
          "stiffness from a stiffness table; allowed: the path of a stiffness table file "
          "('gearmesh-stiffness-table 1'; in the FMU the name of a file inside resources/)";
    return GM_ERR_PARAMETER;
  }
  return GM_OK;
}

namespace {

// The TE excitation (user_tables.hpp): a gap of TE_exc cos(beta_b) along the normal of every
// slice, flank A and B alike, and its rate in the approach rate.
void apply_te_excitation(const gm_model& m, gm_data& d, const gm_kinematics& kin, int n) {
  if (m.te_table.empty()) return;
  const TeExcitation e = te_excitation_at(m.te_table, kin.phi[0]);
  const double cb = m.layout.cos_beta_b;
  const double gap = e.te * cb, gap_rate = e.slope * kin.omega[0] * cb;
  for (int i = 0; i < n; ++i) {
    d.slices[i].approach -= gap;
    d.slices[i].approach_rate -= gap_rate;
  }
}

// Forces, moments and the other outputs from solved slice forces.
void resultants(const gm_model& m, gm_data& d, const gm_kinematics& kin, int n, gm_result& r) {
  const MeshLayout& L = m.layout;
  const double cb2 = L.cos_beta_b * L.cos_beta_b;
  const Eigen::Vector3d c[2] = {
      Eigen::Vector3d(kin.u[0][0], kin.u[0][1], kin.u[0][2]),
      Eigen::Vector3d(L.center_distance + kin.u[1][0], kin.u[1][1], kin.u[1][2])};
  Eigen::Vector3d f[2] = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  Eigen::Vector3d mom[2] = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  const double mu = m.params.friction_coefficient, v0 = m.params.friction_velocity;
  int last_loaded_pair = -1;
  for (int i = 0; i < n; ++i) {
    const ContactSlice& s = d.slices[i];
    double F = d.forces[i];
    if (F <= 0) continue;
    // contact damping on the normal approach rate, loaded slices only, never adhesive (PHYSICS 7)
    if (m.params.damping != 0) F = std::max(0.0, F + m.params.damping * s.width * s.approach_rate);
    d.forces[i] = F;
    Eigen::Vector3d on2 = F * s.normal;  // gear 1 pushes gear 2 along the normal
    if (mu != 0) {
      // regularized Coulomb friction along the profile tangent, opposing the sliding of the
      // flanks (PHYSICS 7); evaluated from the converged normal forces
      const double friction = mu * F * std::tanh(s.sliding_velocity / v0);
      on2 += friction * s.tangent;
      r.friction_power += friction * s.sliding_velocity;
    }
    f[1] += on2;
    f[0] -= on2;
    mom[1] += (s.point - c[1]).cross(on2);
    mom[0] -= (s.point - c[0]).cross(on2);
    r.normal_force += F;
    r.stiffness += d.slice_stiffness[i] * cb2;  // along the transverse line of action
    r.flank |= s.flank > 0 ? 1 : 2;
    r.max_line_load = std::fmax(r.max_line_load, F / s.width);
    if (s.pair != last_loaded_pair) {
      ++r.pairs_in_contact;
      last_loaded_pair = s.pair;
    }
  }
  for (int i = 0; i < 2; ++i) {
    for (int a = 0; a < 3; ++a) {
      r.force[i][a] = f[i][a];
      r.moment[i][a] = mom[i][a];
    }
  }
}

// Load-balance weights of the quasi-static solve: the moment of a slice's unit normal force
// (with its friction) about gear 2's axis, as a force along the TE coordinate (PHYSICS 6).
void balance_weights(const gm_model& m, gm_data& d, const gm_kinematics& kin, int n) {
  const MeshLayout& L = m.layout;
  const Eigen::Vector3d c2(L.center_distance + kin.u[1][0], kin.u[1][1], kin.u[1][2]);
  const double mu = m.params.friction_coefficient, v0 = m.params.friction_velocity;
  for (int i = 0; i < n; ++i) {
    const ContactSlice& s = d.slices[i];
    Eigen::Vector3d dir = s.normal;
    if (mu != 0) dir += mu * std::tanh(s.sliding_velocity / v0) * s.tangent;
    d.balance[i] = -(s.point - c2).cross(dir).z() / (L.sign * L.base_radius[1]);
  }
}

}  // namespace

gm_status evaluate(const gm_model& m, gm_data& d, const gm_kinematics& kin_in, gm_result& res) {
  if (!inputs_finite(kin_in, d.message)) return GM_ERR_INPUT;
  if (!tilts_in_range(kin_in, d.message)) return GM_ERR_INPUT;
  const MeshLayout& L = m.layout;
  const double tol = m.params.solver_tolerance;
  const int max_it = m.params.solver_max_iterations;
  gm_kinematics kin = kin_in;
  gm_result r{};
  int n = 0;
  if (!m.params.quasi_static) {
    n = detect_contacts(L, kin, d.slices.data(), m.slice_capacity, d.message);
    if (n < 0) return GM_ERR_INPUT;
    apply_te_excitation(m, d, kin, n);
    build_laws(m, d, n, false);
    for (int i = 0; i < n; ++i) d.approach[i] = d.slices[i].approach;
    const ForceSolve fs = solve_separable(d.laws.data(), d.approach.data(), n, tol, max_it,
                                          d.forces.data(), d.slice_stiffness.data());
    if (!fs.converged) {
      d.message = fs.message;
      return GM_ERR_SOLVER;
    }
    r.solver_iterations = fs.iterations;
    r.solver_residual = fs.residual;
  } else {
    // Quasi-static (PHYSICS 6): gear 2's spin follows from the load torque. Detect at the TE
    // estimate, solve the load balance for the rigid approach lambda, move there, and repeat
    // while the move changes what detection sees (tip edges); the estimate carries over calls.
    const double s = L.sign, rb1 = L.base_radius[0], rb2 = L.base_radius[1];
    const double load = kin.load_torque / rb2;  // generalized force of the TE coordinate, N
    double te = d.te_estimate;
    for (int pass = 0; pass < 6; ++pass) {
      kin.phi[1] = (te - rb1 * kin.phi[0]) / (s * rb2);
      n = detect_contacts(L, kin, d.slices.data(), m.slice_capacity, d.message);
      if (n < 0) return GM_ERR_INPUT;
      apply_te_excitation(m, d, kin, n);  // detection is redone every pass
      build_laws(m, d, n, true);
      balance_weights(m, d, kin, n);
      const ForceSolve fs = solve_separable_total(d.laws.data(), d.slices.data(), d.balance.data(),
                                                  n, load, 0.0, tol, max_it, d.approach.data(),
                                                  d.forces.data(), d.slice_stiffness.data());
      if (!fs.converged) {
        d.message = fs.message;
        return GM_ERR_SOLVER;
      }
      r.solver_iterations += fs.iterations;
      r.solver_residual = fs.residual;
      te += fs.lambda;
      if (std::fabs(fs.lambda) <= std::max(tol, 1e-12 * L.base_pitch)) break;
    }
    kin.phi[1] = (te - rb1 * kin.phi[0]) / (s * rb2);
    d.te_estimate = te;
    // The last pass ends at the solved pose; its slice forces belong to approach + gain lambda.
    for (int i = 0; i < n; ++i) d.slices[i].approach = d.approach[i];
  }
  resultants(m, d, kin, n, r);
  // TE from the spin angles, as encoders measure it (PHYSICS 0); solved in quasi-static mode.
  r.te = L.base_radius[0] * kin.phi[0] + L.sign * L.base_radius[1] * kin.phi[1];
  r.te_angle = r.te / L.base_radius[1];
  res = r;
  d.message.clear();
  return GM_OK;
}

}  // namespace gm
