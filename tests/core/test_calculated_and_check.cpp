// The calculated parameters of every level against independent closed forms (ISO 6336-1 method B's
// c' and c_gamma_alpha, ISO 21771's transverse contact ratio and path of contact, written out here
// from the standards' formulas), and gm_model_check against gm_model_create: it refuses what the
// model's creation refuses, with the same status and message.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "gearmesh/gearmesh.h"

namespace {

constexpr double kPi = 3.14159265358979323846;

// Set A (gm_default_params): 57/57, m_n 2.6 mm, alpha_n 20 deg, spur, b 23 mm, a 150 mm, x 0.35 each,
// tip diameters from the basic rack (h_aP* = 1), h_fP* = 1.25, steel 210 GPa.
struct SetA {
  double m = 2.6e-3, alpha = 20 * kPi / 180, a = 0.150, x = 0.35, b = 0.023, E = 210e9;
  int z = 57;
  double r() const { return 0.5 * z * m; }
  double r_b() const { return r() * std::cos(alpha); }
  double r_a() const { return r() + m * (1 + x); }
  double alpha_w() const { return std::acos(2 * r_b() / a); }  // cos alpha_w = a_d cos alpha / a
  double roll_tip() const { return std::sqrt(r_a() * r_a() - r_b() * r_b()); }
  double eps_alpha() const {  // (g_a1 + g_a2 - a sin alpha_w) / p_b, ISO 21771
    return (2 * roll_tip() - a * std::sin(alpha_w())) / (kPi * m * std::cos(alpha));
  }
  // ISO 6336-1 method B: q'_min = C1 + C2/z_n1 + C3/z_n2 + C4 x1 + C5 x1/z_n1 + C6 x2 + C7 x2/z_n2
  // + C8 x1^2 + C9 x2^2 (mm um/N); c' = C_M C_R C_B cos beta (E/E_st)/q'_min, C_M 0.8, C_R 1 (solid),
  // C_B = [1 + 0.5 (1.2 - h_fP/m_n)][1 - 0.02 (20 - alpha_n/deg)]; c_gamma_alpha = c'(0.75 eps_alpha + 0.25)
  double c_single() const {
    const double zn = z, q = 0.04723 + 0.15551 / zn + 0.25791 / zn - 0.00635 * x - 0.11654 * x / zn -
                             0.00193 * x - 0.24188 * x / zn + 0.00529 * x * x + 0.00182 * x * x;
    const double C_B = (1 + 0.5 * (1.2 - 1.25)) * 1.0;
    return 0.8 * C_B * (E / 206e9) / (q * 1e-9);  // N/m^2
  }
};

TEST(CalculatedParameters, SetAAgainstClosedFormsAtEveryLevel) {
  const SetA s;
  for (int level = 0; level < GM_STIFFNESS_LEVELS; ++level) {
    gm_model_params p;
    gm_default_params(&p);
    p.stiffness_level = level;
    gm_pair_geometry g{};
    char msg[512] = "";
    // every level: the geometry call publishes them (gm_model_create's are the same, below)
    ASSERT_EQ(gm_compute_geometry(&p, &g, msg, sizeof msg), GM_OK) << msg;
    EXPECT_NEAR(g.eps_alpha, s.eps_alpha(), 1e-12 * s.eps_alpha()) << level;
    EXPECT_NEAR(g.path_end, s.roll_tip(), 1e-12 * s.roll_tip());
    EXPECT_NEAR(g.path_start, s.a * std::sin(s.alpha_w()) - s.roll_tip(), 1e-12 * s.roll_tip());
    EXPECT_NEAR(g.path_end - g.path_start, g.eps_alpha * g.p_bt, 1e-12 * g.path_end);
    EXPECT_EQ(g.face_overlap, s.b);
    EXPECT_NEAR(g.c_single, s.c_single(), 1e-12 * s.c_single());
    EXPECT_NEAR(g.c_gamma_alpha, s.c_single() * (0.75 * s.eps_alpha() + 0.25), 1e-12 * g.c_gamma_alpha);
  }
  // independent of the published number: ISO's c' of set A is about 15.8 N/(mm um) (docs/physics.md §5)
  EXPECT_NEAR(s.c_single() / 1e9, 15.82, 0.01);
}

TEST(CalculatedParameters, TheModelPublishesTheGeometryCallsValuesAndLevel2UsesThem) {
  gm_model_params p;
  gm_default_params(&p);
  p.stiffness_level = GM_STIFFNESS_ISO6336;
  p.rated_line_load = 2e4;  // 20 N/mm: ISO's load correction (20/100)^0.25
  gm_pair_geometry g{};
  char msg[512] = "";
  ASSERT_EQ(gm_compute_geometry(&p, &g, msg, sizeof msg), GM_OK) << msg;
  gm_model* m = nullptr;
  ASSERT_EQ(gm_model_create(&p, &m, msg, sizeof msg), GM_OK) << msg;
  const gm_pair_geometry& mg = *gm_model_geometry(m);
  EXPECT_EQ(mg.c_single, g.c_single);
  EXPECT_EQ(mg.c_gamma_alpha, g.c_gamma_alpha);
  EXPECT_NEAR(g.c_single, SetA{}.c_single() * std::pow(0.2, 0.25), 1e-12 * g.c_single);
  gm_model_free(m);
}

// Each of these parameter sets (and poses) is refused by gm_model_create (gm_evaluate for a pose).
struct Bad {
  const char* what;
  void (*apply)(gm_model_params&, gm_kinematics&);
};

const Bad kBad[] = {
    {"range", [](gm_model_params& p, gm_kinematics&) { p.gear[0].teeth = 3; }},
    {"rack", [](gm_model_params& p, gm_kinematics&) { p.pair.rack_dedendum = 0.9; }},
    {"centre distance", [](gm_model_params& p, gm_kinematics&) { p.pair.center_distance = 0.14; }},
    {"level 1 without its table", [](gm_model_params& p, gm_kinematics&) { p.stiffness_level = 1; }},
    {"a table at level 4", [](gm_model_params& p, gm_kinematics&) { p.stiffness_table = "k.txt"; }},
    {"level 5 without databases", [](gm_model_params& p, gm_kinematics&) { p.stiffness_level = 5; }},
    {"coupled teeth at level 4", [](gm_model_params& p, gm_kinematics&) { p.coupled_teeth = 4; }},
    {"a ring at level 4",
     [](gm_model_params& p, gm_kinematics&) {
       p.pair.internal = 1;
       p.gear[0].teeth = 20;
       p.gear[1].teeth = 60;
       p.gear[0].profile_shift = p.gear[1].profile_shift = 0;
       p.pair.center_distance = 0.052;
     }},
    {"tip relief longer than the profile",
     [](gm_model_params& p, gm_kinematics&) {
       p.gear[0].flank[0].tip_relief = 10e-6;
       p.gear[0].flank[0].tip_relief_length = 0.05;
     }},
    {"tilt", [](gm_model_params&, gm_kinematics& k) { k.r[1][0] = 0.03; }},
    {"spin", [](gm_model_params&, gm_kinematics& k) { k.phi[0] = 2e7; }},
};

TEST(ModelCheck, RefusesWhatCreationRefusesWithTheSameMessage) {
  for (const Bad& bad : kBad) {
    gm_model_params p;
    gm_default_params(&p);
    gm_kinematics k{};
    bad.apply(p, k);
    char check_msg[1024] = "", create_msg[1024] = "";
    const gm_status checked = gm_model_check(&p, &k, check_msg, sizeof check_msg);
    gm_model* m = nullptr;
    gm_status created = gm_model_create(&p, &m, create_msg, sizeof create_msg);
    if (created == GM_OK) {  // a pose: gm_evaluate refuses it
      gm_data* d = nullptr;
      ASSERT_EQ(gm_data_create(m, &d), GM_OK);
      gm_result r;
      created = gm_evaluate(m, d, &k, &r);
      std::snprintf(create_msg, sizeof create_msg, "%s", gm_data_message(d));
      gm_data_free(d);
      gm_model_free(m);
    }
    EXPECT_NE(created, GM_OK) << bad.what;
    EXPECT_EQ(checked, created) << bad.what;
    EXPECT_STREQ(check_msg, create_msg) << bad.what;
  }
}

TEST(ModelCheck, PassesWhatCreationBuildsAtEveryLevelWithoutReadingFiles) {
  for (int level = 0; level < GM_STIFFNESS_LEVELS; ++level) {
    gm_model_params p;
    gm_default_params(&p);
    p.stiffness_level = level;
    // names only: the check reads no file (creation would fail on these)
    if (level == GM_STIFFNESS_USER_VARIABLE) p.stiffness_table = "no such table.txt";
    if (level == GM_STIFFNESS_FE) p.compliance[0] = p.compliance[1] = "no such database.gcdb";
    p.te_table = "no such te table.txt";
    char msg[1024] = "";
    EXPECT_EQ(gm_model_check(&p, nullptr, msg, sizeof msg), GM_OK) << level << ": " << msg;
    EXPECT_STREQ(msg, "");
  }
  char msg[64];
  EXPECT_EQ(gm_model_check(nullptr, nullptr, msg, sizeof msg), GM_ERR_ARGUMENT);
}

}  // namespace
