// Tests of core/src/tooth_compliance.cpp: Weber's beam terms against Timoshenko's closed form,
// the tooth profile against ISO 21771 geometry, monotonicity over the flank, dimensional
// scaling, the run-time table against the exact model, Sainsot's foundation formula, and the
// single-pair stiffness (two teeth + the Hertz law of hertz.hpp) against ISO 6336-1's c'.
// Compliance per unit face width in m^2/N; stiffness in N/m^2 (1 N/(mm um) = 1e9 N/m^2).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "gearmesh/internal/geometry.hpp"
#include "gearmesh/internal/hertz.hpp"
#include "stiffness_iso.hpp"
#include "gearmesh/internal/tooth_compliance.hpp"
#include "test_support.hpp"

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;
constexpr double kMm = 1e-3;
constexpr double kNmmUm = 1e9;

using gm_test::spur_pair;

gm_model_params set_a() {  // docs/physics.md §1/5: 57/57 with x = 0.36139
  return spur_pair(57, 57, 2.6 * kMm, 150 * kMm, 0.36139, 0.36139, 23 * kMm);
}

gm_model_params fzg_c14() {  // docs/physics.md §1
  gm_model_params p = spur_pair(16, 24, 4.5 * kMm, 91.5 * kMm, 0.1817, 0.1715, 14 * kMm);
  p.gear[0].tip_diameter = 82.457 * kMm;
  p.gear[1].tip_diameter = 118.365 * kMm;
  return p;
}

gm_model_params helical() {  // 23/41, m_n 3 mm, beta 18 deg
  gm_model_params p = spur_pair(23, 41, 3 * kMm, 103 * kMm, 0.2, 0.1, 30 * kMm);
  p.pair.helix_angle = 18 * kDeg;
  return p;
}

gm_pair_geometry geometry_of(const gm_model_params& p) {
  gm_pair_geometry g{};
  std::string msg;
  EXPECT_EQ(gm::compute_pair_geometry(p, g, msg), GM_OK) << msg;
  return g;
}

gm::ToothSection section_of(const gm_model_params& p, int gear, gm::ToothSectionOptions o = {}) {
  const gm_pair_geometry g = geometry_of(p);
  gm::ToothSection s;
  std::string msg;
  EXPECT_EQ(gm::build_tooth_section(p, g, gear, o, s, msg), GM_OK) << msg;
  return s;
}

double inv(double a) { return std::tan(a) - a; }

// Single-pair stiffness at the operating pitch point: both teeth (tooth_compliance) plus the
// local Hertz law (secant at line load w) with each body's depth from tooth_contact_depth.
struct PairStiffness {
  double secant = 0, tangent = 0, teeth = 0, hertz = 0;
};
PairStiffness pitch_point_stiffness(const gm_model_params& p, double w) {
  const gm_pair_geometry g = geometry_of(p);
  const gm::ToothSection s1 = section_of(p, 0), s2 = section_of(p, 1);
  const double rho1 = 0.5 * g.gear[0].d_b * std::tan(g.alpha_wt);
  const double rho2 = 0.5 * g.gear[1].d_b * std::tan(g.alpha_wt);
  gm::LocalLaw law;
  law.width = 1e-3;
  law.reduced_radius = gm::reduced_radius(rho1, rho2);
  law.body[0] = {p.gear[0].youngs_modulus, p.gear[0].poisson_ratio,
                 gm::tooth_contact_depth(s1, rho1)};
  law.body[1] = {p.gear[1].youngs_modulus, p.gear[1].poisson_ratio,
                 gm::tooth_contact_depth(s2, rho2)};
  const gm::LocalLawValue v = gm::evaluate_local_law(law, w * law.width);
  PairStiffness k;
  k.teeth = gm::tooth_compliance(s1, rho1) + gm::tooth_compliance(s2, rho2);
  k.hertz = v.approach / w;
  k.secant = 1.0 / (k.teeth + k.hertz);
  k.tangent = 1.0 / (k.teeth + v.slope * law.width);
  return k;
}

}  // namespace

