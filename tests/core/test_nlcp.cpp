// Tests of core/src/nlcp.cpp: the NLCP of paper eq. 1-4 (docs/physics.md §6) against an
// independent brute-force reference (enumeration of all active sets), warm starts, the
// quasi-static variant with a prescribed total force, extremes, bad input, the reuse paths
// (carried law values, the kept tangent) against the plain one, the tangent, and that solving
// allocates nothing.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "gearmesh/internal/hertz.hpp"
#include "nlcp.hpp"

// Counting malloc (glibc): every heap allocation in this process goes through here (operator new
// and Eigen's aligned_malloc both call malloc). Not under AddressSanitizer, which owns malloc:
// gcc says so with __SANITIZE_ADDRESS__, clang 14 only through __has_feature (this malloc in
// clang's build made every ASan start-up fail: tools/run-sanitizers).
#if defined(__SANITIZE_ADDRESS__)
#define GM_TEST_UNDER_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define GM_TEST_UNDER_ASAN 1
#endif
#endif
#if defined(__GLIBC__) && !defined(GM_TEST_UNDER_ASAN)
#define GM_TEST_COUNTS_MALLOC 1
namespace {
std::atomic<bool> g_count_mallocs{false};
std::atomic<long> g_mallocs{0};
}  // namespace
extern "C" void* __libc_malloc(std::size_t size);
extern "C" void* malloc(std::size_t size) noexcept {
  if (g_count_mallocs.load(std::memory_order_relaxed))
    g_mallocs.fetch_add(1, std::memory_order_relaxed);
  return __libc_malloc(size);
}
#endif

namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

constexpr double kMm = 1e-3;

struct Problem {
  MatrixXd C;                    // m/N
  VectorXd delta;                // m
  std::vector<gm::LocalLaw> law; // empty: f = 0
  const gm::LocalLaw* laws() const { return law.empty() ? nullptr : law.data(); }
  int n() const { return static_cast<int>(delta.size()); }
};

double uniform(std::mt19937_64& rng, double a, double b) {
  return std::uniform_real_distribution<double>(a, b)(rng);
}

// A slice at realistic gear values: width 1..5 mm, R' 3..30 mm, steel on steel (a quarter of
// the time steel on a bronze-like mate), depth 1..5 mm.
gm::LocalLaw random_law(std::mt19937_64& rng) {
  gm::LocalLaw law;
  law.width = uniform(rng, 1, 5) * kMm;
  law.reduced_radius = uniform(rng, 3, 30) * kMm;
  const double h = uniform(rng, 1, 5) * kMm;
  law.body[0] = {206e9, 0.3, h};
  law.body[1] = law.body[0];
  if (uniform(rng, 0, 1) < 0.25) law.body[1] = {110e9, 0.34, h};
  return law;
}

// SPD compliance with diagonal ~1e-10..1e-8 m/N: either A A^T + eps I (mixed-sign coupling) or
// an exponential kernel over slice positions (positive coupling, like slices of a tooth).
MatrixXd random_compliance(std::mt19937_64& rng, int n) {
  MatrixXd C(n, n);
  if (uniform(rng, 0, 1) < 0.5) {
    std::normal_distribution<double> normal;
    MatrixXd A(n, n);
    for (int i = 0; i < n * n; ++i) A.data()[i] = normal(rng);
    C = A * A.transpose();
    C.diagonal().array() += 0.05 * C.trace() / n;
  } else {
    std::vector<double> y(n);
    for (double& v : y) v = uniform(rng, 0, 20);
    const double length = uniform(rng, 1, 10);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        C(i, j) = std::exp(-std::abs(y[i] - y[j]) / length) + (i == j ? 0.05 : 0);
  }
  return C * (std::pow(10.0, uniform(rng, -10, -8)) / C.diagonal().mean());
}

Problem random_problem(std::mt19937_64& rng, int n, bool with_laws, double load = 1e-5) {
  Problem p;
  p.C = random_compliance(rng, n);
  p.delta = VectorXd(n);
  for (int i = 0; i < n; ++i) p.delta[i] = uniform(rng, -load, load);
  if (with_laws)
    for (int i = 0; i < n; ++i) p.law.push_back(random_law(rng));
  return p;
}

double law_f(const Problem& p, int i, double F) {
  return p.law.empty() ? 0.0 : gm::evaluate_local_law(p.law[i], F).approach;
}

// g = C F + f(F) - Delta (paper eq. 1), computed here independently of the solver.
VectorXd gap(const Problem& p, const VectorXd& F, const VectorXd& delta) {
  VectorXd g = p.C * F - delta;
  for (int i = 0; i < p.n(); ++i) g[i] += law_f(p, i, F[i]);
  return g;
}

double kkt_residual(const Problem& p, const VectorXd& F, const VectorXd& delta) {
  const VectorXd g = gap(p, F, delta);
  double r = 0;
  for (int i = 0; i < p.n(); ++i) {
    EXPECT_GE(F[i], 0.0);
    r = std::max(r, std::abs(std::min(p.C(i, i) * F[i], g[i])));
  }
  return r;
}

double default_tolerance(const VectorXd& delta) {
  const gm::NlcpOptions o;
  return o.tolerance + o.relative_tolerance * delta.cwiseAbs().maxCoeff();
}

