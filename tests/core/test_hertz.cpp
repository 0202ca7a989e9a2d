// Tests of core/src/hertz.cpp: the local law of docs/physics.md §4 (its worked check, the
// Weber-Banaschek limit), and f', f'', P and the solver helpers (the prepared kernel and its
// jets, the energy change from the jets at both ends) against independent numerics.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <string>

#include "dual.hpp"
#include "gearmesh/internal/hertz.hpp"

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kMm = 1e-3;

gm::HertzBody steel(double depth) { return {206e9, 0.3, depth}; }

// A slice at realistic spur gear values: 2 mm wide, R' = 10 mm, steel, depth 3 mm.
gm::LocalLaw gear_slice() {
  gm::LocalLaw law;
  law.width = 2 * kMm;
  law.reduced_radius = 10 * kMm;
  law.body[0] = steel(3 * kMm);
  law.body[1] = steel(3 * kMm);
  return law;
}

double f(const gm::LocalLaw& law, double F) { return gm::evaluate_local_law(law, F).approach; }

// Adaptive Simpson quadrature (relative tolerance tol) of fun over [a, b].
double simpson(const std::function<double(double)>& fun, double a, double b, double fa, double fm,
               double fb, double whole, double tol, int depth) {
  const double m = 0.5 * (a + b), lm = 0.5 * (a + m), rm = 0.5 * (m + b);
  const double flm = fun(lm), frm = fun(rm);
  const double left = (m - a) / 6 * (fa + 4 * flm + fm), right = (b - m) / 6 * (fm + 4 * frm + fb);
  if (depth <= 0 || std::abs(left + right - whole) <= 15 * tol)
    return left + right + (left + right - whole) / 15;
  return simpson(fun, a, m, fa, flm, fm, left, tol / 2, depth - 1) +
         simpson(fun, m, b, fm, frm, fb, right, tol / 2, depth - 1);
}

double integrate(const std::function<double(double)>& fun, double a, double b, double tol) {
  const double fa = fun(a), fm = fun(0.5 * (a + b)), fb = fun(b);
  return simpson(fun, a, b, fa, fm, fb, (b - a) / 6 * (fa + 4 * fm + fb), tol, 50);
}

}  // namespace

TEST(Hertz, PhysicsWorkedCheck) {
  // docs/physics.md §4: w = 100 N/mm, steel, b_H = 0.05 mm, h = 1 mm.
  const double w = 100.0 / kMm, b = 0.05 * kMm;
  EXPECT_NEAR(gm::hertz_body_approach(w, b, steel(1 * kMm)) / kMm, 9.7736e-4, 0.00005e-4);
  EXPECT_NEAR(gm::weber_banaschek_approach(w, b, steel(1 * kMm)) / kMm, 9.7714e-4, 0.00005e-4);

  // The same through a LocalLaw whose R' gives b_H = 0.05 mm at that line load.
  gm::LocalLaw law;
  law.width = 2 * kMm;
  law.body[0] = law.body[1] = steel(1 * kMm);
  const double E_star = gm::reduced_modulus(law.body[0], law.body[1]);
  EXPECT_NEAR(E_star, 206e9 / (2 * (1 - 0.09)), 1e-3);
  law.reduced_radius = b * b * kPi * E_star / (4 * w);  // from b_H^2 = 4 w R'/(pi E*)
  EXPECT_NEAR(gm::hertz_half_width(w, law.reduced_radius, E_star), b, 1e-18);
  EXPECT_NEAR(f(law, w * law.width) / kMm, 2 * 9.7736e-4, 0.0001e-4);
}

