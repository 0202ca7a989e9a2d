// Tests of core/src/microgeometry.cpp: every design modification against its closed form
// (formulas in microgeometry.hpp, docs/physics.md §2), superposition, the measured deviation
// grid (bilinear, edge hold, sign), pitch deviations (cumulative sums, closure), the deviation
// file parser's errors and a fuzz of the example file. Lengths in m unless a name says mm/um.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "microgeometry.hpp"
#include "params.hpp"

namespace {

constexpr double kMm = 1e-3;
constexpr double kUm = 1e-6;

// Paper set A gear (57 teeth, x 0.35, a 150 mm): active profile 21.4558 .. 34.2754 mm, b 23 mm.
const gm::ActiveFlank kSetA{21.4558 * kMm, 34.2754 * kMm, 23.0 * kMm};
// An internal ring: its tip is the inner circle, so the tip has the smaller roll distance.
const gm::ActiveFlank kRing{60.0 * kMm, 48.0 * kMm, 20.0 * kMm};

gm_gear_params gear_with(const gm_flank_modification& a, const gm_flank_modification& b) {
  gm_gear_params g{};
  g.teeth = 57;
  g.face_width = 23.0 * kMm;
  g.flank[0] = a;
  g.flank[1] = b;
  return g;
}

gm::GearMicrogeometry micro(const gm_flank_modification& mod, const gm::ActiveFlank& act = kSetA,
                            gm::DeviationTable dev = {}) {
  return gm::make_microgeometry(gear_with(mod, mod), act, std::move(dev));
}

// Roll distance at fraction u of the active profile (0 = SAP, 1 = tip).
double rho_at(const gm::ActiveFlank& a, double u) {
  return a.rho_start + u * (a.rho_tip - a.rho_start);
}

double active_length(const gm::ActiveFlank& a) { return std::fabs(a.rho_tip - a.rho_start); }

gm::DeviationTable parse_ok(const std::string& text, int teeth = 57, double b = 23.0 * kMm) {
  gm::DeviationTable t;
  std::string msg;
  const gm_status s = gm::parse_deviations(text, "test.txt", teeth, b, t, msg);
  EXPECT_EQ(s, GM_OK) << msg;
  return t;
}

std::string parse_error(const std::string& text, int teeth = 57, double b = 23.0 * kMm) {
  gm::DeviationTable t;
  std::string msg;
  const gm_status s = gm::parse_deviations(text, "test.txt", teeth, b, t, msg);
  EXPECT_EQ(s, GM_ERR_PARAMETER) << "parsed although it should not:\n" << text;
  return msg;
}

const char* kHeader = "gearmesh-deviations 1\nteeth 57\n";

std::string example_path() {
  std::string here = __FILE__;  // .../tests/core/test_microgeometry.cpp
  const std::size_t cut = here.rfind("tests/core/");
  return here.substr(0, cut) + "scenarios/deviations_example.txt";
}

// ----------------------------------------------------------------------------------------------
// Design modifications, term by term

TEST(Microgeometry, ZeroParametersGiveNoGap) {
  const gm::GearMicrogeometry m = micro(gm_flank_modification{});
  EXPECT_FALSE(m.any);
  for (int f = 0; f < 2; ++f)
    for (double u : {-0.2, 0.0, 0.3, 1.0, 1.2})
      for (double y : {-11.5 * kMm, 0.0, 7.0 * kMm}) EXPECT_EQ(gm::flank_gap(m, f, 3, rho_at(kSetA, u), y), 0.0);
}

TEST(Microgeometry, ProfileCrowningIsParabolaOverActiveProfile) {
  gm_flank_modification mod{};
  mod.profile_crowning = 8 * kUm;
  const gm::GearMicrogeometry m = micro(mod);
  EXPECT_TRUE(m.any);
  // C (2 s/L - 1)^2: C at both ends, 0 in the middle, C/4 at the quarter points.
  EXPECT_NEAR(gm::flank_gap(m, 0, 0, kSetA.rho_start, 0), 8 * kUm, 1e-15);
  EXPECT_NEAR(gm::flank_gap(m, 0, 0, kSetA.rho_tip, 0), 8 * kUm, 1e-15);
  EXPECT_NEAR(gm::flank_gap(m, 0, 0, rho_at(kSetA, 0.5), 0), 0.0, 1e-15);
  EXPECT_NEAR(gm::flank_gap(m, 1, 0, rho_at(kSetA, 0.25), 5 * kMm), 2 * kUm, 1e-15);
  EXPECT_NEAR(gm::flank_gap(m, 1, 0, rho_at(kSetA, 0.75), -5 * kMm), 2 * kUm, 1e-15);
}

TEST(Microgeometry, TipReliefLinearAndParabolic) {
  const double L = active_length(kSetA);
  gm_flank_modification mod{};
  mod.tip_relief = 12 * kUm;
  mod.tip_relief_length = 0.4 * L;
  const gm::GearMicrogeometry lin = micro(mod);
  // Linear: C (d/L_a) with d the depth into the zone: C at the tip, C/2 half-way, 0 at its start.
  EXPECT_NEAR(gm::flank_gap(lin, 0, 0, kSetA.rho_tip, 0), 12 * kUm, 1e-15);
  EXPECT_NEAR(gm::flank_gap(lin, 0, 0, rho_at(kSetA, 0.8), 0), 6 * kUm, 1e-15);
  EXPECT_NEAR(gm::flank_gap(lin, 0, 0, rho_at(kSetA, 0.6), 0), 0.0, 1e-15);
  EXPECT_EQ(gm::flank_gap(lin, 0, 0, rho_at(kSetA, 0.3), 0), 0.0);
  // Beyond the tip the relief continues (tip corner contact): at 10 % of L past the tip.
  EXPECT_NEAR(gm::flank_gap(lin, 0, 0, rho_at(kSetA, 1.1), 0), 12 * kUm * 1.25, 1e-15);

  mod.tip_relief_parabolic = 1;
  const gm::GearMicrogeometry par = micro(mod);
  // Parabolic: C (d/L_a)^2: C at the tip, C/4 half-way.
  EXPECT_NEAR(gm::flank_gap(par, 1, 0, kSetA.rho_tip, 0), 12 * kUm, 1e-15);
  EXPECT_NEAR(gm::flank_gap(par, 1, 0, rho_at(kSetA, 0.8), 0), 3 * kUm, 1e-15);
  EXPECT_EQ(gm::flank_gap(par, 1, 0, rho_at(kSetA, 0.5), 0), 0.0);
}

TEST(Microgeometry, RootReliefLinearAndParabolic) {
  const double L = active_length(kSetA);
  gm_flank_modification mod{};
  mod.root_relief = 10 * kUm;
  mod.root_relief_length = 0.2 * L;
  const gm::GearMicrogeometry lin = micro(mod);
  EXPECT_NEAR(gm::flank_gap(lin, 0, 0, kSetA.rho_start, 0), 10 * kUm, 1e-15);
  EXPECT_NEAR(gm::flank_gap(lin, 0, 0, rho_at(kSetA, 0.1), 0), 5 * kUm, 1e-15);
  EXPECT_EQ(gm::flank_gap(lin, 0, 0, rho_at(kSetA, 0.5), 0), 0.0);
  EXPECT_EQ(gm::flank_gap(lin, 0, 0, kSetA.rho_tip, 0), 0.0);
  mod.root_relief_parabolic = 1;
  const gm::GearMicrogeometry par = micro(mod);
  EXPECT_NEAR(gm::flank_gap(par, 0, 0, kSetA.rho_start, 0), 10 * kUm, 1e-15);
  EXPECT_NEAR(gm::flank_gap(par, 0, 0, rho_at(kSetA, 0.1), 0), 2.5 * kUm, 1e-15);
}

TEST(Microgeometry, ProfileSlopeIsAntisymmetricAboutTheMiddle) {
  gm_flank_modification mod{};
  mod.profile_slope = -6 * kUm;  // slopes may be negative
  const gm::GearMicrogeometry m = micro(mod);
  // f (s/L - 1/2): gap at the tip minus gap at the start = f, 0 in the middle.
  EXPECT_NEAR(gm::flank_gap(m, 0, 0, kSetA.rho_tip, 0) - gm::flank_gap(m, 0, 0, kSetA.rho_start, 0),
              -6 * kUm, 1e-15);
  EXPECT_NEAR(gm::flank_gap(m, 0, 0, rho_at(kSetA, 0.5), 0), 0.0, 1e-15);
  for (double d : {0.1, 0.27, 0.5})
    EXPECT_NEAR(gm::flank_gap(m, 0, 0, rho_at(kSetA, 0.5 + d), 0),
                -gm::flank_gap(m, 0, 0, rho_at(kSetA, 0.5 - d), 0), 1e-15);
  EXPECT_NEAR(gm::flank_gap(m, 0, 0, kSetA.rho_tip, 0), -3 * kUm, 1e-15);
}

TEST(Microgeometry, LeadCrowningHelixSlopeEndRelief) {
  const double b = kSetA.face_width;
  gm_flank_modification mod{};
  mod.lead_crowning = 10 * kUm;
  const gm::GearMicrogeometry cr = micro(mod);
  // C (2 y/b)^2.
  EXPECT_NEAR(gm::flank_gap(cr, 0, 0, rho_at(kSetA, 0.3), b / 2), 10 * kUm, 1e-15);
  EXPECT_NEAR(gm::flank_gap(cr, 0, 0, rho_at(kSetA, 0.3), -b / 2), 10 * kUm, 1e-15);
  EXPECT_NEAR(gm::flank_gap(cr, 0, 0, rho_at(kSetA, 0.3), 0), 0.0, 1e-15);
  EXPECT_NEAR(gm::flank_gap(cr, 0, 0, rho_at(kSetA, 0.3), b / 4), 2.5 * kUm, 1e-15);

  mod = gm_flank_modification{};
  mod.helix_slope = 4 * kUm;
  const gm::GearMicrogeometry hs = micro(mod);
  // f y/b: gap at +b/2 minus gap at -b/2 = f, antisymmetric about mid-face.
  EXPECT_NEAR(gm::flank_gap(hs, 1, 0, 0, b / 2) - gm::flank_gap(hs, 1, 0, 0, -b / 2), 4 * kUm, 1e-15);
  EXPECT_NEAR(gm::flank_gap(hs, 1, 0, 0, 0), 0.0, 1e-15);
  EXPECT_NEAR(gm::flank_gap(hs, 1, 0, 0, 3 * kMm), -gm::flank_gap(hs, 1, 0, 0, -3 * kMm), 1e-15);

  mod = gm_flank_modification{};
  mod.end_relief = 6 * kUm;
  mod.end_relief_length = 4 * kMm;
  const gm::GearMicrogeometry er = micro(mod);
  // C_I (|y| - (b/2 - L_I))/L_I at both ends: C_I at the ends, C_I/2 half-way, 0 inside.
  EXPECT_NEAR(gm::flank_gap(er, 0, 0, 0, b / 2), 6 * kUm, 1e-15);
  EXPECT_NEAR(gm::flank_gap(er, 0, 0, 0, -b / 2), 6 * kUm, 1e-15);
  EXPECT_NEAR(gm::flank_gap(er, 0, 0, 0, b / 2 - 2 * kMm), 3 * kUm, 1e-15);
  EXPECT_NEAR(gm::flank_gap(er, 0, 0, 0, -(b / 2 - 2 * kMm)), 3 * kUm, 1e-15);
  EXPECT_EQ(gm::flank_gap(er, 0, 0, 0, b / 2 - 4.5 * kMm), 0.0);
  EXPECT_EQ(gm::flank_gap(er, 0, 0, 0, 0), 0.0);
}

TEST(Microgeometry, RingTipIsTheInnerEnd) {
  ASSERT_LT(kRing.rho_tip, kRing.rho_start);
  const double L = active_length(kRing);
  gm_flank_modification mod{};
  mod.tip_relief = 10 * kUm;
  mod.tip_relief_length = 0.25 * L;
  mod.root_relief = 4 * kUm;
  mod.root_relief_length = 0.25 * L;
  const gm::GearMicrogeometry m = micro(mod, kRing);
  EXPECT_NEAR(gm::flank_gap(m, 0, 0, kRing.rho_tip, 0), 10 * kUm, 1e-15);        // inner end
  EXPECT_NEAR(gm::flank_gap(m, 0, 0, kRing.rho_tip + 0.125 * L, 0), 5 * kUm, 1e-15);
  EXPECT_NEAR(gm::flank_gap(m, 0, 0, kRing.rho_start, 0), 4 * kUm, 1e-15);      // outer end
  EXPECT_EQ(gm::flank_gap(m, 0, 0, 0.5 * (kRing.rho_tip + kRing.rho_start), 0), 0.0);

  gm_flank_modification slope{};
  slope.profile_slope = 5 * kUm;
  const gm::GearMicrogeometry s = micro(slope, kRing);
  EXPECT_NEAR(gm::flank_gap(s, 0, 0, kRing.rho_tip, 0) - gm::flank_gap(s, 0, 0, kRing.rho_start, 0),
              5 * kUm, 1e-15);
}

TEST(Microgeometry, FlanksAreIndependent) {
  gm_flank_modification a{};
  a.profile_crowning = 5 * kUm;
  const gm::GearMicrogeometry m = gm::make_microgeometry(gear_with(a, gm_flank_modification{}), kSetA, {});
  EXPECT_TRUE(m.any);
  EXPECT_NEAR(gm::flank_gap(m, 0, 0, kSetA.rho_tip, 0), 5 * kUm, 1e-15);
  EXPECT_EQ(gm::flank_gap(m, 1, 0, kSetA.rho_tip, 0), 0.0);
}

TEST(Microgeometry, SuperpositionOfAllTerms) {
  const double L = active_length(kSetA);
  std::vector<gm_flank_modification> parts(7);
  parts[0].profile_crowning = 3 * kUm;
  parts[1].tip_relief = 9 * kUm;
  parts[1].tip_relief_length = 0.3 * L;
  parts[1].tip_relief_parabolic = 1;
  parts[2].root_relief = 7 * kUm;
  parts[2].root_relief_length = 0.2 * L;
  parts[3].profile_slope = -2 * kUm;
  parts[4].lead_crowning = 5 * kUm;
  parts[5].helix_slope = 3 * kUm;
  parts[6].end_relief = 4 * kUm;
  parts[6].end_relief_length = 3 * kMm;
  gm_flank_modification all{};
  all.profile_crowning = 3 * kUm;
  all.tip_relief = 9 * kUm;
  all.tip_relief_length = 0.3 * L;
  all.tip_relief_parabolic = 1;
  all.root_relief = 7 * kUm;
  all.root_relief_length = 0.2 * L;
  all.profile_slope = -2 * kUm;
  all.lead_crowning = 5 * kUm;
  all.helix_slope = 3 * kUm;
  all.end_relief = 4 * kUm;
  all.end_relief_length = 3 * kMm;
  for (const gm::ActiveFlank& act : {kSetA, kRing}) {
    const gm::GearMicrogeometry combined = micro(all, act);
    std::vector<gm::GearMicrogeometry> single;
    for (const gm_flank_modification& p : parts) single.push_back(micro(p, act));
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-0.1, 1.1), v(-0.5, 0.5);
    for (int k = 0; k < 200; ++k) {
      const double rho = rho_at(act, u(rng));
      const double y = v(rng) * act.face_width;
      const int f = k % 2;
      double sum = 0;
      for (const gm::GearMicrogeometry& s : single) sum += gm::flank_gap(s, f, k % 57, rho, y);
      EXPECT_NEAR(gm::flank_gap(combined, f, k % 57, rho, y), sum, 1e-18);
    }
  }
}

