// The output stage of the evaluation, over double and over dual numbers: elastic energy,
// forces, moments and the other outputs from solved slice forces, and the quasi-static
// load-balance weights (docs/physics.md §6, §7). Templates defined here so that the evaluation
// inlines them.
#pragma once

#include <cmath>
#include <cstddef>
#include <type_traits>

#include <Eigen/Geometry>

#include "model.hpp"

namespace gm {

// What a build adds to resultants() for its added outputs (the recipe's test, tests/recipe/): per
// loaded slice, r the result, F its normal force after damping, s the slice.
#ifndef GM_RESULTANTS_EXTRA
#define GM_RESULTANTS_EXTRA(r, F, s)
#endif

// The outputs resultants() computes (the RESULTANT rows of gearmesh/outputs.h): the Real ones over
// a scalar type T (double, or Dual for the derivative), the Integer ones as int.
#define GM_RESULT_T_TYPE_Real(T) T
#define GM_RESULT_T_TYPE_Integer(T) int
#define GM_RESULT_T_RESULTANT(T, type, member, dims) GM_RESULT_T_TYPE_##type(T) member dims = {};
#define GM_RESULT_T_TE(T, type, member, dims)
#define GM_RESULT_T_SOLVER(T, type, member, dims)
#define GM_RESULT_T_ROW(T, member, type, shape, source, name, unit, dunit, lo, hi, bounds, depends, desc) \
  GM_RESULT_T_##source(T, type, member, GM_OUTPUT_DIMS_##shape)
template <class T>
struct ResultT {
  GM_OUTPUTS(GM_RESULT_T_ROW, T)
};

// Every RESULTANT row of `to` and `from` (gearmesh/outputs.h) through f(to member element, from
// member element): the copies of ResultT into gm_result and the derivative's combination.
namespace result_rows {
template <class D, class S, class F>
void each(D& to, S& from, F f) {
  f(to, from);
}
template <class D, class S, std::size_t N, class F>
void each(D (&to)[N], S (&from)[N], F f) {
  for (std::size_t i = 0; i < N; ++i) each(to[i], from[i], f);
}
}  // namespace result_rows

#define GM_RESULT_EACH_RESULTANT(member) result_rows::each(to.member, from.member, f);
#define GM_RESULT_EACH_TE(member)
#define GM_RESULT_EACH_SOLVER(member)
#define GM_RESULT_EACH_ROW(_, member, type, shape, source, name, unit, dunit, lo, hi, bounds, depends, desc) \
  GM_RESULT_EACH_##source(member)
template <class To, class From, class F>
void each_resultant(To& to, From& from, F f) {
  GM_OUTPUTS(GM_RESULT_EACH_ROW, _)
}

// gm_result's RESULTANT outputs from r.
inline void store_result(const ResultT<double>& r, gm_result& out) {
  each_resultant(out, r, [](auto& to, const auto& from) { to = from; });
}

// gm_result's RESULTANT outputs as the derivatives in r (an Integer output's is 0).
inline void store_derivative(const ResultT<Dual>& r, gm_result& out) {
  each_resultant(out, r, [](auto& to, const auto& from) {
    if constexpr (std::is_same_v<std::decay_t<decltype(from)>, Dual>) to = from.d;
    else to = 0;
  });
}




// Elastic potential of the loaded slices at solved forces, J: U = sum_i int_0^Delta_i F dDelta.
// With the complementary energy Psi(F) = F.C.F/2 + sum_i P_i(F_i) (C the coupled compliance of
// level 5, or diag(c_i); P_i = int f_i) and C F + f(F) = Delta on the loaded set,
// U = F.Delta - Psi(F) = sum_i [F_i (Delta_i + f_i(F_i))/2 - P_i(F_i)]: one formula for every
// level that needs no C. It holds along the solution, so the same formula over dual numbers (with
// the implicit derivative of F) is U's exact derivative. Forces before damping.
// d: the first n candidates of candidates<T>(d).
template <class T>
T elastic_energy(gm_data& d, int n) {
  const Candidates<T> c = candidates<T>(d);
  const ContactSliceT<T>* slices = c.slices;
  const SliceLawT<T>* laws = c.laws;
  const T* forces = c.forces;
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

// Forces, moments and the other outputs from the solved forces of d's first n candidates
// (candidates<T>(d); the damped forces are written back) at pose kin.
template <class T, class K>
void resultants(const gm_model& m, gm_data& d, const K& kin, int n, ResultT<T>& r) {
  GM_AD_USING;
  const Candidates<T> cd = candidates<T>(d);
  const ContactSliceT<T>* slices = cd.slices;
  T* forces = cd.forces;
  const T* slice_stiffness = cd.stiffness;
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
  T pair_force = 0, max_pair_force = 0;  // the slices of a tooth pair are consecutive
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
    GM_RESULTANTS_EXTRA(r, F, s);  // a build's added outputs (outputs.h, GM_OUTPUTS_EXTRA)
    r.stiffness += slice_stiffness[i] * cb2;  // along the transverse line of action
    r.flank |= s.flank > 0 ? 1 : 2;
    r.max_line_load = fmax(r.max_line_load, T(F / s.width));
    if (s.pair != last_loaded_pair) {
      ++r.pairs_in_contact;
      last_loaded_pair = s.pair;
      pair_force = 0;
    }
    pair_force += F;
    max_pair_force = fmax(max_pair_force, pair_force);
  }
  if (r.normal_force > 0) r.max_load_share = max_pair_force / r.normal_force;
  for (int i = 0; i < 2; ++i) {
    for (int a = 0; a < 3; ++a) {
      r.force[i][a] = f[i][a];
      r.moment[i][a] = mom[i][a];
    }
  }
}

// Load-balance weights of the quasi-static solve: the moment of a slice's unit normal force
// (with its friction) about gear 2's axis, as a force along the TE coordinate (docs/physics.md §6),
// of d's first n candidates over kin's scalar type T (candidates<T>(d).balance).
template <class K>
void balance_weights(const gm_model& m, gm_data& d, const K& kin, int n) {
  GM_AD_USING;
  using T = ScalarOf<K>;
  const Candidates<T> cd = candidates<T>(d);
  const ContactSliceT<T>* slices = cd.slices;
  T* balance = cd.balance;
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

}  // namespace gm
