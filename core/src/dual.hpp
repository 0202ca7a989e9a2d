// Forward-mode automatic differentiation with one direction (docs/design.md, "Derivatives"): a dual
// number v + d eps, eps^2 = 0, usable as an Eigen scalar, for the templated evaluation path.
//
// Comparisons look at the value only, so branches (candidates, in/out of the path, clamps) take
// the same decisions as the double evaluation; floor/nearbyint/fmod are applied by the callers
// to values (val()). A max or min whose arguments can tie in value (a kink, such as the axial
// overlap of equal face widths) uses fmax/fmin below, which then take the derivative of the
// side the seed points to; std::max/std::min would take the first argument's. Templated code
// calls the maths functions unqualified after GM_AD_USING, so that double arguments reach std::
// and Dual arguments the overloads below (by ADL).
#pragma once

#include <cmath>

#include <Eigen/Core>

namespace gm {
namespace ad {

struct Dual {
  double v = 0;  // value
  double d = 0;  // derivative along the seed direction
  Dual() = default;
  Dual(double value) : v(value), d(0) {}  // NOLINT: constants mix freely into expressions
  Dual(double value, double derivative) : v(value), d(derivative) {}
  Dual& operator+=(const Dual& b) { v += b.v; d += b.d; return *this; }
  Dual& operator-=(const Dual& b) { v -= b.v; d -= b.d; return *this; }
  Dual& operator*=(const Dual& b) { d = d * b.v + v * b.d; v *= b.v; return *this; }
  Dual& operator/=(const Dual& b) { *this = Dual(v / b.v, (d * b.v - v * b.d) / (b.v * b.v)); return *this; }
};

inline Dual operator+(const Dual& a) { return a; }
inline Dual operator-(const Dual& a) { return {-a.v, -a.d}; }
inline Dual operator+(const Dual& a, const Dual& b) { return {a.v + b.v, a.d + b.d}; }
inline Dual operator-(const Dual& a, const Dual& b) { return {a.v - b.v, a.d - b.d}; }
inline Dual operator*(const Dual& a, const Dual& b) { return {a.v * b.v, a.d * b.v + a.v * b.d}; }
inline Dual operator/(const Dual& a, const Dual& b) {
  return {a.v / b.v, (a.d * b.v - a.v * b.d) / (b.v * b.v)};
}
inline Dual operator+(const Dual& a, double b) { return {a.v + b, a.d}; }
inline Dual operator+(double a, const Dual& b) { return {a + b.v, b.d}; }
inline Dual operator-(const Dual& a, double b) { return {a.v - b, a.d}; }
inline Dual operator-(double a, const Dual& b) { return {a - b.v, -b.d}; }
inline Dual operator*(const Dual& a, double b) { return {a.v * b, a.d * b}; }
inline Dual operator*(double a, const Dual& b) { return {a * b.v, a * b.d}; }
inline Dual operator/(const Dual& a, double b) { return {a.v / b, a.d / b}; }
inline Dual operator/(double a, const Dual& b) { return {a / b.v, -a * b.d / (b.v * b.v)}; }
inline Dual operator*(const Dual& a, int b) { return a * static_cast<double>(b); }
inline Dual operator*(int a, const Dual& b) { return static_cast<double>(a) * b; }

#define GM_AD_CMP(op)                                                              \
  inline bool operator op(const Dual& a, const Dual& b) { return a.v op b.v; }    \
  inline bool operator op(const Dual& a, double b) { return a.v op b; }           \
  inline bool operator op(double a, const Dual& b) { return a op b.v; }
GM_AD_CMP(<)
GM_AD_CMP(<=)
GM_AD_CMP(>)
GM_AD_CMP(>=)
GM_AD_CMP(==)
GM_AD_CMP(!=)
#undef GM_AD_CMP

inline Dual sin(const Dual& a) { return {std::sin(a.v), std::cos(a.v) * a.d}; }
inline Dual cos(const Dual& a) { return {std::cos(a.v), -std::sin(a.v) * a.d}; }
inline Dual tan(const Dual& a) {
  const double t = std::tan(a.v);
  return {t, (1 + t * t) * a.d};
}
inline Dual acos(const Dual& a) { return {std::acos(a.v), -a.d / std::sqrt(1 - a.v * a.v)}; }
inline Dual asin(const Dual& a) { return {std::asin(a.v), a.d / std::sqrt(1 - a.v * a.v)}; }
inline Dual atan(const Dual& a) { return {std::atan(a.v), a.d / (1 + a.v * a.v)}; }
inline Dual atan2(const Dual& y, const Dual& x) {
  const double r2 = x.v * x.v + y.v * y.v;
  return {std::atan2(y.v, x.v), (x.v * y.d - y.v * x.d) / r2};
}
inline Dual sqrt(const Dual& a) {
  const double s = std::sqrt(a.v);
  return {s, s > 0 ? a.d / (2 * s) : 0.0};
}
inline Dual hypot(const Dual& a, const Dual& b) {
  const double h = std::hypot(a.v, b.v);
  return {h, h > 0 ? (a.v * a.d + b.v * b.d) / h : 0.0};
}
inline Dual asinh(const Dual& a) { return {std::asinh(a.v), a.d / std::sqrt(1 + a.v * a.v)}; }
inline Dual log(const Dual& a) { return {std::log(a.v), a.d / a.v}; }
inline Dual log1p(const Dual& a) { return {std::log1p(a.v), a.d / (1 + a.v)}; }
inline Dual exp(const Dual& a) {
  const double e = std::exp(a.v);
  return {e, e * a.d};
}
inline Dual tanh(const Dual& a) {
  const double t = std::tanh(a.v);
  return {t, (1 - t * t) * a.d};
}
inline Dual fabs(const Dual& a) { return a.v < 0 ? -a : a; }
inline Dual abs(const Dual& a) { return fabs(a); }
// max and min of a tie (equal values) take the larger (smaller) derivative: the one-sided
// derivative along +seed, d/dt max(a(x + t seed), b(x + t seed)) at t = 0+, which is what a
// finite difference along the seed sees (gm_directional_derivative's rule at a kink).
inline Dual fmax(const Dual& a, const Dual& b) {
  if (a.v != b.v) return a.v < b.v ? b : a;
  return a.d < b.d ? b : a;
}
inline Dual fmin(const Dual& a, const Dual& b) {
  if (a.v != b.v) return b.v < a.v ? b : a;
  return b.d < a.d ? b : a;
}
inline bool isfinite(const Dual& a) { return std::isfinite(a.v) && std::isfinite(a.d); }
inline bool isnan(const Dual& a) { return std::isnan(a.v); }
inline bool isinf(const Dual& a) { return std::isinf(a.v); }

}  // namespace ad

using ad::Dual;

// The value of a scalar: the identity for double.
inline double val(double x) { return x; }
inline double val(const Dual& x) { return x.v; }
// Whether a term can be left out: its value and its derivative are 0 (a weight that is 0 at a
// node can still move with the seed).
inline bool vanishes(double x) { return x == 0; }
inline bool vanishes(const Dual& x) { return x.v == 0 && x.d == 0; }
// Exact identity of two scalars, derivative included (shortcuts that reuse a computation must
// not merge slices whose values agree but whose derivatives differ).
inline bool identical(double a, double b) { return a == b; }
inline bool identical(const Dual& a, const Dual& b) { return a.v == b.v && a.d == b.d; }
// The derivative part (0 for double).
inline double der(double) { return 0; }
inline double der(const Dual& x) { return x.d; }

}  // namespace gm

