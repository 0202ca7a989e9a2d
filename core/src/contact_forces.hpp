// Normal slice forces from approaches (paper section 2.2, eq. 1-4; docs/physics.md §5-§6).
//
// Levels 0-4 have no coupling between slices (the paper's
// Standard and Analytical levels, Figure 1: "convective coupling: no"), so C is diagonal and
// the convex problem min 1/2 F^T C F + sum P_i(F_i) - Delta^T F, F >= 0 separates: each slice
// solves c_i F + f_i(F) = Delta_i exactly (scalar Newton, monotone from below because
// c F + f(F) is concave and increasing), or carries nothing when Delta_i <= 0. The coupled
// problem of the FE level goes to NlcpSolver (nlcp.hpp).
#pragma once

#include <limits>

#include "detection.hpp"
#include "gearmesh/internal/hertz.hpp"

namespace gm {

// The compliance of one slice along its normal.
template <class T>
struct SliceLawT {
  T compliance = 0;       // linear (global) part c_i, m/N
  LocalLawT<T> local;     // local Hertz part f_i (width 0 = none)
};
using SliceLaw = SliceLawT<double>;

struct ForceSolve {
  int iterations = 0;          // Newton iterations, summed over the slices (and lambda updates)
  double residual = 0;         // m: largest |c F + f(F) - Delta| of a loaded slice
  bool converged = true;
  double lambda = 0;           // quasi-static: rigid approach added along te_gain, m
  const char* message = "";
};

// Whether two slices have the same law (bit for bit): repeated slices are solved once.
bool same_law(const SliceLaw& a, const SliceLaw& b);

// One force solve over the n prepared candidates of gm_data (d.slices, d.laws; quasi-static also
// d.balance): the problem each force stage takes beside the model and the data,
// stage(const gm_model&, gm_data&, const ForceProblem&) (pipeline.hpp). The stages write
// d.forces and d.slice_stiffness (N, N/m; 0 on open candidates) and leave d.approach holding
// the approaches they solved at (quasi-static: moved by the solved rigid approach lambda).
struct ForceProblem {
  const gm_kinematics* pose = nullptr;  // the pose detected at (level 5: its axial displacements)
  int n = 0;                            // candidates (a pass sets it from its detection)
  bool all = false;    // every candidate has its law and is solved (the quasi-static setting)
  bool quasi = false;  // solve the load balance sum_i b_i F_i = load for the rigid approach lambda
  double load = 0;     // quasi: the TE coordinate's force, N
  double lambda_start = 0;  // quasi: warm start of lambda, m (levels 0-4; level 5 keeps its own)
  // quasi: a solved |lambda| above this (m) is followed by another pass (evaluate.cpp), which
  // replaces this pass's slice stiffness (level 5 then skips it)
  double next_pass_above = std::numeric_limits<double>::infinity();
};

// A separable solve over n slices in the caller's arrays (the candidates, or the distinct slices
// of the coupled solve, coupled_forces.hpp). Plain (solve_separable): the forces at the
// approaches Delta_i = approach[i]. Total (solve_separable_total, quasi-static): lambda with
// sum_i balance[i] F_i(approach[i] + gain[i] lambda) = load, gain[i] the slices' te_gain w_i
// (how the TE coordinate moves each approach) and balance[i] b_i (the moment of a unit slice
// force about gear 2's axis as a force along the TE coordinate; b = w without friction, by
// virtual work). A zero load gives the lambda at which the first flank that a positive load
// would close touches.
struct SeparableProblem {
  const SliceLaw* laws = nullptr;
  const double* approach = nullptr;  // plain: Delta_i; total: Delta_i at lambda = 0, m
  const double* gain = nullptr;      // total: w_i, -
  const double* balance = nullptr;   // total: b_i, -
  int n = 0;
  double load = 0;          // total: N
  double lambda_start = 0;  // total: warm start of lambda, m
  double tol = 0;           // m
  int max_iterations = 0;
  // force[] holds on entry a start for each slice (used where > 0; the scalar Newton converges
  // from any start, docs/physics.md §6), as the coupled solve's outer iterations have it; total:
  // for its first separable solve (the later ones always start from the last)
  bool warm = false;
};

// Where a separable solve writes, n entries each: forces F (N), tangent stiffnesses
// k = dF/dDelta (N/m); total: the approaches Delta_i + w_i lambda (scratch), m.
struct SeparableAnswer {
  double* force = nullptr;
  double* stiffness = nullptr;
  double* approach = nullptr;
};

ForceSolve solve_separable(const SeparableProblem& p, const SeparableAnswer& out);
ForceSolve solve_separable_total(const SeparableProblem& p, const SeparableAnswer& out);

// The force stage of levels 0-4 without tooth coupling over d's candidates. Plain: the forces at
// d.approach. Quasi-static: the balance over the candidates' approaches and TE gains (d.slices)
// and d.balance, d.approach left holding Delta_i + w_i lambda.
ForceSolve solve_separable(const gm_model& m, gm_data& d, const ForceProblem& p);

}  // namespace gm