TEST(ToothCompliance, RectangularCantileverIsTimoshenko) {
  // Constant thickness h = 2w, length L, load F at the free end across the axis (phi = 0):
  // delta/F = L^3/(3 E' I) + L/(k G A), I = h^3/12, A = h (unit width), k = 5/6.
  const gm::BeamMaterial m = gm::plane_strain_material(206e9, 0.3);
  const double h = 4 * kMm, L = 7 * kMm, y0 = 50 * kMm;
  gm::BeamLoad load{y0 + L, y0 + L, 0.0};
  const gm::BeamCompliance c = gm::beam_compliance([&](double) { return 0.5 * h; }, y0, load, m, 3);
  const double timoshenko = L * L * L / (3 * m.E_prime * h * h * h / 12) + L / (5.0 / 6 * m.G * h);
  EXPECT_NEAR(c.bending + c.shear + c.compression, timoshenko, 1e-6 * timoshenko);
  EXPECT_NEAR(c.shear, L / (5.0 / 6 * m.G * h), 1e-12 * c.shear);
  EXPECT_EQ(c.compression, 0.0);
  // Inclined load crossing the axis below the tip (phi = 0.4, y_F = y0 + 0.8 L):
  // bending 4 cos^2 phi [(y_F - y0)^3 - (y_F - y1)^3]/(E' h^3), shear 1.2 cos^2 phi L/(G h),
  // compression sin^2 phi L/(E' h).
  load = {y0 + L, y0 + 0.8 * L, 0.4};
  const gm::BeamCompliance d = gm::beam_compliance([&](double) { return 0.5 * h; }, y0, load, m, 3);
  const double c2 = std::pow(std::cos(0.4), 2), s2 = std::pow(std::sin(0.4), 2);
  const double bend =
      4 * c2 * (std::pow(0.8 * L, 3) - std::pow(-0.2 * L, 3)) / (m.E_prime * h * h * h);
  EXPECT_NEAR(d.bending, bend, 1e-12 * bend);
  EXPECT_NEAR(d.shear, 1.2 * c2 * L / (m.G * h), 1e-12 * d.shear);
  EXPECT_NEAR(d.compression, s2 * L / (m.E_prime * h), 1e-12 * d.compression);
  // Plane strain constants.
  EXPECT_NEAR(m.E_prime, 206e9 / 0.91, 1e-3);
  EXPECT_NEAR(m.G, 206e9 / 2.6, 1e-3);
}

TEST(ToothCompliance, TaperedBeamAgainstSimpson) {
  // A wedge, 2w falling linearly to half over L: the Gauss-Legendre panels against composite
  // Simpson on 20000 intervals of the same integrands.
  const gm::BeamMaterial m = gm::plane_strain_material(206e9, 0.3);
  const double h0 = 6 * kMm, L = 6 * kMm, y0 = 70 * kMm, phi = 0.3, yF = y0 + 0.9 * L;
  auto w = [&](double y) { return 0.5 * h0 * (1 - 0.5 * (y - y0) / L); };
  const gm::BeamCompliance c = gm::beam_compliance(w, y0, {y0 + L, yF, phi}, m, 16);
  double bend = 0, inv_t = 0;
  const int n = 20000;
  for (int k = 0; k <= n; ++k) {
    const double y = y0 + L * k / n, wt = (k == 0 || k == n) ? 1 : (k % 2 ? 4 : 2);
    const double t = 2 * w(y);
    bend += wt * (yF - y) * (yF - y) / (t * t * t);
    inv_t += wt / t;
  }
  bend *= L / n / 3;
  inv_t *= L / n / 3;
  const double cc = std::cos(phi) * std::cos(phi), ss = std::sin(phi) * std::sin(phi);
  EXPECT_NEAR(c.bending, 12 * cc / m.E_prime * bend, 1e-10 * c.bending);
  EXPECT_NEAR(c.shear, 1.2 * cc / m.G * inv_t, 1e-10 * c.shear);
  EXPECT_NEAR(c.compression, ss / m.E_prime * inv_t, 1e-10 * c.compression);
}

