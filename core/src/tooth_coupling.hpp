// Level 4 (analytical): the coupling between the teeth of one gear through its rim and body
// (docs/model.md, "Tooth coupling at level 4"; docs/physics.md §5).
//
// A line load on one tooth turns and bends the rim and the body under it, which moves the
// neighbouring teeth: tooth d (d = receiver - loaded tooth, counter-clockwise positive as the
// compliance databases count) moves along its flank normal at height h_a by
//     k_d(h_a, h_b) q,   E k_d = c00 + c10 h_a + c01 h_b + c11 h_a h_b      (d = 1, 2, 3)
// per unit line load q (N/m, face-uniform) on tooth 0 at height h_b, heights above the
// reference circle in normal modules; k_-d(h_a, h_b) = k_d(h_b, h_a) (Maxwell-Betti). The
// coefficients are a surrogate of compliance_tool's FE databases, fitted offline
// (tools/gearmesh_dev/coupling_fit.py) over a family of solid-disc gears clamped at a bore of 0.4
// root radius (the body Sainsot's term of level 4 assumes), tabulated over the tooth count and
// b/m_n and interpolated here (linear in 1/z and in b/m_n, clamped at the table's ends; a tooth
// count outside the table flags the gear as extrapolated, a b/m_n outside it does not: the
// kernel moves by < 1 % between the table's widths, and held-out gears beyond them measure the
// clamping, docs/model.md "Tooth coupling at level 4").
//
// Between slices i (receiver) and j (load) of different tooth pairs on the same flank the
// coupled compliance is, per gear g with the offset d_g of their teeth on g,
//     C_ij = sum_g k_dg(h_g(rho_i), h_g(rho_j)) / b_o      (m/N)
// with b_o the axial overlap of the faces: a slice force F_j is read as a line load spread over
// the overlap (face-uniform kernel: the database's face dependence is averaged). Flank B reads
// the mirror image (d -> -d); flanks A and B never couple. Slices of one tooth pair are not
// coupled (level 4's per-tooth Weber/Sainsot compliance is their whole compliance).
#pragma once

#include <cmath>
#include <cstdlib>
#include <string>

#include "detection.hpp"
#include "dual.hpp"
#include "gearmesh/gearmesh.h"

namespace gm {

constexpr int kCouplingMaxOffset = 3;  // tooth offsets the table holds, each side

// The table's coefficients at one gear: c[d - 1] = {c00, c10, c01, c11} (dimensionless E k_d).
struct CouplingCoefficients {
  double c[kCouplingMaxOffset][4] = {};
  bool extrapolated = false;  // teeth outside the table (clamped to its edge)
};

// The table interpolated at `teeth` and b/m_n = width_over_module.
CouplingCoefficients coupling_coefficients(double teeth, double width_over_module);

// The table's range: teeth and b/m_n.
void coupling_table_range(double& teeth_min, double& teeth_max, double& width_min,
                          double& width_max);

struct ToothCouplingGear {
  CouplingCoefficients k;
  int teeth = 0;
  double base_radius = 0;   // r_b, m
  double ref_radius = 0;    // r (transverse reference radius), m
  double inv_module = 0;    // 1 / m_n, 1/m
  double scale = 0;         // 1 / (E b_o), m/N per unit of E k
};

struct ToothCoupling {
  int offsets = 0;          // coupled teeth each side (model.coupled_teeth, <= 3); 0: none
  ToothCouplingGear gear[2];
};

// The coupling of pair p at level 4 (offsets = p.coupled_teeth, 0..3); GM_ERR_PARAMETER with
// msg naming the parameter for what it cannot model (an internal ring: level 4 refuses it anyway).
// `warning`: non-empty when a gear lies outside the table's range (extrapolated), or for a
// helical pair (the coupling is face-uniform: validated for spur gears, docs/model.md).
gm_status build_tooth_coupling(const gm_model_params& p, const gm_pair_geometry& g,
                               ToothCoupling& out, std::string& warning, std::string& msg);

// E k_d(h_a, h_b) of one gear for any offset d != 0 with |d| <= 3.
template <class T>
T coupling_kernel(const CouplingCoefficients& k, int d, const T& ha, const T& hb) {
  const double* c = k.c[std::abs(d) - 1];
  const T& a = d > 0 ? ha : hb;  // receiver's height in the table's orientation
  const T& b = d > 0 ? hb : ha;
  return c[0] + c[1] * a + c[2] * b + c[3] * a * b;
}

// Height of roll distance rho above gear g's reference circle, in modules.
template <class T>
T coupling_height(const ToothCouplingGear& g, const T& rho) {
  using std::sqrt;
  return (sqrt(rho * rho + g.base_radius * g.base_radius) - g.ref_radius) * g.inv_module;
}

// Tooth offset d = ti - tj wrapped to -z/2..z/2.
inline int coupling_offset(int ti, int tj, int z) {
  int d = (ti - tj) % z;
  if (d < 0) d += z;
  if (d > z / 2) d -= z;
  return d;
}

// The offset on gear g as the table reads it (flank B mirrored), 0 when not coupled.
inline int coupling_table_offset(const ToothCoupling& c, int g, int flank, int ti, int tj) {
  int d = coupling_offset(ti, tj, c.gear[g].teeth);
  if (flank < 0) d = -d;
  return std::abs(d) <= c.offsets ? d : 0;
}

// C_ij between receiver si and load sj (0 on the same tooth pair, other flank, or beyond the
// coupled offsets), m/N; heights hi, hj: coupling_height of each slice's roll on gears 1 and 2.
template <class T>
T coupling_compliance(const ToothCoupling& c, const ContactSliceT<T>& si, const T hi[2],
                      const ContactSliceT<T>& sj, const T hj[2]) {
  T sum = T(0.0);
  if (si.flank != sj.flank || c.offsets == 0) return sum;
  for (int g = 0; g < 2; ++g) {
    const int d = coupling_table_offset(c, g, si.flank, si.tooth[g], sj.tooth[g]);
    if (d != 0) sum += c.gear[g].scale * coupling_kernel(c.gear[g].k, d, hi[g], hj[g]);
  }
  return sum;
}

}  // namespace gm
