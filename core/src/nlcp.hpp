// Normal slice forces: the non-linear complementarity problem of paper eq. 1-4
// (docs/physics.md §6)
//
//   g(F) = C F + f(F) - Delta >= 0,   F >= 0,   F^T g = 0,
//
// C symmetric positive definite (m/N), f separable and increasing with f_i(0) = 0 (hertz.hpp, or
// f_i = 0), Delta the approaches (m). It is the optimality condition of the strictly convex
//
//   min Phi(F) = 1/2 F^T C F + sum_i P_i(F_i) - Delta^T F   subject to F >= 0,
//
// solved by a projected Newton method (Bertsekas 1982, "Projected Newton methods for
// optimization problems with simple constraints", SIAM J. Control Optim. 20(2)): Newton on the
// free unknowns, scaled gradient on the eps-active ones, Armijo search on Phi along the
// projection arc. Globally convergent from any start, quadratic once the active set is found;
// warm-started from the caller's previous forces. Per iterate each law is evaluated once (at
// the line search's trial point, carried over when it is accepted); the Newton matrix is
// factorized in place by a plain-loop Cholesky of the free set; a caller that asks for the
// tangent of each answer (loaded_row_sums) has its factorization reused for the next solve's
// first step (NlcpOptions::reuse_tangent).
//
// Stopping: r = ||min(diag(C) F, g)||_inf <= tol, both terms in metres (the force is scaled by
// the slice's own compliance), tol = tolerance + relative_tolerance * max_i |Delta_i|. A gap
// error r is a force error of about r times the mesh stiffness, so the defaults (1e-15 m +
// 1e-10 |Delta|) give forces to ~1e-10 relative, well above the rounding floor of g
// (~n eps |Delta|).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "gearmesh/internal/hertz.hpp"

namespace gm {

enum class NlcpStatus {
  converged,      // residual <= tolerance
  iteration_cap,  // not converged (cap, or the line search hit the rounding floor): best iterate
  bad_input,      // message says why; force is finite (zero if nothing could be done)
};

struct NlcpOptions {
  double tolerance = 1e-15;           // m, absolute part of tol
  double relative_tolerance = 1e-10;  // -, part of tol proportional to max |Delta_i|
  int max_iterations = 50;            // Newton iterations per solve (quasi-static: per lambda)
  int max_approach_updates = 60;      // quasi-static: updates of lambda
  double min_line_load = 1.0;         // N/m: the Newton matrix takes f' at no less than this w
  // Carry the law values (f, f', f'', P) and C s of the accepted trial point of the line search
  // over to the next iterate instead of evaluating them there again (C F then accumulates the
  // accepted C s; the difference is rounding, ~1e-16 of |C F| per iteration). false: evaluate
  // every iterate from scratch (the reference the tests compare with).
  bool reuse_evaluations = true;
  // solve() or solve_total() warm-started from exactly the answer whose tangent
  // loaded_row_sums() factorized (the caller's previous step): take the first Newton step with
  // that factorization when the free set is the same loaded set (a quasi-Newton step: the matrix is that of the previous
  // C and laws; any symmetric positive definite matrix gives a descent direction, and the
  // Armijo search and the following exact Newton steps keep the method and its stopping test
  // as they are). A further step is taken on it too when its last step contracted the residual
  // by 100 or more and that rate predicts the next one to meet the tolerance (a chord step).
  // The same rule for the last Newton factorization of a solve (a chord step on it).
  // solve_total() from such an answer first takes one Newton step of the KKT system (forces and
  // lambda) with that factorization (counted as an iteration), so that its first lambda is
  // nearly the answer's.
  // Within solve_total() the same rule reuses the factorization of this C that an earlier lambda
  // made (its last slope, or a Newton step) for the first step of the next lambda, and that one
  // or the kept tangent for a slope on the same set (the slope only steers the update of lambda).
  // Saves one or two factorizations per call. false: factorize at every iteration.
  bool reuse_tangent = true;
  // Check that C is symmetric (and finite) on every call, an O(n^2) pass over both triangles.
  // false: the caller made C symmetric by construction (level 5's assembly mirrors each entry);
  // only its diagonal is checked (> 0, finite). A non-finite entry elsewhere then ends the solve
  // unconverged (the factorization or the line search fails on it) instead of being named.
  bool check_symmetry = true;
};

struct NlcpResult {
  NlcpStatus status = NlcpStatus::bad_input;
  int iterations = 0;         // Newton iterations (quasi-static: summed over all lambda updates)
  int approach_updates = 0;   // quasi-static only: Newton/bisection updates of lambda
  int factorizations = 0;     // of a Newton matrix (a first step on the kept tangent has none)
  double residual = 0;        // m: ||min(diag(C) F, g)||_inf; quasi-static: max with |lambda error|
  double tolerance = 0;       // m, tol used
  int index = -1;             // bad_input: the unknown at fault, if one is
  bool capped = false;        // iteration_cap: max_iterations reached (else the line search stalled)
  const char* message = "";   // static text; empty when converged
};

// Owns a workspace sized once for up to `capacity` unknowns; solve() and solve_total() then
// allocate nothing (pass C, Delta and F as contiguous column-major storage, e.g. MatrixXd,
// VectorXd or their topLeftCorner/head, so that the Ref arguments bind without a copy).
class NlcpSolver {
 public:
  explicit NlcpSolver(int capacity, const NlcpOptions& options = NlcpOptions());

