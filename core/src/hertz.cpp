#include "gearmesh/internal/hertz.hpp"

#include <cmath>
#include <limits>

namespace gm {

namespace {

constexpr double kPi = 3.14159265358979323846;

// kappa 2 (1 - nu^2)/(pi E), m^2/N: the factor of w in delta_i (docs/physics.md §4).
double body_compliance(const HertzBody& b) {
  return b.near_field * 2.0 * (1.0 - b.poisson_ratio * b.poisson_ratio) / (kPi * b.youngs_modulus);
}

}  // namespace

double reduced_radius(double rho1, double rho2) {
  const double curvature = 1.0 / rho1 + 1.0 / rho2;  // docs/physics.md §4
  return curvature > 0 && std::isfinite(curvature) ? 1.0 / curvature
                                                    : std::numeric_limits<double>::quiet_NaN();
}

double reduced_modulus(const HertzBody& body1, const HertzBody& body2) {
  // 1/E* = sum (1 - nu_i^2)/E_i (docs/physics.md §4)
  auto term = [](const HertzBody& b) {
    return (1.0 - b.poisson_ratio * b.poisson_ratio) / b.youngs_modulus;
  };
  return 1.0 / (term(body1) + term(body2));
}

double corner_near_field(double phi) {
  const double c2 = 0.5 * phi + 0.25 * std::sin(2.0 * phi), s2 = 0.5 * phi - 0.25 * std::sin(2.0 * phi);
  const double sc = 0.5 * std::sin(phi) * std::sin(phi);
  return 0.5 * kPi * c2 / (c2 * s2 - sc * sc);
}

double hertz_half_width(double line_load, double reduced_radius, double reduced_modulus) {
  return std::sqrt(4.0 * line_load * reduced_radius / (kPi * reduced_modulus));  // docs/physics.md §4
}

double hertz_body_approach(double w, double b, const HertzBody& body) {
  const double h = body.depth, nu = body.poisson_ratio;
  return body_compliance(body) * w *
         (std::asinh(h / b) - nu / (1.0 - nu) * h / (std::sqrt(h * h + b * b) + h));
}

double weber_banaschek_approach(double w, double b, const HertzBody& body) {
  const double nu = body.poisson_ratio;
  return body_compliance(body) * w * (std::log(2.0 * body.depth / b) - nu / (2.0 * (1.0 - nu)));
}

const char* local_law_error(const LocalLaw& law) {
  if (law.width == 0) return nullptr;  // no local law
  if (!(law.width > 0) || !std::isfinite(law.width)) return "slice width must be finite and > 0";
  if (!(law.reduced_radius > 0) || !std::isfinite(law.reduced_radius))
    return "reduced radius of curvature R' must be finite and > 0";
  if (!(law.corner_slope >= 0) || !std::isfinite(law.corner_slope))
    return "corner slope tan(delta) must be finite and >= 0";
  for (const HertzBody& b : law.body) {
    if (!(b.youngs_modulus > 0) || !std::isfinite(b.youngs_modulus))
      return "Young's modulus must be finite and > 0";
    if (!(b.poisson_ratio >= 0 && b.poisson_ratio < 0.5))
      return "Poisson ratio must be in [0, 0.5)";
    if (!(b.depth > 0) || !std::isfinite(b.depth)) return "depth h must be finite and > 0";
    if (!(b.near_field >= 1) || !std::isfinite(b.near_field)) return "near-field factor must be finite and >= 1";
  }
  return nullptr;
}

// Per body, with q = b_H/h and r = sqrt(1 + q^2) (so h/(sqrt(h^2 + b_H^2) + h) = 1/(r + 1) and
// r - 1 = q^2/(r + 1) without cancellation), A = asinh(1/q), k = nu/(1 - nu), a = 2(1-nu^2)/(pi E):
//   delta      = a w [A - k/(r+1)]                                               (docs/physics.md §4)
//   d delta/dw = a [A - k/(r+1) - (1 - k (r-1)/(r+1))/(2r)]
//   int_0^w delta = a w^2 [A/2 + (r+2)/(6 (r+1)^2) - k (2r+1)/(3 (r+1)^2)]
// Derivation of the integral: with x = h/b_H = 1/q, proportional to w^(-1/2), substitute
// v = w x^2/xi^2 so that int_0^w v phi(x(v)) dv = 2 w^2 x^4 int_x^inf phi(xi) xi^-5 dxi,
// phi = asinh(xi) - k (xi sqrt(1+xi^2) - xi^2). By parts, int asinh(xi) 2 xi^-5 =
// -asinh(xi)/(2 xi^4) + sqrt(1+xi^2)(2 xi^2 - 1)/(6 xi^3), and int 2 (xi sqrt(1+xi^2) - xi^2) xi^-5
// = -2 (1+xi^2)^(3/2)/(3 xi^3) + 1/xi^2; evaluated from x to inf and multiplied by x^4 these
// give A/2 + (r-1)^2 (r+2)/(6 q^4) and (r-1)^2 (2r+1)/(3 q^4), i.e. the forms above. The
// large-x limit a w^2 [ln(2x)/2 + 1/8 - k/4] matches integrating Weber-Banaschek's form term by
// term; tests compare f' with finite differences and P with adaptive quadrature of f.
// and, differentiating once more (dq/dw = q/(2w), dA/dw = -1/(2 w r), dr/dw = q^2/(2 w r)),
//   d delta/dw = a [A - (1 + k)/(2r)],   d^2 delta/dw^2 = -a (2 + (1 - k) q^2)/(4 w r^3).
LocalLawKernel local_law_kernel(const LocalLaw& law) {
  LocalLawKernel kern;
  if (!has_local_law(law)) return kern;
  kern.width = law.width;
  kern.inv_width = 1.0 / law.width;
  const HertzBody& b0 = law.body[0];
  const HertzBody& b1 = law.body[1];
  // A body's term is a_i G(h_i, k_i): bodies of one Poisson ratio read at one depth share G, so
  // they are one term with a = a_1 + a_2 (whatever their moduli and near-field factors: a tip
  // corner's two bodies differ in kappa only).
  const bool same = b0.poisson_ratio == b1.poisson_ratio && b0.depth == b1.depth;
  kern.terms = same ? 1 : 2;
  double inv_E_star = 0;  // 1/E* = sum (1 - nu_i^2)/E_i (docs/physics.md §4)
  for (int i = 0; i < 2; ++i) {
    const HertzBody& body = law.body[i];
    const int t = same ? 0 : i;
    const double term = (1.0 - body.poisson_ratio * body.poisson_ratio) / body.youngs_modulus;
    inv_E_star += term;
    kern.a[t] += body.near_field * (2.0 / kPi) * term;  // body_compliance
    kern.k[t] = body.poisson_ratio / (1.0 - body.poisson_ratio);
    kern.depth[t] = body.depth;
    kern.inv_depth[t] = 1.0 / body.depth;
  }
  kern.b2_per_load = (4.0 / kPi) * law.reduced_radius * inv_E_star;  // b_H^2 = 4 w R'/(pi E*)
  kern.corner_stiffness = law.corner_slope / inv_E_star;              // E* tan(delta)
  return kern;
}

// The law at a tip corner (hertz.hpp, corner_law). With w(b) = b^2/beta + s b,
//   f = w G(b),  f' = G + rho g1,  f'' = (rho g1 + rho^2 g2)/w + rho' g1,
// g1 = b dG/db = -1/r + k (r-1)/(r (r+1)), g2 = b dg1/db = [1/r^2 + k (1 + 2r - r^2)/(r^2 (r+1)^2)] q^2/r
// (b dr/db = q^2/r, b dA/db = -1/r), rho = (w/b) db/dw = w/(b D), D = dw/db = 2b/beta + s,
// rho' = -(s/beta)/D^3. The integral, in b: P/L = int_0^w f dw = int_0^b w(x) G(x) w'(x) dx with
// w w' = 2x^3/beta^2 + 3 s x^2/beta + s^2 x, so with x = h q
//   P/L = a h^2 [2 h^2/beta^2 I_3 + 3 s h/beta I_2 + s^2 I_1],  I_n = M_n - k N_n,
//   M_n = int_0^q x^n asinh(1/x) dx,  N_n = int_0^q x^n/(sqrt(1+x^2)+1) dx = int_0^q x^(n-2) (r-1) dx:
//   M_1 = q^2 A/2 + (r-1)/2,           N_1 = r - 1 - ln((1+r)/2)      (int sqrt(1+x^2)/x = r - asinh(1/x)),
//   M_2 = q^3 A/3 + (q r - asinh q)/6,  N_2 = (q r + asinh q)/2 - q,
//   M_3 = q^4 A/4 + (r-1)^2 (r+2)/12,   N_3 = (r-1)^2 (2r+1)/6,
// each by parts (d/dx[x^(n+1) asinh(1/x)] = (n+1) x^n asinh(1/x) - x^n/sqrt(1+x^2)); at s = 0
// 2 h^4/beta^2 I_3 is local_law_jet's w^2 [A/2 + ...] (w = b^2/beta). The pairs that cancel for
// small q are summed as series there (q < 0.01). Tests: f' and f'' against finite differences,
// P against quadrature of f, s = 0 against the flank law, the wedge's width limit.
LocalLawJet corner_law_jet(const LocalLawKernel& kern, double force, bool full) {
  LocalLawJet v;
  const double w = force * kern.inv_width, s = kern.corner_stiffness;
  const double b = 2.0 * w / (s + std::sqrt(s * s + 4.0 * w / kern.b2_per_load));  // as corner_law's
  if (!(w > 0) || !(b > 0)) {
    v.slope = std::numeric_limits<double>::infinity();  // F = 0 (or b underflows), as on a flank
    v.curvature = -v.slope;
    return v;
  }
  const CornerLaw<double> c =
      full ? corner_law<double>(w, kern.b2_per_load, s, kern.terms, kern.a, kern.k, kern.depth)
           : corner_law<double, false>(w, kern.b2_per_load, s, kern.terms, kern.a, kern.k, kern.depth);
  v.approach = c.approach;
  v.slope = c.slope * kern.inv_width;
  v.curvature = c.curvature * kern.inv_width * kern.inv_width;
  v.energy = c.energy * kern.width;
  return v;
}

LocalLawValue evaluate_local_law(const LocalLaw& law, double force) {
  const LocalLawJet j = local_law_jet(local_law_kernel(law), force);
  LocalLawValue v;
  v.approach = j.approach;
  v.slope = j.slope;
  v.energy = j.energy;
  return v;
}

double local_law_newton_slope(const LocalLaw& law, double force, double min_line_load) {
  return evaluate_local_law(law, std::fmax(force, min_line_load * law.width)).slope;
}

double local_law_energy_change(const LocalLaw& law, double force, double step) {
  if (!has_local_law(law) || step == 0) return 0;
  if (std::abs(step) <= 0.25 * force) {
    const double half = 0.5 * step, mid = force + half, off = half * std::sqrt(0.6);
    auto f = [&](double F) { return evaluate_local_law(law, F).approach; };
    return half * (5.0 * f(mid - off) + 8.0 * f(mid) + 5.0 * f(mid + off)) / 9.0;
  }
  return evaluate_local_law(law, force + step).energy - evaluate_local_law(law, force).energy;
}

}  // namespace gm
