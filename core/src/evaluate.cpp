#include "evaluate.hpp"

#include <cmath>
#include <cstdio>

#include <Eigen/Geometry>

namespace gm {
namespace {

// Name the first non-finite input, using the FMU variable names.
bool inputs_finite(const gm_kinematics& k, std::string& msg) {
  static const char* const kAxes[3] = {"x", "y", "z"};
  for (int i = 0; i < 2; ++i) {
    const auto bad = [&](const char* prefix, const char* axis, double v) {
      if (std::isfinite(v)) return false;
      char buf[120];
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

}  // namespace

gm_status check_capabilities(const gm_model_params& p, std::string& msg) {
  char buf[240];
  if (p.stiffness_level != GM_STIFFNESS_USER_CONSTANT) {
    std::snprintf(buf, sizeof buf,
                  "model.stiffness = %d: only level 0 (user constant) is in this build yet; "
                  "allowed value 0", p.stiffness_level);
  } else if (p.friction_coefficient != 0) {
    std::snprintf(buf, sizeof buf,
                  "model.friction_coefficient = %g: friction is not in this build yet; allowed "
                  "value 0", p.friction_coefficient);
  } else if (p.damping != 0) {
    std::snprintf(buf, sizeof buf,
                  "model.damping = %g N.s/m2: contact damping is not in this build yet; allowed "
                  "value 0", p.damping);
  } else {
    return GM_OK;
  }
  msg = buf;
  return GM_ERR_PARAMETER;
}

gm_status evaluate(const gm_model& m, gm_data& d, const gm_kinematics& kin, gm_result& res) {
  if (!inputs_finite(kin, d.message)) return GM_ERR_INPUT;
  if (!tilts_in_range(kin, d.message)) return GM_ERR_INPUT;
  const MeshLayout& L = m.layout;
  const int n = detect_contacts(L, kin, d.slices.data(), m.slice_capacity, d.message);
  if (n < 0) return GM_ERR_INPUT;
  // Level 0: k' is per unit face width on the transverse line of action (ISO 6336-1's c'),
  // so along the flank normal of a helical slice it is k' / cos^2(beta_b).
  const double cb2 = L.cos_beta_b * L.cos_beta_b;
  solve_user_constant(m.params.user_stiffness / cb2, d.slices.data(), n, d.forces.data(),
                      d.slice_stiffness.data());

  gm_result r{};
  const Eigen::Vector3d c[2] = {
      Eigen::Vector3d(kin.u[0][0], kin.u[0][1], kin.u[0][2]),
      Eigen::Vector3d(L.center_distance + kin.u[1][0], kin.u[1][1], kin.u[1][2])};
  Eigen::Vector3d f[2] = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  Eigen::Vector3d mom[2] = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  int last_loaded_pair = -1;
  for (int i = 0; i < n; ++i) {
    const double F = d.forces[i];
    if (F <= 0) continue;
    const ContactSlice& s = d.slices[i];
    const Eigen::Vector3d on2 = F * s.normal;  // gear 1 pushes gear 2 along the normal
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
  // TE from the spin angles, as encoders measure it (PHYSICS 0).
  r.te = L.base_radius[0] * kin.phi[0] + L.sign * L.base_radius[1] * kin.phi[1];
  r.te_angle = r.te / L.base_radius[1];
  r.solver_iterations = 0;  // closed form
  r.solver_residual = 0;
  res = r;
  d.message.clear();
  return GM_OK;
}

}  // namespace gm