// Reference on one free set I: the unconstrained minimiser of 1/2 x^T C_II x + sum P_i(x_i^+) -
// Delta_I^T x (f extended by 0 for x < 0: still strictly convex, and a set whose answer needs a
// negative force shows up as such), by damped Newton from the linear answer with f replaced by
// its secant at 100 N/mm.
VectorXd solve_on_set(const Problem& p, const std::vector<int>& I) {
  const int m = static_cast<int>(I.size());
  MatrixXd C(m, m);
  VectorXd d(m);
  for (int a = 0; a < m; ++a) {
    d[a] = p.delta[I[a]];
    for (int b = 0; b < m; ++b) C(a, b) = p.C(I[a], I[b]);
  }
  if (p.law.empty()) return Eigen::LLT<MatrixXd>(C).solve(d);
  auto law_at = [&](int a, double v) {
    return v > 0 ? gm::evaluate_local_law(p.law[I[a]], v) : gm::LocalLawValue{};
  };
  auto phi = [&](const VectorXd& v) {
    double s = 0.5 * v.dot(C * v) - d.dot(v);
    for (int a = 0; a < m; ++a) s += law_at(a, v[a]).energy;
    return s;
  };
  MatrixXd H = C;
  for (int a = 0; a < m; ++a) {
    const double F = 1e5 * p.law[I[a]].width;
    H(a, a) += law_at(a, F).approach / F;
  }
  VectorXd x = Eigen::LLT<MatrixXd>(H).solve(d);
  const double tol = 1e-14 * d.cwiseAbs().maxCoeff();
  for (int it = 0; it < 100; ++it) {
    VectorXd grad = C * x - d;
    H = C;
    for (int a = 0; a < m; ++a) {
      const gm::LocalLawValue lv = law_at(a, x[a]);
      grad[a] += lv.approach;
      H(a, a) += std::isfinite(lv.slope) ? lv.slope : 1e3 * C(a, a);
    }
    if (grad.cwiseAbs().maxCoeff() <= tol) break;
    const VectorXd step = -Eigen::LLT<MatrixXd>(H).solve(grad);
    double t = 1;
    const double phi0 = phi(x), slope = grad.dot(step);
    while (t > 1e-6 && phi(x + t * step) > phi0 + 1e-4 * t * slope) t *= 0.5;
    x += t * step;
  }
  return x;
}

// Brute force over the 2^n free sets (nearest to {Delta_i > 0} first, for speed only): the KKT
// point, unique by strict convexity, is the one whose forces are >= 0 and whose open gaps are
// >= 0. The first set that meets KKT to 1e-12 |Delta| is taken, else the least violation.
VectorXd reference_solution(const Problem& p) {
  const int n = p.n();
  unsigned guess = 0;
  for (int i = 0; i < n; ++i)
    if (p.delta[i] > 0) guess |= 1u << i;
  std::vector<unsigned> masks(1u << n);
  for (unsigned mask = 0; mask < masks.size(); ++mask) masks[mask] = mask;
  std::stable_sort(masks.begin(), masks.end(), [&](unsigned a, unsigned b) {
    return __builtin_popcount(a ^ guess) < __builtin_popcount(b ^ guess);
  });
  const double accept = 1e-12 * p.delta.cwiseAbs().maxCoeff();
  VectorXd best = VectorXd::Zero(n);
  double best_violation = std::numeric_limits<double>::infinity();
  for (unsigned mask : masks) {
    std::vector<int> I;
    for (int i = 0; i < n; ++i)
      if (mask & (1u << i)) I.push_back(i);
    VectorXd F = VectorXd::Zero(n);
    double violation = 0;
    if (!I.empty()) {
      const VectorXd x = solve_on_set(p, I);
      for (size_t a = 0; a < I.size(); ++a) {
        F[I[a]] = std::max(x[a], 0.0);
        violation = std::max(violation, -p.C(I[a], I[a]) * x[a]);
      }
    }
    const VectorXd g = gap(p, F, p.delta);
    for (int i = 0; i < n; ++i)
      violation = std::max(violation, (mask & (1u << i)) ? std::abs(g[i]) : -g[i]);
    if (violation < best_violation) {
      best_violation = violation;
      best = F;
    }
    if (violation <= accept) break;
  }
  return best;
}

// Scale of the forces of p: max |Delta| over the smallest diagonal compliance.
double force_scale(const Problem& p) {
  return p.delta.cwiseAbs().maxCoeff() / p.C.diagonal().minCoeff();
}

}  // namespace

TEST(Nlcp, RandomProblemsAgainstBruteForce) {
  // (a) 1200 random SPD problems, n = 1..12, half with f = 0, half with local laws.
  std::mt19937_64 rng(20240611);
  gm::NlcpSolver solver(12);
  int converged = 0, count = 0, total_iterations = 0, max_iterations = 0;
  for (int k = 0; k < 1200; ++k) {
    const int n = 1 + k % 12;
    const bool with_laws = (k / 12) % 2 == 1;
    const Problem p = random_problem(rng, n, with_laws);
    VectorXd F = VectorXd::Zero(n);
    const gm::NlcpResult res = solver.solve(p.C, p.delta, p.laws(), F);
    ++count;
    converged += res.status == gm::NlcpStatus::converged;
    total_iterations += res.iterations;
    max_iterations = std::max(max_iterations, res.iterations);
    ASSERT_EQ(res.status, gm::NlcpStatus::converged) << "problem " << k << ": " << res.message;
    EXPECT_LE(res.residual, res.tolerance);
    EXPECT_DOUBLE_EQ(res.tolerance, default_tolerance(p.delta));
    // The residual as recomputed here, from scratch.
    EXPECT_LE(kkt_residual(p, F, p.delta), res.tolerance * (1 + 1e-6)) << "problem " << k;
    const VectorXd ref = reference_solution(p);
    EXPECT_LE((F - ref).cwiseAbs().maxCoeff(), 1e-7 * force_scale(p))
        << "problem " << k << " n " << n << (with_laws ? " with laws" : " f = 0") << "\nF   "
        << F.transpose() << "\nref " << ref.transpose();
  }
  EXPECT_EQ(converged, count);
  std::printf("random problems: %d solved, mean %.2f, max %d Newton iterations (cold)\n", count,
              double(total_iterations) / count, max_iterations);
}

