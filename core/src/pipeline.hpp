// The stages of one evaluation pass (docs/design.md "core"), shared by gm_evaluate's plain and
// quasi-static modes (evaluate.cpp) and by the directional derivative (derivatives.cpp):
//   detect (detection.cpp) -> TE excitation, slice laws (laws.hpp) -> [load-balance weights]
//   -> force solve (contact_forces.cpp; coupled_forces.cpp or dense_solve.cpp for the coupled
//   levels) -> resultants (resultants.hpp). A force stage takes the model, the data and one
//   ForceProblem (contact_forces.hpp): the candidates are d's arrays, not arguments. The pass
//   functions are inline: gm_evaluate is the hot path.
#pragma once

#include <limits>
#include <string>

#include "contact_forces.hpp"
#include "coupled_forces.hpp"
#include "dense_solve.hpp"
#include "laws.hpp"
#include "model.hpp"
#include "resultants.hpp"
#include "slice_merge.hpp"

namespace gm {

// Detection, TE excitation, repeated slices merged (levels 0-4, slice_merge.hpp) and slice laws
// at pose kin into d's candidates of kin's scalar type (candidates<T>(d), model.hpp): the number of
// candidates (without `all`, those that can carry load), or -1 with d.message set when the pose
// is outside the detection range.
template <class K>
int prepare_slices(const gm_model& m, gm_data& d, const K& kin, bool all) {
  const Candidates<ScalarOf<K>> c = candidates<ScalarOf<K>>(d);
  // without `all` only the slices that can carry load: those closer than the TE excitation opens
  const double emit_above = all ? -kEmitAll : te_excitation_gap(m, val(kin.phi[0]));
  // levels 0-4: repeated slices merged (slice_merge.hpp), an aligned spur pair's by detection
  const bool merge = m.level.merges_slices;
  int n = detect_contacts(m.layout, kin, c.slices, m.slice_capacity, d.message, emit_above, merge);
  if (n < 0) return n;
  apply_te_excitation(m, c.slices, kin, n);
  if (merge) n = merge_repeated_slices(c.slices, n);
  build_laws(m, c.slices, c.laws, n, all);
  return n;
}

// The force stage over d's p.n prepared candidates (d.slices, d.laws; quasi: d.balance): writes
// d.forces and d.slice_stiffness, and d.approach (quasi: moved by the solved rigid approach).
// The one dispatch between the stages: solve_separable (contact_forces.cpp), solve_coupled
// (coupled_forces.cpp, level 4 with tooth coupling; the dense solve where it cannot) and
// solve_dense (dense_solve.cpp), each called with (model, data, problem).
inline ForceSolve solve_forces(const gm_model& m, gm_data& d, const ForceProblem& p) {
  const bool coupled = m.level.coupled;  // level 5, level 4 with tooth coupling
  const int n = p.n;
  d.dense_energy = std::numeric_limits<double>::quiet_NaN();  // solve_dense's answer sets it
  if (coupled || !p.quasi)  // the separable quasi-static solve writes the approaches itself
    for (int i = 0; i < n; ++i) d.approach[i] = d.slices[i].approach;
  if (coupled && !m.level.database) {
    // level 4 with tooth coupling: the low-rank solve; the dense one where it cannot
    const CoupledSolveResult r = solve_coupled(m, d, p);
    if (!r.fallback) return r.solve;
    for (int i = 0; i < n; ++i) d.approach[i] = d.slices[i].approach;
  }
  if (coupled) return solve_dense(m, d, p);
  return solve_separable(m, d, p);
}

// What a pass found: the candidates (n; -1 outside the detection range) and the solve's report.
struct PassResult {
  gm_status status = GM_OK;
  int n = 0;
  ForceSolve solve;
};

// One pass in double at the pose pass.pose, solved as `pass` says (its n is the pass's own
// detection's): prepare_slices into d, the balance weights (quasi), then solve_forces.
// GM_ERR_INPUT (detection range) or GM_ERR_SOLVER with d.message set.
inline PassResult solve_pass(const gm_model& m, gm_data& d, const ForceProblem& pass) {
  PassResult out;
  const gm_kinematics& kin = *pass.pose;
  out.n = prepare_slices(m, d, kin, pass.all);
  if (out.n < 0) {
    out.status = GM_ERR_INPUT;
    return out;
  }
  ForceProblem p = pass;
  p.n = out.n;
  if (p.quasi) balance_weights(m, d, kin, p.n);
  out.solve = solve_forces(m, d, p);
  if (!out.solve.converged) {
    d.message = out.solve.message;
    out.status = GM_ERR_SOLVER;
  }
  return out;
}

}  // namespace gm