TEST(ToothCompliance, ProfileIsTheGeneratedTooth) {
  for (const gm_model_params& p : {set_a(), fzg_c14(), helical()}) {
    const gm_pair_geometry g = geometry_of(p);
    for (int i = 0; i < 2; ++i) {
      const gm::ToothSection s = section_of(p, i);
      const gm_gear_geometry& gg = g.gear[i];
      // Root: the fillet starts on the root circle. For a spur rack the tooth's half angle there
      // is [pi/2 + 2 (h_fP* - rho_fP*) tan alpha + 2 rho_fP*/cos alpha]/z (rack tip flat's edge
      // rolled onto the gear; x cancels).
      const gm::BeamStation root = gm::tooth_fillet_station(s, 0.0);
      EXPECT_NEAR(std::hypot(root.y, root.half_thickness), 0.5 * gg.d_f, 1e-12);
      if (p.pair.helix_angle == 0) {
        const double a = p.pair.pressure_angle;
        const double theta_f =
            (0.5 * kPi + 2 * (1.25 - 0.38) * std::tan(a) + 2 * 0.38 / std::cos(a)) /
            p.gear[i].teeth;
        EXPECT_NEAR(s.foundation.root_half_angle, theta_f, 1e-14);
        EXPECT_NEAR(std::atan2(root.half_thickness, root.y), theta_f, 1e-14);
      }
      // Form circle: the fillet ends on geometry.cpp's d_Ff, where the involute starts.
      const gm::BeamStation form = gm::tooth_fillet_station(s, s.fillet_end);
      EXPECT_NEAR(std::hypot(form.y, form.half_thickness), 0.5 * gg.d_Ff, 1e-11);
      const gm::BeamStation inv0 = gm::tooth_involute_station(s, s.form_pressure_angle);
      EXPECT_NEAR(form.y, inv0.y, 1e-11);
      EXPECT_NEAR(form.half_thickness, inv0.half_thickness, 1e-11);
      // Involute: chordal half-thickness R sin(s_yt/(2R)), s_yt = d_y (s_t/d + inv alpha_t -
      // inv alpha_yt) (docs/physics.md §1), at the operating pitch and tip circles.
      for (double d_y : {gg.d_w, gg.d_a}) {
        const double a_y = std::acos(gg.d_b / d_y);
        const double s_yt = d_y * (gg.s_t / gg.d + inv(g.alpha_t) - inv(a_y));
        const gm::BeamStation st = gm::tooth_involute_station(s, a_y);
        EXPECT_NEAR(st.half_thickness, 0.5 * d_y * std::sin(s_yt / d_y), 1e-12);
        EXPECT_NEAR(std::hypot(st.y, st.half_thickness), 0.5 * d_y, 1e-12);
      }
      // The beam axis runs root to tip: y grows along both pieces (finite differences agree
      // with the analytic dy/dt).
      for (int k = 1; k < 100; ++k) {
        const double psi = s.fillet_end * k / 100.0, dpsi = 1e-6;
        const gm::BeamStation st = gm::tooth_fillet_station(s, psi);
        const double fd = (gm::tooth_fillet_station(s, psi + dpsi).y -
                           gm::tooth_fillet_station(s, psi - dpsi).y) / (2 * dpsi);
        EXPECT_GT(st.dy_dt, 0);
        EXPECT_NEAR(st.dy_dt, fd, 1e-6 * std::abs(fd) + 1e-12);
      }
      const double a_tip = std::atan2(gg.rho_a, 0.5 * gg.d_b);
      for (int k = 1; k < 100; ++k) {
        const double a = s.form_pressure_angle + (a_tip - s.form_pressure_angle) * k / 100.0;
        const double fd = (gm::tooth_involute_station(s, a + 1e-7).y -
                           gm::tooth_involute_station(s, a - 1e-7).y) / 2e-7;
        EXPECT_NEAR(gm::tooth_involute_station(s, a).dy_dt, fd, 1e-6 * fd);
      }
    }
  }
}

TEST(ToothCompliance, LoadAndDepth) {
  // At the operating pitch circle: phi = alpha_wt - eta, the load line through the contact point
  // (R sin eta, R cos eta) along (cos phi, sin phi) meets the centre line at y_F, and the depth is
  // the length of that segment.
  const gm_model_params p = set_a();
  const gm_pair_geometry g = geometry_of(p);
  const gm::ToothSection s = section_of(p, 0);
  const double R = 0.5 * g.gear[0].d_w, rho = R * std::sin(g.alpha_wt);
  const double s_yt = 2 * R * (g.gear[0].s_t / g.gear[0].d + inv(g.alpha_t) - inv(g.alpha_wt));
  const double eta = s_yt / (2 * R), phi = g.alpha_wt - eta;
  const double xc = R * std::sin(eta), yc = R * std::cos(eta);
  const gm::BeamLoad load = gm::tooth_load(s, rho);
  EXPECT_NEAR(load.angle, phi, 1e-12);
  EXPECT_NEAR(load.station, yc, 1e-12);
  const double len = xc / std::cos(phi);
  EXPECT_NEAR(load.centre_line_point, yc - len * std::sin(phi), 1e-12);
  EXPECT_NEAR(gm::tooth_contact_depth(s, rho), len, 1e-12);
  // Half the chordal thickness order of magnitude: ~ s_yt/2 / cos phi.
  EXPECT_NEAR(gm::tooth_contact_depth(s, rho), 0.5 * s_yt / std::cos(phi), 1e-3 * len);
}