TEST(Nlcp, WarmStartTakesFewerIterations) {
  // (b) re-solve after a small change of Delta, from the previous answer and from zero.
  std::mt19937_64 rng(7);
  gm::NlcpSolver solver(60);
  int warm_total = 0, cold_total = 0;
  for (int k = 0; k < 200; ++k) {
    const int n = 4 + k % 57;
    Problem p = random_problem(rng, n, true);
    VectorXd F = VectorXd::Zero(n);
    ASSERT_EQ(solver.solve(p.C, p.delta, p.laws(), F).status, gm::NlcpStatus::converged);
    for (int i = 0; i < n; ++i) p.delta[i] += 1e-3 * uniform(rng, -1e-5, 1e-5);
    VectorXd cold = VectorXd::Zero(n);
    const gm::NlcpResult rc = solver.solve(p.C, p.delta, p.laws(), cold);
    const gm::NlcpResult rw = solver.solve(p.C, p.delta, p.laws(), F);
    ASSERT_EQ(rc.status, gm::NlcpStatus::converged);
    ASSERT_EQ(rw.status, gm::NlcpStatus::converged);
    EXPECT_LE(rw.iterations, rc.iterations) << "problem " << k;
    EXPECT_LE((F - cold).cwiseAbs().maxCoeff(), 1e-7 * force_scale(p));
    warm_total += rw.iterations;
    cold_total += rc.iterations;
  }
  std::printf("perturbed re-solves: %d Newton iterations warm, %d cold\n", warm_total, cold_total);
  EXPECT_LT(warm_total, cold_total / 2);
}

TEST(Nlcp, TotalForceTwoDiagonalSlicesByHand) {
  // (c) C = diag(c1, c2), f = 0, w = (1, 1): F_i = max(0, (d_i + lambda)/c_i).
  gm::NlcpSolver solver(2);
  const double c1 = 2e-9, c2 = 5e-9, Fbn = 3000;
  MatrixXd C = MatrixXd::Zero(2, 2);
  C(0, 0) = c1;
  C(1, 1) = c2;
  const VectorXd w = VectorXd::Ones(2);
  {  // both loaded: (d1 + l)/c1 + (d2 + l)/c2 = Fbn
    const VectorXd d0 = (VectorXd(2) << 1e-6, -2e-6).finished();
    const double lambda = (Fbn - d0[0] / c1 - d0[1] / c2) / (1 / c1 + 1 / c2);
    VectorXd F = VectorXd::Zero(2);
    double l = 0;
    const gm::NlcpResult res = solver.solve_total(C, d0, nullptr, w, Fbn, F, l);
    ASSERT_EQ(res.status, gm::NlcpStatus::converged) << res.message;
    EXPECT_NEAR(l, lambda, 1e-14);
    EXPECT_NEAR(F[0], (d0[0] + lambda) / c1, 1e-6);
    EXPECT_NEAR(F[1], (d0[1] + lambda) / c2, 1e-6);
  }
  {  // slice 2 open: lambda = c1 Fbn - d1, F = (Fbn, 0), gap d2 + lambda < 0
    const VectorXd d0 = (VectorXd(2) << 1e-6, -20e-6).finished();
    const double lambda = c1 * Fbn - d0[0];
    ASSERT_LT(d0[1] + lambda, 0);
    VectorXd F = VectorXd::Zero(2);
    double l = 0;
    const gm::NlcpResult res = solver.solve_total(C, d0, nullptr, w, Fbn, F, l);
    ASSERT_EQ(res.status, gm::NlcpStatus::converged) << res.message;
    EXPECT_NEAR(l, lambda, 1e-14);
    EXPECT_NEAR(F[0], Fbn, 1e-6);
    EXPECT_EQ(F[1], 0.0);
  }
  {  // w = (1, -1): slice 2 on flank B (wedging), its force takes torque back
    const VectorXd d0 = (VectorXd(2) << 5e-6, 10e-6).finished();
    const VectorXd w1m1 = (VectorXd(2) << 1, -1).finished();
    // (d1 + l)/c1 - (d2 - l)/c2 = Fbn
    const double lambda = (Fbn - d0[0] / c1 + d0[1] / c2) / (1 / c1 + 1 / c2);
    ASSERT_GT(d0[1] - lambda, 0);
    VectorXd F = VectorXd::Zero(2);
    double l = 0;
    const gm::NlcpResult res = solver.solve_total(C, d0, nullptr, w1m1, Fbn, F, l);
    ASSERT_EQ(res.status, gm::NlcpStatus::converged) << res.message;
    EXPECT_NEAR(l, lambda, 1e-14);
    EXPECT_NEAR(F[0], (d0[0] + lambda) / c1, 1e-6);
    EXPECT_NEAR(F[1], (d0[1] - lambda) / c2, 1e-6);
  }
  {  // w = (1, 0): slice 2 carries its own load, only slice 1 counts
    const VectorXd d0 = (VectorXd(2) << -4e-6, 3e-6).finished();
    const VectorXd w10 = (VectorXd(2) << 1, 0).finished();
    VectorXd F = VectorXd::Zero(2);
    double l = 0;
    const gm::NlcpResult res = solver.solve_total(C, d0, nullptr, w10, Fbn, F, l);
    ASSERT_EQ(res.status, gm::NlcpStatus::converged) << res.message;
    EXPECT_NEAR(l, c1 * Fbn - d0[0], 1e-14);
    EXPECT_NEAR(F[0], Fbn, 1e-6);
    EXPECT_NEAR(F[1], d0[1] / c2, 1e-6);
  }
}

