// Tests of core/src/geometry.cpp: the worked checks of docs/physics.md §1 and closed-form
// relations of ISO 21771 geometry. Lengths in m unless a name says mm.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "gearmesh/internal/geometry.hpp"

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;
constexpr double kMm = 1e-3;

double inv(double a) { return std::tan(a) - a; }

// A spur pair with ISO 53 profile A (1.0 / 1.25 / 0.38), unshifted, no allowances.
gm_model_params spur_pair(int z1, int z2, double m_n, double a) {
  gm_model_params p{};
  p.pair.center_distance = a;
  p.pair.normal_module = m_n;
  p.pair.pressure_angle = 20.0 * kDeg;
  p.pair.helix_angle = 0.0;
  p.pair.internal = 0;
  p.pair.rack_addendum = 1.0;
  p.pair.rack_dedendum = 1.25;
  p.pair.rack_tip_radius = 0.38;
  const int z[2] = {z1, z2};
  for (int i = 0; i < 2; ++i) {
    p.gear[i].teeth = z[i];
    p.gear[i].face_width = 23.0 * kMm;
    p.gear[i].youngs_modulus = 206e9;
    p.gear[i].poisson_ratio = 0.3;
  }
  return p;
}

// Paper set A: 57/57, m_n 2.6 mm, a 150 mm, x1 = x2 = x.
gm_model_params set_a(double x, double a = 150.0 * kMm) {
  gm_model_params p = spur_pair(57, 57, 2.6 * kMm, a);
  p.gear[0].profile_shift = p.gear[1].profile_shift = x;
  return p;
}

gm_pair_geometry geometry_ok(const gm_model_params& p) {
  gm_pair_geometry g{};
  std::string msg;
  EXPECT_EQ(gm::compute_pair_geometry(p, g, msg), GM_OK) << msg;
  EXPECT_TRUE(msg.empty());
  return g;
}

std::string geometry_error(const gm_model_params& p) {
  gm_pair_geometry g{};
  std::string msg;
  EXPECT_EQ(gm::compute_pair_geometry(p, g, msg), GM_ERR_PARAMETER);
  return msg;
}

// |actual/expected - 1| <= rel.
void expect_rel(double actual, double expected, double rel, const char* what) {
  EXPECT_LE(std::abs(actual / expected - 1.0), rel) << what << ": " << actual << " vs " << expected;
}

}  // namespace

TEST(Involute, InverseRoundTripAndEdges) {
  for (double a = 1e-3; a < 1.5; a *= 1.3)
    EXPECT_NEAR(gm::inverse_involute(gm::involute(a)), a, 1e-13) << a;  // tan a - a cancels
  EXPECT_NEAR(gm::inverse_involute(inv(20.0 * kDeg)), 20.0 * kDeg, 1e-14);
  EXPECT_EQ(gm::inverse_involute(0.0), 0.0);
  EXPECT_TRUE(std::isnan(gm::inverse_involute(-1e-3)));
  // Beyond (pi/2)^3/3 the cube-root start would lie past pi/2.
  EXPECT_NEAR(gm::involute(gm::inverse_involute(5.0)), 5.0, 1e-12);
}

TEST(Involute, OperatingPressureAngle) {
  // cos alpha = (r_b1 + r_b2)/a external, (r_b2 - r_b1)/a internal.
  EXPECT_NEAR(gm::operating_pressure_angle(0.03, 0.05, false, 0.1), std::acos(0.8), 1e-15);
  EXPECT_NEAR(gm::operating_pressure_angle(0.03, 0.05, true, 0.04), std::acos(0.5), 1e-15);
  EXPECT_TRUE(std::isnan(gm::operating_pressure_angle(0.03, 0.05, false, 0.079)));
  EXPECT_TRUE(std::isnan(gm::operating_pressure_angle(0.05, 0.03, true, 0.04)));
}