  int capacity() const { return capacity_; }
  const NlcpOptions& options() const { return options_; }
  void set_options(const NlcpOptions& options) { options_ = options; }

  // Solve for n = delta.size() unknowns. laws: n entries (a default LocalLaw is f_i = 0), or
  // nullptr for f = 0 throughout. force: in, the warm start (previous forces, which also carry
  // the active set; zeros for a cold start; negative or non-finite entries count as 0, and a
  // warm start with Phi > 0 = Phi(0) is replaced by 0); out, the solution or best iterate.
  NlcpResult solve(const Eigen::Ref<const Eigen::MatrixXd>& compliance,
                   const Eigen::Ref<const Eigen::VectorXd>& delta, const LocalLaw* laws,
                   Eigen::Ref<Eigen::VectorXd> force);

  // Quasi-static loaded TE (docs/physics.md §6): the same problem with Delta = Delta0 +
  // lambda w and the constraint w^T F = total_force (> 0, N); weights finite, at least one > 0.
  // lambda (m) is the multiplier of the constraint: the rigid approach along w added to the pose
  // at which Delta0 was detected. Spur: w_i = 1 on flank A slices, so lambda is the loaded TE
  // increment; a flank B slice in contact (wedging) has w_i = -1 (TE opens it and its force
  // takes torque back); helical: w_i = +-cos(beta_b) for a transverse TE. force and lambda: in,
  // warm start; out, solution.
  // Method: the dual function of lambda is concave with derivative total_force - w^T F(lambda),
  // so lambda is found by a safeguarded Newton iteration (bisection fallback) on
  // w^T F(lambda) = total_force, whose slope w_J^T H_JJ^-1 w_J is the lambda row of the KKT
  // system of the active set (J: loaded unknowns, H = C + diag f'); each F(lambda) is a warm
  // projected-Newton solve as above, started from the first-order predictor H_JJ^-1 w_J dlambda.
  // Stops when the plain residual and the lambda correction are both below tol, and then applies
  // that last correction with its first-order force update when the residual stays below tol
  // (so that w^T F = total_force to rounding).
  NlcpResult solve_total(const Eigen::Ref<const Eigen::MatrixXd>& compliance,
                         const Eigen::Ref<const Eigen::VectorXd>& delta0, const LocalLaw* laws,
                         const Eigen::Ref<const Eigen::VectorXd>& weights, double total_force,
                         Eigen::Ref<Eigen::VectorXd> force, double& lambda);

  // The tangent of the last answer of solve() or solve_total() (force: that answer, unchanged;
  // C: the same matrix): on the loaded unknowns A = {i : F_i > 0}, K = dF_A/dDelta_A =
  // (C_AA + diag f'_A)^-1 with the laws' own slopes at F (no floor), from the law values the
  // solve already holds. Writes the row sums K 1 (N/m: each loaded slice's stiffness under a
  // uniform approach; their sum is the mesh stiffness) to row_sums[i], i in A, and 0 elsewhere.
  // Returns false (row_sums all 0) if force is not this solver's last answer or C_AA + diag f'_A
  // is not numerically positive definite.
  // With reuse_tangent, when the solve's last factorization (an earlier iterate's, same C) is on
  // A, K 1 is summed from it as a Neumann series in the change of the laws' slopes (to an
  // estimated 1e-12 of K 1; else A's own factorization), and that factorization is kept.
  // Keeps the factorization for the next solve (see NlcpOptions::reuse_tangent).
  bool loaded_row_sums(const Eigen::Ref<const Eigen::MatrixXd>& compliance,
                       const Eigen::Ref<const Eigen::VectorXd>& force,
                       Eigen::Ref<Eigen::VectorXd> row_sums);

  // The local law's f_i, f'_i, f''_i and P_i at the last answer (solve, solve_total), i < its n.
  const LocalLawJet& law_at_answer(int i) const { return jet_[i]; }

  // Instead of loaded_row_sums, for a caller that needs no tangent of this answer (a quasi-static
  // pass that another pass follows): keep the factorization the solve last made of this C on
  // the loaded set (at an earlier iterate) for the next solve's first step, as loaded_row_sums
  // keeps its own. false (nothing kept) when reuse_tangent is off, force is not the last answer
  // or there is no such factorization; the caller then calls loaded_row_sums.
  bool keep_last_factorization(const Eigen::Ref<const Eigen::VectorXd>& force);