TEST(Nlcp, TotalForceRandomProblems) {
  // (c) random problems: w^T F = F_bn, KKT with Delta0 + lambda w, and the plain solve at that
  // Delta reproduces F. Weights: ones on a random subset (flank A), random in [0, 1], or +-1
  // (both flanks, wedging).
  std::mt19937_64 rng(99);
  gm::NlcpSolver solver(12), plain(12);
  int updates = 0, iterations = 0;
  for (int k = 0; k < 400; ++k) {
    const int n = 1 + k % 12;
    Problem p = random_problem(rng, n, k % 2 == 1);
    if (k % 3 == 0) p.delta = -p.delta.cwiseAbs();  // everything open at lambda = 0
    VectorXd w(n);
    for (int i = 0; i < n; ++i) {
      const double u = uniform(rng, 0, 1);
      w[i] = k % 4 < 2 ? (u < 0.7 ? 1.0 : 0.0) : k % 4 == 2 ? u : (u < 0.6 ? 1.0 : -1.0);
    }
    if (w.maxCoeff() <= 0) w[0] = 1;
    const double Fbn = uniform(rng, 100, 5000);
    VectorXd F = VectorXd::Zero(n);
    double lambda = 0;
    const gm::NlcpResult res = solver.solve_total(p.C, p.delta, p.laws(), w, Fbn, F, lambda);
    ASSERT_EQ(res.status, gm::NlcpStatus::converged) << "problem " << k << ": " << res.message;
    updates += res.approach_updates;
    iterations += res.iterations;
    EXPECT_NEAR(w.dot(F), Fbn, 1e-7 * Fbn) << "problem " << k;
    const VectorXd delta = p.delta + lambda * w;
    EXPECT_LE(kkt_residual(p, F, delta), res.tolerance * (1 + 1e-6)) << "problem " << k;
    VectorXd F_plain = VectorXd::Zero(n);
    ASSERT_EQ(plain.solve(p.C, delta, p.laws(), F_plain).status, gm::NlcpStatus::converged);
    EXPECT_LE((F - F_plain).cwiseAbs().maxCoeff(), 1e-7 * Fbn) << "problem " << k;
    // Warm start from the answer: nothing to do.
    const gm::NlcpResult again = solver.solve_total(p.C, p.delta, p.laws(), w, Fbn, F, lambda);
    EXPECT_EQ(again.status, gm::NlcpStatus::converged);
    EXPECT_LE(again.approach_updates, 1) << "problem " << k;
  }
  std::printf("quasi-static: mean %.2f lambda updates, %.2f Newton iterations (cold)\n",
              updates / 400.0, iterations / 400.0);
}

TEST(Nlcp, ZeroLoad) {
  // (d) Delta <= 0 everywhere: F = 0, at once from zero and in one step from a warm start.
  std::mt19937_64 rng(3);
  gm::NlcpSolver solver(12);
  for (int k = 0; k < 50; ++k) {
    Problem p = random_problem(rng, 1 + k % 12, k % 2 == 0);
    p.delta = -p.delta.cwiseAbs();
    if (k % 5 == 0) p.delta.setZero();
    VectorXd F = VectorXd::Zero(p.n());
    gm::NlcpResult res = solver.solve(p.C, p.delta, p.laws(), F);
    EXPECT_EQ(res.status, gm::NlcpStatus::converged);
    EXPECT_EQ(res.iterations, 0);
    EXPECT_EQ(F.cwiseAbs().maxCoeff(), 0.0);
    F.setConstant(500.0);  // a stale warm start
    res = solver.solve(p.C, p.delta, p.laws(), F);
    EXPECT_EQ(res.status, gm::NlcpStatus::converged);
    EXPECT_LE(res.iterations, 1) << k;
    EXPECT_EQ(F.cwiseAbs().maxCoeff(), 0.0);
  }
}

TEST(Nlcp, HundredTimesLoadAndHugePenetrations) {
  // (d) 100x the usual approaches, and 1 mm everywhere: converged, and the brute-force answer.
  std::mt19937_64 rng(11);
  gm::NlcpSolver solver(10);
  for (int k = 0; k < 100; ++k) {
    const bool huge = k >= 60;  // +-1 mm at random, or 1 mm on every slice
    Problem p = random_problem(rng, 1 + k % 10, k % 2 == 0, huge ? 1e-3 : 100 * 1e-5);
    if (huge && k % 4 < 2) p.delta.setConstant(1e-3);
    VectorXd F = VectorXd::Zero(p.n());
    const gm::NlcpResult res = solver.solve(p.C, p.delta, p.laws(), F);
    ASSERT_EQ(res.status, gm::NlcpStatus::converged) << k << ": " << res.message;
    EXPECT_LE(kkt_residual(p, F, p.delta), res.tolerance * (1 + 1e-6));
    const VectorXd ref = reference_solution(p);
    EXPECT_LE((F - ref).cwiseAbs().maxCoeff(), 1e-7 * force_scale(p)) << k;
  }
}

TEST(Nlcp, DuplicatedSlices) {
  // (d) slices 1 and 2 identical (C rows, Delta, law): C is singular. With local laws
  // C + diag(f') is definite and the answer is symmetric; with f = 0 the solver reports it.
  std::mt19937_64 rng(5);
  gm::NlcpSolver solver(5);
  Problem p = random_problem(rng, 5, true);
  p.delta = p.delta.cwiseAbs();
  p.C.row(2) = p.C.row(1);
  p.C.col(2) = p.C.col(1);
  p.delta[2] = p.delta[1];
  p.law[2] = p.law[1];
  VectorXd F = VectorXd::Zero(5);
  gm::NlcpResult res = solver.solve(p.C, p.delta, p.laws(), F);
  ASSERT_EQ(res.status, gm::NlcpStatus::converged) << res.message;
  EXPECT_GT(F[1], 0);
  EXPECT_NEAR(F[1], F[2], 1e-9 * F[1]);
  EXPECT_LE(kkt_residual(p, F, p.delta), res.tolerance * (1 + 1e-6));

  p.law.clear();  // f = 0: both duplicates loaded, C_II singular
  F.setZero();
  res = solver.solve(p.C, p.delta, p.laws(), F);
  EXPECT_EQ(res.status, gm::NlcpStatus::bad_input);
  EXPECT_NE(std::string(res.message).find("singular"), std::string::npos) << res.message;
  EXPECT_TRUE(res.index == 1 || res.index == 2) << res.index;
  EXPECT_TRUE(F.allFinite());

  p.delta[1] = p.delta[2] = -1e-5;  // f = 0 but the duplicates stay open: no harm done
  F.setZero();
  res = solver.solve(p.C, p.delta, p.laws(), F);
  EXPECT_EQ(res.status, gm::NlcpStatus::converged) << res.message;
}