TEST(Hertz, LawMatchesLiteralFormula) {
  // evaluate_local_law uses the cancellation-free r-form; compare with docs/physics.md §4 as written,
  // with different bodies (materials and depths) on both sides.
  gm::LocalLaw law = gear_slice();
  law.body[1] = {110e9, 0.34, 2 * kMm};  // a bronze-like mate
  const double E_star = gm::reduced_modulus(law.body[0], law.body[1]);
  for (double w = 1e-3; w <= 1e8; w *= 3.7) {
    const double b = gm::hertz_half_width(w, law.reduced_radius, E_star);
    const double expected = gm::hertz_body_approach(w, b, law.body[0]) +
                            gm::hertz_body_approach(w, b, law.body[1]);
    EXPECT_NEAR(f(law, w * law.width), expected, 1e-13 * expected) << "w = " << w;
  }
}

TEST(Hertz, WeberBanaschekLimit) {
  // h >> b_H: asinh(h/b) = ln(2h/b) + O((b/h)^2) and 1/(r+1) = 1/2 + O((b/h)^2).
  const gm::HertzBody body = steel(3 * kMm);
  const double w = 1e5;
  for (double q : {1e-2, 1e-3, 1e-4, 1e-5}) {
    const double b = q * body.depth;
    const double exact = gm::hertz_body_approach(w, b, body);
    const double log_form = gm::weber_banaschek_approach(w, b, body);
    const double scale = 2 * w * (1 - 0.09) / (kPi * body.youngs_modulus);
    EXPECT_GT(exact, log_form);
    EXPECT_LT(exact - log_form, scale * q * q) << "b/h = " << q;  // (1/4 + k/8) q^2 < q^2
  }
  // docs/physics.md §4: the log form stops being monotone near b_H/h ~ 1 (its d/dw vanishes at
  // b/h = 2 exp(-(1 + k)/2) = 0.98 for nu = 0.3); the exact form keeps increasing.
  gm::LocalLaw law = gear_slice();
  const double E_star = gm::reduced_modulus(law.body[0], law.body[1]);
  auto wb = [&](double w) {
    return 2 * gm::weber_banaschek_approach(w, gm::hertz_half_width(w, law.reduced_radius, E_star),
                                            law.body[0]);
  };
  // Line load with b_H = 1.5 h.
  const double w15 = std::pow(1.5 * law.body[0].depth, 2) * kPi * E_star / (4 * law.reduced_radius);
  EXPECT_LT(wb(1.01 * w15), wb(w15));
  EXPECT_GT(f(law, 1.01 * w15 * law.width), f(law, w15 * law.width));
}

TEST(Hertz, SlopeMatchesFiniteDifferences) {
  const gm::LocalLaw law = gear_slice();
  for (double w = 1e-3; w <= 1e7; w *= 2.9) {
    const double F = w * law.width, dF = 1e-5 * F;
    const double fd = (f(law, F + dF) - f(law, F - dF)) / (2 * dF);
    EXPECT_NEAR(gm::evaluate_local_law(law, F).slope, fd, 1e-8 * fd) << "w = " << w;
  }
}

TEST(Hertz, EnergyMatchesQuadrature) {
  const gm::LocalLaw law = gear_slice();
  for (double w = 1e-3; w <= 1e7; w *= 4.3) {
    const double F = w * law.width;
    // int_0^F f = int_0^1 f(F t^2) 2 F t dt: smooth at 0 where f ~ F ln F.
    const double quad = integrate([&](double t) { return f(law, F * t * t) * 2 * F * t; }, 0, 1,
                                  1e-15 * F * f(law, F));
    EXPECT_NEAR(gm::evaluate_local_law(law, F).energy, quad, 1e-11 * quad) << "w = " << w;
  }
}