// docs/physics.md §1 worked check, 57/57 at 150 mm (values quoted to 5-6 digits: relative tolerance 1e-4).
TEST(PairGeometry, WorkedCheckSetA) {
  const gm_pair_geometry g = geometry_ok(set_a(0.36139));
  expect_rel(g.alpha_wt / kDeg, 21.8107, 1e-4, "alpha_wt");
  expect_rel(g.x_sum_zero_backlash, 0.72278, 1e-4, "x1 + x2 zero backlash");
  expect_rel(g.gear[0].d_b, 139.2624 * kMm, 1e-4, "d_b");
  expect_rel(g.p_bt, 7.67554 * kMm, 1e-4, "p_bt");
  expect_rel(g.gear[0].d_a, 155.279 * kMm, 1e-4, "d_a");
  expect_rel(g.gear[1].d_a, 155.279 * kMm, 1e-4, "d_a");
  expect_rel(g.eps_alpha, 1.6876, 1e-4, "eps_alpha");
  expect_rel(g.gear[0].d_w, 150.0 * kMm, 1e-12, "d_w = a for equal gears");
  // 2 x 0.36139 is the zero-backlash sum rounded: j_bt within 10 nm of 0 (3 nm below), the
  // tight distance within 0.1 um of a.
  EXPECT_NEAR(g.j_bt, 0.0, 1e-8);
  EXPECT_NEAR(g.a_tight, 150.0 * kMm, 1e-7);
  EXPECT_EQ(g.gear[0].undercut, 0);
  EXPECT_EQ(g.gear[0].interference, 0);
  EXPECT_EQ(g.gear[1].interference, 0);
  EXPECT_EQ(g.eps_beta, 0.0);
  // Half base angle of a tooth: s_t/d + inv alpha_t with s_t = m (pi/2 + 2 x tan alpha).
  const double s_t = 2.6 * kMm * (kPi / 2 + 2 * 0.36139 * std::tan(20 * kDeg));
  EXPECT_NEAR(g.gear[0].eta_b, s_t / (57 * 2.6 * kMm) + inv(20 * kDeg), 1e-14);
}

// docs/physics.md §1 worked check, FZG C14 with tip diameters given.
TEST(PairGeometry, WorkedCheckFzgC14) {
  gm_model_params p = spur_pair(16, 24, 4.5 * kMm, 91.5 * kMm);
  p.gear[0].profile_shift = 0.1817;
  p.gear[1].profile_shift = 0.1715;
  p.gear[0].tip_diameter = 82.457 * kMm;
  p.gear[1].tip_diameter = 118.365 * kMm;
  p.gear[0].face_width = p.gear[1].face_width = 14.0 * kMm;
  const gm_pair_geometry g = geometry_ok(p);
  expect_rel(g.eps_alpha, 1.4377, 1e-4, "eps_alpha");
  expect_rel(g.g_alpha, 19.099 * kMm, 1e-4, "g_alpha");
  EXPECT_EQ(g.gear[0].d_a, 82.457 * kMm);
  // The published shifts exceed the zero-backlash sum by 2e-5: j_bt = -0.06 um is accepted
  // (within the rounding tolerance) and reported as is.
  EXPECT_LT(g.j_bt, 0.0);
  EXPECT_GT(g.j_bt, -0.1e-6);
}

// Backlash from profile shift. Exact for spur: s_t is linear in x, so
// j_bt = 2 m_n sin(alpha_n) (x_zero - x1 - x2) (the zero-backlash sum gives j_bt = 0 exactly);
// first-order independent check from the tight distance: dj_bt/da = 2 sin alpha_wt.
TEST(PairGeometry, BacklashFromShift) {
  const gm_pair_geometry g = geometry_ok(set_a(0.35));
  const double m_n = 2.6 * kMm, alpha_n = 20 * kDeg;
  EXPECT_GT(g.j_bt, 0.0);
  EXPECT_NEAR(g.j_bt, 2 * m_n * std::sin(alpha_n) * (g.x_sum_zero_backlash - 0.70), 1e-13);
  EXPECT_NEAR(g.j_wt, g.j_bt / std::cos(g.alpha_wt), 1e-15);
  EXPECT_LT(g.a_tight, 150.0 * kMm);
  // Moving the centres apart by da opens both lines of action by da sin alpha_wt:
  // dj_bt/da = 2 sin alpha_wt. First order (2nd-order term cot^2(a_wt) da/(2a) = 1.1e-3 here):
  expect_rel(g.j_bt, 2 * (150.0 * kMm - g.a_tight) * std::sin(g.alpha_wt), 2e-3,
             "j_bt ~ 2 da sin a_wt");
  // Integrated exactly (d/da [a sin a_w - c a_w] = sin a_w, c = r_b1 + r_b2 = a cos a_w):
  const double c = g.gear[0].d_b, alpha_tight = std::acos(c / g.a_tight);
  EXPECT_NEAR(g.j_bt, 2 * ((150.0 * kMm * std::sin(g.alpha_wt) - c * g.alpha_wt) -
                           (g.a_tight * std::sin(alpha_tight) - c * alpha_tight)), 1e-13);
  // Direct: at a_tight the backlash closes.
  const gm_pair_geometry t = geometry_ok(set_a(0.35, g.a_tight));
  EXPECT_NEAR(t.j_bt, 0.0, 1e-13);
  EXPECT_NEAR(t.x_sum_zero_backlash, 0.70, 1e-10);
}