// ----------------------------------------------------------------------------------------------
// Measured grid

TEST(DeviationGrid, BilinearInterpolationIsExactForBilinearField) {
  // f(r, y) = 1 + 0.5 r - 0.3 y + 0.02 r y (um, r and y in mm) on unequally spaced axes.
  const std::vector<double> r = {21.0, 22.5, 26.0, 30.0, 35.0};
  const std::vector<double> y = {-11.5, -3.0, 0.0, 11.5};
  auto f = [](double rm, double ym) { return 1 + 0.5 * rm - 0.3 * ym + 0.02 * rm * ym; };
  std::string text = kHeader;
  text += "roll_mm";
  for (double x : r) text += " " + std::to_string(x);
  text += "\nface_mm";
  for (double x : y) text += " " + std::to_string(x);
  text += "\ngrid 4 B\n";
  for (double rm : r) {
    for (double ym : y) text += " " + std::to_string(f(rm, ym));
    text += "\n";
  }
  const gm::DeviationTable t = parse_ok(text);
  EXPECT_TRUE(t.has_grid(4, 1));
  EXPECT_FALSE(t.has_grid(4, 0));
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> ur(21.0, 35.0), uy(-11.5, 11.5);
  for (int k = 0; k < 100; ++k) {
    const double rm = ur(rng), ym = uy(rng);
    // + in the file = material added, so the gap is -f.
    EXPECT_NEAR(t.gap(4, 1, rm * kMm, ym * kMm), -f(rm, ym) * kUm, 1e-12 * kUm) << rm << " " << ym;
    EXPECT_NEAR(t.measured(4, 1, rm * kMm, ym * kMm), f(rm, ym) * kUm, 1e-12 * kUm);
  }
  EXPECT_EQ(t.gap(4, 0, 25 * kMm, 0), 0.0);  // flank A of that tooth: not measured
  EXPECT_EQ(t.gap(5, 1, 25 * kMm, 0), 0.0);  // another tooth
}