TEST(Hertz, MonotoneAndConcaveOverLineLoads) {
  // Line loads 1e-3..1e7 N/m, several materials, depths and radii: f > 0 increasing, f' > 0
  // decreasing (f concave), P > 0 increasing.
  for (double nu : {0.0, 0.3, 0.49})
    for (double h : {0.5 * kMm, 3 * kMm, 20 * kMm})
      for (double R : {1 * kMm, 30 * kMm}) {
        gm::LocalLaw law = gear_slice();
        law.reduced_radius = R;
        law.body[0] = {206e9, nu, h};
        law.body[1] = {70e9, 0.33, 2 * h};
        gm::LocalLawValue prev = gm::evaluate_local_law(law, 1e-3 * law.width);
        EXPECT_GT(prev.approach, 0);
        for (double w = 1e-3 * 1.02; w <= 1e7; w *= 1.02) {
          const gm::LocalLawValue v = gm::evaluate_local_law(law, w * law.width);
          const std::string where = "nu " + std::to_string(nu) + " h " + std::to_string(h) +
                                    " R " + std::to_string(R) + " w " + std::to_string(w);
          ASSERT_GT(v.approach, prev.approach) << where;
          ASSERT_GT(v.slope, 0) << where;
          ASSERT_LT(v.slope, prev.slope) << where;
          ASSERT_GT(v.energy, prev.energy);
          prev = v;
        }
      }
}

TEST(Hertz, ZeroTinyAndHugeForces) {
  const gm::LocalLaw law = gear_slice();
  const gm::LocalLawValue zero = gm::evaluate_local_law(law, 0.0);
  EXPECT_EQ(zero.approach, 0.0);
  EXPECT_EQ(zero.energy, 0.0);
  EXPECT_EQ(zero.slope, std::numeric_limits<double>::infinity());
  for (double F : {1e-300, 1e-200, 1e-30, 1e9, 1e12}) {
    const gm::LocalLawValue v = gm::evaluate_local_law(law, F);
    EXPECT_TRUE(std::isfinite(v.approach) && std::isfinite(v.slope) && std::isfinite(v.energy))
        << F;
    EXPECT_GE(v.approach, 0) << F;
    EXPECT_GT(v.slope, 0) << F;
  }
  // f' ~ -(a/L) ln(F)/2 per body as F -> 0: the slope keeps growing, without bound.
  EXPECT_GT(gm::evaluate_local_law(law, 1e-200).slope, gm::evaluate_local_law(law, 1e-30).slope);
  // The Newton floor: f' at the floor line load below it, the true slope above.
  const double floor_F = 1.0 * law.width;
  EXPECT_EQ(gm::local_law_newton_slope(law, 0.0, 1.0), gm::evaluate_local_law(law, floor_F).slope);
  EXPECT_EQ(gm::local_law_newton_slope(law, 1e3, 1.0), gm::evaluate_local_law(law, 1e3).slope);
}

// A subnormal force, so small that b_H underflows to 0: zero approach and energy, infinite slope,
// in the closed forms of the Jacobian (local_law_value) as in the jet. local_law_value's energy
// was NaN there (inf times 0), which made a level-5 elastic energy NaN (tests/fuzz/fuzz_fe_model).
TEST(Hertz, SubnormalForceIsZeroInEveryForm) {
  const gm::LocalLaw law = gear_slice();
  for (double F : {4.9406564584124654e-324, 1e-322}) {
    const gm::LocalLawValueT<double> v = gm::local_law_value(law, F);
    const gm::LocalLawValue j = gm::evaluate_local_law(law, F);
    EXPECT_EQ(v.approach, 0.0) << F;
    EXPECT_EQ(v.energy, 0.0) << F;
    EXPECT_EQ(v.slope, std::numeric_limits<double>::infinity()) << F;
    EXPECT_EQ(j.approach, 0.0) << F;
    EXPECT_EQ(j.energy, 0.0) << F;
  }
}

TEST(Hertz, NoLocalLawIsZero) {
  const gm::LocalLaw none;
  EXPECT_FALSE(gm::has_local_law(none));
  EXPECT_EQ(gm::local_law_error(none), nullptr);
  for (double F : {0.0, 1.0, 1e6}) {
    const gm::LocalLawValue v = gm::evaluate_local_law(none, F);
    EXPECT_EQ(v.approach, 0.0);
    EXPECT_EQ(v.slope, 0.0);
    EXPECT_EQ(v.energy, 0.0);
    EXPECT_EQ(gm::local_law_newton_slope(none, F, 1.0), 0.0);
    EXPECT_EQ(gm::local_law_energy_change(none, F, 1.0), 0.0);
  }
}

