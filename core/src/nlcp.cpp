#include "nlcp.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>


// Keeps GCC from vectorizing a function's loops (see solve_factored).
#if defined(__GNUC__) && !defined(__clang__)
#define GM_SCALAR_LOOPS __attribute__((optimize("no-tree-vectorize")))
#else
#define GM_SCALAR_LOOPS
#endif

namespace gm {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kEps = std::numeric_limits<double>::epsilon();
constexpr double kArmijo = 1e-4;         // sigma of the Armijo rule
constexpr int kMaxBacktracks = 60;       // alpha down to ~1e-18
constexpr double kMinPivotRatio = 1e-12; // L_jj^2/H_jj below this: row j numerically dependent
constexpr double kSingularPivot = 1e-8;  // |L_jj^2| below this H_jj: singular, not indefinite
constexpr double kSymmetryTol = 1e-9;    // |C_ij - C_ji| <= this sqrt(C_ii C_jj)
constexpr double kChordRate = 1e-2;      // a kept-tangent step is repeated only below this rate
constexpr int kSeriesTerms = 3;          // loaded_row_sums' corrections on an earlier factorization
constexpr double kSeriesRate = 0.1;      // ... given up at a slower contraction
constexpr double kSeriesTolerance = 1e-12;  // ... estimated remainder relative to the row sums


}  // namespace

NlcpSolver::NlcpSolver(int capacity, const NlcpOptions& options)
    : capacity_(std::max(capacity, 0)),
      options_(options),
      newton_(capacity_, capacity_),
      newton_inv_(capacity_),
      newton_diag_(capacity_),
      cf_(capacity_),
      g_(capacity_),
      kernel_(capacity_),
      jet_(capacity_),
      trial_jet_(capacity_),
      floor_(capacity_),
      slope_(capacity_),
      step_(capacity_),
      trial_(capacity_),
      c_trial_(capacity_),
      rhs_(capacity_),
      best_(capacity_),
      answer_(capacity_),
      delta_(capacity_),
      free_(capacity_),
      newton_index_(capacity_),
      tangent_(capacity_, capacity_),
      tangent_inv_(capacity_),
      tangent_index_(capacity_),
      tangent_force_(capacity_) {}

const char* NlcpSolver::prepare(const ConstMat& C, const ConstVec& delta, const LocalLaw* laws,
                                Eigen::Ref<Eigen::VectorXd> F, int& index) {
  const Eigen::Index n = delta.size();
  index = -1;
  if (n > capacity_) return "more unknowns than the solver's capacity";
  if (C.rows() != n || C.cols() != n) return "compliance matrix C must be n x n";
  if (F.size() != n) return "force vector must have n entries";
  for (int i = 0; i < n; ++i) {
    index = i;
    if (!std::isfinite(delta[i])) return "approach Delta is not finite";
    // (an aligned spur pair's slices share one law: checked, and made a kernel below, once)
    if (laws && !(i > 0 && same_local_law(laws[i], laws[i - 1])))
      if (const char* err = local_law_error(laws[i])) return err;
  }
  // One pass over C: |C_ij - C_ji| <= kSymmetryTol sqrt(C_ii C_jj), which also fails on any
  // non-finite entry; only if it fails do the loops below look for the fault to name.
  bool ok = true;
  double* root = c_trial_.data();  // sqrt(C_ii) (c_trial_ is free scratch here)
  for (int i = 0; i < n; ++i) {
    const double c = C(i, i);
    ok = ok && c > 0 && c < kInf;
    root[i] = ok ? std::sqrt(c) : 0;
  }
  for (int j = 0; j < n && ok && options_.check_symmetry; ++j) {
    const double* Cj = C.data() + j * C.outerStride();
    const double tol_j = kSymmetryTol * root[j];
    bool column_ok = true;
    for (int i = j + 1; i < n; ++i) column_ok &= std::abs(Cj[i] - C(j, i)) <= tol_j * root[i];
    ok = column_ok;
  }
  if (!ok) {
    for (int i = 0; i < n; ++i) {
      index = i;
      if (!C.col(i).allFinite()) return "compliance matrix C is not finite";
      if (!(C(i, i) > 0))
        return "compliance matrix C: diagonal entry <= 0 (C must be positive definite)";
    }
    for (int i = 0; i < n; ++i) {
      index = i;
      for (int j = 0; j < i; ++j) {
        const double d = C(i, j) - C(j, i);
        if (d * d > kSymmetryTol * kSymmetryTol * C(i, i) * C(j, j))
          return "compliance matrix C is not symmetric";
      }
    }
  }
  index = -1;
  for (int i = 0; i < n; ++i)  // the warm start: anything but a finite F >= 0 counts as 0
    if (!(F[i] > 0) || !std::isfinite(F[i])) F[i] = 0;
  for (int i = 0; i < n; ++i)
    kernel_[i] = !laws                                           ? LocalLawKernel{}
                 : i > 0 && same_local_law(laws[i], laws[i - 1]) ? kernel_[i - 1]
                                                                 : local_law_kernel(laws[i]);
  floor_.head(n).setConstant(std::numeric_limits<double>::quiet_NaN());
  return nullptr;
}