TEST(Nlcp, NearlyParallelRows) {
  // Slices 1 and 2 only 1e-4 mm apart under an exponential kernel (l = 5 mm): their second
  // Cholesky pivot is 4e-5 of the diagonal. Converged with and without laws; the forces are
  // ill-determined between the two, the gaps C F + f(F) are not: compare those.
  const double y[5] = {0, 5, 5.0001, 12, 20};  // mm
  Problem p;
  p.C.resize(5, 5);
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j) p.C(i, j) = 7e-9 * std::exp(-std::abs(y[i] - y[j]) / 5);
  p.delta = (VectorXd(5) << 3e-6, 6e-6, 6e-6, -1e-6, 4e-6).finished();
  gm::NlcpSolver solver(5);
  for (bool with_laws : {false, true}) {
    std::mt19937_64 rng(8);
    p.law.clear();
    if (with_laws)
      for (int i = 0; i < 5; ++i) p.law.push_back(random_law(rng));
    VectorXd F = VectorXd::Zero(5);
    const gm::NlcpResult res = solver.solve(p.C, p.delta, p.laws(), F);
    ASSERT_EQ(res.status, gm::NlcpStatus::converged) << res.message;
    EXPECT_LE(kkt_residual(p, F, p.delta), res.tolerance * (1 + 1e-6));
    const VectorXd ref = reference_solution(p);
    EXPECT_LE((gap(p, F, p.delta) - gap(p, ref, p.delta)).cwiseAbs().maxCoeff(), 1e-14)
        << F.transpose() << "\n" << ref.transpose();
    EXPECT_NEAR(F[1] + F[2], ref[1] + ref[2], 1e-6 * (ref[1] + ref[2]));
  }
}

TEST(Nlcp, SingleSliceClosedForm) {
  // (d) n = 1: C F + f(F) = Delta, by bisection here; and F = Delta/C for f = 0.
  std::mt19937_64 rng(17);
  gm::NlcpSolver solver(1);
  for (int k = 0; k < 50; ++k) {
    Problem p = random_problem(rng, 1, true, 1e-5);
    p.delta[0] = std::abs(p.delta[0]) * (k < 25 ? 1 : 100);
    double lo = 0, hi = p.delta[0] / p.C(0, 0);
    for (int it = 0; it < 200; ++it) {
      const double mid = 0.5 * (lo + hi);
      (p.C(0, 0) * mid + law_f(p, 0, mid) < p.delta[0] ? lo : hi) = mid;
    }
    VectorXd F = VectorXd::Zero(1);
    const gm::NlcpResult res = solver.solve(p.C, p.delta, p.laws(), F);
    ASSERT_EQ(res.status, gm::NlcpStatus::converged) << res.message;
    EXPECT_NEAR(F[0], 0.5 * (lo + hi), 1e-9 * hi) << k;
    p.law.clear();
    F.setZero();
    ASSERT_EQ(solver.solve(p.C, p.delta, p.laws(), F).status, gm::NlcpStatus::converged);
    EXPECT_NEAR(F[0], p.delta[0] / p.C(0, 0), 1e-12 * F[0]);
    EXPECT_LE(solver.solve(p.C, p.delta, p.laws(), F).iterations, 0);  // already solved
  }
}

TEST(Nlcp, BadInput) {
  std::mt19937_64 rng(23);
  const Problem good = random_problem(rng, 4, true);
  gm::NlcpSolver solver(4);
  auto expect_bad = [&](const Problem& p, const char* what) {
    VectorXd F = VectorXd::Constant(p.n(), 10.0);
    const gm::NlcpResult res = solver.solve(p.C, p.delta, p.laws(), F);
    EXPECT_EQ(res.status, gm::NlcpStatus::bad_input) << what;
    EXPECT_STRNE(res.message, "") << what;
    EXPECT_TRUE(F.allFinite()) << what;
    return std::string(res.message);
  };
  Problem p = good;
  p.delta[2] = NAN;
  EXPECT_NE(expect_bad(p, "NaN Delta").find("Delta"), std::string::npos);
  p = good;
  p.C(1, 3) = p.C(3, 1) = INFINITY;
  EXPECT_NE(expect_bad(p, "Inf C").find("finite"), std::string::npos);
  p = good;
  p.C(1, 3) *= 1.01;
  EXPECT_NE(expect_bad(p, "asymmetric C").find("symmetric"), std::string::npos);
  {  // check_symmetry off (a caller that builds C symmetric): not looked at; the diagonal still is
    gm::NlcpOptions trusting;
    trusting.check_symmetry = false;
    gm::NlcpSolver unchecked(4, trusting);
    VectorXd F = VectorXd::Zero(p.n());
    EXPECT_NE(unchecked.solve(p.C, p.delta, p.laws(), F).status, gm::NlcpStatus::bad_input);
    Problem q = good;
    q.C(0, 0) = -q.C(0, 0);
    F.setZero();
    EXPECT_EQ(unchecked.solve(q.C, q.delta, q.laws(), F).status, gm::NlcpStatus::bad_input);
  }
  p = good;
  p.C(0, 0) = -p.C(0, 0);
  EXPECT_NE(expect_bad(p, "negative diagonal").find("positive definite"), std::string::npos);
  p = good;  // indefinite: a 2x2 block with |C_01| > sqrt(C_00 C_11), both slices loaded
  p.delta.setConstant(1e-5);
  p.C.setZero();
  p.C.diagonal().setConstant(1e-9);
  p.C(0, 1) = p.C(1, 0) = -3e-9;
  p.law.clear();
  EXPECT_NE(expect_bad(p, "indefinite C").find("positive definite"), std::string::npos);
  p = good;
  p.law[3].reduced_radius = -1e-3;
  EXPECT_NE(expect_bad(p, "bad law").find("R'"), std::string::npos);
  p = random_problem(rng, 5, false);
  EXPECT_NE(expect_bad(p, "over capacity").find("capacity"), std::string::npos);

  // Quasi-static: weights and total force.
  VectorXd F = VectorXd::Zero(4);
  double lambda = 0;
  VectorXd w = VectorXd::Ones(4);
  EXPECT_EQ(solver.solve_total(good.C, good.delta, good.laws(), w, -1.0, F, lambda).status,
            gm::NlcpStatus::bad_input);
  w.setZero();
  EXPECT_EQ(solver.solve_total(good.C, good.delta, good.laws(), w, 1e3, F, lambda).status,
            gm::NlcpStatus::bad_input);
  w.setOnes();
  w[1] = NAN;
  EXPECT_EQ(solver.solve_total(good.C, good.delta, good.laws(), w, 1e3, F, lambda).status,
            gm::NlcpStatus::bad_input);
  w.setConstant(-1);  // no positive weight: w^T F = total_force > 0 has no answer with F >= 0
  EXPECT_EQ(solver.solve_total(good.C, good.delta, good.laws(), w, 1e3, F, lambda).status,
            gm::NlcpStatus::bad_input);

  // A non-finite or negative warm start is not an error: it counts as zero.
  F << NAN, -5, INFINITY, 1;
  w.setOnes();
  EXPECT_EQ(solver.solve(good.C, good.delta, good.laws(), F).status, gm::NlcpStatus::converged);
}

