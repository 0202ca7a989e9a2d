// Tests of the tip corner's near field (docs/physics.md §4): the wedge's factor against the
// wedge's stress field integrated independently (energy, not displacement), the layout's corner
// angles, and the blend along the flank (laws.hpp) flat at the corner and at its end, its dual
// derivative the difference quotient's.
#include <gtest/gtest.h>

#include <cmath>

#include "detection.hpp"
#include "dual.hpp"
#include "gearmesh/internal/hertz.hpp"
#include "laws.hpp"
#include "test_support.hpp"

namespace {

using gm_test::kPi;

// The apex-loaded wedge of interior angle phi, unit load normal to its face theta = 0: the radial
// field sigma_r = (A cos theta + B sin theta)/r with (A, B) from the load's balance, both by
// trapezoidal quadrature over theta; the complementary energy in the annulus b < r < h is
// ln(h/b)/(2E') times the integral of (A cos + B sin)^2, so the ratio of these integrals to the
// half-plane's (phi = pi) is the ratio of the load point's approaches.
double wedge_energy(double phi) {
  const int n = 20000;
  const double dt = phi / n;
  double m[3] = {0, 0, 0};  // integrals of cos^2, cos sin, sin^2
  for (int k = 0; k <= n; ++k) {
    const double w = (k == 0 || k == n) ? 0.5 : 1.0, t = k * dt;
    m[0] += w * std::cos(t) * std::cos(t) * dt;
    m[1] += w * std::cos(t) * std::sin(t) * dt;
    m[2] += w * std::sin(t) * std::sin(t) * dt;
  }
  // [m0 m1; m1 m2] (A, B) = (0, 1)
  const double det = m[0] * m[2] - m[1] * m[1];
  const double A = -m[1] / det, B = m[0] / det;
  double e = 0;
  for (int k = 0; k <= n; ++k) {
    const double w = (k == 0 || k == n) ? 0.5 : 1.0, t = k * dt;
    const double s = A * std::cos(t) + B * std::sin(t);
    e += w * s * s * dt;
  }
  return e;
}

}  // namespace

TEST(CornerNearField, IsTheWedgesEnergyOverTheHalfPlanes) {
  EXPECT_NEAR(gm::corner_near_field(kPi), 1.0, 1e-12);
  const double half_plane = wedge_energy(kPi);
  for (double phi : {0.5 * kPi, 0.5 * kPi + 0.35, 0.5 * kPi + 0.6, 2.5, 3.0}) {
    const double ratio = wedge_energy(phi) / half_plane;
    EXPECT_NEAR(gm::corner_near_field(phi), ratio, 1e-7 * ratio) << "phi = " << phi;
  }
  EXPECT_NEAR(gm::corner_near_field(0.5 * kPi), 3.36295, 1e-5);  // the quarter plane
}

// The interior angle at the tip corner of a tooth whose half angle at radius R is psi(R), from
// the outline itself: the tip land (towards the tooth's centre line) against the flank's chord
// from the tip radius r_a a step dr into the body (outwards for a ring, inwards otherwise).
template <class Psi>
double tip_corner_angle(double r_a, double dr, Psi psi) {
  const double p0 = psi(r_a), p1 = psi(r_a + dr);
  const double cx = r_a * std::cos(p0), cy = r_a * std::sin(p0);
  const double fx = (r_a + dr) * std::cos(p1) - cx, fy = (r_a + dr) * std::sin(p1) - cy;
  const double tx = std::sin(p0), ty = -std::cos(p0);  // along the tip circle, towards psi = 0
  return std::acos((fx * tx + fy * ty) / std::hypot(fx, fy));
}