// f'(F) for the Newton matrix: at F >= min_line_load L the law's own slope (in jet_[i]), below
// it the slope at that floor (finite; worked out once per solve).
double NlcpSolver::newton_slope(int i, double force) {
  const LocalLawKernel& kern = kernel_[i];
  if (force >= options_.min_line_load * kern.width) return jet_[i].slope;
  if (std::isnan(floor_[i])) floor_[i] = local_law_jet(kern, options_.min_line_load * kern.width).slope;
  return floor_[i];
}

// Fills jet_ (the laws at F), slope_ (floored), C F, g and phi_ = Phi(F) for F; returns the KKT
// residual ||min(diag(C) F, g)||_inf.
double NlcpSolver::evaluate(const ConstMat& C, const ConstVec& delta,
                            const Eigen::Ref<const Eigen::VectorXd>& F) {
  const Eigen::Index n = delta.size();
  cf_.head(n).noalias() = C * F;
  double residual = 0, energy = 0;
  for (int i = 0; i < n; ++i) {
    jet_[i] = local_law_jet(kernel_[i], F[i]);
    energy += jet_[i].energy;
    slope_[i] = newton_slope(i, F[i]);
    g_[i] = cf_[i] + jet_[i].approach - delta[i];  // paper eq. 1
    residual = std::max(residual, std::abs(std::min(C(i, i) * F[i], g_[i])));
  }
  phi_ = 0.5 * F.dot(cf_.head(n)) + energy - delta.dot(F);  // docs/physics.md §6
  return residual;
}

// After F += trial_ (the accepted step): the same as evaluate, from what the line search
// computed at that point (trial_jet_, C trial_), without evaluating a law or C F again. phi_ is
// left as it was (it is only needed for the warm start test).
double NlcpSolver::accept_trial(const ConstMat& C, const ConstVec& delta,
                                const Eigen::Ref<const Eigen::VectorXd>& F) {
  const Eigen::Index n = delta.size();
  cf_.head(n) += c_trial_.head(n);
  double residual = 0;
  for (int i = 0; i < n; ++i) {
    if (trial_[i] != 0) jet_[i] = trial_jet_[i];
    slope_[i] = newton_slope(i, F[i]);
    g_[i] = cf_[i] + jet_[i].approach - delta[i];  // paper eq. 1
    residual = std::max(residual, std::abs(std::min(C(i, i) * F[i], g_[i])));
  }
  return residual;
}

namespace {

// x[i] -= a[i] ya + b[i] yb for i in [lo, hi): two rows per step in one two-lane vector (GCC's and
// Clang's vector extension; each lane does the scalar loop's operations, so the bits are its).
inline void subtract_two_columns(double* __restrict x, const double* a, const double* b, double ya, double yb,
                                 int lo, int hi) {
  int i = lo;
#if defined(__GNUC__)
  typedef double Lanes __attribute__((vector_size(16)));
  for (; i + 1 < hi; i += 2) {
    Lanes xv, av, bv;
    std::memcpy(&xv, x + i, sizeof xv);
    std::memcpy(&av, a + i, sizeof av);
    std::memcpy(&bv, b + i, sizeof bv);
    xv -= av * ya + bv * yb;
    std::memcpy(x + i, &xv, sizeof xv);
  }
#endif
  for (; i < hi; ++i) x[i] -= a[i] * ya + b[i] * yb;
}

}  // namespace