TEST(Nlcp, IterationCapReturnsBestIterate) {
  std::mt19937_64 rng(31);
  gm::NlcpOptions options;
  options.max_iterations = 1;
  gm::NlcpSolver solver(40, options);
  const Problem p = random_problem(rng, 40, true);
  VectorXd F = VectorXd::Zero(40);
  const gm::NlcpResult res = solver.solve(p.C, p.delta, p.laws(), F);
  ASSERT_EQ(res.status, gm::NlcpStatus::iteration_cap);
  EXPECT_STRNE(res.message, "");
  EXPECT_LE(res.iterations, 1);
  EXPECT_TRUE(F.allFinite());
  EXPECT_GT(res.residual, res.tolerance);
  EXPECT_DOUBLE_EQ(res.residual, kkt_residual(p, F, p.delta));
  // Continuing from the best iterate converges.
  options.max_iterations = 50;
  solver.set_options(options);
  EXPECT_EQ(solver.solve(p.C, p.delta, p.laws(), F).status, gm::NlcpStatus::converged);
}

TEST(Nlcp, ReusedEvaluationsEqualThePlainPath) {
  // The default path carries the law values and C s of the accepted trial point over to the next
  // iterate; the plain path evaluates every iterate from scratch. Same iterations, same answer
  // (to rounding), cold and warm, n = 1..40, half with laws.
  std::mt19937_64 rng(53);
  gm::NlcpOptions plain_options;
  plain_options.reuse_evaluations = false;
  plain_options.reuse_tangent = false;
  gm::NlcpSolver reuse(40), plain(40, plain_options);
  int same_iterations = 0, count = 0;
  for (int k = 0; k < 400; ++k) {
    const int n = 1 + k % 40;
    Problem p = random_problem(rng, n, k % 2 == 1);
    VectorXd Fr = VectorXd::Zero(n), Fp = VectorXd::Zero(n);
    for (int pass = 0; pass < 2; ++pass) {  // cold, then warm after a 1e-3 change of Delta
      const gm::NlcpResult rr = reuse.solve(p.C, p.delta, p.laws(), Fr);
      const gm::NlcpResult rp = plain.solve(p.C, p.delta, p.laws(), Fp);
      ASSERT_EQ(rr.status, gm::NlcpStatus::converged) << k << ": " << rr.message;
      ASSERT_EQ(rp.status, gm::NlcpStatus::converged) << k << ": " << rp.message;
      EXPECT_LE(kkt_residual(p, Fr, p.delta), rr.tolerance * (1 + 1e-6)) << k;
      EXPECT_LE((Fr - Fp).cwiseAbs().maxCoeff(), 1e-9 * force_scale(p)) << k;
      EXPECT_LE(std::abs(rr.iterations - rp.iterations), 1) << k;
      EXPECT_LE(rp.factorizations, rp.iterations) << k;  // none when all are active
      same_iterations += rr.iterations == rp.iterations;
      ++count;
      for (int i = 0; i < n; ++i) p.delta[i] += 1e-3 * uniform(rng, -1e-5, 1e-5);
      Fp = Fr;  // both warm-start from the same forces
    }
  }
  std::printf("reuse vs plain: %d of %d solves with the same iteration count\n", same_iterations,
              count);
  EXPECT_GE(same_iterations, count * 99 / 100);
}

