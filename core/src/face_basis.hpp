// Level 5's coupled solve on a reduced face basis (solver.face_shapes = K > 0; docs/model.md,
// "FE level", Reduced face basis). The loads of each loaded tooth pair's slices are a sum of K
// shapes across the face, F = Phi alpha: the model's fixed shapes (face_shapes.hpp: a reference
// pair's responses to smooth approaches at two line loads, then to Legendre polynomials), the
// same for every pair and pose, on the pair's solved slices (min(K, slices of the pair) columns).
// The coupled problem C F + f(F) = Delta is solved in that space
// by Ritz-Galerkin, Phi^T (C Phi alpha + f(Phi alpha) - Delta) = 0, the stationary point of the convex energy
// 1/2 F^T C F + sum_i P_i(F_i) - Delta^T F on the subspace (quasi-static: with the rigid approach
// lambda along the TE gains and the load balance sum_i b_i F_i = load as a bordered row), by
// Newton on alpha: J = Phi^T (C + diag f'(F)) Phi, r x r with r the pairs' columns (2 for two
// spur pairs at K = 1) instead of the slices' n x n. C Phi and Phi^T C Phi come from the full C
// (FaceProblem::C) or, where the caller has them from the cached projections of the databases
// (FeAssembly::project), as they are (FaceProblem::CP, PCP).
//
// Complementarity stays exact: the answer is accepted only when every slice of a loaded pair
// carries a positive load and every solved slice of the other pairs stays open at it (gap >= 0);
// a pair that closes is added and the solve repeated (quasi-static: the loaded pairs are not
// known before lambda). Otherwise (a slice would unload: crowning, tilt, a pair entering or
// leaving mesh; no convergence; a loaded slice's own gap beyond slice_tolerance) the caller
// solves over every slice (dense_solve.cpp), so the reduced answer is only ever used where the
// face loads are positive throughout. Helical pairs are solved over the slices without a reduced
// attempt (dense_solve.cpp: their contact lines end inside the face).
//
// The directional derivative (derivatives.cpp, face_dual_solve) differentiates the same reduced
// equations on the same basis (FaceBasis::used, the per-candidate rows of Phi and alpha it keeps;
// the shapes are the pose's constants).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "detection.hpp"
#include "gearmesh/internal/hertz.hpp"