// LLT of H_JJ = C_JJ + diag(slope_J), J = free_[0..m), in place in the lower triangle of an
// m x m matrix packed at the start of newton_'s storage, then rhs_[0..m) <- H_JJ^-1 rhs_[0..m). Plain loops over the contiguous columns: at
// the sizes of a mesh (m ~ 10..100) Eigen's LLT on a dynamic block spends most of its time in
// per-column dispatch; two columns per update pass take ~25 % off at m = 20..60 (measured). The
// pivot of column j is the Schur complement of the unknowns before it; one below
// kMinPivotRatio H_jj stops the factorization and names unknown j: ~0 (a dependent row) or
// negative (H not positive definite).
NlcpSolver::Fault NlcpSolver::factor(const ConstMat& C, int m, const Eigen::VectorXd& slope) {
  const Eigen::Index ld = m;  // packed: the m x m block is contiguous whatever the capacity
  double* H = newton_.data();
  const bool leading = m == 0 || free_[m - 1] == m - 1;  // free_ ascending: J = 0..m-1
  for (int b = 0; b < m; ++b) {
    const double* Cb = C.data() + free_[b] * C.outerStride();
    double* Hb = H + b * ld;
    if (leading)
      for (int a = b; a < m; ++a) Hb[a] = Cb[a];
    else
      for (int a = b; a < m; ++a) Hb[a] = Cb[free_[a]];
    Hb[b] += slope[free_[b]];
    newton_diag_[b] = slope[free_[b]];
  }
  for (int j = 0; j < m; ++j) {  // left-looking: column j minus L_jk times column k, k < j
    double* __restrict Hj = H + j * ld;
    int k = 0;
    for (; k + 1 < j; k += 2) {  // two columns per pass: half the loads and stores of column j
      const double* __restrict A = H + k * ld;
      const double* __restrict B = A + ld;
      subtract_two_columns(Hj, A, B, A[j], B[j], j, m);
    }
    if (k < j) {
      const double* __restrict A = H + k * ld;
      const double la = A[j];
      for (int i = j; i < m; ++i) Hj[i] -= la * A[i];
    }
    const double Hjj = C(free_[j], free_[j]) + slope[free_[j]];
    const double pivot = Hj[j];
    if (!(pivot >= kMinPivotRatio * Hjj)) return Fault{j, pivot > -kSingularPivot * Hjj};
    const double d = std::sqrt(pivot), inv = 1.0 / d;
    Hj[j] = d;
    newton_inv_[j] = inv;
    for (int i = j + 1; i < m; ++i) {
      Hj[i] *= inv;
      H[i * ld + j] = Hj[i];  // L's rows in the free upper triangle: L^T's columns, for the solves
    }
  }
  return Fault{};
}

// rhs_[0..m) <- (L L^T)^-1 rhs_[0..m), L the lower triangle of the m x m matrix packed at the
// start of L's storage (its rows copied above the diagonal by factor()), inv its diagonal's
// reciprocals (no division on the critical path). Both substitutions as updates (L y = b down
// L's columns, L^T x = y down the copies of its rows), two columns per pass over x (half its
// loads and stores), two rows of x per step in one two-lane vector; the compiler's own
// vectorization stays off here: at m ~ 10..30 its forms (and the dot-product form) stalled on
// loads of entries just stored, 1.9x as long at m = 20. The explicit two-lane steps took level
// 5's evaluation 3 % fewer instructions at the same time or less (docs/performance.md).
GM_SCALAR_LOOPS void NlcpSolver::solve_factored(const Eigen::MatrixXd& L,
                                                const Eigen::VectorXd& inv, int m) {
  const Eigen::Index ld = m;
  const double* H = L.data();
  double* __restrict x = rhs_.data();
  int k = 0;
  for (; k + 1 < m; k += 2) {  // L y = b, two columns per pass over x
    const double* Ha = H + k * ld;
    const double* Hb = Ha + ld;
    const double ya = x[k] * inv[k];
    x[k] = ya;
    const double yb = (x[k + 1] - Ha[k + 1] * ya) * inv[k + 1];
    x[k + 1] = yb;
    subtract_two_columns(x, Ha, Hb, ya, yb, k + 2, m);
  }
  if (k < m) x[k] *= inv[k];
  for (k = m - 1; k > 0; k -= 2) {  // L^T x = y: x_j -= L_kj x_k, j < k (rows k and k - 1 of L)
    const double* ra = H + k * ld;     // row k of L, as factor() copied it above the diagonal
    const double* rb = ra - ld;        // row k - 1
    const double ya = x[k] * inv[k];
    x[k] = ya;
    const double yb = (x[k - 1] - ra[k - 1] * ya) * inv[k - 1];
    x[k - 1] = yb;
    subtract_two_columns(x, ra, rb, ya, yb, 0, k - 1);
  }
  if (k == 0) x[0] *= inv[0];
}

NlcpSolver::Fault NlcpSolver::factor_and_solve(const ConstMat& C, int m,
                                               const Eigen::VectorXd& slope) {
  const Fault fault = factor(C, m, slope);
  if (fault.position < 0) solve_factored(newton_, newton_inv_, m);
  return fault;
}

