#include "evaluate.hpp"

#include <algorithm>
#include <type_traits>
#include <cmath>
#include <cstdio>
#include <limits>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include "dual.hpp"
#include "fe_compliance.hpp"

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

// Spin angles beyond GM_MAX_SPIN_ANGLE are refused (gearmesh.h): one ulp of |phi| <= 1e7 rad is
// at most 2^-29 rad = 1.9e-9 rad, i.e. at most 1.9e-9 r_b of TE (0.13 nm at r_b = 70 mm) and
// 6e-7 of the smallest angular pitch (2 pi/2000); at 1e15 rad one ulp (0.125 rad) exceeds a
// pitch and the pose is meaningless.
bool spins_in_range(const gm_kinematics& k, std::string& msg) {
  for (int i = 0; i < 2; ++i) {
    if (!(std::fabs(k.phi[i]) <= GM_MAX_SPIN_ANGLE)) {
      char buf[300];
      std::snprintf(buf, sizeof buf,
                    "gear%d.phi = %g rad: outside the allowed range [-%g, %g] rad of the spin "
                    "angles (beyond it one ulp of the angle exceeds %.2g rad, so the tooth "
                    "position and the TE lose their precision)", i + 1, k.phi[i], GM_MAX_SPIN_ANGLE,
                    GM_MAX_SPIN_ANGLE, std::ldexp(1.0, std::ilogb(GM_MAX_SPIN_ANGLE) - 52));
      msg = buf;
      return false;
    }
  }
  return true;
}

// phi = n 2 pi + r with |r| <= pi and n whole, r exact to rounding: 2 pi as a double-double
// (hi + lo) and n hi without rounding error (fma); phi - n hi is exact (Sterbenz: for n != 0,
// phi and n hi agree within a factor of two). Detection then works on angles below a turn, where
// one ulp is 8.9e-16 rad, whatever the spin (|phi| <= GM_MAX_SPIN_ANGLE, so |n| < 2^21).
double reduce_turns(double phi, double& n) {
  constexpr double kTwoPiHi = 6.283185307179586;       // 2 pi rounded to double
  constexpr double kTwoPiLo = 2.4492935982947064e-16;  // 2 pi - kTwoPiHi
  n = std::nearbyint(phi / kTwoPiHi);
  if (n == 0) return phi;
  const double p = n * kTwoPiHi;
  const double e = std::fma(n, kTwoPiHi, -p);  // n hi = p + e exactly
  return ((phi - p) - e) - n * kTwoPiLo;
}

// The pose detection sees: both spins reduced by whole turns (a whole turn is a whole number of
// teeth, so tooth identities, deviations and databases are unchanged). Quasi-static mode sets
// gear 2's spin from the TE and gear 1's spin, phi_2 = (TE - r_b1 phi_1)/(s r_b2): with phi_1 =
// r_1 + 2 pi n_1 that is (TE - r_b1 r_1)/(s r_b2) - s 2 pi n_1 z_1/z_2 (r_b1/r_b2 = z_1/z_2, the
// same transverse module), and the last term is, modulo a turn, -s 2 pi ((n_1 z_1) mod z_2)/z_2:
// *phi2_offset, to be added to (TE - r_b1 r_1)/(s r_b2).
gm_kinematics reduced_pose(const MeshLayout& L, const gm_kinematics& in, double* phi2_offset) {
  gm_kinematics k = in;
  double n[2];
  for (int i = 0; i < 2; ++i) k.phi[i] = reduce_turns(in.phi[i], n[i]);
  if (phi2_offset) {
    const long long z1 = L.teeth[0], z2 = L.teeth[1];
    const long long j = ((static_cast<long long>(n[0]) % z2) * z1 % z2 + z2) % z2;
    *phi2_offset = -L.sign * 6.283185307179586 * static_cast<double>(j) / static_cast<double>(z2);
  }
  return k;
}

// The input checks of gm_evaluate and gm_directional_derivative (at `at`), in this order.
bool inputs_valid(const gm_kinematics& k, std::string& msg) {
  return inputs_finite(k, msg) && spins_in_range(k, msg) && tilts_in_range(k, msg);
}

// Table lookups over the scalar type: the double ones as they are; for dual numbers the value
// and the table's slope.
inline double table_stiffness(const StiffnessTable& t, double angle) { return stiffness_at(t, angle); }
inline Dual table_stiffness(const StiffnessTable& t, const Dual& angle) {
  return {stiffness_at(t, angle.v), stiffness_slope_at(t, angle.v) * angle.d};
}
inline double tooth_compliance_t(const ToothSection& s, double rho) { return tooth_compliance(s, rho); }
inline Dual tooth_compliance_t(const ToothSection& s, const Dual& rho) {
  return {tooth_compliance(s, rho.v), tooth_compliance_slope(s, rho.v) * rho.d};
}
inline double tooth_contact_depth_s(const ToothSection& s, double rho) {
  return tooth_contact_depth(s, rho);
}
inline Dual tooth_contact_depth_s(const ToothSection& s, const Dual& rho) {
  return tooth_contact_depth_t<Dual>(s, rho);
}