TEST(DeviationGrid, HoldsTheEdgeValueOutsideTheMeasuredArea) {
  const gm::DeviationTable t = parse_ok(std::string(kHeader) +
                                        "roll_mm 20 30\nface_mm -10 10\n"
                                        "grid 0 A 1 2\n  3 4\n");
  auto g = [&](double rm, double ym) { return t.gap(0, 0, rm * kMm, ym * kMm) / kUm; };
  EXPECT_NEAR(g(10, -20), -1, 1e-12);  // corner (r_1, y_1)
  EXPECT_NEAR(g(40, 20), -4, 1e-12);   // corner (r_2, y_2)
  EXPECT_NEAR(g(10, 0), -1.5, 1e-12);  // below the roll range: the r_1 row, interpolated in y
  EXPECT_NEAR(g(25, 50), -3, 1e-12);   // beyond the face range: the y_2 column
  EXPECT_NEAR(g(25, 0), -2.5, 1e-12);  // centre
}

TEST(DeviationGrid, SinglePointAxisIsConstantAlongIt) {
  const gm::DeviationTable t =
      parse_ok(std::string(kHeader) + "roll_mm 20 30 40\nface_mm 0\ngrid 2 A 1 3 -1\n");
  EXPECT_NEAR(t.gap(2, 0, 25 * kMm, -11 * kMm), -2 * kUm, 1e-18);
  EXPECT_NEAR(t.gap(2, 0, 35 * kMm, 11 * kMm), -1 * kUm, 1e-18);
}