TEST(Hertz, EnergyChange) {
  // Against the closed-form difference where that has no cancellation (|s| >= F/1000).
  const gm::LocalLaw law = gear_slice();
  const double F = 200.0;
  const double P = gm::evaluate_local_law(law, F).energy;
  for (double s : {-0.25 * F, -0.1 * F, -1e-3 * F, 1e-3 * F, 0.1 * F, 0.25 * F, 2.0 * F, -F}) {
    const double exact = gm::evaluate_local_law(law, F + s).energy - P;
    EXPECT_NEAR(gm::local_law_energy_change(law, F, s), exact, 1e-8 * std::abs(exact)) << s;
  }
  // A tiny step: f(F) s to first order, with the second-order term f'(F) s^2/2.
  const double s = 1e-9 * F;
  const gm::LocalLawValue v = gm::evaluate_local_law(law, F);
  EXPECT_NEAR(gm::local_law_energy_change(law, F, s), v.approach * s + 0.5 * v.slope * s * s,
              1e-14 * v.approach * s);
  EXPECT_EQ(gm::local_law_energy_change(law, 0.0, 5.0), gm::evaluate_local_law(law, 5.0).energy);
}

TEST(Hertz, JetCurvatureAndMergedBodies) {
  // local_law_jet: f'' against central differences of f'; identical bodies (merged into one
  // term) against twice the literal formula of docs/physics.md §4, below and above b_H = h (the log and
  // log1p branches of asinh).
  gm::LocalLaw law = gear_slice();
  const gm::LocalLawKernel kern = gm::local_law_kernel(law);
  EXPECT_EQ(kern.terms, 1);
  const double E_star = gm::reduced_modulus(law.body[0], law.body[1]);
  bool above = false, below = false;
  for (double w = 1e-3; w <= 1e9; w *= 3.3) {
    const double F = w * law.width, dF = 1e-5 * F;
    const gm::LocalLawJet j = gm::local_law_jet(kern, F);
    const double fd = (gm::local_law_jet(kern, F + dF).slope - gm::local_law_jet(kern, F - dF).slope) /
                      (2 * dF);
    EXPECT_LT(j.curvature, 0) << "w = " << w;
    EXPECT_NEAR(j.curvature, fd, 1e-7 * std::abs(fd)) << "w = " << w;
    const double b = gm::hertz_half_width(w, law.reduced_radius, E_star);
    (b < law.body[0].depth ? below : above) = true;
    const double literal = 2 * gm::hertz_body_approach(w, b, law.body[0]);
    EXPECT_NEAR(j.approach, literal, 1e-13 * literal) << "w = " << w;
  }
  EXPECT_TRUE(above && below);
  law.body[1].depth *= 1.5;  // different depths: two terms
  EXPECT_EQ(gm::local_law_kernel(law).terms, 2);
  EXPECT_EQ(gm::local_law_kernel(gm::LocalLaw{}).terms, 0);
}

