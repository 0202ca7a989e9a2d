// Normal slice forces from approaches (paper section 2.2, eq. 1-4; docs/physics.md §5-§6).
//
// Levels 0-4 have no coupling between slices (the paper's
// Standard and Analytical levels, Figure 1: "convective coupling: no"), so C is diagonal and
// the convex problem min 1/2 F^T C F + sum P_i(F_i) - Delta^T F, F >= 0 separates: each slice
// solves c_i F + f_i(F) = Delta_i exactly (scalar Newton, monotone from below because
// c F + f(F) is concave and increasing), or carries nothing when Delta_i <= 0. The coupled
// problem of the FE level goes to NlcpSolver (nlcp.hpp).
#pragma once

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

// Plain solve: forces F (N) and tangent stiffnesses k = dF/dDelta (N/m) of n slices. warm:
// force[] holds on entry a start for each slice (used where > 0; the scalar Newton converges
// from any start, docs/physics.md §6), as the coupled solve's outer iterations have it.
ForceSolve solve_separable(const SliceLaw* laws, const double* approach, int n, double tol,
                           int max_iterations, double* force, double* stiffness,
                           bool warm = false);

// Quasi-static: find lambda with sum_i b_i F_i(Delta_i + w_i lambda) = load (N), with w_i the
// slices' te_gain (how the TE coordinate moves each approach) and b_i the balance weights (the
// moment of a unit slice force about gear 2's axis as a force along the TE coordinate; b = w
// without friction, by virtual work). lambda_start is the warm start. A zero load gives the
// lambda at which the first flank that a positive load would close touches. approach: scratch
// of n, left holding Delta_i + w_i lambda.
ForceSolve solve_separable_total(const SliceLaw* laws, const ContactSlice* slices,
                                 const double* balance, int n, double load, double lambda_start,
                                 double tol, int max_iterations, double* approach, double* force,
                                 double* stiffness);

// The same over arrays: base[i] the approach at lambda = 0, gain[i] the te_gain. warm: as
// solve_separable's, for the first of its separable solves (the later ones always start from
// the last).
ForceSolve solve_separable_total(const SliceLaw* laws, const double* base, const double* gain,
                                 const double* balance, int n, double load, double lambda_start,
                                 double tol, int max_iterations, bool warm, double* approach,
                                 double* force, double* stiffness);

}  // namespace gm
