// The force-solve stage of level 5 (dense_solve.cpp): the coupled solve over the candidates with
// the compliance C of the databases (docs/physics.md §5), and the quasi-static TE history that
// predicts its first pass.
#pragma once

#include "model.hpp"

namespace gm {

// The force stage of the coupled solve (level 5, and level 4's dense one) over d's candidates
// (ForceProblem, contact_forces.hpp; p.all: every candidate, the quasi-static setting, else those
// with Delta > 0). Plain: forces for the approaches d.approach. Quasi-static: the rigid approach
// lambda along te_gain with sum_i b_i F_i = load (b: d.balance), added to d.approach. Writes
// d.forces and d.slice_stiffness for all n candidates (0 where not loaded); a quasi-static
// |lambda| above p.next_pass_above is followed by another pass (evaluate.cpp), so this answer's
// slice stiffness is not computed (left 0). p.pose: the pose detected at.
ForceSolve solve_dense(const gm_model& m, gm_data& d, const ForceProblem& p);

// Level 5 quasi-static: the TE to detect at first (extrapolated from the last three solves).
double predicted_te(gm_data& d, double phi, double load_torque);

// Level 5 quasi-static: record a solved TE at gear 1's angle phi and the load torque.
void record_te(gm_data& d, double phi, double te, double load_torque);

}  // namespace gm
