// Where modified flanks touch: the rigid approach's growth when a profile modification moves the
// touch point off the involutes' conjugate point (docs/physics.md §3), for the detection
// (detection.cpp) over double and dual numbers.
#pragma once

#include <algorithm>
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
// profile (smooth_profile_gap: profile crowning and slope), so the stationary point
// x = -R' G'(x) exists and the fixed point reaches it (it contracts by R' G'', a few per cent for
// crowning), within the flanks' active profiles. The derivative is the envelope's, at the touch
// point held (at an end of a profile, that end held). Left out: the reliefs and measured
// deviations (a relief starts at a point, where the touch point's path has a kink and the
// approach's curvature a step that the integrator and the Jacobian would meet; a measured table
// has such points everywhere), and the touch point's own shift (x* = -R' G', 0.1 mm for set B)
// in the compliances.
struct TouchSearch {
  double x = 0;     // the touch point's arc length from the conjugate point, m
  double gain = 0;  // the rigid approach's growth, m (transverse)
  int edge = -1;    // the gear whose active profile's end holds the touch point (-1: none)
  double edge_rho = 0;  // that end's roll distance, m
};

inline double touch_roll(double rho, double dir_rb, double x) {
  return std::sqrt(std::fmax(rho * rho + 2.0 * dir_rb * x, 0.0));
}

inline TouchSearch touch_search(const MeshLayout& L, int fl, double rho1, double rho2) {
  TouchSearch out;
  const double inv_r = 1.0 / rho1 + L.sign / rho2;
  if (!(rho1 > 0 && rho2 > 0 && inv_r > 0)) return out;
  const double R = 1.0 / inv_r, cb = L.cos_beta_b;
  const double dir_rb[2] = {L.base_radius[0], -L.sign * L.base_radius[1]};
  const double rho[2] = {rho1, rho2};
  // the arc lengths that keep both contact points on their active profiles, and whose end each is
  double lo = -1e300, hi = 1e300, lo_rho = 0, hi_rho = 0;
  int lo_gear = -1, hi_gear = -1;
  for (int g = 0; g < 2; ++g) {
    double ends[2] = {std::fmin(L.rho_form[g], L.rho_tip[g]), std::fmax(L.rho_form[g], L.rho_tip[g])};
    double x1 = (ends[0] * ends[0] - rho[g] * rho[g]) / (2.0 * dir_rb[g]);
    double x2 = (ends[1] * ends[1] - rho[g] * rho[g]) / (2.0 * dir_rb[g]);
    if (x1 > x2) {
      std::swap(x1, x2);
      std::swap(ends[0], ends[1]);
    }
    if (x1 > lo) lo = x1, lo_gear = g, lo_rho = ends[0];
    if (x2 < hi) hi = x2, hi_gear = g, hi_rho = ends[1];
  }
  // a conjugate point beyond an end (a contact entering or leaving the profile): the search
  // reaches back to it, so that the growth stays continuous as the point crosses the end
  if (lo > 0) lo = 0, lo_gear = -1;
  if (hi < 0) hi = 0, hi_gear = -1;
  // G(x) and G'(x)
  const auto gap = [&](double x, double& slope) {
    double G = 0;
    slope = 0;
    for (int g = 0; g < 2; ++g) {
      if (!L.micro[g].profile_any[fl]) continue;
      const double r = touch_roll(rho[g], dir_rb[g], x);
      double d_rho = 0;
      G += smooth_profile_gap(L.micro[g], fl, r, d_rho);
      if (r > 0) slope += d_rho * dir_rb[g] / r;
    }
    return G / cb;
  };
  double slope = 0;
  const double G0 = gap(0, slope);
  if (slope == 0) return out;
  // the root of phi(x) = x + R' G'(x) by secant steps from the fixed point's first two iterates
  // (phi' = 1 + R' G'', near 1), kept within [lo, hi]
  double x0 = 0, phi0 = R * slope, x = std::fmin(std::fmax(-R * slope, lo), hi);
  double G = gap(x, slope);
  for (int k = 0; k < 20; ++k) {
    const double phi = x + R * slope;
    if (std::fabs(phi) <= 1e-9 * std::fabs(x) + 1e-16 || phi == phi0) break;
    const double next = std::fmin(std::fmax(x - phi * (x - x0) / (phi - phi0), lo), hi);
    if (next == x) break;  // held at an end
    x0 = x, phi0 = phi, x = next;
    G = gap(x, slope);
  }
  out.gain = G0 - G - 0.5 * x * x / R;
  out.x = x;
  if (x == lo && x != 0) out.edge = lo_gear, out.edge_rho = lo_rho;
  if (x == hi && x != 0) out.edge = hi_gear, out.edge_rho = hi_rho;
  if (!(out.gain > 0)) out = TouchSearch{};
  return out;
}

// The growth of touch_search at its touch point, over the scalar type (dual numbers: the
// envelope's derivative, the touch point held; at an end of an active profile, that end held).
inline double touch_profile_gap(const GearMicrogeometry& m, int fl, double rho) {
  double d_rho = 0;
  return smooth_profile_gap(m, fl, rho, d_rho);
}
inline Dual touch_profile_gap(const GearMicrogeometry& m, int fl, const Dual& rho) {
  return smooth_profile_gap(m, fl, rho);
}

// Whether either gear's flank fl has a profile modification touch_search takes.
inline bool touch_applies(const MeshLayout& L, int fl) {
  return L.micro[0].profile_any[fl] || L.micro[1].profile_any[fl];
}

template <class T>
T touch_gain(const MeshLayout& L, int fl, const T& rho1, const T& rho2) {
  GM_AD_USING;
  const TouchSearch t = touch_search(L, fl, val(rho1), val(rho2));
  if (t.gain <= 0) return T(0);
  const T inv_r = 1.0 / rho1 + L.sign / rho2;
  const double dir_rb[2] = {L.base_radius[0], -L.sign * L.base_radius[1]};
  const T rho[2] = {rho1, rho2};
  const T x = t.edge < 0 ? T(t.x) : (t.edge_rho * t.edge_rho - rho[t.edge] * rho[t.edge]) / (2.0 * dir_rb[t.edge]);
  T change = 0;
  for (int g = 0; g < 2; ++g) {
    if (!L.micro[g].profile_any[fl]) continue;
    change += touch_profile_gap(L.micro[g], fl, rho[g]) -
              touch_profile_gap(L.micro[g], fl, T(sqrt(rho[g] * rho[g] + 2.0 * dir_rb[g] * x)));
  }
  return change / L.cos_beta_b - 0.5 * x * x * inv_r;
}

}  // namespace gm