// Backlash from thickness allowances. s_t changes by E_sn/cos(beta) at d; carried to the line
// of action, dj_bt = -(E_sn1 + E_sn2) cos(alpha_t)/cos(beta)
//                  = -(E_sn1 + E_sn2) cos(alpha_n)/cos(beta_b)
// (the normal backlash change -(E_sn1 + E_sn2) cos alpha_n over cos beta_b), independent of a.
TEST(PairGeometry, BacklashFromAllowances) {
  for (double beta : {0.0, 15.0 * kDeg}) {
    gm_model_params p = set_a(0.35);
    p.pair.helix_angle = beta;
    p.pair.center_distance = (beta > 0 ? 157.0 : 150.0) * kMm;  // the helical a_d is 153.4 mm
    const gm_pair_geometry g0 = geometry_ok(p);
    p.gear[0].thickness_allowance = -40e-6;
    p.gear[1].thickness_allowance = -60e-6;
    const gm_pair_geometry g1 = geometry_ok(p);
    const double dj = g1.j_bt - g0.j_bt;
    EXPECT_NEAR(dj, 100e-6 * std::cos(g0.alpha_t) / std::cos(beta), 1e-13) << beta;
    EXPECT_NEAR(dj, 100e-6 * std::cos(20 * kDeg) / std::cos(g0.beta_b), 1e-13) << beta;
    // x_E = x + E_sn/(2 m_n tan alpha_n); the tight mesh moves closer by the same backlash.
    EXPECT_NEAR(g1.gear[0].x_E, 0.35 - 40e-6 / (2 * 2.6 * kMm * std::tan(20 * kDeg)), 1e-14);
    EXPECT_LT(g1.a_tight, g0.a_tight);
    EXPECT_EQ(g1.gear[0].d_a, g0.gear[0].d_a);  // the tip is turned, not generated
    EXPECT_LT(g1.gear[0].d_f, g0.gear[0].d_f);  // the root is cut deeper at x_E
  }
}

// Helical: m_t, alpha_t, beta_b, eps_beta, and the transverse section equals a spur pair with
// m = m_t, alpha = alpha_t and the rack heights and shifts rescaled so x m_n and h* m_n match.
TEST(PairGeometry, HelicalMatchesTransverseSpur) {
  const double beta = 20.0 * kDeg, m_n = 2.6 * kMm, alpha_n = 20 * kDeg;
  gm_model_params h = spur_pair(31, 47, m_n, 109.0 * kMm);
  h.pair.helix_angle = -beta;  // hand does not change the geometry
  h.pair.rack_tip_radius = 0.0;  // a tip round is circular only in the normal section
  h.gear[0].profile_shift = 0.3;
  h.gear[1].profile_shift = -0.1;
  h.gear[0].thickness_allowance = -50e-6;
  h.gear[0].face_width = 30 * kMm;
  h.gear[1].face_width = 25 * kMm;
  const gm_pair_geometry gh = geometry_ok(h);
  expect_rel(gh.m_t, m_n / std::cos(beta), 1e-14, "m_t");
  expect_rel(std::tan(gh.alpha_t), std::tan(alpha_n) / std::cos(beta), 1e-14, "tan alpha_t");
  expect_rel(std::sin(gh.beta_b), std::sin(beta) * std::cos(alpha_n), 1e-14, "sin beta_b");
  expect_rel(gh.eps_beta, 25 * kMm * std::sin(beta) / (kPi * m_n), 1e-14,
             "eps_beta, b = min(b1, b2)");
  expect_rel(gh.p_bn, gh.p_bt * std::cos(gh.beta_b), 1e-14, "p_bn");

  const double c = std::cos(beta);
  gm_model_params s = h;
  s.pair.helix_angle = 0.0;
  s.pair.normal_module = gh.m_t;
  s.pair.pressure_angle = gh.alpha_t;
  s.pair.rack_addendum *= c;
  s.pair.rack_dedendum *= c;
  for (auto& gp : s.gear) {
    gp.profile_shift *= c;
    gp.thickness_allowance /= c;
  }
  const gm_pair_geometry gs = geometry_ok(s);
  const double tol = 1e-12;
  expect_rel(gs.alpha_wt, gh.alpha_wt, tol, "alpha_wt");
  expect_rel(gs.p_bt, gh.p_bt, tol, "p_bt");
  expect_rel(gs.j_bt, gh.j_bt, 1e-9, "j_bt");
  expect_rel(gs.a_tight, gh.a_tight, tol, "a_tight");
  expect_rel(gs.g_alpha, gh.g_alpha, tol, "g_alpha");
  expect_rel(gs.eps_alpha, gh.eps_alpha, tol, "eps_alpha");
  expect_rel(gs.x_sum_zero_backlash, gh.x_sum_zero_backlash * c, 1e-10, "x sum scales by cos beta");
  for (int i = 0; i < 2; ++i) {
    expect_rel(gs.gear[i].d_b, gh.gear[i].d_b, tol, "d_b");
    expect_rel(gs.gear[i].d_a, gh.gear[i].d_a, tol, "d_a");
    expect_rel(gs.gear[i].d_f, gh.gear[i].d_f, tol, "d_f");
    expect_rel(gs.gear[i].d_Ff, gh.gear[i].d_Ff, tol, "d_Ff");
    expect_rel(gs.gear[i].d_sap, gh.gear[i].d_sap, tol, "d_sap");
    expect_rel(gs.gear[i].s_t, gh.gear[i].s_t, tol, "s_t");
    expect_rel(gs.gear[i].eta_b, gh.gear[i].eta_b, tol, "eta_b");
  }
  EXPECT_EQ(gs.eps_beta, 0.0);
}