TEST(DeviationGrid, FlankGapAddsTheGridAndReducesTheToothIndex) {
  gm::DeviationTable t = parse_ok(std::string(kHeader) + "roll_mm 20 40\nface_mm -5 5\n"
                                                         "grid 56 B 2 2 2 2\n");
  gm_flank_modification mod{};
  mod.lead_crowning = 1 * kUm;
  const gm::GearMicrogeometry m = micro(mod, kSetA, std::move(t));
  EXPECT_TRUE(m.any);
  EXPECT_NEAR(gm::flank_gap(m, 1, 56, 30 * kMm, 0), -2 * kUm, 1e-18);
  EXPECT_NEAR(gm::flank_gap(m, 1, -1, 30 * kMm, 0), -2 * kUm, 1e-18);  // -1 is tooth 56
  EXPECT_NEAR(gm::flank_gap(m, 1, 56, 30 * kMm, kSetA.face_width / 2), -1 * kUm, 1e-18);
  EXPECT_NEAR(gm::flank_gap(m, 0, 56, 30 * kMm, 0), 0.0, 1e-18);

  // Deviations alone make the gear non-trivial.
  const gm::GearMicrogeometry d = micro(gm_flank_modification{}, kSetA,
                                        parse_ok(std::string(kHeader) + "pitch 1 A 1\npitch 2 A -1\n"));
  EXPECT_TRUE(d.any);
  // An empty file is no deviation at all.
  EXPECT_FALSE(micro(gm_flank_modification{}, kSetA, parse_ok(kHeader)).any);
}