TEST(ToothCompliance, IncreasesFromRootToTip) {
  // Strictly increasing over the active profile (start of active profile to tip). Below it, near
  // the base circle, the load line tilts away from the root (phi < 0, its crossing y_F above the
  // contact point) and the compliance may dip slightly as the contact rises (0.034 % for the FZG
  // C14 pinion between its form circle and rho = 1.93 mm, below its SAP at 4.47 mm): allowed
  // there up to 0.1 %.
  for (const gm_model_params& p : {set_a(), fzg_c14(), helical()}) {
    const gm_pair_geometry g = geometry_of(p);
    for (int i = 0; i < 2; ++i) {
      const gm::ToothSection s = section_of(p, i);
      const gm_gear_geometry& gg = g.gear[i];
      const double rho_sap = 0.5 * std::sqrt(gg.d_sap * gg.d_sap - gg.d_b * gg.d_b);
      ASSERT_GE(rho_sap, s.rho_min);
      double prev_exact = 0, prev_table = 0;
      for (int k = 0; k <= 400; ++k) {
        const double rho = rho_sap + (s.rho_max - rho_sap) * k / 400.0;
        const double exact = gm::tooth_compliance_exact(s, rho).total();
        const double table = gm::tooth_compliance(s, rho);
        EXPECT_GT(exact, prev_exact) << "gear " << i << " rho " << rho;
        EXPECT_GT(table, prev_table) << "gear " << i << " rho " << rho;
        prev_exact = exact;
        prev_table = table;
      }
      const double c_form = gm::tooth_compliance_exact(s, s.rho_min).total();
      for (int k = 0; k <= 100; ++k) {
        const double rho = s.rho_min + (rho_sap - s.rho_min) * k / 100.0;
        EXPECT_GT(gm::tooth_compliance_exact(s, rho).total(), (1 - 1e-3) * c_form);
        EXPECT_LT(gm::tooth_compliance_exact(s, rho).total(),
                  gm::tooth_compliance_exact(s, rho_sap).total() * (1 + 1e-12));
      }
      // And clearly: the tip is at least twice as compliant as the form circle.
      EXPECT_GT(gm::tooth_compliance(s, s.rho_max), 2 * gm::tooth_compliance(s, s.rho_min));
    }
  }
}

TEST(ToothCompliance, DimensionalScaling) {
  // Per unit face width, compliance * E is dimensionless: invariant when every length scales
  // (module, centre distance, face width, tip diameters; the default bore scales with r_f), and
  // compliance ~ 1/E at fixed nu. The depth scales with the lengths.
  for (const gm_model_params& p : {fzg_c14(), helical()}) {
    const double f = 3.7;
    gm_model_params q = p;
    q.pair.center_distance *= f;
    q.pair.normal_module *= f;
    for (gm_gear_params& gp : q.gear) {
      gp.face_width *= f;
      gp.tip_diameter *= f;
    }
    gm_model_params stiff = p;
    for (gm_gear_params& gp : stiff.gear) gp.youngs_modulus *= 2.5;
    for (int i = 0; i < 2; ++i) {
      const gm::ToothSection a = section_of(p, i), b = section_of(q, i), c = section_of(stiff, i);
      for (int k = 0; k <= 10; ++k) {
        const double rho = a.rho_min + (a.rho_max - a.rho_min) * k / 10.0;
        const double ca = gm::tooth_compliance_exact(a, rho).total();
        EXPECT_NEAR(gm::tooth_compliance_exact(b, f * rho).total(), ca, 1e-9 * ca);
        EXPECT_NEAR(gm::tooth_compliance_exact(c, rho).total() * 2.5, ca, 1e-12 * ca);
        EXPECT_NEAR(gm::tooth_compliance(b, f * rho), gm::tooth_compliance(a, rho), 1e-9 * ca);
        EXPECT_NEAR(gm::tooth_contact_depth(b, f * rho), f * gm::tooth_contact_depth(a, rho),
                    1e-12 * f * gm::tooth_contact_depth(a, rho));
      }
    }
  }
}

