// Benchmark of one NLCP solve (core/src/nlcp.cpp) for n = 10..200 slices of 3 tooth pairs:
// median and interquartile range of the wall time of one solve over many repetitions, cold
// (F = 0) and warm (from the previous answer, Delta changed by ~1e-3 between calls as in a time
// step), and "step": what a level-5 evaluation does per time step, a warm solve followed by the
// tangent (loaded_row_sums), whose factorization the next warm solve takes its first Newton step
// on; each with its ratio to a baseline measured in the same run: one Eigen LLT factorization
// and solve of the full n x n matrix C + diag(f'). Prints; never asserts on time.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "gearmesh/internal/hertz.hpp"
#include "nlcp.hpp"

namespace {

using Clock = std::chrono::steady_clock;
using Eigen::MatrixXd;
using Eigen::VectorXd;

constexpr double kMm = 1e-3, kUm = 1e-6;

struct Gear {
  MatrixXd C;
  VectorXd delta;
  std::vector<gm::LocalLaw> law;
};

// n slices over 3 tooth pairs of face width b = 23 mm. Compliance: influence of slice j on
// slice i, k(y) = exp(-|y|/l)/(2 l c') with l = 5 mm, c' = 14 N/(mm um) (so that a uniform line
// load w deflects w/c'), coupled across teeth by 0.2^|tooth distance|, plus 5% on the diagonal.
// Approach: 10, 6 and -2 um on the three pairs minus a lead crowning of 10 um (about half of
// the slices carry load). Local law: R' = 10 mm, steel, depth 3 mm.
Gear make_gear(int n) {
  const double b = 23 * kMm, l = 5 * kMm, c_prime = 14e9, k0 = 1 / (2 * l * c_prime);
  const double mean_approach[3] = {10 * kUm, 6 * kUm, -2 * kUm};
  Gear g;
  g.C.resize(n, n);
  g.delta.resize(n);
  std::vector<int> tooth(n);
  std::vector<double> y(n);
  int per_tooth[3] = {n / 3, n / 3, n - 2 * (n / 3)};
  for (int i = 0, t = 0, k = 0; i < n; ++i, ++k) {
    if (k == per_tooth[t]) t++, k = 0;
    tooth[i] = t;
    y[i] = ((k + 0.5) / per_tooth[t] - 0.5) * b;
    const double u = 2 * y[i] / b;
    g.delta[i] = mean_approach[t] - 10 * kUm * u * u;
    gm::LocalLaw law;
    law.width = b / per_tooth[t];
    law.reduced_radius = 10 * kMm;
    law.body[0] = law.body[1] = {206e9, 0.3, 3 * kMm};
    g.law.push_back(law);
  }
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      g.C(i, j) = k0 * std::exp(-std::abs(y[i] - y[j]) / l) *
                      std::pow(0.2, std::abs(tooth[i] - tooth[j])) +
                  (i == j ? 0.05 * k0 : 0.0);
  return g;
}

struct Stats {
  double median, q25, q75;
};

Stats stats(std::vector<double> t) {
  std::sort(t.begin(), t.end());
  auto q = [&](double p) { return t[static_cast<size_t>(p * (t.size() - 1))]; };
  return {q(0.5), q(0.25), q(0.75)};
}

double micros(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::micro>(b - a).count();
}

}  // namespace

