// The input checks of gm_evaluate and gm_directional_derivative, and the pose detection sees
// (spins reduced by whole turns).
#include "inputs.hpp"

#include <cmath>
#include <cstdio>

namespace gm {

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

namespace {

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

}  // namespace

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

}  // namespace gm