// ----------------------------------------------------------------------------------------------
// Pitch deviations

TEST(PitchDeviation, CumulativeSumsAndGap) {
  const gm::DeviationTable t = parse_ok(std::string(kHeader) +
                                        "pitch 0 B 1.5\npitch 1 B -0.5\npitch 10 B -1\n"
                                        "pitch 5 A 3\npitch 6 A -1\npitch 7 A -2\n");
  // F_p(k) = sum_{j<=k} f_pt(j).
  const double expected_b[] = {1.5, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0};
  for (int k = 0; k < 12; ++k) {
    EXPECT_NEAR(t.cumulative_pitch(k, 1), expected_b[k] * kUm, 1e-18) << k;
    EXPECT_NEAR(t.gap(k, 1, 25 * kMm, 0), -expected_b[k] * kUm, 1e-18) << k;
  }
  EXPECT_NEAR(t.cumulative_pitch(56, 1), 0.0, 1e-18);
  EXPECT_EQ(t.cumulative_pitch(4, 0), 0.0);
  EXPECT_NEAR(t.cumulative_pitch(5, 0), 3 * kUm, 1e-18);
  EXPECT_NEAR(t.cumulative_pitch(6, 0), 2 * kUm, 1e-18);
  EXPECT_NEAR(t.cumulative_pitch(7, 0), 0.0, 1e-18);
  EXPECT_NEAR(t.cumulative_pitch(30, 0), 0.0, 1e-18);
}

TEST(PitchDeviation, MustCloseAroundTheGear) {
  const std::string msg =
      parse_error(std::string(kHeader) + "pitch 3 A 2\n# comment\npitch 4 A -1.5\n");
  EXPECT_NE(msg.find("test.txt:5:"), std::string::npos) << msg;
  EXPECT_NE(msg.find("flank A do not close"), std::string::npos) << msg;
  // Within the tolerance 0.001 um + 0.001 max |f_pt|: 0.0015 um residual on 1 um steps is fine.
  parse_ok(std::string(kHeader) + "pitch 3 B 1\npitch 4 B -0.9985\n");
  parse_error(std::string(kHeader) + "pitch 3 B 1\npitch 4 B -0.9975\n");
}

// ----------------------------------------------------------------------------------------------
// Parser

TEST(DeviationFile, ExampleParses) {
  gm::DeviationTable t;
  std::string msg;
  ASSERT_EQ(gm::load_deviations(example_path().c_str(), 57, 23.0 * kMm, t, msg), GM_OK) << msg;
  EXPECT_FALSE(t.empty());
  ASSERT_EQ(t.roll_axis().size(), 6u);
  ASSERT_EQ(t.face_axis().size(), 3u);
  EXPECT_NEAR(t.roll_axis()[0], 21.5 * kMm, 1e-15);
  EXPECT_TRUE(t.has_grid(0, 0));
  EXPECT_TRUE(t.has_grid(3, 1));
  EXPECT_FALSE(t.has_grid(0, 1));
  EXPECT_NEAR(t.measured(0, 0, 27.5 * kMm, 0), 1.0 * kUm, 1e-18);
  EXPECT_NEAR(t.measured(0, 0, 33.5 * kMm, 11.5 * kMm), 0.5 * kUm, 1e-18);
  EXPECT_NEAR(t.measured(3, 1, 30.5 * kMm, -11.5 * kMm), 1.5 * kUm, 1e-18);
  EXPECT_NEAR(t.cumulative_pitch(5, 0), 3 * kUm, 1e-18);
  EXPECT_NEAR(t.cumulative_pitch(6, 0), 2 * kUm, 1e-18);
  EXPECT_NEAR(t.cumulative_pitch(7, 0), 0.0, 1e-18);
  EXPECT_EQ(gm::validate_deviation_coverage("gear1", t, kSetA, msg), GM_OK) << msg;
}

TEST(DeviationFile, ContinuationLinesEqualOneLine) {
  const gm::DeviationTable a =
      parse_ok(std::string(kHeader) + "roll_mm 1 2\nface_mm -1 0 1\ngrid 1 A 1 2 3 4 5 6\n");
  const gm::DeviationTable b = parse_ok(std::string(kHeader) +
                                        "roll_mm 1 2\nface_mm -1 0 1\ngrid 1 A\n\t1 2 3  # r1\n\n"
                                        "4\n5 6\n");
  for (double r : {1.0, 1.3, 2.0})
    for (double y : {-1.0, 0.2, 1.0})
      EXPECT_EQ(a.gap(1, 0, r * kMm, y * kMm), b.gap(1, 0, r * kMm, y * kMm));
}

TEST(DeviationFile, ByteOrderMarkCrLfAndPlusSign) {
  const gm::DeviationTable t = parse_ok(
      "\xEF\xBB\xBFgearmesh-deviations 1\r\nteeth 57\r\nroll_mm 1 2\r\nface_mm 0\r\n"
      "grid 0 B +1.5 -2.5e0\r\n");
  EXPECT_NEAR(t.measured(0, 1, 1 * kMm, 0), 1.5 * kUm, 1e-18);
  EXPECT_NEAR(t.measured(0, 1, 2 * kMm, 0), -2.5 * kUm, 1e-18);
}