bool NlcpSolver::same_as_newton(int m) const {
  if (m != newton_m_) return false;
  for (int a = 0; a < m; ++a)
    if (free_[a] != newton_index_[a]) return false;
  return true;
}

bool NlcpSolver::same_as_tangent(int m) const { return tangent_usable_ && on_tangent_set(m); }

bool NlcpSolver::on_tangent_set(int m) const {
  if (m != tangent_m_) return false;
  for (int a = 0; a < m; ++a)
    if (free_[a] != tangent_index_[a]) return false;
  return true;
}

const char* NlcpSolver::fault_message(const Fault& fault) {
  return fault.singular ? "C + diag(f') is numerically singular on the loaded unknowns "
                          "(e.g. duplicated slices without a local law)"
                        : "C + diag(f') is not positive definite on the loaded unknowns";
}

NlcpResult NlcpSolver::iterate(const ConstMat& C, const ConstVec& delta,
                               Eigen::Ref<Eigen::VectorXd> F) {
  const int n = static_cast<int>(delta.size());
  NlcpResult res;
  res.status = NlcpStatus::iteration_cap;
  res.tolerance = options_.tolerance +
                  options_.relative_tolerance * (n ? delta.cwiseAbs().maxCoeff() : 0.0);
  double r = evaluate(C, delta, F);
  if (phi_ > 0) {  // a stale warm start, worse than F = 0 (Phi(0) = 0 >= min Phi): drop it
    F.setZero();
    r = evaluate(C, delta, F);
  }
  double best_r = r;
  best_.head(n) = F;
  bool on_tangent = false;  // the last step was taken on the kept tangent
  bool on_newton = false;   // the last step was taken on newton_, factorized in this solve for
                            // the free set newton_index_[0..newton_m_)
  double rate = 1;          // residual after / before the last step
  for (;;) {
    if (r <= res.tolerance) {
      res.status = NlcpStatus::converged;
      break;
    }
    if (res.iterations >= options_.max_iterations) {
      res.message = "no convergence within the iteration cap (NlcpOptions::max_iterations)";
      res.capped = true;
      break;
    }
    // eps-active set (Bertsekas 1982, eq. 31 with a diagonal scaling D = diag(1/H_ii)):
    // eps = ||F - [F - D g]^+||_inf; unknowns with F_i <= eps and g_i > 0 take the scaled
    // gradient step -D_i g_i, the others (free) a Newton step on H_II = C_II + diag(f'_I).
    double eps = 0;
    for (int i = 0; i < n; ++i)
      eps = std::max(eps, F[i] - std::max(0.0, F[i] - g_[i] / (C(i, i) + slope_[i])));
    int m = 0;
    for (int i = 0; i < n; ++i) {
      if (F[i] <= eps && g_[i] > 0)
        step_[i] = -g_[i] / (C(i, i) + slope_[i]);
      else
        free_[m++] = i;
    }
    double decrease_free = 0;  // -g_I^T d_I = g_I^T H_II^-1 g_I
    if (m == 0) on_tangent = on_newton = false;
    if (m > 0) {
      for (int a = 0; a < m; ++a) rhs_[a] = -g_[free_[a]];
      Fault fault;
      // The previous answer's tangent for the first step, and again for a step that the
      // contraction it showed (rate, the residual ratio of its last step) predicts to end the
      // solve; else a Newton factorization.
      // The same rule for the last Newton factorization of this solve: after a Newton step the
      // rate is ~K |F_k - F_k-1|, which is also the rate of a chord step on that matrix.
      // A quasi-static solve's first step for a new lambda also takes the factorization its
      // last slope or Newton step made of this C, when the free set is the same (newton_current_).
      const bool chord = rate <= kChordRate && r * rate <= 0.5 * res.tolerance;
      const bool first = res.iterations == 0;
      on_tangent = same_as_tangent(m) && (first || (on_tangent && chord));
      on_newton = !on_tangent && newton_current_ && same_as_newton(m) &&
                  ((first && options_.reuse_tangent) || (on_newton && chord));
      if (on_tangent) {
        solve_factored(tangent_, tangent_inv_, m);
      } else if (on_newton) {
        solve_factored(newton_, newton_inv_, m);
      } else {
        fault = factor_and_solve(C, m, slope_), ++res.factorizations;
        on_newton = newton_current_ = fault.position < 0;
        newton_m_ = m;
        newton_index_.head(m) = free_.head(m);
      }
      if (fault.position >= 0) {
        res.status = NlcpStatus::bad_input;
        res.index = free_[fault.position];
        res.message = fault_message(fault);
        break;
      }
      for (int a = 0; a < m; ++a) {
        step_[free_[a]] = rhs_[a];
        decrease_free -= g_[free_[a]] * rhs_[a];
      }
    }
    // Armijo rule on Phi along the projection arc F(alpha) = [F + alpha d]^+ (Bertsekas 1982,
    // eq. 34). Phi(F + s) - Phi(F) = (C F - Delta)^T s + s^T C s/2 + sum dP_i, each term computed
    // from s itself so that short steps near the solution are not lost to cancellation; dP_i
    // from the laws at both ends (local_law_energy_change), those at F + s kept for the next
    // iterate.
    bool accepted = false;
    double alpha = 1;
    for (int k = 0; k < kMaxBacktracks && !accepted; ++k, alpha *= 0.5) {
      double change = 0, size = 0, decrease_active = 0;
      for (int i = 0; i < n; ++i) {
        const double s = std::max(0.0, F[i] + alpha * step_[i]) - F[i];
        trial_[i] = s;
        double dP = 0;
        if (s != 0) {  // the law at exactly the F[i] + s that F += trial_ will give
          trial_jet_[i] = local_law_jet(kernel_[i], F[i] + s);
          dP = local_law_energy_change(kernel_[i], F[i], s, jet_[i], trial_jet_[i]);
        }
        change += (cf_[i] - delta[i]) * s + dP;
        size += std::abs((cf_[i] - delta[i]) * s) + std::abs(dP);
        if (F[i] <= eps && g_[i] > 0) decrease_active -= g_[i] * s;
      }
      c_trial_.head(n).noalias() = C * trial_.head(n);
      const double quadratic = 0.5 * trial_.head(n).dot(c_trial_.head(n));
      change += quadratic;
      // Allowance for rounding in the sum only (a few ulps of its terms).
      const double rounding = 8 * kEps * (size + quadratic);
      accepted = change <= -kArmijo * (alpha * decrease_free + decrease_active) + rounding;
    }
    if (!accepted) {
      res.message = "line search stalled at the rounding floor";
      break;
    }
    F += trial_.head(n);
    ++res.iterations;
    const double r_before = r;
    r = options_.reuse_evaluations ? accept_trial(C, delta, F) : evaluate(C, delta, F);
    rate = r / r_before;
    if (r < best_r) {
      best_r = r;
      best_.head(n) = F;
    }
  }
  if (res.status != NlcpStatus::converged && best_r < r) {
    F = best_.head(n);
    r = evaluate(C, delta, F);
  }
  res.residual = r;
  answer_.head(n) = F;
  answer_n_ = n;
  return res;
}