// The layout's kappa per gear: the wedge between the tip circle and the flank, measured on the
// involute outline. An external tooth and a ring's tooth both narrow towards their tips (the
// ring's half angle pi/z - eta_b + inv alpha_R grows outwards, to its root), so both corners are
// obtuse, pi/2 + alpha_a.
TEST(CornerNearField, LayoutTakesTheTipsAngle) {
  auto inv = [](double a) { return std::tan(a) - a; };
  const gm_test::Pair P = gm_test::make_pair(gm_test::paper());
  for (int i = 0; i < 2; ++i) {
    const gm_gear_geometry& gi = P.g.gear[i];
    const double rb = 0.5 * gi.d_b, ra = 0.5 * gi.d_a;
    const double phi = tip_corner_angle(ra, -1e-7, [&](double R) { return gi.eta_b - inv(std::acos(rb / R)); });
    EXPECT_NEAR(P.L.corner_near_field[i], gm::corner_near_field(phi), 1e-4);
    EXPECT_GT(phi, 0.5 * kPi);
  }
  const gm_test::Pair R = gm_test::make_pair(gm_test::ring());
  const gm_gear_geometry& ring = R.g.gear[1];
  const double z = R.p.gear[1].teeth, rb = 0.5 * std::fabs(ring.d_b), ra = 0.5 * std::fabs(ring.d_a);
  ASSERT_GT(ra, rb);
  const double phi = tip_corner_angle(ra, 1e-7, [&](double Rr) {
    return kPi / z - ring.eta_b + inv(std::acos(rb / Rr));
  });
  EXPECT_GT(phi, 0.5 * kPi);  // obtuse: the ring's tooth is no sharper than a right angle
  EXPECT_NEAR(R.L.corner_near_field[1], gm::corner_near_field(phi), 1e-4);
  EXPECT_LT(R.L.corner_near_field[1], gm::corner_near_field(0.5 * kPi));
  // the figures docs/physics.md §4 quotes
  EXPECT_NEAR(P.L.corner_near_field[0], 1.55, 0.005);
  EXPECT_NEAR(R.L.corner_near_field[1], 2.12, 0.005);
}

// Along gear g's flank at depth h: kappa at the corner contact, the same on the flank at the tip,
// 1 beyond kCornerBlend h, falling in between with a flat start and end; the dual number's slope
// (along the roll distance and the depth) the central difference's.
TEST(CornerNearField, BlendAlongTheFlankIsSmoothAndItsSlopeExact) {
  using gm::laws_detail::corner_near_field_at;
  const gm_test::Pair P = gm_test::make_pair(gm_test::paper());
  const gm::MeshLayout& L = P.L;
  const double h = 0.5e-3, l = gm::laws_detail::kCornerBlend * h;
  for (int g = 0; g < 2; ++g) {
    gm::ContactSlice s;
    s.kind = g == 0 ? gm::kTipOfGear1 : gm::kTipOfGear2;
    const double kw = corner_near_field_at(L, g, s, h);
    EXPECT_EQ(kw, L.corner_near_field[g]);
    s.kind = gm::kFlankContact;
    // roll distance at arc length a below the tip: rho^2 = rho_a^2 - 2 r_b a
    const auto roll_at = [&](double a) {
      return std::sqrt(L.rho_tip[g] * L.rho_tip[g] - 2 * L.base_radius[g] * a);
    };
    const auto at = [&](double a) {
      gm::ContactSlice f = s;
      f.roll[g] = roll_at(a);
      return corner_near_field_at(L, g, f, h);
    };
    EXPECT_NEAR(at(0), kw, 1e-12);
    EXPECT_NEAR(at(1e-4 * l), kw, 1e-6 * (kw - 1));  // flat onto the corner
    EXPECT_NEAR(at(0.5 * l), 1 + 0.5 * (kw - 1), 1e-9);
    EXPECT_EQ(at(l * (1 + 1e-9)), 1.0);
    EXPECT_NEAR(at(l * (1 - 1e-4)), 1.0, 1e-6 * (kw - 1));  // flat at the end
    double last = kw;
    for (int k = 1; k <= 20; ++k) {
      const double kappa = at(l * k / 20.0);
      EXPECT_LT(kappa, last);
      last = kappa;
    }
    for (double a : {0.1 * l, 0.4 * l, 0.8 * l}) {
      const double rho = roll_at(a), e = 1e-9;
      for (int along = 0; along < 2; ++along) {  // the roll distance, then the depth
        gm::ContactSliceT<gm::Dual> d;
        d.kind = gm::kFlankContact;
        d.roll[g] = gm::Dual(rho, along == 0 ? 1.0 : 0.0);
        const gm::Dual k = corner_near_field_at(L, g, d, gm::Dual(h, along == 1 ? 1.0 : 0.0));
        gm::ContactSlice up = s, down = s;
        up.roll[g] = rho + (along == 0 ? e : 0);
        down.roll[g] = rho - (along == 0 ? e : 0);
        const double hu = h + (along == 1 ? e : 0), hd = h - (along == 1 ? e : 0);
        const double fd = (corner_near_field_at(L, g, up, hu) - corner_near_field_at(L, g, down, hd)) / (2 * e);
        EXPECT_NEAR(k.d, fd, 1e-5 * std::fabs(fd)) << "gear " << g + 1 << ", a/l = " << a / l << ", along " << along;
        EXPECT_GT(k.d, 0);  // kappa grows towards the tip (rho grows) and with the depth
      }
    }
  }
}

