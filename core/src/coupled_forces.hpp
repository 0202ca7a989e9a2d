// Level 4's force solve with tooth coupling (tooth_coupling.hpp): the coupling between slices
// is low rank, C = D + Phi B Phi^T, so the solve runs on the pairs' load moments rather than on
// the slices (docs/model.md, "Tooth coupling at level 4", Solve).
//
// D = diag(c_i) holds each slice's own (Weber/Sainsot) compliance. A slice of tooth pair P at
// heights h_1, h_2 on the two gears is moved by the other pairs' loads through [1, h_1, h_2]:
// the coupling of gear g reads the receiver's [1, h_g] against the load's [force, h_g force]
// (tooth_coupling.hpp), and the force column is the same for both gears. So Phi (n x r) has
// per pair the basis [1, h_1, h_2] on its slices (rank 1, the column [1], when the pair's
// slices are all alike, as on an aligned spur pair), and B (r x r) holds the coefficients
// s_g A_d between different pairs of one flank in that basis, (Phi B Phi^T)_ij =
// coupling_compliance(i, j). With the moments m = Phi^T F the coupled problem
// C F + f(F) = Delta, F >= 0 splits into the separable problem of the uncoupled level at the
// approaches Delta - Phi B m and the r equations
//     G(m) = m - Phi^T F_sep(Delta - Phi B m) = 0,
// solved by Newton: J = I + Phi^T K Phi B, K = diag(dF_i/dDelta_i) (0 on open slices); each
// iteration one separable solve, started from the last one's forces. Quasi-static: the
// separable solve is the load-balanced one (solve_separable_total) and J has the rank-one term
// of the balance, -(Phi^T K w)(b^T K Phi B)/(b^T K w). Converged when the coupled gap residual
// ||Phi B G||_inf <= tol. Tangent stiffness of each slice (row sums of (C + diag f')^-1 on the
// loaded set, as level 5 reports): x = K (1 - Phi B y) with J y = Phi^T K 1.
//
// Repeated slices (consecutive candidates of one pair with the same approach, law and roll,
// and in quasi-static mode the same TE gain and balance weight: an aligned spur pair's) are
// solved once, with their count as weight in Phi^T. Every call starts from the uncoupled
// answer (m = 0): results do not depend on the call history. The workspace is sized at
// gm_data_create (no allocation); more tooth pairs than it holds, or no convergence within
// solver.max_iterations, return converged = false with `fallback` set, and the caller
// solves with the dense coupled solver instead (dense_solve.cpp).
#pragma once

#include <vector>

#include "contact_forces.hpp"
#include "tooth_coupling.hpp"

namespace gm {

struct CoupledWorkspace {
  static constexpr int kMaxPairs = 16;  // tooth pairs (groups) one call can hold
  static constexpr int kBasis = 3;      // [1, h_1, h_2] per pair at most
  int pair_key[kMaxPairs][3] = {};      // tooth on gear 1, tooth on gear 2, flank
  int pair_dim[kMaxPairs] = {};         // basis size of the pair: 1 or kBasis
  int pair_col[kMaxPairs] = {};         // its first column in Phi
  int pair_slices[kMaxPairs] = {};      // its distinct slices
  bool loaded[kMaxPairs] = {};          // a slice of the pair carries load
  std::vector<int> rep;                 // per candidate: its distinct slice (-1: not solved)
  // per distinct slice
  std::vector<int> group;               // its pair
  std::vector<double> weight;            // how many candidates it stands for
  std::vector<double> base;              // its approach handed in (quasi: at lambda = 0), m
  std::vector<double> gain, balance;     // quasi-static: te_gain, balance weight
  std::vector<double> balance_sum;       // the balance weights of the candidates it stands for
  std::vector<double> basis;             // kBasis per slice: 1, h_1, h_2 (modules)
  std::vector<double> shifted, approach; // Delta - Phi B m; the total solve's scratch
  std::vector<double> force, stiffness;  // the separable solve's answer
  std::vector<SliceLaw> laws;
  std::vector<double> B, J, Jr, m, v, G, a, c, y;  // r x r (3) and r-vectors
  std::vector<int> index;                          // r
  std::vector<unsigned char> active;               // r: the column's pair is loaded
  void reserve(int capacity);
};

struct CoupledSolveResult {
  ForceSolve solve;
  bool fallback = false;  // not solved here: use the dense coupled solver
};

// The force stage of level 4 with tooth coupling over d's candidates (ForceProblem,
// contact_forces.hpp), in the model's coupling and d.coupled. Plain: forces for d.approach (left
// as it is). Quasi-static: the rigid approach lambda (out.solve.lambda, warm start
// p.lambda_start) with sum_i b_i F_i = load (b: d.balance); d.approach is left holding
// Delta_i + w_i lambda. d.slices are read only.
CoupledSolveResult solve_coupled(const gm_model& m, gm_data& d, const ForceProblem& p);

}  // namespace gm