NlcpResult NlcpSolver::solve(const ConstMat& C, const ConstVec& delta, const LocalLaw* laws,
                             Eigen::Ref<Eigen::VectorXd> force) {
  NlcpResult res;
  answer_n_ = -1;
  if (const char* err = prepare(C, delta, laws, force, res.index)) {
    if (force.size() == delta.size()) force.setZero();
    res.message = err;
    res.residual = kInf;
    return res;
  }
  newton_current_ = tangent_related_ = false;
  tangent_usable_ = options_.reuse_tangent && tangent_n_ == delta.size() &&
                    force == tangent_force_.head(tangent_n_);
  tangent_n_ = -1;  // one use
  const NlcpResult out = iterate(C, delta, force);
  tangent_usable_ = false;
  return out;
}

bool NlcpSolver::loaded_row_sums(const ConstMat& C, const ConstVec& F,
                                 Eigen::Ref<Eigen::VectorXd> row_sums) {
  const int n = static_cast<int>(F.size());
  row_sums.setZero();
  tangent_n_ = -1;
  if (n != answer_n_ || F != answer_.head(n)) return false;
  int m = 0;
  for (int i = 0; i < n; ++i) {
    if (F[i] > 0) {
      trial_[i] = jet_[i].slope;  // (trial_ is free scratch between solves)
      free_[m++] = i;
    }
  }
  if (m == 0) return true;
  const bool series = options_.reuse_tangent && newton_current_ && same_as_newton(m) &&
                      row_sums_by_series(m);
  if (!series) {
    for (int a = 0; a < m; ++a) rhs_[a] = 1;
    if (factor(C, m, trial_).position >= 0) return false;
  }
  keep_newton_as_tangent(F, m);
  if (!series) solve_factored(tangent_, tangent_inv_, m);
  for (int a = 0; a < m; ++a) row_sums[free_[a]] = rhs_[a];
  return true;
}

