// Local (surface-to-depth) compliance of one contact slice: 2-D Hertz with the approach of
// each body measured to a point at depth h_i (docs/physics.md §4; paper section 2.2, the
// non-linear term f of eq. 1, after Weber and Banaschek [16]).
//
// f(F) is the sum over both bodies of
//   delta_i = (2 w (1 - nu_i^2)/(pi E_i))
//             [asinh(h_i/b_H) - (nu_i/(1 - nu_i)) h_i/(sqrt(h_i^2 + b_H^2) + h_i)]
// with w = F/L and b_H = sqrt(4 w R'/(pi E*)). f(0) = 0; f is increasing and concave
// (f' falls from +inf at F = 0 like -ln(F)/2 and grows like sqrt(F) for b_H >> h_i), checked
// for 0 <= nu < 0.5 over b_H/h from 1e-9 to 1e3 and tested over line loads 1e-3..1e7 N/m. Its
// integral P is what the solver minimises, so P is exact too (closed form in hertz.cpp).
//
// At a tip corner the corner's own flank leaves the mate's at an angle delta (0 at the path's
// end, growing past it), and the contact's half-width b solves w = E* (b tan(delta) + pi b^2/(4R'))
// instead (the 2-D load-width relation is linear in the profile's slope: the wedge's
// w = E* b tan(delta) plus Hertz's, Johnson, Contact Mechanics, §5.2). delta = 0 gives b_H; a
// corner far past the path's end presses over b -> w/(E* tan(delta)), much narrower than b_H, and
// its local approach grows by about ln(b_H/b) (docs/physics.md §4). f stays increasing and
// concave; f, f', f'' and P have closed forms (corner_law below, derived in hertz.cpp).
#pragma once

#include <cmath>
#include <limits>