TEST(Hertz, EnergyChangeFromJets) {
  // The two-point Hermite rule (|s| <= F/8) and the closed-form difference beyond it, from the
  // jets at both ends: against the closed-form difference where that has no cancellation, and
  // against f s + f' s^2/2 for a tiny step; relative error below 1e-9 at |s| = F/8.
  gm::LocalLaw law = gear_slice();
  law.body[1] = {110e9, 0.34, 2 * kMm};
  const gm::LocalLawKernel kern = gm::local_law_kernel(law);
  for (double F : {0.2, 200.0, 2e4, 2e6}) {
    const gm::LocalLawJet at = gm::local_law_jet(kern, F);
    for (double r : {-0.125, -0.1, -0.01, -1e-3, 1e-3, 0.01, 0.1, 0.125, 0.5, 2.0, -0.5, -1.0}) {
      const double s = r * F;
      const gm::LocalLawJet end = gm::local_law_jet(kern, F + s);
      const double exact = end.energy - at.energy;
      EXPECT_NEAR(gm::local_law_energy_change(kern, F, s, at, end), exact, 1e-9 * std::abs(exact))
          << "F " << F << " s/F " << r;
      // the Gauss rule of the law-based overload agrees
      EXPECT_NEAR(gm::local_law_energy_change(kern, F, s, at, end),
                  gm::local_law_energy_change(law, F, s), 1e-9 * std::abs(exact));
    }
    const double s = 1e-9 * F;
    const double dP = gm::local_law_energy_change(kern, F, s, at, gm::local_law_jet(kern, F + s));
    EXPECT_NEAR(dP, at.approach * s + 0.5 * at.slope * s * s, 1e-14 * at.approach * s);
  }
  // From zero, and between forces so small that b_H underflows (infinite slopes): finite.
  const gm::LocalLawJet zero = gm::local_law_jet(kern, 0.0), five = gm::local_law_jet(kern, 5.0);
  EXPECT_EQ(gm::local_law_energy_change(kern, 0.0, 5.0, zero, five), five.energy);
  const gm::LocalLawJet t1 = gm::local_law_jet(kern, 1e-320), t2 = gm::local_law_jet(kern, 1.01e-320);
  EXPECT_EQ(gm::local_law_energy_change(kern, 1e-320, 0.01e-320, t1, t2), 0.0);
  const gm::LocalLawKernel none;
  EXPECT_EQ(gm::local_law_energy_change(none, 1.0, 0.1, gm::LocalLawJet{}, gm::LocalLawJet{}), 0.0);
}

TEST(Hertz, InputChecksAndReducedRadius) {
  EXPECT_NEAR(gm::reduced_radius(10 * kMm, 40 * kMm), 8 * kMm, 1e-15);
  EXPECT_NEAR(gm::reduced_radius(10 * kMm, -40 * kMm), 40.0 / 3.0 * kMm, 1e-15);  // internal flank
  EXPECT_TRUE(std::isnan(gm::reduced_radius(10 * kMm, -5 * kMm)));   // concave tighter than convex
  EXPECT_TRUE(std::isnan(gm::reduced_radius(10 * kMm, -10 * kMm)));  // conforming: R' infinite
  EXPECT_EQ(gm::local_law_error(gear_slice()), nullptr);
  auto broken = [](auto edit) {
    gm::LocalLaw law = gear_slice();
    edit(law);
    return gm::local_law_error(law);
  };
  EXPECT_NE(broken([](gm::LocalLaw& l) { l.width = -1; }), nullptr);
  EXPECT_NE(broken([](gm::LocalLaw& l) { l.width = NAN; }), nullptr);
  EXPECT_NE(broken([](gm::LocalLaw& l) { l.reduced_radius = 0; }), nullptr);
  EXPECT_NE(broken([](gm::LocalLaw& l) { l.reduced_radius = NAN; }), nullptr);
  EXPECT_NE(broken([](gm::LocalLaw& l) { l.body[1].youngs_modulus = 0; }), nullptr);
  EXPECT_NE(broken([](gm::LocalLaw& l) { l.body[0].poisson_ratio = 0.5; }), nullptr);
  EXPECT_NE(broken([](gm::LocalLaw& l) { l.body[0].poisson_ratio = -0.1; }), nullptr);
  EXPECT_NE(broken([](gm::LocalLaw& l) { l.body[1].depth = 0; }), nullptr);
  EXPECT_NE(broken([](gm::LocalLaw& l) { l.body[1].depth = INFINITY; }), nullptr);
}