int main() {
  std::printf("NLCP solve, one call, wall time in us (median [q25, q75]); baseline = one LLT "
              "factorization + solve of the full n x n system\n");
  std::printf("%5s %6s %7s %26s %26s %26s %26s %9s %9s %9s %8s %8s %8s %9s\n", "n", "reps",
              "active", "baseline", "cold", "warm", "step", "cold/base", "warm/base",
              "step/base", "it cold", "it warm", "it step", "fact step");
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> jitter(-1, 1);
  volatile double sink = 0;
  for (int n : {10, 20, 50, 100, 200}) {
    const Gear g = make_gear(n);
    const int reps = 300 + 200000 / n;
    gm::NlcpSolver solver(n), stepper(n);
    // Baseline: the Newton matrix of all n unknowns at a typical load, factorized and solved.
    MatrixXd H = g.C;
    for (int i = 0; i < n; ++i)
      H(i, i) += gm::evaluate_local_law(g.law[i], 1e5 * g.law[i].width).slope;
    Eigen::LLT<MatrixXd> llt(n);
    VectorXd x(n);
    // The sequence of approaches: Delta0 with a fresh 1e-3 |Delta|_inf jitter per call.
    std::vector<VectorXd> deltas(reps, g.delta);
    const double scale = 1e-3 * g.delta.cwiseAbs().maxCoeff();
    for (VectorXd& d : deltas)
      for (int i = 0; i < n; ++i) d[i] += scale * jitter(rng);
    std::vector<double> t_base, t_cold, t_warm, t_step;
    long it_cold = 0, it_warm = 0, it_step = 0, fact_step = 0, active = 0;
    VectorXd F_cold(n), F_warm = VectorXd::Zero(n), F_step = VectorXd::Zero(n), sums(n);
    for (int r = -20; r < reps; ++r) {  // 20 warm-up calls
      const VectorXd& d = deltas[std::max(r, 0)];
      const Clock::time_point t0 = Clock::now();
      llt.compute(H);
      x.noalias() = llt.solve(d);
      const Clock::time_point t1 = Clock::now();
      F_cold.setZero();
      const gm::NlcpResult rc = solver.solve(g.C, d, g.law.data(), F_cold);
      const Clock::time_point t2 = Clock::now();
      const gm::NlcpResult rw = solver.solve(g.C, d, g.law.data(), F_warm);
      const Clock::time_point t3 = Clock::now();
      const gm::NlcpResult rs = stepper.solve(g.C, d, g.law.data(), F_step);
      const bool tangent = stepper.loaded_row_sums(g.C, F_step, sums);
      const Clock::time_point t4 = Clock::now();
      sink = sink + x[0] + F_cold[0] + F_warm[0] + sums[0];
      if (rc.status != gm::NlcpStatus::converged || rw.status != gm::NlcpStatus::converged ||
          rs.status != gm::NlcpStatus::converged || !tangent)
        std::printf("n = %d: not converged: %s %s %s\n", n, rc.message, rw.message, rs.message);
      if (r < 0) continue;
      t_base.push_back(micros(t0, t1));
      t_cold.push_back(micros(t1, t2));
      t_warm.push_back(micros(t2, t3));
      t_step.push_back(micros(t3, t4));
      it_cold += rc.iterations;
      it_warm += rw.iterations;
      it_step += rs.iterations;
      fact_step += rs.factorizations + 1;
      active += (F_cold.array() > 0).count();
    }
    const Stats b = stats(t_base), c = stats(t_cold), w = stats(t_warm), st = stats(t_step);
    auto fmt = [](char* buf, const Stats& s) {
      std::snprintf(buf, 32, "%8.2f [%7.2f, %7.2f]", s.median, s.q25, s.q75);
    };
    char sb[32], sc[32], sw[32], ss[32];
    fmt(sb, b);
    fmt(sc, c);
    fmt(sw, w);
    fmt(ss, st);
    std::printf("%5d %6d %6.0f%% %26s %26s %26s %26s %9.2f %9.2f %9.2f %8.2f %8.2f %8.2f %9.2f\n",
                n, reps, 100.0 * active / (double(reps) * n), sb, sc, sw, ss, c.median / b.median,
                w.median / b.median, st.median / b.median, double(it_cold) / reps,
                double(it_warm) / reps, double(it_step) / reps, double(fact_step) / reps);
  }
  std::printf("(checksum %g)\n", static_cast<double>(sink));  // keeps the results alive
  return 0;
}