// x = (H + D)^-1 1 on the loaded set from newton_ = LLT of H, the Newton matrix of an earlier
// iterate of this C on the same set: H + D is the tangent at the answer, D = diag(f'(F) -
// newton_diag_) (the laws' slopes moved with the last step). Neumann series
// x = sum_k (-H^-1 D)^k H^-1 1, each term one solve; it stops when the estimated remainder
// |t_k| rho/(1 - rho) (rho = |t_k|/|t_k-1|) is below kSeriesTolerance |x| (1e-12: far below
// the solve's own tolerance on the forces), and gives up (false: factorize instead) when rho
// exceeds kSeriesRate or kSeriesTerms corrections do not reach it. Leaves x in rhs_.
bool NlcpSolver::row_sums_by_series(int m) {
  double* x = c_trial_.data();  // (free scratch between solves, as step_)
  double* jump = step_.data();  // D
  for (int a = 0; a < m; ++a) {
    jump[a] = trial_[free_[a]] - newton_diag_[a];
    rhs_[a] = 1;
  }
  solve_factored(newton_, newton_inv_, m);
  double size = 0;
  for (int a = 0; a < m; ++a) {
    x[a] = rhs_[a];
    size = std::max(size, std::abs(x[a]));
  }
  double last = size;
  for (int k = 0; k < kSeriesTerms; ++k) {
    for (int a = 0; a < m; ++a) rhs_[a] *= -jump[a];
    solve_factored(newton_, newton_inv_, m);
    double term = 0;
    for (int a = 0; a < m; ++a) {
      x[a] += rhs_[a];
      term = std::max(term, std::abs(rhs_[a]));
    }
    const double rate = last > 0 ? term / last : 0;
    if (!(rate <= kSeriesRate)) return false;
    if (term * rate / (1 - rate) <= kSeriesTolerance * size) {
      for (int a = 0; a < m; ++a) rhs_[a] = x[a];
      return true;
    }
    last = term;
  }
  return false;
}

bool NlcpSolver::keep_last_factorization(const ConstVec& F) {
  const int n = static_cast<int>(F.size());
  tangent_n_ = -1;
  if (!options_.reuse_tangent || !newton_current_ || n != answer_n_ || F != answer_.head(n))
    return false;
  int m = 0;
  for (int i = 0; i < n; ++i)
    if (F[i] > 0) free_[m++] = i;
  if (m == 0 || !same_as_newton(m)) return false;
  keep_newton_as_tangent(F, m);
  return true;
}

// newton_ (on free_[0..m), the loaded set of answer F) becomes the tangent kept for the next
// solve (reuse_tangent); swaps storage only.
void NlcpSolver::keep_newton_as_tangent(const ConstVec& F, int m) {
  const int n = static_cast<int>(F.size());
  newton_current_ = tangent_related_ = false;
  newton_.swap(tangent_);
  newton_inv_.swap(tangent_inv_);
  tangent_index_.head(m) = free_.head(m);
  tangent_force_.head(n) = F;
  tangent_n_ = n;
  tangent_m_ = m;
}

// Slope of w^T F(lambda): w_J^T H_JJ^-1 w_J over J = loaded unknowns and the unknowns with
// w_i > 0 at their threshold (g_i <= tol; raising lambda closes them), so that the right
// derivative is found at a kink. Leaves J in free_[0..m) and H_JJ^-1 w_J in rhs_[0..m).
// Returns 0 (and m = 0) if no weighted unknown is in J; fault as from factor_and_solve.
double NlcpSolver::total_force_slope(const ConstMat& C, const ConstVec& weights,
                                     const Eigen::Ref<const Eigen::VectorXd>& F, double tol,
                                     int& m, Fault& fault, bool& factored) {
  const int n = static_cast<int>(weights.size());
  bool weighted = false;
  m = 0;
  for (int i = 0; i < n; ++i) {
    if (F[i] > 0 || (weights[i] > 0 && g_[i] <= tol)) {
      rhs_[m] = weights[i];
      weighted = weighted || weights[i] != 0;
      free_[m++] = i;
    }
  }
  fault = Fault{};
  factored = false;
  if (!weighted) {
    m = 0;
    return 0;
  }
  // The slope only steers the update of lambda (and its first-order force predictor), so the
  // factorization of an earlier iterate of this C on the same set serves: the safeguarded
  // Newton on lambda keeps its stopping test, the slope's error only slows it.
  // So does the tangent this solve started from (the previous answer's, of a nearby C).
  const bool reuse = options_.reuse_tangent;
  if (reuse && newton_current_ && same_as_newton(m)) {
    solve_factored(newton_, newton_inv_, m);
  } else if (reuse && tangent_related_ && on_tangent_set(m)) {
    solve_factored(tangent_, tangent_inv_, m);
  } else {
    factored = true;
    fault = factor_and_solve(C, m, slope_);
    newton_current_ = fault.position < 0;
    newton_m_ = m;
    newton_index_.head(m) = free_.head(m);
  }
  double slope = 0;
  for (int a = 0; a < m; ++a) slope += weights[free_[a]] * rhs_[a];
  return slope;
}