// Templated code: `GM_AD_USING;` at the top of a function body, then unqualified calls.
#define GM_AD_USING                                                                          \
  using std::sin;                                                                            \
  using std::cos;                                                                            \
  using std::tan;                                                                            \
  using std::acos;                                                                           \
  using std::asin;                                                                           \
  using std::atan2;                                                                          \
  using std::sqrt;                                                                           \
  using std::hypot;                                                                          \
  using std::asinh;                                                                          \
  using std::log;                                                                            \
  using std::tanh;                                                                           \
  using std::fabs;                                                                           \
  using std::fmax;                                                                           \
  using std::fmin;                                                                           \
  using std::isfinite

namespace Eigen {
template <>
struct NumTraits<gm::ad::Dual> : NumTraits<double> {
  typedef gm::ad::Dual Real;
  typedef gm::ad::Dual NonInteger;
  typedef gm::ad::Dual Nested;
  typedef gm::ad::Dual Literal;
  enum {
    IsComplex = 0,
    IsInteger = 0,
    IsSigned = 1,
    RequireInitialization = 1,
    ReadCost = 2,
    AddCost = 2,
    MulCost = 3
  };
};
template <>
struct ScalarBinaryOpTraits<gm::ad::Dual, double, internal::scalar_product_op<gm::ad::Dual, double>> {
  typedef gm::ad::Dual ReturnType;
};
template <>
struct ScalarBinaryOpTraits<double, gm::ad::Dual, internal::scalar_product_op<double, gm::ad::Dual>> {
  typedef gm::ad::Dual ReturnType;
};
}  // namespace Eigen