namespace gm {

struct FaceBasis {
  static constexpr int kMaxPairs = 16;   // tooth pairs one call can hold
  static constexpr int kMaxShapes = 8;   // solver.face_shapes' upper bound
  // The last accepted answer (the derivative's basis): per candidate its first column in Phi
  // (-1: not loaded) and its row of Phi (kMaxShapes values, the pair's dim of them used).
  bool used = false;
  int columns = 0;
  int shapes = 0;  // K of the answer (face_shape's)
  // The quasi-static derivative's plain passes (derivatives.cpp) answer as the evaluation did:
  // -1 the solve chooses (every evaluation); 0 over the slices; 1 on the reduced basis with the
  // slice-gap acceptance waived (its gaps are measured against another approach there)
  int branch = -1;
  std::vector<int> cand_col, cand_dim;
  std::vector<double> cand_phi;
  // scratch, sized at gm_data_create
  int pairs = 0;
  int key[kMaxPairs][4] = {};  // tooth 1, tooth 2, flank, first solved slice index
  int first[kMaxPairs] = {}, count[kMaxPairs] = {}, dim[kMaxPairs] = {}, col[kMaxPairs] = {};
  bool active[kMaxPairs] = {};
  std::vector<int> pair_of, member;  // per solved slice: its pair; the pairs' slices, grouped
  std::vector<double> phi;           // per grouped slice: kMaxShapes values
  static constexpr int kOuter = kMaxShapes * (kMaxShapes + 1) / 2;
  std::vector<int> slice_of;         // per grouped slice: its slice across the face
  Eigen::MatrixXd CP, PCP, A;        // C Phi (n x r), Phi^T C Phi, the Newton matrix (r x r)
  Eigen::MatrixXd all_CP, all_PCP;   // FeAssembly::project's: every pair's columns
  Eigen::VectorXd alpha, step, G, x1, x2, F, trial;
  Eigen::VectorXd inv_norm;          // per column: 1 / sum_a |phi_ak|
  // the derivative's (derivatives.cpp): Phi (n x r) and a per-slice vector
  Eigen::MatrixXd Phi;
  Eigen::VectorXd v;
  std::vector<LocalLawKernel> kern;
  std::vector<LocalLawJet> jet;
  // warm start: the last accepted answer's alpha per pair (key: tooth 1, tooth 2, flank, first
  // slice, slices); part of the solve's warm start (reset with it, kept across a derivative)
  struct Warm {
    int pairs = 0;
    int key[kMaxPairs][5] = {};
    double alpha[kMaxPairs][kMaxShapes] = {};
  } warm;
  void reserve(int capacity);
};

// The gathered system of one call (dense_solve.cpp's solved set).
struct FaceProblem {
  int n = 0;                          // solved slices
  const int* index = nullptr;         // their candidate indices
  const ContactSlice* slices = nullptr;
  const double* C = nullptr;          // n x n, column-major, leading dimension ld
  int ld = 0;
  // or, without C, FeAssembly::project's C Phi and Phi^T C Phi over every pair's K columns
  // (pair q's shape k: column q K + k; the pairs those of FeAssembly, `groups` of them)
  const Eigen::MatrixXd* all_CP = nullptr;
  const Eigen::MatrixXd* all_PCP = nullptr;
  int groups = 0;
  const double* delta = nullptr;      // Delta_a, m
  const LocalLaw* laws = nullptr;
  int shapes = 0;                     // K
  const double* shape_table = nullptr;  // per slice across the face: kMaxShapes values (face_shapes.hpp)
  const double* shape_products = nullptr;  // per slice: kOuter values (face_shape_products)
  double tolerance = 0;               // m, on the pairs' mean gaps (the NLCP's tol)
  // -, each loaded slice's own gap over the largest approach: two shapes on an aligned spur pair
  // leave below 0.3 % (the synthetic databases, 50-300 N m; TE within 0.001 % of the full
  // solve's), a tilted pair 0.3-1 % (three shapes, TE within 0.002 %), a helical pair's diagonal
  // contact lines mostly 3-10 % (and 1 % in its mesh order 3 where such answers were taken)
  double slice_tolerance = 0.01;
  int max_iterations = 50;
  bool quasi = false;
  const double* gain = nullptr;       // quasi: te_gain per solved slice
  const double* balance = nullptr;    // quasi: b per candidate
  double load = 0;                    // quasi: sum_i b_i F_i, N
  bool tangent = true;                // the slice stiffnesses wanted
};

struct FaceAnswer {
  bool accepted = false;
  int iterations = 0;
  double residual = 0;  // m
  double lambda = 0;    // quasi: the rigid approach along te_gain, m
  double energy = 0;    // sum_a [F_a (Delta_a + lambda w_a + f_a)/2 - P_a], J
  double slice_gap = 0;  // largest |gap| of a loaded slice over the largest approach, -
};

// Up to this many of the K shapes are responses to a uniform approach across the face, the rest
// to a tilt and its bendings (face_shapes.cpp).
constexpr int kUniformShapes = 3;

// Groups p's solved slices by tooth pair (FaceBasis::pairs, key, first/count, member, pair_of)
// and sets each pair's rows of Phi from p.shape_table; face_basis_may_hold and solve_face_basis
// work on this grouping. false: nothing to group (no shapes) or more pairs than the workspace holds.
bool group_face_pairs(FaceBasis& w, const FaceProblem& p);

// Whether the basis may hold p's answer (grouped by group_face_pairs), before anything is solved: within each tooth pair the
// approaches Delta across the face, less what the shapes answer (their mean; with a tilt shape,
// their least-squares line; with more, anything), stay within slice_tolerance of the largest.
// Otherwise (lead crowning, a tilt without tilt shapes) some slice's gap would stay beyond the
// acceptance or the slice unload, and the solve over the slices answers without a reduced attempt.
bool face_basis_may_hold(FaceBasis& w, const FaceProblem& p);

// Solves p (grouped by group_face_pairs) on the reduced basis into force[a] and (p.tangent) stiffness[a] (row sums of
// Phi (Phi^T H Phi)^-1 Phi^T, H = C + diag f'), for the n solved slices. Not accepted: the caller
// solves over the slices (force and stiffness then hold nothing of use).
FaceAnswer solve_face_basis(FaceBasis& w, const FaceProblem& p, double* force, double* stiffness);

// The leading r x r block of A replaced by its Cholesky factor (lower); false if not positive
// definite. x := A^-1 x with that factor.
bool face_cholesky(Eigen::MatrixXd& A, int r);
void face_cholesky_solve(const Eigen::MatrixXd& L, int r, double* x);

}  // namespace gm
