// The stages of one evaluation pass (docs/design.md "core"), shared by gm_evaluate's plain and
// quasi-static modes (evaluate.cpp) and by the directional derivative (derivatives.cpp):
//   detect (detection.cpp) -> TE excitation, slice laws (laws.hpp) -> [load-balance weights]
//   -> force solve (contact_forces.cpp, or fe_solve.cpp at level 5) -> resultants
//   (resultants.hpp). The pass functions are inline: gm_evaluate is the hot path.
#pragma once

#include <limits>
#include <string>

#include "contact_forces.hpp"
#include "fe_solve.hpp"
#include "laws.hpp"
#include "model.hpp"
#include "resultants.hpp"
#include "slice_merge.hpp"

namespace gm {

// How a pass solves: `all` builds the laws of every candidate (open ones too) and hands them
// all to the level-5 solve; `quasi` solves the load balance sum_i b_i F_i = load (N) for the
// rigid approach along the TE coordinate instead of taking the approaches as they are.
struct PassMode {
  bool all = false;
  bool quasi = false;
  double load = 0;
  // quasi: a solved rigid approach |lambda| above this (m) is followed by another pass
  // (evaluate.cpp), which replaces this pass's slice stiffness (level 5 then skips it)
  double next_pass_above = std::numeric_limits<double>::infinity();
};

// Detection, TE excitation, repeated slices merged (levels 0-4, slice_merge.hpp) and slice laws
// at pose kin: the number of candidates (without `all`, those that can carry load), or -1 with
// msg set when the pose is outside the detection range.
template <class T, class K>
int prepare_slices(const gm_model& m, const K& kin, ContactSliceT<T>* slices, SliceLawT<T>* laws,
                   bool all, std::string& msg) {
  // without `all` only the slices that can carry load: those closer than the TE excitation opens
  const double emit_above = all ? -kEmitAll : te_excitation_gap(m, val(kin.phi[0]));
  // levels 0-4: repeated slices merged (slice_merge.hpp), an aligned spur pair's by detection
  const bool merge = m.params.stiffness_level != GM_STIFFNESS_FE;
  int n = detect_contacts(m.layout, kin, slices, m.slice_capacity, msg, emit_above, merge);
  if (n < 0) return n;
  apply_te_excitation(m, slices, kin, n);
  if (merge) n = merge_repeated_slices(slices, n);
  build_laws(m, slices, laws, n, all);
  return n;
}

// The force solve over d's n prepared candidates (d.slices, d.laws; quasi: d.balance): writes
// d.forces and d.slice_stiffness, and d.approach (quasi: moved by the solved rigid approach).
inline ForceSolve solve_forces(const gm_model& m, gm_data& d, const gm_kinematics& kin, int n,
                               const PassMode& mode) {
  const bool fe = coupled_solve(m);  // level 5, level 4 with tooth coupling
  const double tol = m.params.solver_tolerance;
  const int max_it = m.params.solver_max_iterations;
  d.fe_energy = std::numeric_limits<double>::quiet_NaN();  // fe_solve's answer sets it
  if (fe || !mode.quasi)  // the separable quasi-static solve writes the approaches itself
    for (int i = 0; i < n; ++i) d.approach[i] = d.slices[i].approach;
  if (fe && m.params.stiffness_level == GM_STIFFNESS_ANALYTICAL) {
    // level 4 with tooth coupling: the low-rank solve; the dense one where it cannot
    const CoupledSolveResult r =
        solve_coupled(m.coupling, d.laws.data(), d.slices.data(), d.balance.data(), n,
                      mode.quasi, mode.load, 0.0, tol, max_it, d.approach.data(),
                      d.forces.data(), d.slice_stiffness.data(), d.coupled);
    if (!r.fallback) return r.solve;
    for (int i = 0; i < n; ++i) d.approach[i] = d.slices[i].approach;
  }
  if (fe) return fe_solve(m, d, kin, n, mode.all, mode.quasi, mode.load, mode.next_pass_above);
  if (mode.quasi)
    return solve_separable_total(d.laws.data(), d.slices.data(), d.balance.data(), n, mode.load,
                                 0.0, tol, max_it, d.approach.data(), d.forces.data(),
                                 d.slice_stiffness.data());
  return solve_separable(d.laws.data(), d.approach.data(), n, tol, max_it, d.forces.data(),
                         d.slice_stiffness.data());
}

// One pass in double at pose kin: prepare_slices into d, the balance weights (quasi), then
// solve_forces. n: the candidates; fs: the solve's report. GM_ERR_INPUT (detection range) or
// GM_ERR_SOLVER with d.message set.
inline gm_status solve_pass(const gm_model& m, gm_data& d, const gm_kinematics& kin,
                            const PassMode& mode, int& n, ForceSolve& fs) {
  n = prepare_slices(m, kin, d.slices.data(), d.laws.data(), mode.all, d.message);
  if (n < 0) return GM_ERR_INPUT;
  if (mode.quasi) balance_weights(m, d.slices.data(), kin, n, d.balance.data());
  fs = solve_forces(m, d, kin, n, mode);
  if (!fs.converged) {
    d.message = fs.message;
    return GM_ERR_SOLVER;
  }
  return GM_OK;
}

}  // namespace gm