TEST(Nlcp, LoadedRowSumsAreTheTangent) {
  // K 1 with K = (C_AA + diag f'_A)^-1 on the loaded set: against an Eigen LLT built here from
  // evaluate_local_law, and against central differences of the solve under a uniform shift t of
  // Delta (dF_A/dt = K 1 while the active set holds).
  std::mt19937_64 rng(59);
  gm::NlcpOptions tight;
  tight.relative_tolerance = 1e-14;
  gm::NlcpSolver solver(20, tight), other(20, tight);
  int differenced = 0;
  for (int k = 0; k < 200; ++k) {
    const int n = 1 + k % 20;
    const Problem p = random_problem(rng, n, k % 4 != 0);
    VectorXd F = VectorXd::Zero(n), sums(n);
    ASSERT_EQ(solver.solve(p.C, p.delta, p.laws(), F).status, gm::NlcpStatus::converged);
    ASSERT_TRUE(solver.loaded_row_sums(p.C, F, sums));
    std::vector<int> A;
    for (int i = 0; i < n; ++i)
      if (F[i] > 0) A.push_back(i); else EXPECT_EQ(sums[i], 0.0) << k;
    const int m = static_cast<int>(A.size());
    if (m == 0) continue;
    MatrixXd H(m, m);
    for (int a = 0; a < m; ++a) {
      for (int b = 0; b < m; ++b) H(a, b) = p.C(A[a], A[b]);
      if (!p.law.empty()) H(a, a) += gm::evaluate_local_law(p.law[A[a]], F[A[a]]).slope;
    }
    const VectorXd ref = Eigen::LLT<MatrixXd>(H).solve(VectorXd::Ones(m));
    for (int a = 0; a < m; ++a)
      EXPECT_NEAR(sums[A[a]], ref[a], 1e-10 * ref.cwiseAbs().maxCoeff()) << k;
    // Central differences, where the active set is the same on both sides.
    const double t = 1e-7 * p.delta.cwiseAbs().maxCoeff();
    VectorXd Fp = F, Fm = F;
    const VectorXd dp = p.delta.array() + t, dm = p.delta.array() - t;
    ASSERT_EQ(other.solve(p.C, dp, p.laws(), Fp).status, gm::NlcpStatus::converged);
    ASSERT_EQ(other.solve(p.C, dm, p.laws(), Fm).status, gm::NlcpStatus::converged);
    bool stable = true;
    for (int i = 0; i < n; ++i) stable = stable && (Fp[i] > 0) == (F[i] > 0) && (Fm[i] > 0) == (F[i] > 0);
    if (!stable) continue;
    ++differenced;
    for (int a = 0; a < m; ++a) {
      const double fd = (Fp[A[a]] - Fm[A[a]]) / (2 * t);
      EXPECT_NEAR(sums[A[a]], fd, 1e-5 * ref.cwiseAbs().maxCoeff()) << k;
    }
  }
  std::printf("tangent row sums: %d of 200 problems also checked by differences\n", differenced);
  EXPECT_GE(differenced, 100);
}

TEST(Nlcp, FirstStepOnThePreviousTangent) {
  // A time step: solve, take the tangent (loaded_row_sums), then solve a slightly changed problem
  // (C, laws and Delta all moved by ~1e-3) warm: the first Newton step runs on the kept
  // factorization (and a second one where the first contracted enough), so fewer factorizations
  // than iterations, and the answer is the plain path's.
  // Then a stale tangent (C five times stiffer since) still converges, to the brute-force answer.
  std::mt19937_64 rng(61);
  gm::NlcpOptions plain_options;
  plain_options.reuse_tangent = false;
  gm::NlcpSolver reuse(30), plain(30, plain_options);
  int reused = 0, chord = 0, count = 0, factorizations_reuse = 0, factorizations_plain = 0;
  for (int k = 0; k < 150; ++k) {
    const int n = 2 + k % 29;
    Problem p = random_problem(rng, n, true);
    VectorXd F = VectorXd::Zero(n), sums(n);
    ASSERT_EQ(reuse.solve(p.C, p.delta, p.laws(), F).status, gm::NlcpStatus::converged);
    ASSERT_TRUE(reuse.loaded_row_sums(p.C, F, sums));
    const VectorXd y = VectorXd::Random(n);
    p.C += 1e-3 * p.C.diagonal().mean() * (y * y.transpose()) / n;  // stays SPD
    for (gm::LocalLaw& law : p.law) law.reduced_radius *= 1.001;
    for (int i = 0; i < n; ++i) p.delta[i] += 1e-3 * uniform(rng, -1e-5, 1e-5);
    VectorXd Fp = F;
    const gm::NlcpResult rr = reuse.solve(p.C, p.delta, p.laws(), F);
    const gm::NlcpResult rp = plain.solve(p.C, p.delta, p.laws(), Fp);
    ASSERT_EQ(rr.status, gm::NlcpStatus::converged) << k << ": " << rr.message;
    ASSERT_EQ(rp.status, gm::NlcpStatus::converged) << k << ": " << rp.message;
    EXPECT_LE(kkt_residual(p, F, p.delta), rr.tolerance * (1 + 1e-6)) << k;
    EXPECT_LE((F - Fp).cwiseAbs().maxCoeff(), 1e-7 * force_scale(p)) << k;
    EXPECT_LE(rr.iterations, rp.iterations + 1) << k;
    EXPECT_LE(rp.factorizations, rp.iterations) << k;
    EXPECT_LE(rr.factorizations, rp.factorizations) << k;
    reused += rr.iterations > 0 && rr.factorizations < rr.iterations;
    chord += rr.factorizations < rr.iterations - 1;  // a second step on the tangent too
    factorizations_reuse += rr.factorizations;
    factorizations_plain += rp.factorizations;
    ++count;
    // The kept tangent is one-shot: a second solve from the same forces factorizes as the plain
    // path does.
    VectorXd again = F, again_plain = F;
    p.delta *= 1.01;
    const gm::NlcpResult second = reuse.solve(p.C, p.delta, p.laws(), again);
    EXPECT_EQ(second.factorizations, plain.solve(p.C, p.delta, p.laws(), again_plain).factorizations)
        << k;
  }
  std::printf("time steps: %d of %d took their first step on the kept tangent, %d a second one; "
              "%d factorizations (%d factorizing every step)\n",
              reused, count, chord, factorizations_reuse, factorizations_plain);
  EXPECT_GE(reused, count * 9 / 10);
  for (int k = 0; k < 60; ++k) {  // stale: the tangent of a much softer C
    const int n = 1 + k % 12;
    Problem p = random_problem(rng, n, k % 2 == 0);
    VectorXd F = VectorXd::Zero(n), sums(n);
    ASSERT_EQ(reuse.solve(p.C, p.delta, p.laws(), F).status, gm::NlcpStatus::converged);
    ASSERT_TRUE(reuse.loaded_row_sums(p.C, F, sums));
    p.C /= 5;
    const gm::NlcpResult res = reuse.solve(p.C, p.delta, p.laws(), F);
    ASSERT_EQ(res.status, gm::NlcpStatus::converged) << k << ": " << res.message;
    EXPECT_LE((F - reference_solution(p)).cwiseAbs().maxCoeff(), 1e-7 * force_scale(p)) << k;
  }
}