TEST(ToothCompliance, TableAndQuadratureAccuracy) {
  // The run-time table (64 nodes, cubic Hermite) against the exact model, and the exact model's
  // quadrature (16 panels of 8 Gauss points per piece) against 64 panels.
  double worst_table = 0, worst_quad = 0;
  for (const gm_model_params& p : {set_a(), fzg_c14(), helical()}) {
    for (int i = 0; i < 2; ++i) {
      const gm::ToothSection s = section_of(p, i);
      gm::ToothSectionOptions fine;
      fine.panels = 64;
      fine.table_points = 4;
      const gm::ToothSection r = section_of(p, i, fine);
      for (int k = 0; k <= 2000; ++k) {
        const double rho = s.rho_min + (s.rho_max - s.rho_min) * k / 2000.0;
        const double exact = gm::tooth_compliance_exact(s, rho).total();
        worst_table = std::max(worst_table, std::abs(gm::tooth_compliance(s, rho) / exact - 1));
        if (k % 50 == 0)
          worst_quad = std::max(worst_quad,
                                std::abs(gm::tooth_compliance_exact(r, rho).total() / exact - 1));
      }
      // Outside the table: clamped to its ends.
      EXPECT_EQ(gm::tooth_compliance(s, s.rho_max * 1.1), gm::tooth_compliance(s, s.rho_max));
      EXPECT_EQ(gm::tooth_compliance(s, s.rho_min - 1e-3), gm::tooth_compliance(s, s.rho_min));
    }
  }
  std::printf("[ measured ] table vs exact: max relative error %.2e; quadrature 16 vs 64 panels: "
              "%.2e\n", worst_table, worst_quad);
  EXPECT_LT(worst_table, 2e-6);
  EXPECT_LT(worst_quad, 1e-10);
}

TEST(ToothCompliance, SainsotFoundation) {
  // Sainsot, Velex, Duverger 2004 with the coefficient table retyped:
  // X* = A/th^2 + B h^2 + C h/th + D/th + E h + F, rows L, M, P, Q.
  const double A[4] = {-5.574e-5, 60.111e-5, -50.952e-5, -6.2042e-5};
  const double B[4] = {-1.9986e-3, 28.100e-3, 185.50e-3, 9.0889e-3};
  const double C[4] = {-2.3015e-4, -83.431e-4, 0.0538e-4, -4.0964e-4};
  const double D[4] = {4.7702e-3, -9.9256e-3, 53.300e-3, 7.8297e-3};
  const double E[4] = {0.0271, 0.1624, 0.2895, -0.1472};
  const double F[4] = {6.8045, 0.9086, 0.9236, 0.6904};
  const gm::FoundationGeometry fg{0.07, 0.06, 0.028};
  const double th = 0.06, h = 0.07 / 0.028;
  double X[4];
  for (int i = 0; i < 4; ++i)
    X[i] = A[i] / (th * th) + B[i] * h * h + C[i] * h / th + D[i] / th + E[i] * h + F[i];
  const gm::SainsotCoefficients k = gm::sainsot_coefficients(fg);
  EXPECT_NEAR(k.L, X[0], 1e-13);
  EXPECT_NEAR(k.M, X[1], 1e-13);
  EXPECT_NEAR(k.P, X[2], 1e-13);
  EXPECT_NEAR(k.Q, X[3], 1e-13);
  EXPECT_TRUE(k.in_fitted_range);
  const double u = 4e-3, phi = 0.3, Sf = 2 * 0.07 * 0.06, Em = 206e9;
  const double expected = std::cos(phi) * std::cos(phi) / Em *
                          (X[0] * (u / Sf) * (u / Sf) + X[1] * u / Sf +
                           X[2] * (1 + X[3] * std::tan(phi) * std::tan(phi)));
  EXPECT_NEAR(gm::sainsot_foundation_compliance(fg, k, u, phi, Em), expected, 1e-12 * expected);
  // A thin rim (h_f = 1.1) lies outside the fitted range and is flagged.
  EXPECT_FALSE(gm::sainsot_coefficients({0.07, 0.06, 0.07 / 1.1}).in_fitted_range);
  // The default bore keeps both test pairs inside it.
  for (const gm_model_params& p : {set_a(), fzg_c14()})
    for (int i = 0; i < 2; ++i) EXPECT_FALSE(section_of(p, i).foundation_extrapolated);
}

