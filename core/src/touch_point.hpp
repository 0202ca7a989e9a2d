// Where modified flanks touch: the rigid approach's growth when a profile modification moves the
// touch point off the involutes' conjugate point (docs/physics.md §3), for the detection
// (detection.cpp) over double and dual numbers.
#pragma once

#include <cmath>

#include "detection.hpp"
#include "dual.hpp"
#include "microgeometry.hpp"

namespace gm {

// Where modified flanks touch (docs/physics.md §3). The involutes are conjugate: off their
// contact point, at arc length x along the common tangent of the transverse section, they part by
// x^2/(2 R'), R' = 1/(1/rho_1 + s/rho_2) (s = -1 for a ring). A modification whose gap changes
// along the profile tilts that parabola, so the flanks meet where the gap less the parting is
// largest, not at the conjugate point: the rigid approach grows by
//   max_x [G(0) - G(x) - x^2/(2 R')],   G = (gap_1 + gap_2)/cos(beta_b),
// R' G'^2/2 for a gap of slope G' (0.35 um for set B's crowning half a pitch from the pitch
// point, where the CalculiX reference finds 0.33 um). The involute's arc from its base point is
// rho^2/(2 r_b), so x moves rho_1^2 by 2 r_b1 x and rho_2^2 by -2 s r_b2 x (towards gear 1's tip
// is towards gear 2's root). G is the part of the design gap that is smooth over the whole
// profile (smooth_profile_jet: profile crowning and slope). Left out: the reliefs and measured
// deviations (a relief starts at a point, where the touch point's path has a kink and the
// approach's curvature a step that the integrator and the Jacobian would meet; a measured table
// has such points everywhere), and the touch point's own shift (x* = -R' G', 0.1 mm for set B)
// in the compliances.
//
// The largest is taken from the quadratic model at the conjugate point: G(x) ~ G'x + G''x^2/2 with the
// derivatives along the arc (the chain through rho(x): d rho/dx = r_b/rho, d2 rho/dx2 = -r_b^2/rho^3,
// signed per gear), so the touch point is x* = -G'/(1/R' + G'') and the growth G'^2/(2(1/R' + G''))
// (crowning and slope are quadratic in rho, so the model's only error is the arc's curvature in
// rho: a part in 10^3 of the growth for set B). Within the flanks' active profiles: held at the
// nearer end when x* lies beyond it. One evaluation per gear, a closed form over the scalar type
// (its derivative is the formula's).
struct TouchPoint {
  double x = 0;     // the touch point's arc length from the conjugate point, m
  double gain = 0;  // the rigid approach's growth, m (transverse)
  int edge = -1;    // the gear whose active profile's end holds it (-1: none)
};

template <class T>
T touch_gain(const MeshLayout& L, int fl, const T& rho1, const T& rho2, TouchPoint* where = nullptr) {
  if (where) *where = TouchPoint{};
  const T inv_r = 1.0 / rho1 + L.sign / rho2;
  if (!(val(rho1) > 0 && val(rho2) > 0 && val(inv_r) > 0)) return T(0);
  const double dir_rb[2] = {L.base_radius[0], -L.sign * L.base_radius[1]};
  const T rho[2] = {rho1, rho2};
  T G1 = 0, G2 = 0;  // dG/dx and d2G/dx2 at the conjugate point
  for (int g = 0; g < 2; ++g) {
    if (!L.micro[g].profile_any[fl]) continue;
    T d1 = 0;
    double d2 = 0;
    smooth_profile_jet(L.micro[g], fl, rho[g], d1, d2);
    const T a = dir_rb[g] / rho[g];
    G1 += d1 * a;
    G2 += d2 * a * a - d1 * a * a / rho[g];
  }
  G1 /= L.cos_beta_b;
  G2 /= L.cos_beta_b;
  if (val(G1) == 0) return T(0);
  T k = inv_r + G2;
  if (val(k) < 0.5 * val(inv_r)) k = 0.5 * inv_r;  // a relief curved against the flanks (not met)
  T x = -G1 / k;
  // held at the nearer end of either active profile that x* passes (never past the conjugate point)
  int edge = -1;
  for (int g = 0; g < 2; ++g) {
    for (const double end : {L.rho_form[g], L.rho_tip[g]}) {
      const T xe = (end * end - rho[g] * rho[g]) / (2.0 * dir_rb[g]);
      if ((val(x) > 0 && val(xe) >= 0 && val(xe) < val(x)) || (val(x) < 0 && val(xe) <= 0 && val(xe) > val(x))) {
        x = xe;
        edge = g;
      }
    }
  }
  const T gain = -G1 * x - 0.5 * k * x * x;
  if (where) {
    where->x = val(x);
    where->gain = val(gain);
    where->edge = edge;
  }
  return gain;
}

// Whether either gear's flank fl has a profile modification touch_gain takes.
inline bool touch_applies(const MeshLayout& L, int fl) {
  return L.micro[0].profile_any[fl] || L.micro[1].profile_any[fl];
}

}  // namespace gm