// A tip corner's slope (detection's corner_slope, the local law's contact width, docs/physics.md
// §4): the angle between the mate's flank (the slice's normal) and the corner's own flank, the
// latter's tangent taken here by differences of the involute's polar form theta(R) = theta_P
// +- (inv alpha(R) - inv alpha_a) through the corner point (the sign: the branch nearer the
// mate's flank, the other is the tooth's other side); then the onset's rounding. The 21/62 ring,
// whose corners carry far past the path's ends, and set A, over a pitch at a large approach.
TEST(CornerNearField, CornerSlopeIsTheFlanksAngle) {
  auto inv = [](double a) { return std::tan(a) - a; };
  for (const gm_model_params& base : {gm_test::ring(), gm_test::paper()}) {
    const gm_test::Pair P = gm_test::make_pair(base);
    const gm::MeshLayout& L = P.L;
    std::vector<gm::ContactSlice> slices(512);
    int corners = 0;
    double largest = 0;
    for (int pose = 0; pose < 40; ++pose) {
      gm_kinematics k{};
      k.phi[0] = 2 * kPi / P.p.gear[0].teeth * pose / 40;
      k.phi[1] = gm_test::phi2_for(L, 30e-6, k.phi[0]);
      std::string msg;
      const int n = gm::detect_contacts(L, k, slices.data(), int(slices.size()), msg);
      ASSERT_GE(n, 0) << msg;
      for (int i = 0; i < n; ++i) {
        const gm::ContactSlice& s = slices[std::size_t(i)];
        if (s.kind == gm::kFlankContact) {
          EXPECT_EQ(s.corner_slope, 0.0);
          continue;
        }
        const int g = s.kind == gm::kTipOfGear1 ? 0 : 1;
        const double cx = g == 0 ? 0.0 : L.center_distance;
        const double dx = s.point.x() - cx, dy = s.point.y(), R = std::hypot(dx, dy);
        const double rb = L.base_radius[g], theta = std::atan2(dy, dx);
        const double e = 1e-5 * R;  // central differences (the polar form runs on past the tip)
        const double m[2] = {s.normal.x(), s.normal.y()};
        double best = 1e300;
        for (const double side : {1.0, -1.0}) {
          auto at = [&](double Rr, double& x, double& y) {
            const double th = theta + side * (inv(std::acos(rb / Rr)) - inv(std::acos(rb / R)));
            x = Rr * std::cos(th);
            y = Rr * std::sin(th);
          };
          double x1, y1, x2, y2;
          at(R + e, x1, y1);
          at(R - e, x2, y2);
          const double tx = x1 - x2, ty = y1 - y2;
          // the flank's tangent against the mate's normal: delta from perpendicular
          const double cosang = std::fabs(tx * m[0] + ty * m[1]) / std::hypot(tx, ty);
          best = std::min(best, std::tan(std::asin(std::min(1.0, cosang))));
        }
        const double want = best < gm::kCornerSlopeOnset ? best * best / (2 * gm::kCornerSlopeOnset)
                                                         : best - 0.5 * gm::kCornerSlopeOnset;
        EXPECT_NEAR(s.corner_slope, want, 1e-7 * best + 1e-10) << "pose " << pose << ", gear " << g + 1;
        ++corners;
        largest = std::max(largest, best);
      }
    }
    std::printf("  %s: %d corner slices, tan(delta) up to %.3f\n", L.sign < 0 ? "ring" : "set A", corners, largest);
    EXPECT_GT(corners, 10);
    EXPECT_GT(largest, 2 * gm::kCornerSlopeOnset);
  }
}