TEST(ToothCompliance, SinglePairStiffness57AgainstIso) {
  // Two teeth + Hertz (secant at 300 N/mm) at the pitch point, against ISO 6336-1's c' = 15.55
  // N/(mm um) (docs/physics.md §5). Weber-type models give 12-16 N/(mm um) for standard steel spur gears.
  const gm_model_params p = set_a();
  const gm_pair_geometry g = geometry_of(p);
  gm::IsoStiffness iso;
  std::string msg;
  ASSERT_EQ(gm::iso_stiffness(p, g, {}, iso, msg), GM_OK);
  const PairStiffness k = pitch_point_stiffness(p, 300e3);
  const double ratio = k.secant / iso.c_single;
  std::printf("[ measured ] 57/57 pitch point, 300 N/mm: teeth %.3e + Hertz %.3e m^2/N -> c = "
              "%.2f N/(mm um) (tangent %.2f); ISO c' = %.2f; ratio %.3f\n",
              k.teeth, k.hertz, k.secant / kNmmUm, k.tangent / kNmmUm, iso.c_single / kNmmUm,
              ratio);
  EXPECT_GT(ratio, 0.7);
  EXPECT_LT(ratio, 1.3);
  EXPECT_GT(k.secant / kNmmUm, 11.0);
  EXPECT_LT(k.secant / kNmmUm, 17.0);
}

TEST(ToothCompliance, SinglePairStiffnessFzgC14AgainstIso) {
  const gm_model_params p = fzg_c14();
  const gm_pair_geometry g = geometry_of(p);
  gm::IsoStiffness iso;
  std::string msg;
  ASSERT_EQ(gm::iso_stiffness(p, g, {}, iso, msg), GM_OK);
  const PairStiffness k = pitch_point_stiffness(p, 300e3);
  const double ratio = k.secant / iso.c_single;
  std::printf("[ measured ] FZG C14 pitch point, 300 N/mm: teeth %.3e + Hertz %.3e m^2/N -> c = "
              "%.2f N/(mm um) (tangent %.2f); ISO c' = %.2f; ratio %.3f\n",
              k.teeth, k.hertz, k.secant / kNmmUm, k.tangent / kNmmUm, iso.c_single / kNmmUm,
              ratio);
  EXPECT_GT(ratio, 0.7);
  EXPECT_LT(ratio, 1.3);
}

TEST(ToothCompliance, UnsupportedCasesSaySo) {
  std::string msg;
  gm::ToothSection s;
  // Internal ring.
  gm_model_params r = spur_pair(20, 60, 2 * kMm, 40 * kMm, 0.2, -0.25, 20 * kMm);
  r.pair.internal = 1;
  const gm_pair_geometry gr = geometry_of(r);
  EXPECT_EQ(gm::build_tooth_section(r, gr, 0, {}, s, msg), GM_OK) << msg;  // the pinion works
  EXPECT_EQ(gm::build_tooth_section(r, gr, 1, {}, s, msg), GM_ERR_PARAMETER);
  EXPECT_NE(msg.find("internal ring"), std::string::npos) << msg;
  EXPECT_EQ(msg.rfind("pair.internal", 0), 0u) << msg;  // names the parameter first
  // Undercut pinion: 12 teeth, x = 0.
  const gm_model_params u = spur_pair(12, 30, 2 * kMm, 42.5 * kMm, 0.0, 0.0, 20 * kMm);
  const gm_pair_geometry gu = geometry_of(u);
  ASSERT_TRUE(gu.gear[0].undercut);
  EXPECT_EQ(gm::build_tooth_section(u, gu, 0, {}, s, msg), GM_ERR_PARAMETER);
  EXPECT_NE(msg.find("undercut"), std::string::npos) << msg;
  // A bore at the root circle.
  gm::ToothSectionOptions o;
  o.bore_radius = 1.0;
  const gm_model_params a = set_a();
  EXPECT_EQ(gm::build_tooth_section(a, geometry_of(a), 0, o, s, msg), GM_ERR_PARAMETER);
  EXPECT_NE(msg.find("bore"), std::string::npos) << msg;
}