// Internal pair 20/60, m 2 mm, unshifted, at a = m (|z2| - z1)/2 = 40 mm.
TEST(PairGeometry, InternalPairStandard) {
  gm_model_params p = spur_pair(20, 60, 2.0 * kMm, 40.0 * kMm);
  p.pair.internal = 1;
  const gm_pair_geometry g = geometry_ok(p);
  const double alpha = 20 * kDeg, m = 2.0 * kMm;
  EXPECT_NEAR(g.alpha_wt, alpha, 1e-12);
  EXPECT_NEAR(g.T1T2, 40 * kMm * std::sin(alpha), 1e-15);
  EXPECT_NEAR(g.a_d, 40 * kMm, 1e-15);
  EXPECT_NEAR(g.a_tight, 40 * kMm, 1e-13);
  EXPECT_NEAR(g.x_sum_zero_backlash, 0.0, 1e-10);
  EXPECT_NEAR(g.j_bt, 0.0, 1e-15);
  EXPECT_NEAR(g.gear[0].d_w, 40 * kMm, 1e-15);
  EXPECT_NEAR(g.gear[1].d_w, 120 * kMm, 1e-15);
  EXPECT_NEAR(g.gear[1].d_a, 116 * kMm, 1e-15);  // inner tip: |d| - 2 m h_aP*
  EXPECT_NEAR(g.gear[1].d_f, 125 * kMm, 1e-15);  // |d| + 2 m h_fP*
  // Textbook internal contact ratio, from the radii directly.
  const double r_b1 = 20 * kMm * std::cos(alpha), r_b2 = 60 * kMm * std::cos(alpha);
  const double r_a1 = 22 * kMm, r_a2 = 58 * kMm;
  const double eps = (std::sqrt(r_a1 * r_a1 - r_b1 * r_b1) - std::sqrt(r_a2 * r_a2 - r_b2 * r_b2) +
                      40 * kMm * std::sin(alpha)) / (kPi * m * std::cos(alpha));
  EXPECT_GT(g.eps_alpha, 1.0);
  EXPECT_NEAR(g.eps_alpha, eps, 1e-12);
  // Ring: half space angle at its base circle, pi/(2 |z2|) + inv alpha for an unshifted ring.
  EXPECT_NEAR(g.gear[1].eta_b, kPi / 120 + inv(alpha), 1e-15);
  EXPECT_NEAR(g.gear[0].eta_b, kPi / 40 + inv(alpha), 1e-15);
  // Ring form circle from the mirrored rack lies between its reference and root circles.
  EXPECT_GT(g.gear[1].d_Ff, g.gear[1].d);
  EXPECT_LT(g.gear[1].d_Ff, g.gear[1].d_f);
  EXPECT_EQ(g.gear[1].undercut, 0);
  // The ring's SAP is its outer end: r = sqrt(r_b2^2 + (T1T2 + rho_a1)^2).
  EXPECT_NEAR(g.gear[1].d_sap, 2 * std::hypot(r_b2, g.T1T2 + g.gear[0].rho_a), 1e-15);
  EXPECT_EQ(g.gear[1].interference, 0);
  // Involute interference of the pinion (KHK's internal-gear condition): the standard ring tip
  // reaches past T1 when z1/z2 < 1 - tan(alpha_a2)/tan(alpha_w); 20/60 sits just inside it.
  const double alpha_a2 = std::acos(r_b2 / r_a2);
  EXPECT_LT(20.0 / 60.0, 1 - std::tan(alpha_a2) / std::tan(g.alpha_wt));
  EXPECT_EQ(g.gear[0].interference, 1);
}

