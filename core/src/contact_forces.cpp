#include "contact_forces.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <type_traits>
#include <limits>
#include <string>

#include "model.hpp"
#include "params.hpp"

namespace gm {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// c F + f(F) = delta for delta > 0: Newton from F0 (delta/c when no start is given, an upper
// bound since f >= 0). g(F) = c F + f(F) - delta is concave and increasing, so its tangents lie
// above it: after the first step from any start every iterate is below the root and they rise
// monotonically onto it.
double solve_slice(const SliceLaw& law, double delta, double start, double tol,
                   int max_iterations, int& iterations, double& residual, double& stiffness) {
  if (law.local.width == 0) {
    stiffness = 1 / law.compliance;
    residual = 0;
    return delta / law.compliance;
  }
  double F = start > 0 ? start : delta / law.compliance;
  const LocalLawKernel kernel = local_law_kernel(law.local);
  for (int i = 0; i < max_iterations; ++i) {
    const LocalLawJet v = local_law_slope(kernel, F);
    const double g = law.compliance * F + v.approach - delta;
    const double slope = law.compliance + v.slope;
    ++iterations;
    residual = std::fabs(g);
    stiffness = 1 / slope;
    if (residual <= tol) return F;
    const double next = F - g / slope;
    F = next > 0 ? next : F * 1e-3;  // stay on the positive side, where f is defined
  }
  return F;
}

}  // namespace

bool same_law(const SliceLaw& a, const SliceLaw& b) {
  // bit for bit: twelve doubles, no padding (a law's -0.0 and 0.0 count as different laws)
  static_assert(std::is_trivially_copyable_v<SliceLaw> && sizeof(SliceLaw) == 12 * sizeof(double));
  return std::memcmp(&a, &b, sizeof(SliceLaw)) == 0;
}

ForceSolve solve_separable(const SeparableProblem& p, const SeparableAnswer& a) {
  const SliceLaw* laws = p.laws;
  const double* approach = p.approach;
  double* force = a.force;
  double* stiffness = a.stiffness;
  const int n = p.n;
  const double tol = p.tol;
  ForceSolve out;
  for (int i = 0; i < n; ++i) {
    const double start = p.warm ? force[i] : 0.0;
    force[i] = 0;
    stiffness[i] = 0;
    if (approach[i] <= 0) continue;
    // slices of an aligned spur pair repeat each other exactly: solve once
    if (i > 0 && approach[i] == approach[i - 1] && same_law(laws[i], laws[i - 1])) {
      force[i] = force[i - 1];
      stiffness[i] = stiffness[i - 1];
      continue;
    }
    double r = 0;
    force[i] = solve_slice(laws[i], approach[i], start, tol, p.max_iterations, out.iterations, r,
                           stiffness[i]);
    out.residual = std::max(out.residual, r);
  }
  out.converged = out.residual <= tol;
  if (!out.converged) {
    // a static text, built once: a char array, which nothing destroys at exit (a std::string's
    // destructor would run from exit after an importer unloaded the FMU: a crash) and no allocation
    static char text[128];
    static const bool built = std::snprintf(text, sizeof text, "a slice's force did not converge within %s iterations",
                                            GM_PARAM_NAME(solver_max_iterations)) > 0;
    out.message = built ? text : "a slice's force did not converge";
  }
  return out;
}

