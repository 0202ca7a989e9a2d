// Level 4's force solve with tooth coupling (tooth_coupling.hpp): the coupling between slices
// is low rank, C = D + Phi B Phi^T, so the solve runs on the pairs' load moments rather than on
// the slices (docs/physics.md §6, "Level 4 with tooth coupling").
//
// D = diag(c_i) holds each slice's own (Weber/Sainsot) compliance; Phi (n x r) has, per gear g
// and tooth pair P, the columns [1, h_g(rho_i)] on P's slices (0 elsewhere); B (r x r) the
// coupling coefficients s_g A_d between different pairs of one flank (tooth_coupling.hpp), so
// that (Phi B Phi^T)_ij = coupling_compliance(i, j). With the moments m = Phi^T F the coupled
// problem C F + f(F) = Delta, F >= 0 splits into the separable problem of the uncoupled level
// at the approaches Delta - Phi B m and the r equations
//     G(m) = m - Phi^T F_sep(Delta - Phi B m) = 0,
// solved by Newton: J = I + Phi^T K Phi B, K = diag(dF_i/dDelta_i) (0 on open slices). r = 4 x
// the tooth pairs (2-3 pairs: 8-12 unknowns), each iteration one separable solve. Quasi-static:
// the separable solve is the load-balanced one (solve_separable_total) and J has the rank-one
// term of the balance, -(Phi^T K w)(b^T K Phi B)/(b^T K w). Converged when the coupled gap
// residual ||Phi B G||_inf <= tol. Tangent stiffness of each slice (row sums of
// (C + diag f')^-1 on the loaded set, as level 5 reports): x = K (1 - Phi B y) with
// J y = Phi^T K 1.
//
// Every call starts from the uncoupled answer (m = 0): results do not depend on the call
// history. The workspace is sized at gm_data_create (no allocation); more tooth pairs than it
// holds, or no convergence within model.solver_max_iterations, return converged = false with
// `fallback` set, and the caller solves with the dense coupled solver instead (fe_solve.cpp).
#pragma once

#include <vector>

#include "contact_forces.hpp"
#include "tooth_coupling.hpp"

namespace gm {

struct CoupledWorkspace {
  static constexpr int kMaxPairs = 16;  // tooth pairs (groups) one call can hold
  int pair_key[kMaxPairs][3] = {};      // tooth on gear 1, tooth on gear 2, flank
  std::vector<int> group;               // per candidate: its pair
  std::vector<double> height;           // per candidate: h on gear 1, gear 2
  std::vector<double> original;         // per candidate: the approach handed in
  std::vector<double> B, J, Jr, m, v, G, a, c, y;  // r x r (3) and r-vectors (r <= 4 kMaxPairs)
  std::vector<int> index;                          // r
  bool loaded[kMaxPairs] = {};                     // per pair: a slice carries load
  void reserve(int capacity);
};

struct CoupledSolveResult {
  ForceSolve solve;
  bool fallback = false;  // not solved here: use the dense coupled solver
};

// Plain (quasi false): forces for approach[0..n) (left as they are). Quasi-static: the rigid
// approach lambda (out.solve.lambda, warm start lambda_start) with sum_i b_i F_i = load;
// approach[i] is left holding Delta_i + w_i lambda. slices: the candidates (their approaches are
// read, and restored bit for bit after the quasi-static solve).
CoupledSolveResult solve_coupled(const ToothCoupling& coupling, const SliceLaw* laws,
                                 ContactSlice* slices, const double* balance, int n, bool quasi,
                                 double load, double lambda_start, double tol, int max_iterations,
                                 double* approach, double* force, double* stiffness,
                                 CoupledWorkspace& w);

}  // namespace gm