// Internal backlash signs: the ring's x > 0 thickens its teeth (signed ISO 21771 convention);
// a larger centre distance pushes the pinion into the ring and closes the backlash.
TEST(PairGeometry, InternalPairBacklash) {
  gm_model_params p = spur_pair(20, 60, 2.0 * kMm, 40.0 * kMm);
  p.pair.internal = 1;
  const double m = 2.0 * kMm, alpha = 20 * kDeg;
  p.gear[1].profile_shift = -0.2;  // thinner ring teeth
  const gm_pair_geometry g = geometry_ok(p);
  EXPECT_NEAR(g.j_bt, 2 * m * std::sin(alpha) * 0.2, 1e-13);
  EXPECT_GT(g.a_tight, 40 * kMm);
  // Internal: dj_bt/da = -2 sin alpha_w, integrated as in BacklashFromShift with c = r_b2 - r_b1.
  const double c = 0.5 * (g.gear[1].d_b - g.gear[0].d_b), alpha_tight = std::acos(c / g.a_tight);
  EXPECT_NEAR(g.j_bt, 2 * ((g.a_tight * std::sin(alpha_tight) - c * alpha_tight) -
                           (40 * kMm * std::sin(g.alpha_wt) - c * g.alpha_wt)), 1e-13);
  // At a larger distance the zero-backlash sum is negative (signed z2 < 0) and j_bt shrinks.
  p.pair.center_distance = 40.2 * kMm;
  const gm_pair_geometry h = geometry_ok(p);
  EXPECT_LT(h.x_sum_zero_backlash, 0.0);
  EXPECT_LT(h.j_bt, g.j_bt);
  EXPECT_NEAR(h.j_bt, 2 * m * std::sin(alpha) * (h.x_sum_zero_backlash + 0.2), 1e-13);
  // Unshifted ring beyond 40 mm: overlap, reported on the centre distance.
  p.gear[1].profile_shift = 0.0;
  p.pair.center_distance = 40.1 * kMm;
  EXPECT_NE(geometry_error(p).find("pair.center_distance"), std::string::npos);
}

// Undercut limit x < h_FfP/m_n - z sin^2(alpha_t)/(2 cos beta);
// h_FfP/m_n = 1.25 - 0.38 (1 - sin 20) = 0.99997, so z_min = 2 h_FfP/(m sin^2 alpha) = 17.1:
// z = 17 undercuts, z = 18 does not.
TEST(PairGeometry, Undercut) {
  gm_model_params p = spur_pair(10, 30, 2.0 * kMm, 40.0 * kMm);
  gm_pair_geometry g = geometry_ok(p);
  EXPECT_EQ(g.gear[0].undercut, 1);
  EXPECT_EQ(g.gear[0].d_Ff, g.gear[0].d_b);
  EXPECT_EQ(g.gear[0].rho_Ff, 0.0);
  EXPECT_EQ(g.gear[1].undercut, 0);
  p.gear[0].profile_shift = 0.5;  // V-zero pair: same centre distance
  p.gear[1].profile_shift = -0.5;
  g = geometry_ok(p);
  EXPECT_EQ(g.gear[0].undercut, 0);
  EXPECT_GT(g.gear[0].d_Ff, g.gear[0].d_b);
  EXPECT_EQ(g.gear[1].undercut, 0);
  EXPECT_EQ(geometry_ok(spur_pair(17, 40, 2.0 * kMm, 57.0 * kMm)).gear[0].undercut, 1);
  EXPECT_EQ(geometry_ok(spur_pair(18, 40, 2.0 * kMm, 58.0 * kMm)).gear[0].undercut, 0);
}