struct BadFile {
  const char* text;
  const char* expect;  // substring of the message, including "test.txt:<line>:"
};

TEST(DeviationFile, ErrorsNameFileLineAndWhatIsAllowed) {
  const std::string h = kHeader;
  const std::string axes = h + "roll_mm 20 25 30\nface_mm -10 10\n";  // lines 3, 4
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", "test.txt:1: empty file"},
      {"# only a comment\n\n# and another\n", "test.txt:1: empty file"},
      {"gearmesh-deviation 1\n", "test.txt:1: expected the magic word"},
      {"\n# c\ngearmesh-deviations 2\n", "test.txt:3: unsupported format version '2'"},
      {"gearmesh-deviations\n", "test.txt:1: unsupported format version (none)"},
      {"gearmesh-deviations 1\nteeth 58\n", "test.txt:2: the file is for a gear with 58 teeth; allowed: 'teeth 57'"},
      {"gearmesh-deviations 1\nteeth\n", "test.txt:2: malformed 'teeth' line"},
      {"gearmesh-deviations 1\npitch 0 A 1\n", "test.txt:2: 'pitch' line before the 'teeth' line"},
      {h + "teeth 57\n", "test.txt:3: duplicate 'teeth' line"},
      {h + "roll_mm 20 25 25\n", "test.txt:3: roll_mm values are not strictly increasing"},
      {h + "roll_mm 20 30\nface_mm 1 -1\n", "test.txt:4: face_mm values are not strictly increasing"},
      {h + "roll_mm -1 2\n", "test.txt:3: roll_mm value -1 is negative"},
      {h + "roll_mm 20 nan\n", "test.txt:3: roll_mm value 2 'nan' is not finite"},
      {h + "roll_mm 20 inf\n", "is not finite"},
      {h + "roll_mm 20 1e999\n", "is out of the range of a double"},
      {h + "roll_mm 20 2,5\n", "test.txt:3: roll_mm value 2 '2,5' is not a number"},
      {h + "roll_mm\n", "test.txt:3: 'roll_mm' without values"},
      {h + "roll_mm 1\nroll_mm 2\n", "test.txt:4: duplicate 'roll_mm' line"},
      {h + "roll_mm 20\nface_mm -11.6 0\n", "test.txt:4: face_mm value -11.6 mm lies outside the face width"},
      {h + "grid 0 A 1\n", "test.txt:3: grid line before the axes"},
      {h + "roll_mm 20\ngrid 0 A 1\n", "test.txt:4: grid line before the axes"},
      {axes + "grid 0 A 1 2 3 4 5\npitch 0 A 0\n",
       "test.txt:6: grid 0 A of line 5 has only 5 of 6 values before 'pitch'"},
      {axes + "grid 0 A 1 2 3 4 5 6 7\n", "test.txt:5: grid 0 A of line 5 has more than 6 values"},
      {axes + "grid 0 A 1 2 3\n4 5\n", "test.txt:5: grid 0 A has 5 of 6 values at the end of the file"},
      {axes + "grid 57 A 1 2 3 4 5 6\n", "test.txt:5: tooth 57 out of range; allowed: 0..56"},
      {axes + "grid -1 A 1 2 3 4 5 6\n", "test.txt:5: tooth -1 out of range"},
      {axes + "grid x A 1 2 3 4 5 6\n", "test.txt:5: tooth 'x' is not an integer"},
      {axes + "grid 1 C 1 2 3 4 5 6\n", "test.txt:5: bad flank 'C'; allowed: 'A' or 'B'"},
      {axes + "grid 1 a 1 2 3 4 5 6\n", "bad flank 'a'"},
      {axes + "grid 1 A 1 2 inf 4 5 6\n", "test.txt:5: grid value 'inf' is not finite"},
      {axes + "grid 1 A 1 2 3 4 5 1e5\n", "test.txt:5: grid value 100000 um is implausible"},
      {axes + "grid 1 A 1 2 3 4 5 6\n# again\ngrid 1 A 1 2 3 4 5 6\n",
       "test.txt:7: duplicate grid for tooth 1 A (first on line 5)"},
      {h + "pitch 1 B 2\npitch 1 B -2\n", "test.txt:4: duplicate pitch for tooth 1 B (first on line 3)"},
      {h + "pitch 1 B\n", "test.txt:3: 'pitch' line with 0 values"},
      {h + "pitch 1\n", "test.txt:3: malformed 'pitch' line"},
      {h + "pitch 1 B 1 2\n", "test.txt:3: 'pitch' line with 2 values"},
      {h + "pitch 1 B NaN\n", "test.txt:3: pitch value 'NaN' is not finite"},
      {h + "1 2 3\n", "test.txt:3: values outside a grid: '1'"},
      {h + "profile 1 2\n", "test.txt:3: unknown keyword 'profile'"},
      {h + "gearmesh-deviations 1\n", "test.txt:3: second 'gearmesh-deviations' line"},
      {h + "r\x01\xFFoll 1\n", "unknown keyword 'r\\x01\\xFFoll'"},
  };
  for (const auto& [text, expect] : cases) {
    gm::DeviationTable t = parse_ok(std::string(kHeader) + "pitch 1 A 1\npitch 2 A -1\n");
    const gm::DeviationTable before = t;
    std::string msg;
    EXPECT_EQ(gm::parse_deviations(text, "test.txt", 57, 23.0 * kMm, t, msg), GM_ERR_PARAMETER)
        << text;
    EXPECT_NE(msg.find(expect), std::string::npos) << "message: " << msg << "\nexpected: " << expect;
    EXPECT_NE(msg.find("; allowed: "), std::string::npos) << "no 'what is allowed' part: " << msg;
    // The table is left as it was.
    EXPECT_NEAR(t.cumulative_pitch(1, 0), before.cumulative_pitch(1, 0), 0.0);
    EXPECT_FALSE(t.has_grid(0, 0));
  }
}