// ---- a tip corner: the contact's half-width from the flanks' angle (hertz.hpp, corner_law) ----

namespace {

// gear_slice at a tip corner whose flank leaves the mate's at tan(delta) = slope; bodies of
// different depth and material, so that both terms and the un-merged kernel are exercised.
gm::LocalLaw corner_slice(double slope) {
  gm::LocalLaw law = gear_slice();
  law.body[0].near_field = 1.55;
  law.body[1] = {110e9, 0.34, 2 * kMm};
  law.corner_slope = slope;
  return law;
}

}  // namespace

TEST(Hertz, CornerLawIsTheLiteralFormulaAtItsWidth) {
  // At every line load, the corner's approach is docs/physics.md §4's delta_i summed at the
  // half-width b that solves w = E* (b tan(delta) + pi b^2/(4 R')), found here by bisection;
  // with R' -> infinity that is Johnson's wedge, b = w/(E* tan(delta)).
  for (double slope : {1e-3, 0.03, 0.3}) {
    const gm::LocalLaw law = corner_slice(slope);
    const double E_star = gm::reduced_modulus(law.body[0], law.body[1]);
    for (double w = 1e-2; w <= 1e7; w *= 7.1) {
      double lo = 0, hi = 1.0;
      for (int it = 0; it < 200; ++it) {
        const double b = 0.5 * (lo + hi);
        (E_star * (b * slope + kPi * b * b / (4 * law.reduced_radius)) < w ? lo : hi) = b;
      }
      const double b = 0.5 * (lo + hi);
      const double literal = gm::hertz_body_approach(w, b, law.body[0]) + gm::hertz_body_approach(w, b, law.body[1]);
      EXPECT_NEAR(f(law, w * law.width), literal, 1e-11 * literal) << "tan delta " << slope << ", w " << w;
    }
    gm::LocalLaw wedge = law;
    wedge.reduced_radius = 1e9;  // a flat mate: the wedge alone
    const double w = 3e4, b = w / (E_star * slope);
    const double literal = gm::hertz_body_approach(w, b, wedge.body[0]) + gm::hertz_body_approach(w, b, wedge.body[1]);
    EXPECT_NEAR(f(wedge, w * wedge.width), literal, 1e-6 * literal) << "tan delta " << slope;
  }
}

TEST(Hertz, CornerLawWithoutAngleIsTheFlanksLaw) {
  // tan(delta) -> 0: the corner's law tends to the flank's (Hertz) in every derivative and the
  // energy (its width differs from b_H by a share of about E* tan(delta) sqrt(pi R'/(4 w E*)): at
  // tan(delta) = 1e-14 below 1e-9 from w = 1 N/m); and it is more compliant at every angle (its
  // contact is narrower).
  const gm::LocalLaw flank = corner_slice(0);
  for (double w = 1.0; w <= 1e7; w *= 5.3) {
    const double F = w * flank.width;
    const gm::LocalLawJet h = gm::local_law_jet(gm::local_law_kernel(flank), F);
    const gm::LocalLawJet c = gm::local_law_jet(gm::local_law_kernel(corner_slice(1e-14)), F);
    EXPECT_NEAR(c.approach, h.approach, 1e-9 * h.approach) << "w " << w;
    EXPECT_NEAR(c.slope, h.slope, 1e-9 * h.slope) << "w " << w;
    EXPECT_NEAR(c.curvature, h.curvature, 1e-7 * std::abs(h.curvature)) << "w " << w;
    EXPECT_NEAR(c.energy, h.energy, 1e-9 * h.energy) << "w " << w;
    EXPECT_GT(f(corner_slice(0.01), F), h.approach) << "w " << w;
  }
}