// The last lambda correction dlambda = -mismatch/slope of a converged solve_total, applied with
// its first-order force update F_J += H_JJ^-1 w_J dlambda (rhs_, from total_force_slope): w^T F
// then meets total_force to rounding instead of to slope * tol, which a caller balancing a
// moment to a relative 1e-12 would otherwise chase with repeated solves. Kept only if the KKT
// residual at the new point is still within tol (no force hits 0), else everything is restored.
void NlcpSolver::polish_total(const ConstMat& C, const ConstVec& delta0, const ConstVec& weights,
                              double total_force, double slope, int m,
                              Eigen::Ref<Eigen::VectorXd> force, double& lambda, NlcpResult& res) {
  const int n = static_cast<int>(delta0.size());
  const double mismatch = weights.dot(force) - total_force;
  const double dl = -mismatch / slope;
  bool clamped = false;
  best_.head(n) = force;
  for (int a = 0; a < m; ++a) {
    const double next = force[free_[a]] + rhs_[a] * dl;
    clamped = clamped || !(next > 0);
    force[free_[a]] = next;
  }
  if (!clamped) {
    delta_.head(n) = delta0 + (lambda + dl) * weights;
    const double r = evaluate(C, delta_.head(n), force);
    const double after = std::abs(weights.dot(force) - total_force);
    if (r <= res.tolerance && after <= std::abs(mismatch)) {
      lambda += dl;
      answer_.head(n) = force;
      res.residual = std::max(r, after / slope);
      return;
    }
  }
  force = best_.head(n);
  delta_.head(n) = delta0 + lambda * weights;
  evaluate(C, delta_.head(n), force);  // the laws at the restored answer, for loaded_row_sums
}

// solve_total warm-started from the answer whose tangent loaded_row_sums kept (the previous
// step): one Newton step of the KKT system on its loaded set A with that factorization,
//   H_AA dF_A - w_A dlambda = -g_A,   w_A^T (F_A + dF_A) = total_force,
// i.e. dlambda = (total - w^T F + w_A^T H^-1 g_A) / (w_A^T H^-1 w_A), dF_A = H^-1 (w_A dlambda
// - g_A) (forces kept >= 0): lambda and F start near the new answer, so that the first inner
// solve is mostly its last. Only the start changes (the stopping tests are as they are).
bool NlcpSolver::predict_total(const ConstMat& C, const ConstVec& delta0, const ConstVec& weights,
                               double total_force, Eigen::Ref<Eigen::VectorXd> force,
                               double& lambda) {
  const int n = static_cast<int>(delta0.size());
  const int m = tangent_m_;
  if (m <= 0) return false;
  delta_.head(n) = delta0 + lambda * weights;
  evaluate(C, delta_.head(n), force);  // g_ at the warm start
  for (int a = 0; a < m; ++a) rhs_[a] = weights[tangent_index_[a]];
  solve_factored(tangent_, tangent_inv_, m);
  double slope = 0;
  for (int a = 0; a < m; ++a) {
    step_[a] = rhs_[a];  // H^-1 w_A (step_ is free scratch between iterations)
    slope += weights[tangent_index_[a]] * rhs_[a];
  }
  if (!(slope > 0)) return false;
  for (int a = 0; a < m; ++a) rhs_[a] = g_[tangent_index_[a]];
  solve_factored(tangent_, tangent_inv_, m);
  double wg = 0;
  for (int a = 0; a < m; ++a) wg += weights[tangent_index_[a]] * rhs_[a];
  const double dl = (total_force - weights.dot(force) + wg) / slope;
  if (!std::isfinite(dl)) return false;
  for (int a = 0; a < m; ++a) {
    const int i = tangent_index_[a];
    force[i] = std::max(0.0, force[i] + step_[a] * dl - rhs_[a]);
  }
  lambda += dl;
  return true;
}