// Transverse stiffness per unit face width of one slice's tooth pair, N/m^2 (the levels that
// have one; docs/physics.md §5).
template <class T>
T pair_stiffness(const gm_model& m, const ContactSliceT<T>& s) {
  switch (m.params.stiffness_level) {
    case GM_STIFFNESS_ISO6336: {
      // c' at the middle of the path, falling parabolically towards its ends so that the mean
      // mesh stiffness is ISO's c_gamma_alpha = c'(0.75 eps_alpha + 0.25).
      using std::fmax;
      using std::fmin;
      const T u = fmin(fmax(s.path_position, T(0.0)), T(1.0)) * 2 - 1;
      return m.iso_c_prime * (1 - m.iso_shape * u * u);
    }
    case GM_STIFFNESS_USER_VARIABLE:
      // the user's table over gear 1's roll angle at the contact point (user_tables.hpp)
      return table_stiffness(m.stiffness_table, T(s.roll[0] / m.layout.base_radius[0]));
    case GM_STIFFNESS_TIME_VARYING:
      // contact-line-length model: constant per unit contact line, c_gamma_alpha / eps_alpha
      return T(m.iso_c_gamma / m.geometry.eps_alpha);
    default:
      return T(m.params.user_stiffness);
  }
}

// Per-slice compliance laws along the normal (docs/physics.md §5). Linear levels: k' L / cos^2(beta_b).
// Analytical level: both teeth's Weber/Sainsot compliance (per unit face width on the
// transverse line of action) plus the exact local Hertz law of docs/physics.md §4 over the contact line
// L / cos(beta_b), its approach referred to each tooth's centre line.
template <class T>
void build_laws(const gm_model& m, const ContactSliceT<T>* slices, SliceLawT<T>* laws, int n,
                bool all) {
  const MeshLayout& L = m.layout;
  const double cb = L.cos_beta_b, cb2 = cb * cb;
  const bool fe = m.params.stiffness_level == GM_STIFFNESS_FE;
  const bool analytical = m.params.stiffness_level == GM_STIFFNESS_ANALYTICAL || fe;
  const double rho_floor = 1e-3 * m.params.pair.normal_module;  // degenerate curvature guard
  for (int i = 0; i < n; ++i) {
    const ContactSliceT<T>& s = slices[i];
    SliceLawT<T>& law = laws[i];
    law.local = LocalLawT<T>{};
    if (!all && s.approach <= 0) continue;  // an open slice carries nothing whatever its law
    if (!analytical) {
      law.compliance = cb2 / (pair_stiffness(m, s) * s.width);
      continue;
    }
    if (i > 0 && identical(s.roll[0], slices[i - 1].roll[0]) &&
        identical(s.roll[1], slices[i - 1].roll[1]) && identical(s.width, slices[i - 1].width) &&
        (all || slices[i - 1].approach > 0)) {
      law = laws[i - 1];  // the next slice of an aligned spur pair: the same law
      continue;
    }
    using std::fmax;
    const T rho1 = fmax(s.roll[0], T(rho_floor)), rho2 = fmax(s.roll[1], T(rho_floor));
    // FE: the global part is the coupled C of fe_assemble, not a per-slice compliance
    law.compliance = fe ? T(0.0)
                        : (tooth_compliance_t(m.tooth[0], rho1) +
                           tooth_compliance_t(m.tooth[1], rho2)) * cb2 / s.width;
    law.local.width = s.width / cb;
    law.local.reduced_radius = 1 / (cb / rho1 + L.sign * cb / rho2);  // normal-plane curvatures
    for (int g = 0; g < 2; ++g) {
      law.local.body[g].youngs_modulus = m.params.gear[g].youngs_modulus;
      law.local.body[g].poisson_ratio = m.params.gear[g].poisson_ratio;
      // FE: the database's depth h (along the normal), the depth its displacements were taken at
      law.local.body[g].depth = fe ? T(m.compliance[g].depth)
                                   : tooth_contact_depth_s(m.tooth[g], g == 0 ? rho1 : rho2) * cb;
    }
  }
}

}  // namespace