TEST(DeviationFile, MissingFileAndBadArguments) {
  gm::DeviationTable t;
  std::string msg;
  EXPECT_EQ(gm::load_deviations("/nonexistent/dev.txt", 57, 0.023, t, msg), GM_ERR_PARAMETER);
  EXPECT_NE(msg.find("/nonexistent/dev.txt: cannot open the deviation file"), std::string::npos) << msg;
  EXPECT_NE(msg.find("; allowed: "), std::string::npos) << msg;
  EXPECT_EQ(gm::load_deviations("/tmp", 57, 0.023, t, msg), GM_ERR_PARAMETER);  // a directory
  EXPECT_EQ(gm::load_deviations(nullptr, 57, 0.023, t, msg), GM_ERR_ARGUMENT);
  EXPECT_EQ(gm::parse_deviations(kHeader, "x", 0, 0.023, t, msg), GM_ERR_ARGUMENT);
  EXPECT_EQ(gm::parse_deviations(kHeader, "x", 57, NAN, t, msg), GM_ERR_ARGUMENT);
}

TEST(DeviationFile, FuzzedExampleNeverCrashes) {
  gm::DeviationTable example;
  std::string msg;
  ASSERT_EQ(gm::load_deviations(example_path().c_str(), 57, 23.0 * kMm, example, msg), GM_OK) << msg;
  std::FILE* f = std::fopen(example_path().c_str(), "rb");
  ASSERT_NE(f, nullptr);
  std::string text;
  char buf[4096];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, f)) > 0;) text.append(buf, n);
  std::fclose(f);

  std::mt19937 rng(20240611);
  const std::string alphabet = "0123456789 .-+eEABx#\n\t\r,";
  int parsed = 0, rejected = 0;
  for (int k = 0; k < 3000; ++k) {
    std::string s = text;
    const int edits = 1 + static_cast<int>(rng() % 4);
    for (int e = 0; e < edits && !s.empty(); ++e) {
      const std::size_t at = rng() % s.size();
      const char c = (rng() % 2) ? alphabet[rng() % alphabet.size()] : static_cast<char>(rng() % 256);
      switch (rng() % 4) {
        case 0: s[at] = c; break;
        case 1: s.insert(s.begin() + static_cast<std::ptrdiff_t>(at), c); break;
        case 2: s.erase(at, 1 + rng() % 8); break;
        default: s.resize(at); break;  // truncation
      }
    }
    gm::DeviationTable t;
    std::string m;
    const gm_status st = gm::parse_deviations(s, "fuzz.txt", 57, 23.0 * kMm, t, m);
    if (st == GM_OK) {
      ++parsed;
      for (int tooth : {0, 3, 5, 56})
        for (int fl = 0; fl < 2; ++fl)
          ASSERT_TRUE(std::isfinite(t.gap(tooth, fl, 27 * kMm, 1 * kMm)));
    } else {
      ++rejected;
      ASSERT_EQ(st, GM_ERR_PARAMETER);
      ASSERT_EQ(m.rfind("fuzz.txt:", 0), 0u) << m;
      for (char ch : m) ASSERT_TRUE(ch >= 0x20 && ch < 0x7f) << "unprintable byte in message: " << m;
    }
  }
  // Both outcomes occur (edits inside comments leave the file valid).
  EXPECT_GT(parsed, 100);
  EXPECT_GT(rejected, 100);
}

// ----------------------------------------------------------------------------------------------
// Validation of the FMU parameters

TEST(ValidateModification, AcceptsZeroAndTypicalValues) {
  std::string msg;
  EXPECT_EQ(gm::validate_modification("gear1", gm_flank_modification{}, kSetA, msg), GM_OK) << msg;
  const double L = active_length(kSetA);
  gm_flank_modification m{};
  m.profile_crowning = 3 * kUm;
  m.tip_relief = 10 * kUm;
  m.tip_relief_length = 0.5 * L;
  m.tip_relief_parabolic = 1;
  m.root_relief = 5 * kUm;
  m.root_relief_length = 0.5 * L;  // together exactly L
  m.profile_slope = -5 * kUm;
  m.lead_crowning = 8 * kUm;
  m.helix_slope = -10 * kUm;
  m.end_relief = 5 * kUm;
  m.end_relief_length = 0.5 * kSetA.face_width;
  EXPECT_EQ(gm::validate_modification("gear1", m, kSetA, msg), GM_OK) << msg;
  EXPECT_EQ(gm::validate_modification("gear2", m, kRing, msg), GM_ERR_PARAMETER);  // ring L = 12 mm
  // A relief length is unused while its relief is 0.
  gm_flank_modification z{};
  z.tip_relief_length = 1.0;
  EXPECT_EQ(gm::validate_modification("gear1", z, kSetA, msg), GM_OK) << msg;
}