NlcpResult NlcpSolver::solve_total(const ConstMat& C, const ConstVec& delta0, const LocalLaw* laws,
                                   const ConstVec& weights, double total_force,
                                   Eigen::Ref<Eigen::VectorXd> force, double& lambda) {
  const int n = static_cast<int>(delta0.size());
  NlcpResult res;
  answer_n_ = -1;
  const char* err = prepare(C, delta0, laws, force, res.index);
  if (!err && weights.size() != n) err = "weights must have n entries";
  if (!err) {
    bool weighted = false;
    for (int i = 0; i < n && !err; ++i) {
      if (!std::isfinite(weights[i])) {
        err = "weights must be finite";
        res.index = i;
      }
      weighted = weighted || weights[i] > 0;
    }
    if (!err && !weighted) err = "weights: at least one must be > 0";
  }
  if (!err && !(total_force > 0 && std::isfinite(total_force)))
    err = "total force must be finite and > 0";
  if (err) {
    tangent_n_ = -1;
    if (force.size() == n) force.setZero();
    res.message = err;
    res.residual = kInf;
    return res;
  }
  if (!std::isfinite(lambda)) lambda = 0;
  // the first inner solve may take its first step on the kept tangent, as in solve()
  newton_current_ = false;
  tangent_usable_ = options_.reuse_tangent && tangent_n_ == n && force == tangent_force_.head(n);
  tangent_related_ = tangent_usable_;
  tangent_n_ = -1;
  // (counted as an iteration: it is a Newton step of the KKT system)
  if (tangent_usable_ && predict_total(C, delta0, weights, total_force, force, lambda))
    ++res.iterations;

  // Safeguarded Newton on s(lambda) = w^T F(lambda) = total_force: s is continuous and
  // non-decreasing for weights of any sign (it is total_force minus the derivative of the
  // concave dual function), strictly increasing while a weighted unknown carries load, so the
  // root is unique. Bisection replaces a Newton
  // step that leaves the bracket or does not halve the previous one (rtsafe, Numerical Recipes
  // section 9.4).
  double lo = -kInf, hi = kInf, last_step = kInf;
  for (;;) {
    delta_.head(n) = delta0 + lambda * weights;
    const NlcpResult inner = iterate(C, delta_.head(n), force);
    tangent_usable_ = false;
    res.iterations += inner.iterations;
    res.factorizations += inner.factorizations;
    res.tolerance = inner.tolerance;
    res.status = inner.status;
    res.message = inner.message;
    res.capped = inner.capped;
    res.index = inner.index;
    if (inner.status == NlcpStatus::bad_input) return res;
    const double mismatch = weights.dot(force) - total_force;
    int m = 0;
    Fault fault;
    bool factored = false;
    const double slope = total_force_slope(C, weights, force, inner.tolerance, m, fault, factored);
    res.factorizations += factored;
    if (fault.position >= 0) {
      res.status = NlcpStatus::bad_input;
      res.index = free_[fault.position];
      res.message = fault_message(fault);
      return res;
    }
    const double correction = slope > 0 ? std::abs(mismatch) / slope : kInf;  // lambda error, m
    const double lambda_error = std::min(correction, hi - lo);
    res.residual = std::max(inner.residual, lambda_error);
    if (inner.status == NlcpStatus::converged && lambda_error <= inner.tolerance) {
      if (slope > 0 && mismatch != 0 && correction <= inner.tolerance)
        polish_total(C, delta0, weights, total_force, slope, m, force, lambda, res);
      return res;
    }
    if (res.approach_updates >= options_.max_approach_updates) {
      res.status = NlcpStatus::iteration_cap;
      res.message = "cap on updates of the rigid approach reached";
      return res;
    }
    (mismatch < 0 ? lo : hi) = lambda;
    double next;
    if (slope > 0) {
      next = lambda - mismatch / slope;
    } else {  // no weighted unknown loaded: move to the first threshold, lambda + min g_i/w_i
      double jump = kInf;
      for (int i = 0; i < n; ++i)
        if (weights[i] > 0) jump = std::min(jump, g_[i] / weights[i]);
      next = lambda + jump;
    }
    const bool bracketed = std::isfinite(lo) && std::isfinite(hi);
    const bool slow = 2 * std::abs(next - lambda) > std::abs(last_step);
    if (bracketed && (!(next > lo && next < hi) || slow)) next = 0.5 * (lo + hi);
    last_step = next - lambda;
    if (slope > 0)  // first-order predictor F_J += H_JJ^-1 w_J dlambda as the next warm start
      for (int a = 0; a < m; ++a)
        force[free_[a]] = std::max(0.0, force[free_[a]] + rhs_[a] * last_step);
    lambda = next;
    ++res.approach_updates;
  }
}

}  // namespace gm