namespace gm {

// One body at a slice. T: double, or a dual number for the Jacobian (geometry-dependent depth).
template <class T>
struct HertzBodyT {
  double youngs_modulus = 0;  // E_i, Pa
  double poisson_ratio = 0;   // nu_i, 0 <= nu_i < 0.5
  T depth = 0;                // h_i, m: depth of the point the global compliance refers to
  // kappa_i >= 1: the body's near field over a half-space's (1 on a flank; a tip corner loaded
  // at its edge: corner_near_field of its angle), a factor on delta_i
  T near_field = 1.0;
};
using HertzBody = HertzBodyT<double>;

// The local law of one slice. A default LocalLaw (width 0) means "no local law": f = 0, the
// linear stiffness levels.
template <class T>
struct LocalLawT {
  T width = 0;           // L, m
  T reduced_radius = 0;  // R', m, 1/R' = 1/rho_1 + 1/rho_2; must be > 0
  T corner_slope = 0;    // tan(delta) at a tip corner, >= 0 (0: Hertz, a flank contact)
  HertzBodyT<T> body[2];
};
using LocalLaw = LocalLawT<double>;

// The value, slope and integral of f at one force.
struct LocalLawValue {
  double approach = 0;  // f(F), m
  double slope = 0;     // f'(F), m/N; +inf at F = 0
  double energy = 0;    // P(F) = int_0^F f, J
};

// R' from the radii of curvature of both flanks, m; rho < 0 for a concave (internal) flank.
// NaN unless R' > 0 (a concave flank flatter than its convex mate).
double reduced_radius(double rho1, double rho2);

// E*, Pa: 1/E* = sum (1 - nu_i^2)/E_i.
double reduced_modulus(const HertzBody& body1, const HertzBody& body2);

// Hertz half-width b_H = sqrt(4 w R'/(pi E*)), m, for line load w (N/m).
double hertz_half_width(double line_load, double reduced_radius, double reduced_modulus);

// delta_i of docs/physics.md §4 for line load w (N/m) and a given half-width b_H (m), literally
// as written there; the law below evaluates the same formula in a cancellation-free form.
double hertz_body_approach(double line_load, double half_width, const HertzBody& body);

// kappa of a body whose contact is the apex of an elastic wedge of interior angle phi (rad,
// 0 < phi <= pi), loaded normal to one of its faces, against a half-plane's: the wedge's radial
// stress field sigma_r = (A cos theta + B sin theta)/r (Timoshenko and Goodier, the wedge loaded
// at its apex) puts the work-conjugate displacement of the apex relative to depth h at kappa times
// Flamant's, kappa = (pi/2) p^T M^-1 p with M the integrals of (cos, sin)(cos, sin)^T over the
// wedge and p the load's unit direction (here normal to the face theta = 0):
// kappa = (pi/2) c2 / (c2 s2 - sc^2), c2 = phi/2 + sin(2 phi)/4, s2 = phi/2 - sin(2 phi)/4,
// sc = sin^2(phi)/2. 1 at phi = pi (a half-plane), 3.363 at pi/2.
double corner_near_field(double phi);

// Weber-Banaschek's h >> b_H limit of delta_i:
// (2 w (1 - nu^2)/(pi E)) [ln(2h/b_H) - nu/(2(1 - nu))].
double weber_banaschek_approach(double line_load, double half_width, const HertzBody& body);

// nullptr if law is usable (or is "no local law"), else a static text naming the fault.
const char* local_law_error(const LocalLaw& law);

inline bool has_local_law(const LocalLaw& law) { return law.width > 0; }

// Whether two laws are the same law (every field equal): one evaluation serves both.
inline bool same_local_law(const LocalLaw& a, const LocalLaw& b) {
  if (a.width != b.width || a.reduced_radius != b.reduced_radius || a.corner_slope != b.corner_slope)
    return false;
  for (int g = 0; g < 2; ++g)
    if (a.body[g].depth != b.body[g].depth || a.body[g].youngs_modulus != b.body[g].youngs_modulus ||
        a.body[g].poisson_ratio != b.body[g].poisson_ratio || a.body[g].near_field != b.body[g].near_field)
      return false;
  return true;
}

// f, f' and P at force F >= 0 (N). Zero for "no local law". At F = 0 (or F so small that b_H
// underflows): approach = energy = 0, slope = +inf. Through local_law_jet.
LocalLawValue evaluate_local_law(const LocalLaw& law, double force);

// The same law prepared for many evaluations (the coupled solver's inner loop): its constants
// worked out once, and both bodies merged into one term when they share nu and h (the usual case
// of two steel gears read at the same depth, a tip corner's bodies too: they differ in kappa).
struct LocalLawKernel {
  double width = 0;         // L, m; 0: no local law
  double inv_width = 0;     // 1/L, 1/m
  double b2_per_load = 0;   // b_H^2/w = 4 R'/(pi E*), m^2/(N/m)
  double corner_stiffness = 0;  // E* tan(delta), Pa: 0 on a flank (Hertz), > 0 at a tip corner
  int terms = 0;            // 0 (no law), 1 (bodies of one nu and h, merged) or 2
  double a[2] = {0, 0};     // kappa 2 (1 - nu^2)/(pi E) per term (summed over merged bodies), m^2/N
  double k[2] = {0, 0};     // nu/(1 - nu)
  double depth[2] = {0, 0};      // h, m
  double inv_depth[2] = {0, 0};  // 1/h, 1/m
};

// f, f', f'' and P at one force: what the solver needs from an iterate.
struct LocalLawJet {
  double approach = 0;   // f(F), m
  double slope = 0;      // f'(F), m/N; +inf at F = 0
  double curvature = 0;  // f''(F), m/N^2 (< 0: f is concave); -inf at F = 0
  double energy = 0;     // P(F), J
};

LocalLawKernel local_law_kernel(const LocalLaw& law);

// The law at a tip corner, per unit width: f(w) = w sum_t a_t G_t(b), its w-derivatives and
// P(w)/L = int_0^w f, with b solving w = b^2/beta + s b (beta = 4R'/(pi E*), s = E* tan(delta));
// G_t = asinh(h_t/b) - k_t h_t/(sqrt(h_t^2 + b^2) + h_t) as on a flank. Terms t: a_t (with the
// near-field factor), k_t = nu/(1 - nu), h_t. w > 0, s >= 0. T: double or a dual number.
// The closed forms are derived in hertz.cpp; s = 0 gives local_law_jet's.
template <class T>
struct CornerLaw {
  T approach = 0, slope = 0, curvature = 0, energy = 0;  // f, df/dw, d2f/dw2, int_0^w f dw
};

// Full = false: f and f' only (curvature and energy left 0), what a Newton on one slice needs.
template <class T, bool Full = true>
CornerLaw<T> corner_law(const T& w, const T& beta, const T& s, int terms, const T* a,
                        const double* k, const T* h) {
  using std::asinh;
  using std::log;
  using std::log1p;
  using std::sqrt;
  const T b = 2.0 * w / (s + sqrt(s * s + 4.0 * w / beta));  // the root, free of cancellation
  const T D = 2.0 * b / beta + s;                            // dw/db
  const T rho = w / (b * D);                                 // (w/b) db/dw: 1/2 (Hertz) .. 1 (wedge)
  const T drho = -(s / beta) / (D * D * D);                  // d rho/dw
  CornerLaw<T> v;
  for (int t = 0; t < terms; ++t) {
    const double kk = k[t];
    const T q = b / h[t], q2 = q * q, r = sqrt(1.0 + q2), r1 = r + 1.0, rm1 = q2 / r1;  // r - 1
    const T A = log(r1 / q);                                  // asinh(1/q)
    const T G = A - kk / r1;
    const T g1 = -1.0 / r + kk * rm1 / (r * r1);              // b dG/db
    v.approach += a[t] * G;
    v.slope += a[t] * (G + rho * g1);
    if constexpr (!Full) continue;
    const T g2 = (1.0 / (r * r) + kk * (2.0 * r + 1.0 - r * r) / (r * r * r1 * r1)) * q2 / r;  // b d(g1)/db
    v.curvature += a[t] * ((rho * g1 + rho * rho * g2) / w + drho * g1);
    // int_0^q x^n G(x h) dx = M_n - k N_n (hertz.cpp), with the cancelling pairs by series
    T qr_as, n2;  // q r - asinh(q), (q r + asinh(q))/2 - q
    if (q < 0.01) {
      qr_as = q2 * q * (2.0 / 3.0 - q2 * (1.0 / 5.0 - q2 * (3.0 / 28.0)));
      n2 = q2 * q * (1.0 / 6.0 - q2 * (1.0 / 40.0 - q2 / 112.0));
    } else {
      const T as = asinh(q);
      qr_as = q * r - as;
      n2 = 0.5 * (q * r + as) - q;
    }
    const T I1 = 0.5 * q2 * A + 0.5 * rm1 - kk * (rm1 - log1p(0.5 * rm1));
    const T I2 = q2 * q * A / 3.0 + qr_as / 6.0 - kk * n2;
    const T I3 = 0.25 * q2 * q2 * A + rm1 * rm1 * ((r + 2.0) / 12.0 - kk * (2.0 * r + 1.0) / 6.0);
    const T h2 = h[t] * h[t];
    v.energy += a[t] * h2 * (2.0 * h2 / (beta * beta) * I3 + 3.0 * s * h[t] / beta * I2 + s * s * I1);
  }
  v.approach *= w;
  return v;
}

// local_law_jet at a tip corner (kern.corner_stiffness > 0): corner_law, out of line; full =
// false: f and f' only (local_law_slope).
LocalLawJet corner_law_jet(const LocalLawKernel& kern, double force, bool full = true);

// f, f', f'' and P at F >= 0: the closed forms of evaluate_local_law (which calls this), with
// asinh(1/q) = ln((1 + r)/q) (log1p of the same where q >= 1, to keep full relative accuracy
// for b_H >= h). Cost per distinct body: 1 sqrt, 1 log and 2 divisions; plus 1 sqrt and 1
// division. The closed forms are derived in hertz.cpp. Inline, as is the energy change below:
// both sit in the coupled solver's innermost loops.
inline LocalLawJet local_law_jet(const LocalLawKernel& kern, double force) {
  LocalLawJet v;
  if (kern.terms == 0) return v;
  if (kern.corner_stiffness > 0) return corner_law_jet(kern, force);
  const double w = force * kern.inv_width;
  const double b = std::sqrt(w * kern.b2_per_load);
  if (!(b > 0)) {  // F = 0, or so small that b_H underflows
    v.slope = std::numeric_limits<double>::infinity();
    v.curvature = -v.slope;
    return v;
  }
  const double inv_b = 1.0 / b;
  const double inv_w = kern.b2_per_load * inv_b * inv_b;  // 1/w = (b_H^2/w)/b_H^2
  double approach_w = 0, slope_w = 0, curvature_ww = 0, energy_ww = 0;
  for (int t = 0; t < kern.terms; ++t) {
    const double a = kern.a[t], k = kern.k[t];
    const double q = b * kern.inv_depth[t], inv_q = kern.depth[t] * inv_b;
    const double r = std::sqrt(1.0 + q * q);
    const double r1 = r + 1.0;
    const double inv_r = 1.0 / r, inv_r1 = 1.0 / r1;
    // asinh(1/q) = ln((1 + r)/q); for q >= 1 (argument <= 1 + sqrt 2) as log1p of
    // (1 + r)/q - 1 = (1 + r - q)/q with r - q = 1/(r + q), free of cancellation
    const double A = q < 1.0 ? std::log(r1 * inv_q) : std::log1p((1.0 + 1.0 / (r + q)) * inv_q);
    approach_w += a * (A - k * inv_r1);
    slope_w += a * (A - 0.5 * (1.0 + k) * inv_r);
    curvature_ww -= a * (2.0 + (1.0 - k) * q * q) * 0.25 * (inv_r * inv_r * inv_r);
    energy_ww += a * (0.5 * A + ((r + 2.0) / 6.0 - k * (2.0 * r + 1.0) / 3.0) * (inv_r1 * inv_r1));
  }
  v.approach = approach_w * w;
  v.slope = slope_w * kern.inv_width;                                   // d/dF = (1/L) d/dw
  v.curvature = curvature_ww * inv_w * (kern.inv_width * kern.inv_width);
  v.energy = energy_ww * w * w * kern.width;                            // int dF = L int dw
  return v;
}


// f and f' at F >= 0 (the curvature and energy may be left 0): a Newton on one slice. The same
// as local_law_jet on a flank, without a tip corner's extra logarithms.
inline LocalLawJet local_law_slope(const LocalLawKernel& kern, double force) {
  if (kern.corner_stiffness > 0 && kern.terms != 0) return corner_law_jet(kern, force, false);
  return local_law_jet(kern, force);
}


// P(F + s) - P(F) from the jets at both ends (F >= 0, F + s >= 0): the two-point Hermite
// quadrature with f, f', f'' at both ends (exact for quintics; error s^7 |f^(6)|/100800) when
// |s| <= F/8, where its relative error is below ~1e-9 and falls like (s/F)^6; the closed-form
// difference otherwise (its cancellation costs at most ~16 ulps there). No new law evaluation.
inline double local_law_energy_change(const LocalLawKernel& kern, double force, double step,
                                      const LocalLawJet& at_force, const LocalLawJet& at_end) {
  if (kern.terms == 0 || step == 0) return 0;
  // (a force so small that b_H underflows has infinite slopes: closed form, both energies 0)
  if (std::abs(step) <= 0.125 * force && std::isfinite(at_force.curvature) &&
      std::isfinite(at_end.curvature))
    return step * (0.5 * (at_force.approach + at_end.approach) +
                   step * ((at_force.slope - at_end.slope) / 10.0 +
                           step * (at_force.curvature + at_end.curvature) / 120.0));
  return at_end.energy - at_force.energy;
}


// f, f' and the integral P(F) = int_0^F f of evaluate_local_law over a scalar type T (the
// Jacobian: dual numbers carry the derivatives along the law's geometry and the force; the closed
// forms as in local_law_jet, derived in hertz.cpp). F > 0 and a local law required.
template <class T>
struct LocalLawValueT {
  T approach = 0, slope = 0, energy = 0;
};

template <class T>
LocalLawValueT<T> local_law_value(const LocalLawT<T>& law, const T& force) {
  using std::sqrt;
  using std::asinh;
  constexpr double kPi = 3.14159265358979323846;
  const T w = force / law.width;
  double inv_E_star = 0;
  for (const auto& body : law.body)
    inv_E_star += (1.0 - body.poisson_ratio * body.poisson_ratio) / body.youngs_modulus;
  const T b = sqrt(4.0 * w * law.reduced_radius * inv_E_star / kPi);
  LocalLawValueT<T> v;
  if (law.corner_slope > 0 && b > 0) {  // a tip corner: corner_law
    T a[2], h[2];
    double k[2];
    for (int t = 0; t < 2; ++t) {
      const auto& body = law.body[t];
      a[t] = body.near_field * (2.0 * (1.0 - body.poisson_ratio * body.poisson_ratio) / (kPi * body.youngs_modulus));
      k[t] = body.poisson_ratio / (1.0 - body.poisson_ratio);
      h[t] = body.depth;
    }
    const CornerLaw<T> c = corner_law<T>(w, T(4.0 * law.reduced_radius * inv_E_star / kPi),
                                         law.corner_slope / inv_E_star, 2, a, k, h);
    v.approach = c.approach;
    v.slope = c.slope / law.width;
    v.energy = c.energy * law.width;
    return v;
  }
  // a force so small (subnormal) that b_H underflows to 0: approach and energy are 0, the slope
  // infinite, as in local_law_jet (1/q would be infinite and energy_ww w^2 = inf 0 = NaN)
  if (!(b > 0)) {
    v.slope = std::numeric_limits<double>::infinity();
    return v;
  }
  T slope_w = 0, energy_ww = 0;
  for (const auto& body : law.body) {
    const T a = body.near_field * (2.0 * (1.0 - body.poisson_ratio * body.poisson_ratio) / (kPi * body.youngs_modulus));
    const double k = body.poisson_ratio / (1.0 - body.poisson_ratio);
    const T q = b / body.depth;
    const T r = sqrt(1.0 + q * q);
    const T r1 = r + 1.0;
    const T A = asinh(1.0 / q);
    const T bracket = A - k / r1;
    v.approach += a * w * bracket;
    slope_w += a * (bracket - (1.0 - k * q * q / (r1 * r1)) / (2.0 * r));
    energy_ww += a * (0.5 * A + ((r + 2.0) / 6.0 - k * (2.0 * r + 1.0) / 3.0) / (r1 * r1));
  }
  v.slope = slope_w / law.width;
  v.energy = energy_ww * w * w * law.width;
  return v;
}

// f and f' alone (the implicit derivative of the slice forces).
template <class T>
void local_law_approach_slope(const LocalLawT<T>& law, const T& force, T& approach, T& slope) {
  const LocalLawValueT<T> v = local_law_value(law, force);
  approach = v.approach;
  slope = v.slope;
}

// f'(max(F, w_min L)) for a Newton matrix: finite, and never used in the merit function.
double local_law_newton_slope(const LocalLaw& law, double force, double min_line_load);

// P(F + s) - P(F), J, for F >= 0 and F + s >= 0, without the cancellation of the closed-form
// difference when |s| << F: 3-point Gauss-Legendre quadrature of f when |s| <= F/4 (f is smooth
// there; relative error below 1e-8 at |s| = F/4, falling like (s/F)^6), closed form otherwise.
double local_law_energy_change(const LocalLaw& law, double force, double step);

}  // namespace gm