namespace {

// solve_separable_total over accessors base(i) (the approach at lambda = 0) and gain(i).
// warm: the first separable solve starts from force[]; chain: every later one from the last.
template <class Base, class Gain>
ForceSolve total_solve(const SeparableProblem& p, const Base& base, const Gain& gain, bool chain,
                       const SeparableAnswer& a) {
  const double* balance = p.balance;
  const int n = p.n;
  const double load = p.load;
  double* approach = a.approach;
  double* force = a.force;
  double* stiffness = a.stiffness;
  bool warm = p.warm;
  SeparableProblem plain = p;  // the separable solve at each lambda: approach[] there
  plain.approach = approach;
  ForceSolve out;
  // h(lambda) = sum b_i F_i(Delta_i + w_i lambda) - load is nondecreasing while b_i w_i >= 0
  // (friction never reverses a slice's moment); Newton with a bracket, bisection where Newton
  // leaves it.
  const auto h = [&](double lambda, double& slope) {
    for (int i = 0; i < n; ++i) approach[i] = base(i) + gain(i) * lambda;
    plain.warm = warm;
    const ForceSolve s = solve_separable(plain, a);
    warm = chain;
    out.iterations += s.iterations;
    out.residual = std::max(out.residual, s.residual);
    double sum = 0;
    slope = 0;
    for (int i = 0; i < n; ++i) {
      sum += balance[i] * force[i];
      slope += balance[i] * gain(i) * stiffness[i];
    }
    return sum - load;
  };
  // Where the next slice that the load closes starts to touch (h is flat until then).
  const auto next_touch = [&](double lambda, int direction) {
    double best = kInf;
    for (int i = 0; i < n; ++i) {
      const double w = gain(i);
      if (w * direction <= 0) continue;
      const double at = -base(i) / w;
      if ((at - lambda) * direction >= 0) best = std::min(best, std::fabs(at - lambda));
    }
    return std::isfinite(best) ? lambda + direction * best * (1 + 1e-12) + direction * 1e-15
                               : kInf;
  };
  double lambda = p.lambda_start;
  if (load == 0) {
    // No load: inside the backlash any TE balances it; report where the flanks a positive load
    // would close first touch (the unloaded TE). A wedged mesh has no such free position: the
    // solve below finds its preloaded balance.
    double first = kInf;
    for (int i = 0; i < n; ++i)
      if (gain(i) > 0) first = std::min(first, -base(i) / gain(i));
    lambda = std::isfinite(first) ? first : 0;
    double slope0 = 0;
    if (h(lambda, slope0) == 0 && slope0 == 0) {
      out.lambda = lambda;
      return out;
    }
  }
  const double load_tol = 1e-12 * std::fabs(load) + 1e-9;
  double lo = -kInf, hi = kInf, slope = 0;
  for (int it = 0; it < 200; ++it) {
    const double value = h(lambda, slope);
    if (std::fabs(value) <= load_tol) {
      out.lambda = lambda;
      out.converged = out.residual <= p.tol;
      return out;
    }
    if (value < 0) lo = lambda; else hi = lambda;
    double next;
    if (slope > 0) {
      next = lambda - value / slope;
    } else {
      next = next_touch(lambda, value < 0 ? 1 : -1);
      if (!std::isfinite(next)) {
        out.converged = false;
        out.message = "no flank can carry the load torque at this pose";
        return out;
      }
    }
    if (!(next > lo && next < hi)) {
      next = std::isfinite(lo) && std::isfinite(hi) ? 0.5 * (lo + hi) : next;
      if (!(next > lo && next < hi)) next = std::isfinite(lo) ? lo + 2 * std::fabs(lambda - lo) + 1e-9
                                                              : hi - 2 * std::fabs(hi - lambda) - 1e-9;
    }
    lambda = next;
  }
  out.lambda = lambda;
  out.converged = false;
  out.message = "the load balance did not converge";
  return out;
}

}  // namespace

ForceSolve solve_separable_total(const SeparableProblem& p, const SeparableAnswer& a) {
  const double* base = p.approach;
  const double* gain = p.gain;
  return total_solve(p, [base](int i) { return base[i]; }, [gain](int i) { return gain[i]; }, true, a);
}

ForceSolve solve_separable(const gm_model& m, gm_data& d, const ForceProblem& fp) {
  SeparableProblem p;
  p.laws = d.laws.data();
  p.approach = d.approach.data();
  p.n = fp.n;
  p.tol = m.params.solver_tolerance;
  p.max_iterations = m.params.solver_max_iterations;
  const SeparableAnswer a{d.forces.data(), d.slice_stiffness.data(), d.approach.data()};
  if (!fp.quasi) return solve_separable(p, a);
  // the balance over the candidates' own approaches and TE gains
  const ContactSlice* slices = d.slices.data();
  p.balance = d.balance.data();
  p.load = fp.load;
  p.lambda_start = fp.lambda_start;
  return total_solve(
      p, [slices](int i) { return slices[i].approach; }, [slices](int i) { return slices[i].te_gain; },
      false, a);
}

}  // namespace gm