TEST(ValidateModification, NamesTheBadParameter) {
  const double L = active_length(kSetA);
  struct Case {
    void (*set)(gm_flank_modification&, double L);
    const char* name;
  };
  const Case cases[] = {
      {[](gm_flank_modification& m, double) { m.profile_crowning = -1e-6; }, "gear2.profile_crowning = -1e-06 m"},
      {[](gm_flank_modification& m, double) { m.profile_crowning = NAN; }, "gear2.profile_crowning = nan"},
      {[](gm_flank_modification& m, double) { m.profile_crowning = 20; }, "gear2.profile_crowning = 20 m: allowed range [0, 0.001] m"},
      {[](gm_flank_modification& m, double) { m.tip_relief = -1e-6; }, "gear2.tip_relief ="},
      {[](gm_flank_modification& m, double) { m.tip_relief = 1e-5; }, "gear2.tip_relief_length = 0 m: allowed range (0,"},
      {[](gm_flank_modification& m, double L) { m.tip_relief = 1e-5; m.tip_relief_length = 1.01 * L; }, "gear2.tip_relief_length ="},
      {[](gm_flank_modification& m, double) { m.tip_relief_parabolic = 2; }, "gear2.tip_relief_parabolic = 2: allowed 0"},
      {[](gm_flank_modification& m, double) { m.root_relief = INFINITY; }, "gear2.root_relief = inf"},
      {[](gm_flank_modification& m, double) { m.root_relief = 1e-5; m.root_relief_length = -1e-3; }, "gear2.root_relief_length ="},
      {[](gm_flank_modification& m, double L) {
         m.tip_relief = 1e-5; m.tip_relief_length = 0.6 * L; m.root_relief = 1e-5; m.root_relief_length = 0.6 * L;
       }, "gear2.root_relief_length"},
      {[](gm_flank_modification& m, double) { m.root_relief_parabolic = -1; }, "gear2.root_relief_parabolic = -1"},
      {[](gm_flank_modification& m, double) { m.profile_slope = NAN; }, "gear2.profile_slope"},
      {[](gm_flank_modification& m, double) { m.profile_slope = -2e-3; }, "gear2.profile_slope = -0.002 m"},
      {[](gm_flank_modification& m, double) { m.lead_crowning = -1e-6; }, "gear2.lead_crowning"},
      {[](gm_flank_modification& m, double) { m.helix_slope = INFINITY; }, "gear2.helix_slope"},
      {[](gm_flank_modification& m, double) { m.end_relief = -1e-6; }, "gear2.end_relief ="},
      {[](gm_flank_modification& m, double) { m.end_relief = 1e-6; m.end_relief_length = 0.012; }, "gear2.end_relief_length = 0.012 m: allowed range (0, 0.0115] m"},
      {[](gm_flank_modification& m, double) { m.end_relief_length = NAN; }, "gear2.end_relief_length = nan"},
  };
  for (const Case& c : cases) {
    // the static ranges and flags on either flank (the parameter table's, validate_params), then
    // the bounds that depend on the gear (validate_modification)
    gm_flank_modification m{};
    c.set(m, L);
    gm_model_params p;
    gm_default_params(&p);
    p.gear[1].flank[1] = m;
    std::string msg;
    const gm_status st = gm::validate_params(p, msg);
    EXPECT_EQ(st == GM_OK ? gm::validate_modification("gear2", m, kSetA, msg) : st, GM_ERR_PARAMETER) << c.name;
    EXPECT_EQ(msg.rfind(c.name, 0), 0u) << "message: " << msg << "\nexpected start: " << c.name;
  }
}

TEST(ValidateDeviationCoverage, RejectsRollAxesOutsideTheActiveProfile) {
  std::string msg;
  const gm::DeviationTable diam =
      parse_ok(std::string(kHeader) + "roll_mm 145 150 155\nface_mm 0\ngrid 0 A 1 2 3\n");
  EXPECT_EQ(gm::validate_deviation_coverage("gear1", diam, kSetA, msg), GM_ERR_PARAMETER);
  EXPECT_EQ(msg.rfind("gear1.deviations: the measured roll distances 145..155 mm", 0), 0u) << msg;
  EXPECT_NE(msg.find("; allowed: "), std::string::npos) << msg;
  const gm::DeviationTable part =
      parse_ok(std::string(kHeader) + "roll_mm 30 40\nface_mm 0\ngrid 0 A 1 2\n");
  EXPECT_EQ(gm::validate_deviation_coverage("gear1", part, kSetA, msg), GM_OK) << msg;
  EXPECT_EQ(gm::validate_deviation_coverage("gear1", gm::DeviationTable{}, kSetA, msg), GM_OK);
}

}  // namespace