// Rack form circle by coordinates, independent of the roll-distance form used in geometry.cpp:
// gear centre at the origin, pitch point C = (0, r), rolling line y = r; the generating line of
// action through C rises at alpha to it, direction (cos a, sin a). The rack's straight flank ends
// h = h_FfP - x m_n below the rolling line, at P = C - (h/sin a)(cos a, sin a); r_Ff = |P|.
TEST(PairGeometry, FormCircleFromRack) {
  const gm_pair_geometry g = geometry_ok(set_a(0.35));
  const double m = 2.6 * kMm, alpha = 20 * kDeg, r = 57 * m / 2;
  const double h = m * (1.25 - 0.38 * (1 - std::sin(alpha))) - 0.35 * m;
  const double s = h / std::sin(alpha);
  EXPECT_NEAR(std::hypot(-s * std::cos(alpha), r - s * std::sin(alpha)), g.gear[0].d_Ff / 2, 1e-15);
  EXPECT_GT(g.gear[0].d_Ff, g.gear[0].d_b);
  EXPECT_LT(g.gear[0].d_Ff, g.gear[0].d_sap);  // no interference in set A
}

TEST(PairGeometryErrors, CenterDistanceBelowBaseCircles) {
  // r_b1 + r_b2 = 139.26 mm: no operating pressure angle.
  const std::string msg = geometry_error(set_a(0.35, 0.139));
  EXPECT_NE(msg.find("pair.center_distance"), std::string::npos) << msg;
  EXPECT_NE(msg.find("no operating pressure angle"), std::string::npos) << msg;
}

TEST(PairGeometryErrors, TipInsideBaseCircle) {
  gm_model_params p = set_a(0.35);
  p.gear[0].tip_diameter = 139.0 * kMm;  // d_b = 139.26 mm
  const std::string msg = geometry_error(p);
  EXPECT_NE(msg.find("gear1.tip_diameter"), std::string::npos) << msg;
}

TEST(PairGeometryErrors, NegativeBacklash) {
  const gm_pair_geometry g = geometry_ok(set_a(0.35));
  std::string msg = geometry_error(set_a(0.35, g.a_tight - 1e-6));
  EXPECT_NE(msg.find("pair.center_distance"), std::string::npos) << msg;
  EXPECT_NE(msg.find("tight-mesh distance"), std::string::npos) << msg;
  geometry_ok(set_a(0.35, g.a_tight + 1e-9));
}

TEST(PairGeometryErrors, NoPathOfContact) {
  const std::string msg = geometry_error(set_a(0.35, 0.170));
  EXPECT_NE(msg.find("pair.center_distance"), std::string::npos) << msg;
  EXPECT_NE(msg.find("path of contact"), std::string::npos) << msg;
}

TEST(PairGeometryErrors, PointedTipAndTipClearance) {
  gm_model_params p = set_a(0.35);
  p.gear[0].tip_diameter = 160.0 * kMm;  // beyond the pointed-tooth diameter (~159.5 mm)
  std::string msg = geometry_error(p);
  EXPECT_NE(msg.find("gear1.tip_diameter"), std::string::npos) << msg;
  EXPECT_NE(msg.find("point"), std::string::npos) << msg;
  p.gear[0].tip_diameter = 158.0 * kMm;  // a tooth, but its tip digs into the mate's root
  msg = geometry_error(p);
  EXPECT_NE(msg.find("gear1.tip_diameter"), std::string::npos) << msg;
  EXPECT_NE(msg.find("root circle of gear 2"), std::string::npos) << msg;
}

TEST(PairGeometryErrors, InternalRing) {
  gm_model_params p = spur_pair(20, 24, 2.0 * kMm, 4.0 * kMm);
  p.pair.internal = 1;
  std::string msg = geometry_error(p);
  EXPECT_NE(msg.find("gear2.teeth"), std::string::npos) << msg;
  // Ring tip (inner) not larger than the pinion tip.
  p = spur_pair(20, 25, 2.0 * kMm, 5.0 * kMm);
  p.pair.internal = 1;
  p.gear[0].profile_shift = 1.0;          // pinion tip 48 mm
  p.gear[1].tip_diameter = 47.5 * kMm;    // ring base circle 46.98 mm
  msg = geometry_error(p);
  EXPECT_NE(msg.find("gear2.tip_diameter"), std::string::npos) << msg;
}

TEST(PairGeometryErrors, FaceWidthsDoNotOverlap) {
  gm_model_params p = set_a(0.35);
  p.gear[1].axial_offset = 30.0 * kMm;
  const std::string msg = geometry_error(p);
  EXPECT_NE(msg.find("gear2.axial_offset"), std::string::npos) << msg;
}