TEST(Nlcp, TotalForceMetToRounding) {
  // solve_total applies its last lambda correction: w^T F = total_force to ~1e-12 relative (the
  // stopping test alone leaves slope * tol, ~1e-10 of it here), the KKT residual of
  // Delta0 + lambda w still within tol. Then a time step: the tangent kept, the problem moved by
  // ~1e-3, a warm solve_total (first step on the kept tangent) agrees with a solver that
  // factorizes every step.
  std::mt19937_64 rng(67);
  gm::NlcpOptions plain_options;
  plain_options.reuse_tangent = false;
  gm::NlcpSolver solver(30), plain(30, plain_options);
  int reused = 0, updates_reuse = 0, updates_plain = 0;
  for (int k = 0; k < 100; ++k) {
    const int n = 2 + k % 29;
    Problem p = random_problem(rng, n, true);
    VectorXd w(n);
    for (int i = 0; i < n; ++i) w[i] = uniform(rng, 0.5, 1.0);
    const double total = uniform(rng, 1e2, 1e4);
    VectorXd F = VectorXd::Zero(n), sums(n);
    double lambda = 0;
    const gm::NlcpResult res = solver.solve_total(p.C, p.delta, p.laws(), w, total, F, lambda);
    ASSERT_EQ(res.status, gm::NlcpStatus::converged) << k << ": " << res.message;
    EXPECT_NEAR(w.dot(F), total, 1e-12 * total) << k;
    const VectorXd delta = p.delta + lambda * w;
    EXPECT_LE(kkt_residual(p, F, delta), res.tolerance * (1 + 1e-6)) << k;
    ASSERT_TRUE(solver.loaded_row_sums(p.C, F, sums)) << k;
    const VectorXd y = VectorXd::Random(n);
    p.C += 1e-3 * p.C.diagonal().mean() * (y * y.transpose()) / n;
    for (gm::LocalLaw& law : p.law) law.reduced_radius *= 1.001;
    for (int i = 0; i < n; ++i) p.delta[i] += 1e-3 * uniform(rng, -1e-5, 1e-5);
    VectorXd Fp = F;
    double lambda_p = lambda;
    const gm::NlcpResult rr = solver.solve_total(p.C, p.delta, p.laws(), w, total, F, lambda);
    const gm::NlcpResult rp = plain.solve_total(p.C, p.delta, p.laws(), w, total, Fp, lambda_p);
    ASSERT_EQ(rr.status, gm::NlcpStatus::converged) << k << ": " << rr.message;
    ASSERT_EQ(rp.status, gm::NlcpStatus::converged) << k << ": " << rp.message;
    EXPECT_LE((F - Fp).cwiseAbs().maxCoeff(), 1e-7 * force_scale(p)) << k;
    EXPECT_NEAR(lambda, lambda_p, 1e-7 * p.delta.cwiseAbs().maxCoeff()) << k;
    EXPECT_NEAR(w.dot(F), total, 1e-12 * total) << k;
    // the warm start is first moved by one KKT Newton step on the kept tangent (predict_total):
    // the answer still meets the stopping test at its own lambda
    EXPECT_LE(kkt_residual(p, F, p.delta + lambda * w), rr.tolerance * (1 + 1e-6)) << k;
    reused += rr.factorizations < rp.factorizations;
    updates_reuse += rr.approach_updates;
    updates_plain += rp.approach_updates;
  }
  std::printf("quasi-static time steps: %d of 100 saved a factorization on the kept tangent; "
              "%d lambda updates (%d factorizing every step)\n",
              reused, updates_reuse, updates_plain);
  EXPECT_GE(reused, 50);
}

TEST(Nlcp, SolveDoesNotAllocate) {
  // (e) n up to the capacity of 200, cold and warm, the quasi-static variant and bad input.
#ifndef GM_TEST_COUNTS_MALLOC
  GTEST_SKIP() << "malloc is not countable in this build (sanitizer or non-glibc)";
#else
  // The counter works: a known allocation is seen.
  void* (*volatile allocate)(std::size_t) = std::malloc;
  g_mallocs = 0;
  g_count_mallocs = true;
  void* probe = allocate(64);
  g_count_mallocs = false;
  std::free(probe);
  ASSERT_EQ(g_mallocs.load(), 1) << "malloc counting does not work here";

  std::mt19937_64 rng(41);
  gm::NlcpSolver solver(200);
  for (int n : {1, 7, 50, 200}) {
    const Problem p = random_problem(rng, n, n != 7);
    VectorXd F = VectorXd::Zero(n), F2 = VectorXd::Zero(n), w = VectorXd::Ones(n);
    VectorXd delta2 = p.delta * 1.001, sums(n);
    MatrixXd Cbad = p.C;
    Cbad(0, 0) = NAN;
    double lambda = 0;
    g_mallocs = 0;
    g_count_mallocs = true;
    const gm::NlcpResult cold = solver.solve(p.C, p.delta, p.laws(), F);
    const gm::NlcpResult warm = solver.solve(p.C, delta2, p.laws(), F);
    const bool tangent = solver.loaded_row_sums(p.C, F, sums);
    const gm::NlcpResult next = solver.solve(p.C, p.delta, p.laws(), F);  // on the kept tangent
    const gm::NlcpResult total = solver.solve_total(p.C, p.delta, p.laws(), w, 2e3, F2, lambda);
    const gm::NlcpResult bad = solver.solve(Cbad, p.delta, p.laws(), F2);
    g_count_mallocs = false;
    EXPECT_TRUE(tangent);
    EXPECT_EQ(next.status, gm::NlcpStatus::converged);
    EXPECT_EQ(g_mallocs.load(), 0) << "n = " << n;
    EXPECT_EQ(cold.status, gm::NlcpStatus::converged);
    EXPECT_EQ(warm.status, gm::NlcpStatus::converged);
    EXPECT_EQ(total.status, gm::NlcpStatus::converged) << total.message;
    EXPECT_EQ(bad.status, gm::NlcpStatus::bad_input);
    EXPECT_GT(cold.iterations, 0);
  }
#endif
}
