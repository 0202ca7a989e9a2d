// The law stage of the evaluation: per-slice compliance laws per stiffness level and the TE
// excitation, templates over double and dual numbers (the directional derivative), defined
// here so that the evaluation inlines them.
#pragma once

#include <cmath>
#include <string>

#include "levels.hpp"
#include "model.hpp"

namespace gm {

// Per-slice laws (docs/physics.md §5) and the TE excitation, over double and dual numbers.
namespace laws_detail {

// Lookups over the scalar type: the double ones as they are; for dual numbers the value and the
// slope.
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

// kappa of gear g's body at slice s (hertz.hpp, HertzBodyT::near_field): the wedge's
// (MeshLayout::corner_near_field) at a contact on its tip corner, 1 on the flank beyond
// kCornerBlend h of the corner (h the body's depth), and in between 1 + (kappa_w - 1) s(u),
// s(u) = u^2 (3 - 2u), u = 1 - a/(kCornerBlend h), a the involute's arc length to the tip.
// Where the contact's half-width b_H reaches the edge the whole near field is the wedge's; a
// contact at a from it sees the wedge's field beyond a only, a share ln(h/a)/ln(h/b_H) of the
// logarithm (about a half at a = 0.3 h for b_H = h/10). The smooth step is sharper than that
// share, as the CalculiX references favour (docs/validation.md), and flat at both ends: a contact
// moving onto the corner sees no step in its compliance nor in its slope, which the integrator's
// Newton and the step's derivative need.
inline constexpr double kCornerBlend = 0.3;

template <class T>
T corner_near_field_at(const MeshLayout& L, int g, const ContactSliceT<T>& s, const T& depth) {
  const double kw = L.corner_near_field[g];
  if (s.kind == (g == 0 ? kTipOfGear1 : kTipOfGear2)) return T(kw);
  if (s.kind != kFlankContact || kw == 1.0) return T(1.0);
  using std::fabs;
  const T rho = s.roll[g];
  const T arc = fabs(L.rho_tip[g] * L.rho_tip[g] - rho * rho) / (2.0 * L.base_radius[g]);
  const T length = kCornerBlend * depth;
  if (!(arc < length)) return T(1.0);
  const T u = 1.0 - arc / length;
  return 1.0 + (kw - 1.0) * u * u * (3.0 - 2.0 * u);
}

}  // namespace laws_detail

// Per-slice compliance laws along the normal (docs/physics.md §5), for the level `Level`
// (core/src/level<k>_<name>.hpp). A linear level: its pair stiffness k', k' L / cos^2(beta_b). A tooth law
// (levels 4, 5): both teeth's Weber/Sainsot compliance (per unit face width on the transverse line
// of action; level 5: none, its coupled C is the databases') plus the exact local Hertz law of
// docs/physics.md §4 over the contact line L / cos(beta_b), its approach referred to each tooth's
// centre line (level 5: at the databases' depth).
template <class Level, class T>
void build_level_laws(const gm_model& m, const ContactSliceT<T>* slices, SliceLawT<T>* laws, int n, bool all) {
  using namespace laws_detail;
  const MeshLayout& L = m.layout;
  const double cb = L.cos_beta_b, cb2 = cb * cb;
  constexpr bool database = Level::traits.database;
  const double rho_floor = 1e-3 * m.params.pair.normal_module;  // degenerate curvature guard
  for (int i = 0; i < n; ++i) {
    const ContactSliceT<T>& s = slices[i];
    SliceLawT<T>& law = laws[i];
    law.local = LocalLawT<T>{};
    if (!all && s.approach <= 0) continue;  // an open slice carries nothing whatever its law
    if constexpr (!Level::traits.tooth_law) {
      law.compliance = cb2 / (Level::pair_stiffness(m, s) * s.width);
      continue;
    } else {
      if (i > 0 && identical(s.roll[0], slices[i - 1].roll[0]) &&
          identical(s.roll[1], slices[i - 1].roll[1]) && identical(s.width, slices[i - 1].width) &&
          identical(s.corner_slope, slices[i - 1].corner_slope) &&
          (all || slices[i - 1].approach > 0)) {
        law = laws[i - 1];  // the next slice of an aligned spur pair: the same law
        continue;
      }
      using std::fmax;
      const T rho1 = fmax(s.roll[0], T(rho_floor)), rho2 = fmax(s.roll[1], T(rho_floor));
    // FE: the global part is the coupled C of fe_assemble, not a per-slice compliance
      law.compliance = database ? T(0.0)
                                : (tooth_compliance_t(m.tooth[0], rho1) +
                                   tooth_compliance_t(m.tooth[1], rho2)) *
                                      cb2 / s.width;
      law.local.width = s.width / cb;
      law.local.reduced_radius = 1 / (cb / rho1 + L.sign * cb / rho2);  // normal-plane curvatures
      law.local.corner_slope = s.corner_slope;  // a tip corner's flank angle (docs/physics.md §4)
      for (int g = 0; g < 2; ++g) {
        law.local.body[g].youngs_modulus = m.params.gear[g].youngs_modulus;
        law.local.body[g].poisson_ratio = m.params.gear[g].poisson_ratio;
      // FE: the database's depth h (along the normal), the depth its displacements were taken at
        law.local.body[g].depth = database ? T(m.compliance[g].depth)
                                           : tooth_contact_depth_s(m.tooth[g], g == 0 ? rho1 : rho2) * cb;
        law.local.body[g].near_field = corner_near_field_at(L, g, s, law.local.body[g].depth);
      }
    }
  }
}

// The laws of m's level: the one dispatch of the laws stage (levels.hpp).
template <class T>
void build_laws(const gm_model& m, const ContactSliceT<T>* slices, SliceLawT<T>* laws, int n, bool all) {
  with_level(m.params.stiffness_level,
             [&](auto level) { build_level_laws<decltype(level)>(m, slices, laws, n, all); });
}


// The gap the TE excitation opens along every slice's normal at gear 1's angle phi1, m.
inline double te_excitation_gap(const gm_model& m, double phi1) {
  if (m.te_table.empty()) return 0;
  return te_excitation_at(m.te_table, phi1).te * m.layout.cos_beta_b;
}

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

}  // namespace gm