gm_status check_capabilities(const gm_model_params& p, std::string& msg) {
  const int level = p.stiffness_level;
  for (int g = 0; g < 2; ++g) {
    const bool given = p.compliance[g] && *p.compliance[g];
    const std::string name = "gear" + std::to_string(g + 1) + ".compliance";
    if (level == GM_STIFFNESS_FE && !given) {
      msg = name + " = \"\": model.stiffness = 5 (FE) takes each gear's compliance from its "
            "compliance database; allowed: the path of a .gcdb file made by compliance_tool for "
            "this gear (in the FMU the name of a file inside resources/)";
      return GM_ERR_PARAMETER;
    }
    if (level != GM_STIFFNESS_FE && given) {
      msg = name + " = \"" + p.compliance[g] + "\": a compliance database is used at "
            "model.stiffness = 5 (FE) only; allowed: \"\" at this level";
      return GM_ERR_PARAMETER;
    }
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
template <class T, class K>
void apply_te_excitation(const gm_model& m, ContactSliceT<T>* slices, const K& kin, int n) {
  if (m.te_table.empty()) return;
  const TeExcitation e = te_excitation_at(m.te_table, val(kin.phi[0]));
  const double cb = m.layout.cos_beta_b;
  // the table is linear between rows: d TE_exc = slope d phi_1, its slope is piecewise constant
  const T gap = T(e.te * cb) + (e.slope * cb) * (kin.phi[0] - val(kin.phi[0]));
  const T gap_rate = (e.slope * cb) * kin.omega[0];
  for (int i = 0; i < n; ++i) {
    slices[i].approach -= gap;
    slices[i].approach_rate -= gap_rate;
  }
}

// The Real outputs of gm_result over a scalar type, and the integer ones.
template <class T>
struct ResultT {
  T force[2][3] = {};
  T moment[2][3] = {};
  T normal_force = 0, stiffness = 0, friction_power = 0, max_line_load = 0;
  T elastic_energy = 0, damping_power = 0;
  int pairs_in_contact = 0, flank = 0;
};

bool same_local_law(const LocalLaw& a, const LocalLaw& b) {
  return a.width == b.width && a.reduced_radius == b.reduced_radius &&
         a.body[0].depth == b.body[0].depth && a.body[1].depth == b.body[1].depth &&
         a.body[0].youngs_modulus == b.body[0].youngs_modulus &&
         a.body[1].youngs_modulus == b.body[1].youngs_modulus &&
         a.body[0].poisson_ratio == b.body[0].poisson_ratio &&
         a.body[1].poisson_ratio == b.body[1].poisson_ratio;
}

// Elastic potential of the loaded slices at solved forces, J: U = sum_i int_0^Delta_i F dDelta.
// With the complementary energy Psi(F) = F.C.F/2 + sum_i P_i(F_i) (C the coupled compliance of
// level 5, or diag(c_i); P_i = int f_i) and C F + f(F) = Delta on the loaded set,
// U = F.Delta - Psi(F) = sum_i [F_i (Delta_i + f_i(F_i))/2 - P_i(F_i)]: one formula for every
// level that needs no C. It holds along the solution, so the same formula over dual numbers (with
// the implicit derivative of F) is U's exact derivative. Forces before damping.
template <class T>
T elastic_energy(const ContactSliceT<T>* slices, const SliceLawT<T>* laws, const T* forces, int n) {
  T u = 0, last = 0;
  for (int i = 0; i < n; ++i) {
    const T& F = forces[i];
    if (!(F > 0)) continue;
    if constexpr (std::is_same_v<T, double>) {
      // the next slice of an aligned spur pair: the same law, force and approach, the same term
      if (i > 0 && F == forces[i - 1] && slices[i].approach == slices[i - 1].approach &&
          same_local_law(laws[i].local, laws[i - 1].local)) {
        u += last;
        continue;
      }
    }
    LocalLawValueT<T> local;  // zero without a local law
    if (laws[i].local.width > 0) local = local_law_value(laws[i].local, F);
    last = 0.5 * F * (slices[i].approach + local.approach) - local.energy;
    u += last;
  }
  return u;
}

// Forces, moments and the other outputs from solved slice forces.
template <class T, class K>
void resultants(const gm_model& m, const ContactSliceT<T>* slices, T* forces,
                const T* slice_stiffness, const K& kin, int n, ResultT<T>& r) {
  GM_AD_USING;
  using std::fmax;
  using V3 = Eigen::Matrix<T, 3, 1>;
  const MeshLayout& L = m.layout;
  const double cb2 = L.cos_beta_b * L.cos_beta_b;
  const V3 c[2] = {V3(kin.u[0][0], kin.u[0][1], kin.u[0][2]),
                   V3(L.center_distance + kin.u[1][0], kin.u[1][1], kin.u[1][2])};
  V3 f[2] = {V3::Zero(), V3::Zero()};
  V3 mom[2] = {V3::Zero(), V3::Zero()};
  const double mu = m.params.friction_coefficient, v0 = m.params.friction_velocity;
  int last_loaded_pair = -1;
  for (int i = 0; i < n; ++i) {
    const ContactSliceT<T>& s = slices[i];
    T F = forces[i];
    if (F <= 0) continue;
    // contact damping on the normal approach rate, loaded slices only, never adhesive (docs/physics.md §7)
    if (m.params.damping != 0) {
      const T damped = fmax(T(0.0), T(F + m.params.damping * s.width * s.approach_rate));
      r.damping_power += (damped - F) * s.approach_rate;  // the damper's force times its rate
      F = damped;
    }
    forces[i] = F;
    V3 on2 = F * s.normal;  // gear 1 pushes gear 2 along the normal
    if (mu != 0) {
      // regularized Coulomb friction along the profile tangent, opposing the sliding of the
      // flanks (docs/physics.md §7); evaluated from the converged normal forces
      const T friction = mu * F * tanh(s.sliding_velocity / v0);
      on2 += friction * s.tangent;
      r.friction_power += friction * s.sliding_velocity;
    }
    f[1] += on2;
    f[0] -= on2;
    mom[1] += (s.point - c[1]).cross(on2);
    mom[0] -= (s.point - c[0]).cross(on2);
    r.normal_force += F;
    r.stiffness += slice_stiffness[i] * cb2;  // along the transverse line of action
    r.flank |= s.flank > 0 ? 1 : 2;
    r.max_line_load = fmax(r.max_line_load, T(F / s.width));
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
// (with its friction) about gear 2's axis, as a force along the TE coordinate (docs/physics.md §6).
template <class T, class K>
void balance_weights(const gm_model& m, const ContactSliceT<T>* slices, const K& kin, int n,
                     T* balance) {
  GM_AD_USING;
  using V3 = Eigen::Matrix<T, 3, 1>;
  const MeshLayout& L = m.layout;
  const V3 c2(L.center_distance + kin.u[1][0], kin.u[1][1], kin.u[1][2]);
  const double mu = m.params.friction_coefficient, v0 = m.params.friction_velocity;
  for (int i = 0; i < n; ++i) {
    const ContactSliceT<T>& s = slices[i];
    V3 dir = s.normal;
    if (mu != 0) dir += T(mu * tanh(s.sliding_velocity / v0)) * s.tangent;
    balance[i] = -(s.point - c2).cross(dir).z() / (L.sign * L.base_radius[1]);
  }
}


constexpr double kNlcpRelativeTolerance = 1e-10;  // NlcpOptions' default

// The coupled solve of level 5 over the candidates (all: every candidate, the quasi-static
// setting; else those with Delta > 0). Plain (quasi false): forces for the approaches.
// Quasi-static: the rigid approach lambda along te_gain with sum_i b_i F_i = load. Writes
// d.forces and d.slice_stiffness for all n candidates (0 where not loaded).
ForceSolve fe_solve(const gm_model& m, gm_data& d, const gm_kinematics& kin, int n, bool all,
                    bool quasi, double load) {
  ForceSolve out;
  const ContactSlice* S = d.slices.data();
  int na = 0;
  for (int i = 0; i < n; ++i) {
    d.forces[i] = 0;
    d.slice_stiffness[i] = 0;
    if (all || d.approach[i] > 0) d.fe_index[na++] = i;
  }
  if (na == 0) {
    if (quasi) {  // no candidate: nothing to balance
      out.converged = false;
      out.message = "no candidate slice to carry the load";
    }
    d.fe_prev_n = 0;
    return out;
  }
  Eigen::MatrixXd& C = d.fe_compliance;
  for (int a = 0; a < na; ++a) {
    const ContactSlice& sa = S[d.fe_index[a]];
    d.fe_key[a] = ((static_cast<long long>(sa.tooth[0]) * 100003 + sa.tooth[1]) * 2 +
                   (sa.flank > 0)) * 4099 + a;
    d.fe_laws[a] = d.laws[d.fe_index[a]].local;
    d.fe_delta[a] = d.approach[d.fe_index[a]];
    d.fe_weights[a] = sa.te_gain;
  }
  const double uz[2] = {kin.u[0][2], kin.u[1][2]};
  d.fe_assembly.assemble(m, S, d.fe_index.data(), na, uz, C);
  // warm start from the previous call's forces when the candidates are the same
  bool same = d.fe_prev_n == na;
  for (int a = 0; same && a < na; ++a) same = d.fe_key[a] == d.fe_prev_key[a];
  if (!same) d.fe_force.head(na).setZero();
  for (int a = 0; a < na; ++a) d.fe_prev_key[a] = d.fe_key[a];
  d.fe_prev_n = na;
  NlcpOptions opt = d.nlcp->options();
  // NlcpSolver's own tolerances (1e-15 m + 1e-10 |Delta|): model.solver_tolerance (1e-10 m by
  // default) on the rigid approach would leave the load balance ~1e-5 off
  opt.tolerance = std::min(opt.tolerance, m.params.solver_tolerance);
  // The relative part on the approaches that can load a slice: the open candidates of the
  // quasi-static solve (backlash gaps of ~100 um) would loosen it by their size. A
  // model.solver_tolerance below the absolute part (1e-15 m) tightens it in proportion.
  {
    double closing = 0, all_max = 0;
    for (int a = 0; a < na; ++a) {
      closing = std::max(closing, d.fe_delta[a]);
      all_max = std::max(all_max, std::fabs(d.fe_delta[a]));
    }
    const double rel = kNlcpRelativeTolerance * std::min(1.0, m.params.solver_tolerance / 1e-15);
    opt.relative_tolerance = all_max > 0 && closing > 0 ? rel * closing / all_max : rel;
  }
  opt.max_iterations = m.params.solver_max_iterations;
  d.nlcp->set_options(opt);
  const auto Cn = C.topLeftCorner(na, na);
  NlcpResult res;
  if (!quasi) {
    res = d.nlcp->solve(Cn, d.fe_delta.head(na), d.fe_laws.data(), d.fe_force.head(na));
    out.iterations = res.iterations;
  } else if (load == 0) {
    // the rigid approach at which the first slice a positive load would close touches
    double lambda = std::numeric_limits<double>::infinity();
    for (int a = 0; a < na; ++a)
      if (d.fe_weights[a] > 0) lambda = std::min(lambda, -d.fe_delta[a] / d.fe_weights[a]);
    if (!std::isfinite(lambda)) lambda = 0;
    d.fe_force.head(na).setZero();
    out.lambda = lambda;
    for (int i = 0; i < n; ++i) d.approach[i] += lambda * S[i].te_gain;
    return out;
  } else {
    // w^T F = total with w = sign(load) te_gain; the balance b (with friction) differs from w,
    // so total is rescaled until sum b_i F_i = load
    const double sgn = load > 0 ? 1.0 : -1.0;
    d.fe_weights.head(na) *= sgn;
    double total = std::fabs(load), lambda = 0;
    for (int outer = 0; outer < 30; ++outer) {
      lambda = 0;
      res = d.nlcp->solve_total(Cn, d.fe_delta.head(na), d.fe_laws.data(), d.fe_weights.head(na),
                                total, d.fe_force.head(na), lambda);
      out.iterations += res.iterations;
      if (res.status != NlcpStatus::converged) break;
      double bal = 0;
      for (int a = 0; a < na; ++a) bal += d.balance[d.fe_index[a]] * d.fe_force[a];
      if (!(bal * sgn > 0)) break;
      if (std::fabs(bal - load) <= 1e-12 * std::fabs(load)) break;
      total *= load / bal;
    }
    out.lambda = sgn * lambda;
    for (int i = 0; i < n; ++i) d.approach[i] += out.lambda * S[i].te_gain;
  }
  out.residual = res.residual;
  if (res.status != NlcpStatus::converged) {
    out.converged = false;
    out.message = res.message && *res.message ? res.message
                                               : "level 5 (FE): the coupled force solve did not "
                                                 "converge; raise model.solver_max_iterations";
    return out;
  }
  // forces, and each loaded slice's tangent stiffness: row sums of (C_AA + diag f'_A)^-1, so
  // that their sum is the mesh stiffness under a uniform approach
  d.nlcp->loaded_row_sums(Cn, d.fe_force.head(na), d.fe_work.head(na));
  for (int a = 0; a < na; ++a) {
    d.forces[d.fe_index[a]] = d.fe_force[a];
    d.slice_stiffness[d.fe_index[a]] = d.fe_work[a];
  }
  return out;
}

// Level 5 quasi-static: the TE to detect at first. The solved TE is a smooth function of gear
// 1's angle between mesh events, so it is extrapolated linearly from the last two solves when
// they were made at the same load torque and this step is no longer than twice theirs; else
// the last solved TE. Only where the pass loop starts: the answer is the same fixed point (to
// the pass loop's tolerance), reached with fewer solver iterations and passes.
double predicted_te(gm_data& d, double phi, double load_torque) {
  gm_data::TeHistory& h = d.te_history;
  if (d.fe_prev_n < 0) h.n = 0;  // reset or restored state: cold
  if (h.n < 2 || h.load[0] != load_torque || h.load[1] != load_torque) return d.te_estimate;
  const double step = h.phi[0] - h.phi[1];
  if (step == 0 || std::fabs(phi - h.phi[0]) > 2 * std::fabs(step)) return d.te_estimate;
  return d.te_estimate + (h.te[0] - h.te[1]) / step * (phi - h.phi[0]);
}

void record_te(gm_data& d, double phi, double te, double load_torque) {
  gm_data::TeHistory& h = d.te_history;
  if (h.n > 0 && phi == h.phi[0] && load_torque == h.load[0]) {  // the same pose again
    h.te[0] = te;
    return;
  }
  h.phi[1] = h.phi[0];
  h.te[1] = h.te[0];
  h.load[1] = h.load[0];
  h.phi[0] = phi;
  h.te[0] = te;
  h.load[0] = load_torque;
  h.n = std::min(h.n + 1, 2);
}
}  // namespace

gm_status evaluate(const gm_model& m, gm_data& d, const gm_kinematics& kin_in, gm_result& res) {
  if (!inputs_valid(kin_in, d.message)) return GM_ERR_INPUT;
  const MeshLayout& L = m.layout;
  const double tol = m.params.solver_tolerance;
  const int max_it = m.params.solver_max_iterations;
  double phi2_offset = 0;  // quasi-static: gear 2's whole-turn-reduced spin offset
  gm_kinematics kin = reduced_pose(L, kin_in, &phi2_offset);
  double te_out = 0;
  gm_result r{};
  const bool fe = m.params.stiffness_level == GM_STIFFNESS_FE;
  int n = 0;
  if (!m.params.quasi_static) {
    n = detect_contacts(L, kin, d.slices.data(), m.slice_capacity, d.message);
    if (n < 0) return GM_ERR_INPUT;
    apply_te_excitation(m, d.slices.data(), kin, n);
    build_laws(m, d.slices.data(), d.laws.data(), n, false);
    for (int i = 0; i < n; ++i) d.approach[i] = d.slices[i].approach;
    const ForceSolve fs =
        fe ? fe_solve(m, d, kin, n, false, false, 0.0)
           : solve_separable(d.laws.data(), d.approach.data(), n, tol, max_it, d.forces.data(),
                             d.slice_stiffness.data());
    if (!fs.converged) {
      d.message = fs.message;
      return GM_ERR_SOLVER;
    }
    r.solver_iterations = fs.iterations;
    r.solver_residual = fs.residual;
  } else {
    // Quasi-static (docs/physics.md §6): gear 2's spin follows from the load torque. Detect at the TE
    // estimate, solve the load balance for the rigid approach lambda, move there, and repeat
    // while the move changes what detection sees (tip edges); the estimate carries over calls.
    const double s = L.sign, rb1 = L.base_radius[0], rb2 = L.base_radius[1];
    const double load = kin.load_torque / rb2;  // generalized force of the TE coordinate, N
    double te = fe ? predicted_te(d, kin_in.phi[0], kin.load_torque) : d.te_estimate;
    for (int pass = 0; pass < 6; ++pass) {
      kin.phi[1] = (te - rb1 * kin.phi[0]) / (s * rb2) + phi2_offset;
      n = detect_contacts(L, kin, d.slices.data(), m.slice_capacity, d.message);
      if (n < 0) return GM_ERR_INPUT;
      apply_te_excitation(m, d.slices.data(), kin, n);  // detection is redone every pass
      build_laws(m, d.slices.data(), d.laws.data(), n, true);
      balance_weights(m, d.slices.data(), kin, n, d.balance.data());
      if (fe)
        for (int i = 0; i < n; ++i) d.approach[i] = d.slices[i].approach;
      const ForceSolve fs =
          fe ? fe_solve(m, d, kin, n, true, true, load)
             : solve_separable_total(d.laws.data(), d.slices.data(), d.balance.data(), n, load,
                                     0.0, tol, max_it, d.approach.data(), d.forces.data(),
                                     d.slice_stiffness.data());
      if (!fs.converged) {
        d.message = fs.message;
        return GM_ERR_SOLVER;
      }
      r.solver_iterations += fs.iterations;
      r.solver_residual = fs.residual;
      te += fs.lambda;
      if (std::fabs(fs.lambda) <= std::max(tol, 1e-12 * L.base_pitch)) break;
    }
    kin.phi[1] = (te - rb1 * kin.phi[0]) / (s * rb2) + phi2_offset;
    d.te_estimate = te;
    te_out = te;
    if (fe) record_te(d, kin_in.phi[0], te, kin.load_torque);
    // The last pass ends at the solved pose; its slice forces belong to approach + gain lambda.
    for (int i = 0; i < n; ++i) d.slices[i].approach = d.approach[i];
  }
  ResultT<double> rt;
  r.elastic_energy = elastic_energy(d.slices.data(), d.laws.data(), d.forces.data(), n);
  resultants(m, d.slices.data(), d.forces.data(), d.slice_stiffness.data(), kin, n, rt);
  for (int i = 0; i < 2; ++i) {
    for (int a = 0; a < 3; ++a) {
      r.force[i][a] = rt.force[i][a];
      r.moment[i][a] = rt.moment[i][a];
    }
  }
  r.normal_force = rt.normal_force;
  r.stiffness = rt.stiffness;
  r.friction_power = rt.friction_power;
  r.damping_power = rt.damping_power;
  r.max_line_load = rt.max_line_load;
  r.pairs_in_contact = rt.pairs_in_contact;
  r.flank = rt.flank;
  // TE from the spin angles as given, as encoders measure it; solved in quasi-static mode.
  r.te = m.params.quasi_static
             ? te_out
             : L.base_radius[0] * kin_in.phi[0] + L.sign * L.base_radius[1] * kin_in.phi[1];
  r.te_angle = r.te / L.base_radius[1];
  res = r;
  d.message.clear();
  return GM_OK;
}

namespace {

// The inputs as dual numbers: values from `at`, derivatives from `seed`.
KinematicsT<Dual> dual_kinematics(const gm_kinematics& at, const gm_kinematics& seed) {
  KinematicsT<Dual> k;
  for (int i = 0; i < 2; ++i) {
    for (int a = 0; a < 3; ++a) {
      k.u[i][a] = Dual(at.u[i][a], seed.u[i][a]);
      k.v[i][a] = Dual(at.v[i][a], seed.v[i][a]);
    }
    for (int a = 0; a < 2; ++a) {
      k.r[i][a] = Dual(at.r[i][a], seed.r[i][a]);
      k.w[i][a] = Dual(at.w[i][a], seed.w[i][a]);
    }
    k.phi[i] = Dual(at.phi[i], seed.phi[i]);
    k.omega[i] = Dual(at.omega[i], seed.omega[i]);
  }
  k.load_torque = Dual(at.load_torque, seed.load_torque);
  return k;
}

// One pass of the evaluation over dual numbers at the pose kin (gear 2's spin included):
// detection, laws, the force solve in double with the implicit derivative of each loaded
// slice, c F + f(F) = Delta => dF = (dDelta - F dc - df/dp dp)/(c + f'(F)) (never
// differentiating Newton iterations), and the resultants. `all`: laws of every slice (the
// quasi-static solve's setting). Quasi-static extras: the load balance sum_i b_i F_i, and for a
// free mesh (no slice loaded) the approach of the flank-A slice that touches first.
struct DualPass {
  ResultT<Dual> r;
  Dual balance;   // sum_i b_i F_i, N (normal forces before damping)
  Dual touch;     // approach of the first-touching slice (free mesh), m
  bool loaded = false;
  bool has_touch = false;
};

// Levels 0-4: the value problem solved as gm_evaluate solves it, then the implicit derivative
// of each loaded slice (the slices are independent).
gm_status separable_dual_forces(const gm_model& m, gm_data& d, int n) {
  const ContactSliceT<Dual>* slices = d.dual_slices.data();
  // the value problem, solved as gm_evaluate solves it
  for (int i = 0; i < n; ++i) {
    const SliceLawT<Dual>& dl = d.dual_laws[i];
    SliceLaw& law = d.laws[i];
    law.compliance = dl.compliance.v;
    law.local.width = dl.local.width.v;
    law.local.reduced_radius = dl.local.reduced_radius.v;
    for (int g = 0; g < 2; ++g) {
      law.local.body[g].youngs_modulus = dl.local.body[g].youngs_modulus;
      law.local.body[g].poisson_ratio = dl.local.body[g].poisson_ratio;
      law.local.body[g].depth = dl.local.body[g].depth.v;
    }
    d.approach[i] = slices[i].approach.v;
  }
  const ForceSolve fs = solve_separable(d.laws.data(), d.approach.data(), n,
                                        m.params.solver_tolerance,
                                        m.params.solver_max_iterations, d.forces.data(),
                                        d.slice_stiffness.data());
  if (!fs.converged) {
    d.message = fs.message;
    return GM_ERR_SOLVER;
  }
  // implicit derivative of each loaded slice; open slices stay at F = 0
  for (int i = 0; i < n; ++i) {
    const double F = d.forces[i];
    if (!(F > 0)) {
      d.dual_forces[i] = Dual(0);
      d.dual_stiffness[i] = Dual(0);
      continue;
    }
    const SliceLawT<Dual>& law = d.dual_laws[i];
    if (!has_local_law(d.laws[i].local)) {
      d.dual_forces[i] = Dual(F, (slices[i].approach.d - F * law.compliance.d) / law.compliance.v);
      d.dual_stiffness[i] = 1.0 / law.compliance;
      continue;
    }
    Dual f, fp;
    local_law_approach_slope(law.local, Dual(F, 0), f, fp);  // f.d = (df/dp) dp at fixed F
    const double dF = (slices[i].approach.d - F * law.compliance.d - f.d) / (law.compliance.v + fp.v);
    d.dual_forces[i] = Dual(F, dF);
    local_law_approach_slope(law.local, d.dual_forces[i], f, fp);  // f' along F and p
    d.dual_stiffness[i] = 1.0 / (law.compliance + fp);
  }
  return GM_OK;
}

// Level 5: the value problem as gm_evaluate solves it (detection, laws and the coupled solve in
// double at the values; the same candidates in the same order as the dual detection), then the
// implicit derivative on the loaded set A, where C_AA F_A + f_A(F_A) = Delta_A holds:
//   (C_AA + diag f'_A) dF_A = dDelta_A - dC_AA F_A - (df/dp)_A dp,
// dC from the database interpolation over dual numbers (roll weights: the slope of the linear
// interpolation; face shares: of the slice's interval), df/dp of the local Hertz law at fixed F.
// The tangent stiffness of each loaded slice, x = (C_AA + diag f'_A)^-1 1, moves with
// dx = -(C_AA + diag f'_A)^-1 (dC_AA + diag df'_A) x.
gm_status fe_dual_forces(const gm_model& m, gm_data& d, const KinematicsT<Dual>& kin, int n,
                         bool all) {
  gm_kinematics kv{};
  for (int i = 0; i < 2; ++i) {
    for (int a = 0; a < 3; ++a) {
      kv.u[i][a] = kin.u[i][a].v;
      kv.v[i][a] = kin.v[i][a].v;
    }
    for (int a = 0; a < 2; ++a) {
      kv.r[i][a] = kin.r[i][a].v;
      kv.w[i][a] = kin.w[i][a].v;
    }
    kv.phi[i] = kin.phi[i].v;
    kv.omega[i] = kin.omega[i].v;
  }
  kv.load_torque = kin.load_torque.v;
  const int nv = detect_contacts(m.layout, kv, d.slices.data(), m.slice_capacity, d.message);
  if (nv < 0) return GM_ERR_INPUT;
  const ContactSliceT<Dual>* S = d.dual_slices.data();
  bool same = nv == n;
  for (int i = 0; same && i < n; ++i)
    same = d.slices[i].tooth[0] == S[i].tooth[0] && d.slices[i].tooth[1] == S[i].tooth[1] &&
           d.slices[i].flank == S[i].flank;
  if (!same) {
    d.message = "level 5 (FE): the derivative's detection found other candidates than the "
                "evaluation's (internal error)";
    return GM_ERR_SOLVER;
  }
  apply_te_excitation(m, d.slices.data(), kv, n);
  build_laws(m, d.slices.data(), d.laws.data(), n, all);
  for (int i = 0; i < n; ++i) d.approach[i] = d.slices[i].approach;
  const ForceSolve fs = fe_solve(m, d, kv, n, all, false, 0.0);
  if (!fs.converged) {
    d.message = fs.message;
    return GM_ERR_SOLVER;
  }
  int na = 0;
  for (int i = 0; i < n; ++i) {
    d.dual_forces[i] = Dual(0);
    d.dual_stiffness[i] = Dual(0);
    if (d.forces[i] > 0) d.fe_index[na++] = i;
  }
  if (na == 0) return GM_OK;
  const Dual uz[2] = {kin.u[0][2], kin.u[1][2]};
  auto H = d.fe_tangent.topLeftCorner(na, na);
  auto dC = d.fe_dual_c.topLeftCorner(na, na);
  for (int p = 0; p < na; ++p) {
    for (int q = 0; q <= p; ++q) {
      const Dual c = fe_pair_compliance(m, S[d.fe_index[p]], S[d.fe_index[q]], uz);
      H(p, q) = H(q, p) = c.v;
      dC(p, q) = dC(q, p) = c.d;
    }
  }
  auto rhs = d.fe_delta.head(na);
  auto x = d.fe_work.head(na);
  auto dx = d.fe_weights.head(na);
  for (int p = 0; p < na; ++p) {
    const int i = d.fe_index[p];
    double fd = 0;
    if (has_local_law(d.laws[i].local)) {
      Dual f, fp;
      local_law_approach_slope(d.dual_laws[i].local, Dual(d.forces[i], 0), f, fp);
      H(p, p) += fp.v;
      fd = f.d;
    }
    double dcf = 0;
    for (int q = 0; q < na; ++q) dcf += dC(p, q) * d.forces[d.fe_index[q]];
    rhs[p] = S[i].approach.d - dcf - fd;
  }
  Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt(H);
  if (llt.info() != Eigen::Success) {
    d.message = "level 5 (FE): C + diag(f') is not positive definite on the loaded slices";
    return GM_ERR_SOLVER;
  }
  llt.solveInPlace(rhs);  // dF_A
  x.setOnes();
  llt.solveInPlace(x);
  for (int p = 0; p < na; ++p) {
    const int i = d.fe_index[p];
    d.dual_forces[i] = Dual(d.forces[i], rhs[p]);
    double dfp = 0;
    if (has_local_law(d.laws[i].local)) {
      Dual f, fp;
      local_law_approach_slope(d.dual_laws[i].local, d.dual_forces[i], f, fp);
      dfp = fp.d;
    }
    dx[p] = dfp * x[p];
    for (int q = 0; q < na; ++q) dx[p] += dC(p, q) * x[q];
  }
  llt.solveInPlace(dx);
  for (int p = 0; p < na; ++p) d.dual_stiffness[d.fe_index[p]] = Dual(x[p], -dx[p]);
  return GM_OK;
}

gm_status dual_pass(const gm_model& m, gm_data& d, const KinematicsT<Dual>& kin, bool all,
                    DualPass& out) {
  const int n = detect_contacts(m.layout, kin, d.dual_slices.data(), m.slice_capacity, d.message);
  if (n < 0) return GM_ERR_INPUT;
  ContactSliceT<Dual>* slices = d.dual_slices.data();
  apply_te_excitation(m, slices, kin, n);
  build_laws(m, slices, d.dual_laws.data(), n, all);
  if (m.params.stiffness_level == GM_STIFFNESS_FE) {
    const gm_status st = fe_dual_forces(m, d, kin, n, all);
    if (st != GM_OK) return st;
  } else {
    const gm_status st = separable_dual_forces(m, d, n);
    if (st != GM_OK) return st;
  }
  out = DualPass{};
  if (all) {
    balance_weights(m, slices, kin, n, d.dual_balance.data());
    double closest = std::numeric_limits<double>::infinity();
    for (int i = 0; i < n; ++i) {
      out.balance += d.dual_balance[i] * d.dual_forces[i];
      out.loaded = out.loaded || d.forces[i] > 0;
      // gm::evaluate at zero load on a free mesh: the TE where the first slice with a positive
      // TE gain touches (approach 0)
      if (slices[i].te_gain.v > 0 && std::fabs(slices[i].approach.v) < closest) {
        closest = std::fabs(slices[i].approach.v);
        out.touch = slices[i].approach;
        out.has_touch = true;
      }
    }
  }
  const Dual energy = elastic_energy(slices, d.dual_laws.data(), d.dual_forces.data(), n);
  resultants(m, slices, d.dual_forces.data(), d.dual_stiffness.data(), kin, n, out.r);
  out.r.elastic_energy = energy;
  return GM_OK;
}

// Level 5: saves the coupled solve's warm start (previous forces and candidates) and restores
// it when the derivative returns, so that gm_evaluate's next result does not depend on it.
class FeWarmStartGuard {
 public:
  FeWarmStartGuard(gm_data& d, bool active) : d_(d), active_(active), n_(d.fe_prev_n) {
    for (int a = 0; active_ && a < n_; ++a) {
      d_.fe_saved_force[a] = d_.fe_force[a];
      d_.fe_saved_key[a] = d_.fe_prev_key[a];
    }
  }
  ~FeWarmStartGuard() {
    if (!active_) return;
    for (int a = 0; a < n_; ++a) {
      d_.fe_force[a] = d_.fe_saved_force[a];
      d_.fe_prev_key[a] = d_.fe_saved_key[a];
    }
    d_.fe_prev_n = n_;
  }
  FeWarmStartGuard(const FeWarmStartGuard&) = delete;
  FeWarmStartGuard& operator=(const FeWarmStartGuard&) = delete;

 private:
  gm_data& d_;
  bool active_;
  int n_;
};

}  // namespace

gm_status directional_derivative(const gm_model& m, gm_data& d, const gm_kinematics& at_in,
                                 const gm_kinematics& seed, gm_result& res) {
  if (!inputs_valid(at_in, d.message)) return GM_ERR_INPUT;
  if (!inputs_finite(seed, d.message)) {
    d.message = "seed: " + d.message;
    return GM_ERR_INPUT;
  }
  // level 5: the coupled solve's warm start is the evaluation's, left as it was
  const FeWarmStartGuard guard(d, m.params.stiffness_level == GM_STIFFNESS_FE);
  const MeshLayout& L = m.layout;
  const double s = L.sign, rb1 = L.base_radius[0], rb2 = L.base_radius[1];
  double phi2_offset = 0;
  const gm_kinematics at = reduced_pose(L, at_in, &phi2_offset);  // as gm_evaluate detects
  KinematicsT<Dual> kin = dual_kinematics(at, seed);
  gm_result out{};
  Dual te, te_angle;
  DualPass p;
  if (!m.params.quasi_static) {
    const gm_status st = dual_pass(m, d, kin, false, p);
    if (st != GM_OK) return st;
    te = rb1 * kin.phi[0] + s * rb2 * kin.phi[1];
  } else {
    // The solved TE at `at` (the warm start is restored afterwards), then two passes at that
    // pose: A along the seed with the TE held, B along the TE alone. Every output is linear in
    // the direction, so output' = A + dTE B with dTE from the load balance:
    // d(sum b_i F_i) = d(load_torque)/r_b2 (or, on a free mesh at zero load, from the touching
    // slice's approach staying 0).
    const double warm = d.te_estimate;
    const gm_data::TeHistory history = d.te_history;
    gm_result r0;
    const gm_status st0 = evaluate(m, d, at_in, r0);
    d.te_estimate = warm;
    d.te_history = history;
    if (st0 != GM_OK) return st0;
    kin.phi[1] = Dual((r0.te - rb1 * at.phi[0]) / (s * rb2) + phi2_offset,
                      -rb1 * seed.phi[0] / (s * rb2));
    DualPass a, b;
    gm_status st = dual_pass(m, d, kin, true, a);
    if (st != GM_OK) return st;
    KinematicsT<Dual> kb = dual_kinematics(at, gm_kinematics{});
    kb.phi[1] = Dual(kin.phi[1].v, 1 / (s * rb2));
    st = dual_pass(m, d, kb, true, b);
    if (st != GM_OK) return st;
    double dte = 0;
    if (a.loaded && b.balance.d != 0) {
      dte = (seed.load_torque / rb2 - a.balance.d) / b.balance.d;
    } else if (a.has_touch && b.touch.d != 0) {
      dte = -a.touch.d / b.touch.d;
    }
    const auto combine = [dte](Dual& x, const Dual& y) { x.d += dte * y.d; };
    for (int i = 0; i < 2; ++i) {
      for (int c = 0; c < 3; ++c) {
        combine(a.r.force[i][c], b.r.force[i][c]);
        combine(a.r.moment[i][c], b.r.moment[i][c]);
      }
    }
    combine(a.r.normal_force, b.r.normal_force);
    combine(a.r.stiffness, b.r.stiffness);
    combine(a.r.friction_power, b.r.friction_power);
    combine(a.r.max_line_load, b.r.max_line_load);
    combine(a.r.elastic_energy, b.r.elastic_energy);
    combine(a.r.damping_power, b.r.damping_power);
    p = a;
    te = Dual(r0.te, dte);
  }
  te_angle = te / rb2;
  for (int i = 0; i < 2; ++i) {
    for (int c = 0; c < 3; ++c) {
      out.force[i][c] = p.r.force[i][c].d;
      out.moment[i][c] = p.r.moment[i][c].d;
    }
  }
  out.te = te.d;
  out.te_angle = te_angle.d;
  out.normal_force = p.r.normal_force.d;
  out.stiffness = p.r.stiffness.d;
  out.friction_power = p.r.friction_power.d;
  out.max_line_load = p.r.max_line_load.d;
  out.elastic_energy = p.r.elastic_energy.d;
  out.damping_power = p.r.damping_power.d;
  res = out;
  d.message.clear();
  return GM_OK;
}

}  // namespace gm