 private:
  using ConstMat = Eigen::Ref<const Eigen::MatrixXd>;
  using ConstVec = Eigen::Ref<const Eigen::VectorXd>;

  // Checks the input and prepares the laws' kernels (kernel_, floor_).
  const char* prepare(const ConstMat& C, const ConstVec& delta, const LocalLaw* laws,
                      Eigen::Ref<Eigen::VectorXd> F, int& index);
  double newton_slope(int i, double force);
  double evaluate(const ConstMat& C, const ConstVec& delta,
                  const Eigen::Ref<const Eigen::VectorXd>& F);
  double accept_trial(const ConstMat& C, const ConstVec& delta,
                      const Eigen::Ref<const Eigen::VectorXd>& F);
  struct Fault {
    int position = -1;      // in the free set; -1: factorized
    bool singular = false;  // pivot ~0 (dependent rows) rather than negative
  };
  Fault factor(const ConstMat& C, int m, const Eigen::VectorXd& slope);
  void solve_factored(const Eigen::MatrixXd& L, const Eigen::VectorXd& inv_diagonal, int m);
  Fault factor_and_solve(const ConstMat& C, int m, const Eigen::VectorXd& slope);
  bool row_sums_by_series(int m);
  void keep_newton_as_tangent(const ConstVec& F, int m);
  bool same_as_tangent(int m) const;
  bool on_tangent_set(int m) const;  // free_[0..m) is tangent_index_[0..tangent_m_)
  bool same_as_newton(int m) const;
  static const char* fault_message(const Fault& fault);
  NlcpResult iterate(const ConstMat& C, const ConstVec& delta, Eigen::Ref<Eigen::VectorXd> F);
  void polish_total(const ConstMat& C, const ConstVec& delta0, const ConstVec& weights,
                    double total_force, double slope, int m, Eigen::Ref<Eigen::VectorXd> force,
                    double& lambda, NlcpResult& res);
  bool predict_total(const ConstMat& C, const ConstVec& delta0, const ConstVec& weights,
                     double total_force, Eigen::Ref<Eigen::VectorXd> force, double& lambda);
  double total_force_slope(const ConstMat& C, const ConstVec& weights,
                           const Eigen::Ref<const Eigen::VectorXd>& F, double tol, int& m,
                           Fault& fault, bool& factored);

  int capacity_;
  NlcpOptions options_;
  Eigen::MatrixXd newton_;    // storage of H_II = C_II + diag(f'_I) (m x m packed with leading
                              // dimension m, the free unknowns' order); its LLT in place
  Eigen::VectorXd newton_inv_;  // 1/L_jj of newton_ (multiplies in the substitutions)
  Eigen::VectorXd newton_diag_; // the slopes factor() added to newton_'s diagonal, per position
  Eigen::VectorXd cf_;        // C F, m
  Eigen::VectorXd g_;         // g(F), m
  std::vector<LocalLawKernel> kernel_;  // the laws of the current solve
  std::vector<LocalLawJet> jet_;        // f, f', f'', P at F
  std::vector<LocalLawJet> trial_jet_;  // the same at F + trial_
  Eigen::VectorXd floor_;     // f' at the floor line load min_line_load (NaN: not yet known)
  Eigen::VectorXd slope_;     // f'(F) floored for the Newton matrix, m/N
  Eigen::VectorXd step_;      // search direction d, N
  Eigen::VectorXd trial_;     // projected step s = max(0, F + alpha d) - F, N
  Eigen::VectorXd c_trial_;   // C s, m
  Eigen::VectorXd rhs_;       // packed right-hand side / solution on the free set
  Eigen::VectorXd best_;      // best iterate so far, N
  Eigen::VectorXd answer_;    // the last answer (jet_ holds the laws there), N
  int answer_n_ = -1;         // its size; -1: none
  Eigen::VectorXd delta_;     // quasi-static: Delta0 + lambda w, m
  Eigen::VectorXi free_;      // indices of the free unknowns
  Eigen::VectorXi newton_index_;  // the free set newton_ was last factorized for (in iterate)
  int newton_m_ = -1;             // its size
  bool newton_current_ = false;   // newton_ is of this call's C (solve, solve_total), made at an
                                  // earlier iterate (slope_ there) on newton_index_
  // The factorization kept by loaded_row_sums for the next solve (reuse_tangent).
  Eigen::MatrixXd tangent_;        // its LLT (lower), packed on tangent_index_[0..tangent_m_)
  Eigen::VectorXd tangent_inv_;    // 1/L_jj of tangent_
  Eigen::VectorXi tangent_index_;
  Eigen::VectorXd tangent_force_;  // the answer it was made at
  int tangent_n_ = -1;             // its number of unknowns; -1: none
  int tangent_m_ = 0;
  bool tangent_usable_ = false;    // this solve started from tangent_force_
  bool tangent_related_ = false;   // solve_total: it did (tangent_ stays valid for its slopes)
  double phi_ = 0;            // Phi at the last evaluated F, J
};

}  // namespace gm