TEST(Hertz, CornerLawSlopeCurvatureAndEnergy) {
  // f' and f'' against central differences, P against quadrature of f, f increasing and concave.
  for (double slope : {1e-3, 0.03, 0.3}) {
    const gm::LocalLaw law = corner_slice(slope);
    const gm::LocalLawKernel kern = gm::local_law_kernel(law);
    EXPECT_EQ(kern.terms, 2);
    double last_f = 0, last_slope = std::numeric_limits<double>::infinity();
    for (double w = 1e-2; w <= 1e7; w *= 3.7) {
      const double F = w * law.width, dF = 1e-5 * F;
      const gm::LocalLawJet j = gm::local_law_jet(kern, F);
      const double fd = (f(law, F + dF) - f(law, F - dF)) / (2 * dF);
      const double fdd = (gm::local_law_jet(kern, F + dF).slope - gm::local_law_jet(kern, F - dF).slope) / (2 * dF);
      EXPECT_NEAR(j.slope, fd, 1e-8 * fd) << "tan delta " << slope << ", w " << w;
      EXPECT_NEAR(j.curvature, fdd, 1e-6 * std::abs(fdd)) << "tan delta " << slope << ", w " << w;
      const double quad = integrate([&](double t) { return f(law, F * t * t) * 2 * F * t; }, 0, 1,
                                    1e-15 * F * j.approach);
      EXPECT_NEAR(j.energy, quad, 1e-10 * quad) << "tan delta " << slope << ", w " << w;
      EXPECT_GT(j.approach, last_f);
      EXPECT_LT(j.slope, last_slope);
      EXPECT_GT(j.slope, 0);
      last_f = j.approach;
      last_slope = j.slope;
    }
  }
}

TEST(Hertz, CornerLawOverDualNumbers) {
  // local_law_value over dual numbers: its value is the double law's, and its derivative along
  // the corner's angle and along the force are the central differences.
  using gm::ad::Dual;
  for (double slope : {1e-3, 0.03}) {
    const gm::LocalLaw law = corner_slice(slope);
    for (double w : {1e2, 3e4, 1e6}) {
      const double F = w * law.width;
      gm::LocalLawT<Dual> dl;
      dl.width = law.width;
      dl.reduced_radius = law.reduced_radius;
      dl.corner_slope = Dual(slope, 1.0);
      for (int g = 0; g < 2; ++g) {
        dl.body[g].youngs_modulus = law.body[g].youngs_modulus;
        dl.body[g].poisson_ratio = law.body[g].poisson_ratio;
        dl.body[g].depth = law.body[g].depth;
        dl.body[g].near_field = law.body[g].near_field;
      }
      const gm::LocalLawValueT<Dual> v = gm::local_law_value(dl, Dual(F, 0));
      const gm::LocalLawValue d = gm::evaluate_local_law(law, F);
      EXPECT_NEAR(v.approach.v, d.approach, 1e-12 * d.approach);
      EXPECT_NEAR(v.slope.v, d.slope, 1e-12 * d.slope);
      EXPECT_NEAR(v.energy.v, d.energy, 1e-11 * d.energy);
      const double e = 1e-6 * slope;
      gm::LocalLaw up = law, down = law;
      up.corner_slope += e;
      down.corner_slope -= e;
      const double fd = (f(up, F) - f(down, F)) / (2 * e);
      EXPECT_NEAR(v.approach.d, fd, 1e-6 * std::abs(fd)) << "tan delta " << slope << ", w " << w;
      gm::LocalLawT<Dual> fixed_angle = dl;
      fixed_angle.corner_slope = Dual(slope, 0);
      EXPECT_NEAR(gm::local_law_value(fixed_angle, Dual(F, 1.0)).approach.d, d.slope, 1e-12 * d.slope);
    }
  }
  gm::LocalLaw bad = corner_slice(-0.01);
  EXPECT_NE(gm::local_law_error(bad), nullptr);
  bad.corner_slope = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(std::string(gm::local_law_error(bad)).find("corner slope"), std::string::npos);
}
