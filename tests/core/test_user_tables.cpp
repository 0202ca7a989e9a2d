// Tests of core/src/user_tables.cpp and of their use in the model: the two parsers (examples,
// every malformed case with file:line and "allowed", a fuzz), the lookups against their
// closed forms, stiffness level 1 (a constant table is level 0; a table linear in roll angle gives
// each slice the stiffness at its own roll angle) and the TE excitation (the unloaded TE of a
// perfect pair is the table at every level; under load the loaded TE is shifted by it; both
// flanks open by it). That evaluating with the tables allocates nothing is checked by
// tests/alloc/test_no_alloc.cpp (its own executable: it replaces operator new).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "detection.hpp"
#include "gearmesh/gearmesh.h"
#include "test_support.hpp"
#include "user_tables.hpp"

namespace {

using namespace gm_test;

constexpr double kDeg = kPi / 180;
constexpr double kUm = 1e-6;
constexpr double kNmmUm = 1e9;  // N/(mm um) in N/m^2

std::string repo_file(const char* relative) {
  std::string here = __FILE__;  // .../tests/core/test_user_tables.cpp
  return here.substr(0, here.rfind("tests/core/")) + relative;
}

std::string read_text(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  EXPECT_NE(f, nullptr) << path;
  std::string text;
  if (!f) return text;
  char buf[4096];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, f)) > 0;) text.append(buf, n);
  std::fclose(f);
  return text;
}

std::string stiffness_error(const std::string& text) {
  gm::StiffnessTable t;
  std::string msg;
  EXPECT_EQ(gm::parse_stiffness_table(text, "k.txt", t, msg), GM_ERR_PARAMETER)
      << "parsed although it should not:\n" << text;
  EXPECT_TRUE(t.empty());
  return msg;
}

std::string te_error(const std::string& text, int teeth = 57) {
  gm::TeTable t;
  std::string msg;
  EXPECT_EQ(gm::parse_te_table(text, "te.txt", teeth, t, msg), GM_ERR_PARAMETER)
      << "parsed although it should not:\n" << text;
  EXPECT_TRUE(t.empty());
  return msg;
}

// The text of a stiffness table from rows (deg, N/(mm um)).
std::string stiffness_text(const std::vector<std::pair<double, double>>& rows) {
  std::string s = "gearmesh-stiffness-table 1\n";
  char buf[80];
  for (const auto& [a, k] : rows) {
    std::snprintf(buf, sizeof buf, "%.17g %.17g\n", a, k);
    s += buf;
  }
  return s;
}

// A TE table of n rows sampling amplitude_um sin(2 pi phi/pitch) of a z1-tooth gear 1.
std::string sine_te_text(int z1, int n, double amplitude_um) {
  std::string s = "gearmesh-te-table 1\n# sine over one pitch\n";
  char buf[80];
  for (int k = 0; k < n; ++k) {
    std::snprintf(buf, sizeof buf, "%.17g %.17g\n", 360.0 / z1 * k / n,
                  amplitude_um * std::sin(2 * kPi * k / n));
    s += buf;
  }
  return s;
}

// Linear interpolation of the sine table at phi1 (rad), periodic: the test's own reference.
double sine_table_at(int z1, int n, double amplitude, double phi1) {
  const double pitch = 2 * kPi / z1;
  double u = std::fmod(phi1, pitch) / pitch;
  if (u < 0) u += 1;
  const int k = static_cast<int>(std::floor(u * n)) % n;
  const double f = u * n - k;
  return amplitude * ((1 - f) * std::sin(2 * kPi * k / n) + f * std::sin(2 * kPi * (k + 1) / n));
}

// ----------------------------------------------------------------------------------------------
// Parsers

TEST(UserTables, ExampleStiffnessTableParses) {
  gm::StiffnessTable t;
  std::string msg;
  const std::string path = repo_file("scenarios/user_stiffness_example.txt");
  ASSERT_EQ(gm::load_stiffness_table(path.c_str(), t, msg), GM_OK) << msg;
  ASSERT_EQ(t.roll_angle.size(), 15u);
  EXPECT_DOUBLE_EQ(t.roll_angle.front(), 17 * kDeg);
  EXPECT_DOUBLE_EQ(t.roll_angle.back(), 29 * kDeg);
  EXPECT_DOUBLE_EQ(t.stiffness[7], 15.499 * kNmmUm);  // 23 deg, mid-path
  EXPECT_DOUBLE_EQ(gm::stiffness_at(t, 23 * kDeg), 15.499 * kNmmUm);
  EXPECT_DOUBLE_EQ(gm::stiffness_at(t, 22.5 * kDeg), 0.5 * (15.353 + 15.499) * kNmmUm);
}

TEST(UserTables, ExampleTeTableParses) {
  gm::TeTable t;
  std::string msg;
  const std::string path = repo_file("scenarios/user_te_example.txt");
  ASSERT_EQ(gm::load_te_table(path.c_str(), 57, t, msg), GM_OK) << msg;
  ASSERT_EQ(t.angle.size(), 24u);
  EXPECT_DOUBLE_EQ(t.period, 2 * kPi / 57);
  EXPECT_EQ(t.angle.front(), 0.0);
  EXPECT_NEAR(t.te[6], 0.5 * kUm, 1e-12);  // a quarter pitch: the sine's crest
  EXPECT_NEAR(gm::te_excitation_at(t, t.period / 4).te, 0.5 * kUm, 1e-12);
  // fewer teeth: a longer pitch, the same rows fit; more teeth: the last rows leave the pitch
  EXPECT_EQ(gm::load_te_table(path.c_str(), 40, t, msg), GM_OK) << msg;
  EXPECT_EQ(gm::load_te_table(path.c_str(), 60, t, msg), GM_ERR_PARAMETER);
  EXPECT_NE(msg.find("user_te_example.txt:"), std::string::npos) << msg;
  EXPECT_NE(msg.find("360/60"), std::string::npos) << msg;
}

TEST(UserTables, FormatDetailsAreAccepted) {
  gm::StiffnessTable k;
  std::string msg;
  // BOM, CRLF, tabs, comments, blank lines, '+', exponents
  const std::string text =
      "\xEF\xBB\xBF# leading comment\r\n\r\ngearmesh-stiffness-table 1   # header\r\n"
      "+17\t1.5e1\r\n  18.5 16 # a row\r\n\n29 +0.15E2\r\n";
  ASSERT_EQ(gm::parse_stiffness_table(text, "k.txt", k, msg), GM_OK) << msg;
  ASSERT_EQ(k.roll_angle.size(), 3u);
  EXPECT_EQ(k.stiffness[0], 15 * kNmmUm);
  EXPECT_EQ(k.stiffness[2], 15 * kNmmUm);
  EXPECT_DOUBLE_EQ(k.roll_angle[1], 18.5 * kDeg);
  gm::TeTable te;
  ASSERT_EQ(gm::parse_te_table("gearmesh-te-table 1\n2.5 -1.25\n", "te.txt", 57, te, msg), GM_OK) << msg;
  for (double phi : {-1.0, 0.0, 0.3, 100.0}) {  // one row: constant
    EXPECT_EQ(gm::te_excitation_at(te, phi).te, -1.25 * kUm);
    EXPECT_EQ(gm::te_excitation_at(te, phi).slope, 0.0);
  }
}

TEST(UserTables, MalformedStiffnessTablesAreNamedWithLineAndAllowed) {
  struct Case {
    std::string text;
    const char* where;  // "k.txt:<line>:"
    const char* says;
  };
  const std::string h = "gearmesh-stiffness-table 1\n";
  const Case cases[] = {
      {"", "k.txt:1:", "empty file"},
      {"# only a comment\n\n", "k.txt:1:", "empty file"},
      {"gearmesh-deviations 1\n17 15\n29 15\n", "k.txt:1:", "magic word"},
      {"gearmesh-te-table 1\n17 15\n29 15\n", "k.txt:1:", "magic word"},
      {"gearmesh-stiffness-table 2\n17 15\n29 15\n", "k.txt:1:", "version '2'"},
      {"gearmesh-stiffness-table\n17 15\n29 15\n", "k.txt:1:", "version (none)"},
      {"gearmesh-stiffness-table 1 x\n17 15\n29 15\n", "k.txt:1:", "version"},
      {"\n17 15\n29 15\n", "k.txt:2:", "magic word"},
      {h, "k.txt:1:", "0 rows"},
      {h + "17 15\n", "k.txt:2:", "1 rows"},
      {h + "# c\n17 15\n\n# trailing\n", "k.txt:3:", "1 rows"},
      {h + "17 15 3\n29 15\n", "k.txt:2:", "3 values"},
      {h + "17\n29 15\n", "k.txt:2:", "1 values"},
      {h + "17 15\n29 15\ngearmesh-stiffness-table 1\n", "k.txt:4:", "second"},
      {h + "17 15\n29,5 15\n", "k.txt:3:", "roll angle '29,5' is not a number"},
      {h + "17 15\n29 fifteen\n", "k.txt:3:", "stiffness 'fifteen' is not a number"},
      {h + "17 nan\n29 15\n", "k.txt:2:", "stiffness 'nan' is not finite"},
      {h + "17 inf\n29 15\n", "k.txt:2:", "not"},
      {h + "17 1e400\n29 15\n", "k.txt:2:", "out of the range of a double"},
      {h + "17 15\n29 0\n", "k.txt:3:", "stiffness 0 N/(mm um) is out of range"},
      {h + "17 -15\n29 15\n", "k.txt:2:", "stiffness -15"},
      {h + "17 15\n29 2e5\n", "k.txt:3:", "stiffness 200000"},
      {h + "-1 15\n29 15\n", "k.txt:2:", "roll angle -1 deg is out of range"},
      {h + "17 15\n400 15\n", "k.txt:3:", "roll angle 400"},
      {h + "17 15\n29 15\n29 16\n", "k.txt:4:", "not strictly increasing"},
      {h + "17 15\n16 15\n", "k.txt:3:", "not strictly increasing (16 after 17)"},
      {h + "17 15\n++29 15\n", "k.txt:3:", "not a number"},
      {h + "17 15\n29 1\xFF\n", "k.txt:3:", "\\xFF"},
  };
  for (const Case& c : cases) {
    const std::string msg = stiffness_error(c.text);
    EXPECT_EQ(msg.rfind(c.where, 0), 0u) << msg;
    EXPECT_NE(msg.find(c.says), std::string::npos) << msg;
    EXPECT_NE(msg.find("; allowed: "), std::string::npos) << msg;
  }
}

TEST(UserTables, MalformedTeTablesAreNamedWithLineAndAllowed) {
  struct Case {
    std::string text;
    const char* where;
    const char* says;
  };
  const std::string h = "gearmesh-te-table 1\n";
  const Case cases[] = {
      {"", "te.txt:1:", "empty file"},
      {"gearmesh-stiffness-table 1\n0 1\n", "te.txt:1:", "magic word"},
      {"gearmesh-te-table 0\n0 1\n", "te.txt:1:", "version '0'"},
      {h, "te.txt:1:", "0 rows"},
      {h + "0 1\n1 1 1\n", "te.txt:3:", "3 values"},
      {h + "0 1\n6.315789473684211 1\n", "te.txt:3:", "angle 6.31578947 deg is out of range"},
      {h + "0 1\n7 1\n", "te.txt:3:", "360/57"},
      {h + "-0.1 1\n", "te.txt:2:", "angle -0.1"},
      {h + "1 1\n0.5 1\n", "te.txt:3:", "not strictly increasing"},
      {h + "0 1\n1 1\n1 2\n", "te.txt:4:", "not strictly increasing"},
      {h + "0 1001\n", "te.txt:2:", "TE 1001 um is out of range"},
      {h + "0 -2000\n", "te.txt:2:", "[-1000, 1000] um"},
      {h + "0 1um\n", "te.txt:2:", "TE '1um' is not a number"},
      {h + "0 1\ngearmesh-te-table 1\n", "te.txt:3:", "second"},
  };
  for (const Case& c : cases) {
    const std::string msg = te_error(c.text);
    EXPECT_EQ(msg.rfind(c.where, 0), 0u) << msg;
    EXPECT_NE(msg.find(c.says), std::string::npos) << msg;
    EXPECT_NE(msg.find("; allowed: "), std::string::npos) << msg;
  }
  // the period follows the gear's teeth
  EXPECT_NE(te_error(h + "0 1\n10 1\n", 36).find("te.txt:3: angle 10 deg"), std::string::npos);
}

TEST(UserTables, MissingFilesAreNamed) {
  gm::StiffnessTable k;
  gm::TeTable te;
  std::string msg;
  EXPECT_EQ(gm::load_stiffness_table("/nonexistent/k.txt", k, msg), GM_ERR_PARAMETER);
  EXPECT_EQ(msg.rfind("/nonexistent/k.txt: cannot open the stiffness table", 0), 0u) << msg;
  EXPECT_NE(msg.find("allowed"), std::string::npos) << msg;
  EXPECT_EQ(gm::load_te_table("/nonexistent/te.txt", 57, te, msg), GM_ERR_PARAMETER);
  EXPECT_EQ(msg.rfind("/nonexistent/te.txt: cannot open the TE table", 0), 0u) << msg;
  EXPECT_NE(msg.find("allowed"), std::string::npos) << msg;
  // a directory opens but does not read
  EXPECT_EQ(gm::load_te_table(testing::TempDir().c_str(), 57, te, msg), GM_ERR_PARAMETER);
  EXPECT_NE(msg.find("allowed"), std::string::npos) << msg;
}

// Random edits of the example files: every result is a table whose lookups are finite, or an
// error naming the file and the line with what is allowed; never a crash.
TEST(UserTables, FuzzedExamplesNeverCrash) {
  const std::string texts[2] = {read_text(repo_file("scenarios/user_stiffness_example.txt")),
                                read_text(repo_file("scenarios/user_te_example.txt"))};
  std::mt19937 rng(20261121);
  const std::string alphabet = "0123456789 .-+eE#\n\t\r,gx";
  int parsed = 0, rejected = 0;
  for (int k = 0; k < 2000; ++k) {
    const bool te_file = k % 2;
    std::string s = texts[te_file];
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
    std::string msg;
    gm_status st;
    if (te_file) {
      gm::TeTable t;
      st = gm::parse_te_table(s, "fuzz.txt", 57, t, msg);
      if (st == GM_OK)
        for (double phi : {-7.0, 0.0, 0.05, 0.11, 1e6}) {
          const gm::TeExcitation e = gm::te_excitation_at(t, phi);
          ASSERT_TRUE(std::isfinite(e.te) && std::isfinite(e.slope));
          ASSERT_LE(std::fabs(e.te), 1000 * kUm);
        }
    } else {
      gm::StiffnessTable t;
      st = gm::parse_stiffness_table(s, "fuzz.txt", t, msg);
      if (st == GM_OK)
        for (double a : {-1.0, 0.0, 0.3, 0.4, 0.5, 10.0}) {
          const double v = gm::stiffness_at(t, a);
          ASSERT_TRUE(std::isfinite(v) && v > 0);
        }
    }
    if (st == GM_OK) {
      ++parsed;
    } else {
      ++rejected;
      ASSERT_EQ(st, GM_ERR_PARAMETER);
      ASSERT_EQ(msg.rfind("fuzz.txt:", 0), 0u) << msg;
      ASSERT_NE(msg.find("; allowed: "), std::string::npos) << msg;
    }
  }
  EXPECT_GT(parsed, 100);  // most edits hit comments
  EXPECT_GT(rejected, 100);
}

// ----------------------------------------------------------------------------------------------
// Lookups

TEST(UserTables, StiffnessIsLinearBetweenRowsAndHeldOutside) {
  gm::StiffnessTable t;
  std::string msg;
  ASSERT_EQ(gm::parse_stiffness_table(stiffness_text({{10, 5}, {20, 15}, {40, 5}}), "k.txt", t, msg), GM_OK);
  EXPECT_DOUBLE_EQ(gm::stiffness_at(t, 15 * kDeg), 10 * kNmmUm);
  EXPECT_DOUBLE_EQ(gm::stiffness_at(t, 30 * kDeg), 10 * kNmmUm);
  EXPECT_DOUBLE_EQ(gm::stiffness_at(t, 20 * kDeg), 15 * kNmmUm);
  EXPECT_EQ(gm::stiffness_at(t, 0.0), 5 * kNmmUm);
  EXPECT_EQ(gm::stiffness_at(t, -1.0), 5 * kNmmUm);
  EXPECT_EQ(gm::stiffness_at(t, 2.0), 5 * kNmmUm);
}

TEST(UserTables, TeExcitationIsPeriodicWithWrapAround) {
  gm::TeTable t;
  std::string msg;
  // rows at 1 and 4 deg of a 60-tooth gear (pitch 6 deg): 1 -> 2 um, 4 -> -1 um
  ASSERT_EQ(gm::parse_te_table("gearmesh-te-table 1\n1 2\n4 -1\n", "te.txt", 60, t, msg), GM_OK) << msg;
  const auto at = [&](double deg) { return gm::te_excitation_at(t, deg * kDeg); };
  EXPECT_NEAR(at(1).te, 2 * kUm, 1e-15);
  EXPECT_NEAR(at(2.5).te, 0.5 * kUm, 1e-15);
  EXPECT_NEAR(at(2.5).slope, -1 * kUm / kDeg, 1e-12);
  // wrap: from 4 deg (-1) to 7 deg = 1 + pitch (2): +1 um per deg
  EXPECT_NEAR(at(5.5).te, 0.5 * kUm, 1e-15);
  EXPECT_NEAR(at(0).te, 1 * kUm, 1e-15);
  EXPECT_NEAR(at(0.5).te, 1.5 * kUm, 1e-15);
  EXPECT_NEAR(at(5.999999).te, 0.999999 * kUm, 1e-14);
  EXPECT_NEAR(at(0.5).slope, 1 * kUm / kDeg, 1e-12);
  // any phi1: reduced modulo the pitch, also negative and many revolutions away
  for (double deg : {0.0, 0.5, 2.5, 4.0, 5.5})
    for (int pitches : {-1000, -3, -1, 1, 7, 60000}) {
      EXPECT_NEAR(at(deg + 6.0 * pitches).te, at(deg).te, 1e-12 * kUm * (1 + std::abs(pitches)))
          << deg << " " << pitches;
    }
}

// ----------------------------------------------------------------------------------------------
// The model: level 1 and the TE excitation

// A model's creation message for p ("" if it was created).
std::string create_error(const gm_model_params& p) {
  gm_model* m = nullptr;
  char msg[512] = "";
  const gm_status st = gm_model_create(&p, &m, msg, sizeof msg);
  gm_model_free(m);
  if (st == GM_OK) return "";
  EXPECT_EQ(m, nullptr);
  return msg;
}

TEST(UserTables, ModelRefusesWhatItCannotUse) {
  const std::string good = write_temp("user_tables_good_k.txt", stiffness_text({{17, 15}, {29, 15}}));
  gm_model_params p = paper();
  p.stiffness_level = GM_STIFFNESS_USER_VARIABLE;
  std::string msg = create_error(p);  // level 1 without a table
  EXPECT_EQ(msg.rfind("model.stiffness_table", 0), 0u) << msg;
  EXPECT_NE(msg.find("allowed"), std::string::npos) << msg;
  p.stiffness_table = "";
  EXPECT_EQ(create_error(p).rfind("model.stiffness_table", 0), 0u);
  p.stiffness_table = good.c_str();
  EXPECT_EQ(create_error(p), "");

  const std::string bad = write_temp("user_tables_bad_k.txt", "gearmesh-stiffness-table 1\n17 15\n29 -1\n");
  p.stiffness_table = bad.c_str();
  msg = create_error(p);
  EXPECT_EQ(msg.rfind("model.stiffness_table: " + bad + ":3: stiffness -1", 0), 0u) << msg;
  EXPECT_NE(msg.find("allowed"), std::string::npos) << msg;
  p.stiffness_table = "/nonexistent/k.txt";
  msg = create_error(p);
  EXPECT_EQ(msg.rfind("model.stiffness_table: /nonexistent/k.txt: cannot open", 0), 0u) << msg;

  // radians instead of degrees: the table misses gear 1's active profile (17.7 .. 28.2 deg)
  const std::string radians = write_temp("user_tables_rad_k.txt", stiffness_text({{0.3, 15}, {0.5, 15}}));
  p.stiffness_table = radians.c_str();
  msg = create_error(p);
  EXPECT_NE(msg.find("model.stiffness_table"), std::string::npos) << msg;
  EXPECT_NE(msg.find("active profile, 17.65"), std::string::npos) << msg;
  EXPECT_NE(msg.find("allowed"), std::string::npos) << msg;
  const std::string beyond = write_temp("user_tables_beyond_k.txt", stiffness_text({{28.5, 15}, {40, 15}}));
  p.stiffness_table = beyond.c_str();
  EXPECT_NE(create_error(p).find("miss gear 1's active profile"), std::string::npos);

  // a stiffness table at another level would be ignored: refused
  for (int level : {0, 2, 3, 4}) {
    gm_model_params q = paper();
    q.stiffness_level = level;
    q.stiffness_table = good.c_str();
    msg = create_error(q);
    EXPECT_EQ(msg.rfind("model.stiffness_table = \"" + good + "\"", 0), 0u) << msg;
    EXPECT_NE(msg.find("allowed: \"\""), std::string::npos) << msg;
  }
  // level 5 without its compliance databases is refused, naming the missing one
  gm_model_params q = paper();
  q.stiffness_level = GM_STIFFNESS_FE;
  msg = create_error(q);
  EXPECT_EQ(msg.rfind("gear1.compliance = \"\"", 0), 0u) << msg;

  // the TE table: bad file named with its parameter, at any level
  const std::string bad_te = write_temp("user_tables_bad_te.txt", "gearmesh-te-table 1\n0 1\n7 1\n");
  q = paper();
  q.te_table = bad_te.c_str();
  msg = create_error(q);
  EXPECT_EQ(msg.rfind("model.te_table: " + bad_te + ":3: angle 7 deg", 0), 0u) << msg;
  q.te_table = "/nonexistent/te.txt";
  EXPECT_EQ(create_error(q).rfind("model.te_table: /nonexistent/te.txt: cannot open", 0), 0u);
}

TEST(UserTables, PathsAreReadAtCreationAndNotKept) {
  const std::string k = write_temp("user_tables_kept_k.txt", stiffness_text({{17, 15}, {29, 15}}));
  const std::string te = write_temp("user_tables_kept_te.txt", sine_te_text(57, 24, 1.0));
  gm_model_params p = paper();
  p.stiffness_level = GM_STIFFNESS_USER_VARIABLE;
  p.stiffness_table = k.c_str();
  p.te_table = te.c_str();
  Instance in(p);
  EXPECT_EQ(gm_model_parameters(in.m)->stiffness_table, nullptr);
  EXPECT_EQ(gm_model_parameters(in.m)->te_table, nullptr);
  std::remove(k.c_str());
  std::remove(te.c_str());
  EXPECT_GT(in.at(5e-6, 0.0).normal_force, 0);  // the model has what it needs
}

// Level 1 with a constant table of 15 N/(mm um) is level 0 with k' = 1.5e10 N/m^2: the same
// results bit for bit over a pitch, spur and helical with slices, flank A and flank B.
TEST(UserTables, ConstantTableReproducesLevelZero) {
  const std::string path = write_temp("user_tables_const_k.txt", stiffness_text({{0, 15}, {40, 15}}));
  gm_model_params spur = paper();
  gm_model_params helical = paper();
  helical.pair.helix_angle = 15 * kPi / 180;
  helical.gear[0].profile_shift = helical.gear[1].profile_shift = 0;
  helical.pair.center_distance = 0.0026 / std::cos(helical.pair.helix_angle) * 57 + 50e-6;
  helical.slices = 10;
  helical.friction_coefficient = 0.1;
  helical.damping = 1e4;
  for (const gm_model_params& base : {spur, helical}) {
    gm_model_params level0 = base, level1 = base;
    level0.user_stiffness = 1.5e10;
    level1.stiffness_level = GM_STIFFNESS_USER_VARIABLE;
    level1.stiffness_table = path.c_str();
    level1.user_stiffness = 7e9;  // not used at level 1
    Instance a(level0), b(level1);
    const double pitch = a.geo().p_bt / a.rb(0);
    int loaded = 0;
    for (int s = 0; s < 40; ++s) {
      const double phi1 = pitch * s / 40;
      for (double te : {6e-6, -a.geo().j_bt - 3e-6}) {
        gm_kinematics k{};
        k.phi[0] = phi1;
        k.phi[1] = (te - a.rb(0) * phi1) / a.rb(1);
        k.omega[0] = 10;
        k.omega[1] = -10 * a.rb(0) / a.rb(1) + 0.01;
        const gm_result ra = a.eval(k), rb = b.eval(k);
        loaded += ra.normal_force > 0;
        EXPECT_EQ(ra.normal_force, rb.normal_force) << s;
        EXPECT_EQ(ra.stiffness, rb.stiffness);
        EXPECT_EQ(ra.friction_power, rb.friction_power);
        EXPECT_EQ(ra.pairs_in_contact, rb.pairs_in_contact);
        EXPECT_EQ(ra.flank, rb.flank);
        for (int g = 0; g < 2; ++g)
          for (int c = 0; c < 3; ++c) {
            EXPECT_EQ(ra.force[g][c], rb.force[g][c]);
            EXPECT_EQ(ra.moment[g][c], rb.moment[g][c]);
          }
      }
    }
    EXPECT_EQ(loaded, 80);
  }
}

// A table linear in roll angle, k(theta) = (theta/deg - 5) N/(mm um): each loaded slice gets the
// stiffness at its own roll angle roll[0]/r_b1, found here by detection itself.
TEST(UserTables, LinearTableGivesEachSliceTheStiffnessAtItsRollAngle) {
  const std::string path = write_temp("user_tables_linear_k.txt", stiffness_text({{10, 5}, {40, 35}}));
  const auto k_of = [](double roll_angle) { return (roll_angle / kDeg - 5) * kNmmUm; };
  // spur, single contact near the pitch point: F = k(theta) b TE, mesh stiffness k(theta) b
  gm_model_params p = paper();
  p.stiffness_level = GM_STIFFNESS_USER_VARIABLE;
  p.stiffness_table = path.c_str();
  Instance in(p);
  const double b = p.gear[0].face_width, te = 5e-6;
  for (double phi1 : {-0.006, 0.0, 0.006}) {  // single contact: |phi1| < 0.0077
    const gm_result r = in.at(te, phi1);
    ASSERT_EQ(r.pairs_in_contact, 1) << phi1;
    // the contact point moves by r_b1 phi1 from the pitch point towards gear 1's tip; detection
    // puts it midway between the overlapping flanks, te/2 back from gear 1's flank
    const double theta = std::tan(in.geo().alpha_wt) + phi1 - 0.5 * te / in.rb(0);
    EXPECT_NEAR(r.stiffness, k_of(theta) * b, 1e-9 * k_of(theta) * b) << phi1;
    EXPECT_NEAR(r.normal_force, k_of(theta) * b * te, 1e-9 * k_of(theta) * b * te);
  }
  // helical, 10 slices: the slices of a contact line have different roll angles
  gm_model_params h = p;
  h.pair.helix_angle = 15 * kPi / 180;
  h.gear[0].profile_shift = h.gear[1].profile_shift = 0;
  h.pair.center_distance = 0.0026 / std::cos(h.pair.helix_angle) * 57 + 50e-6;
  h.slices = 10;
  Instance hel(h);
  const Pair pair = make_pair(h);
  std::vector<gm::ContactSlice> slices(gm::slice_capacity(pair.L));
  const double cb2 = std::pow(std::cos(hel.geo().beta_b), 2);
  for (double phi1 : {0.0, 0.021, 0.05}) {
    gm_kinematics k{};
    k.phi[0] = phi1;
    k.phi[1] = phi2_for(pair.L, te, phi1);
    std::string msg;
    const int n = gm::detect_contacts(pair.L, k, slices.data(), static_cast<int>(slices.size()), msg);
    ASSERT_GT(n, 0) << msg;
    double stiffness = 0, force = 0, lo = 1e9, hi = 0;
    for (int i = 0; i < n; ++i) {
      const gm::ContactSlice& s = slices[i];
      if (s.approach <= 0) continue;
      const double theta = s.roll[0] / pair.L.base_radius[0];
      lo = std::min(lo, theta);
      hi = std::max(hi, theta);
      stiffness += k_of(theta) * s.width;                // along the transverse line of action
      force += k_of(theta) * s.width / cb2 * s.approach;  // along the normal
    }
    ASSERT_GT(hi - lo, 0.5 * kDeg);  // the test means something: the roll angles differ
    const gm_result r = hel.eval(k);
    EXPECT_NEAR(r.stiffness, stiffness, 1e-9 * stiffness) << phi1;
    EXPECT_NEAR(r.normal_force, force, 1e-9 * force) << phi1;
  }
}

// A sine of 1 um over the pitch: the quasi-static TE at zero load of perfect gears is the table
// at every phi1, at every level.
TEST(UserTables, UnloadedTeIsTheTeTableAtEveryLevel) {
  const int rows = 24;
  const std::string te_path = write_temp("user_tables_sine_te.txt", sine_te_text(57, rows, 1.0));
  const std::string k_path = write_temp("user_tables_level1_k.txt", stiffness_text({{17, 12}, {23, 15.5}, {29, 12}}));
  for (int level : {0, 1, 2, 3, 4}) {
    gm_model_params p = paper();
    p.quasi_static = 1;
    p.stiffness_level = level;
    p.te_table = te_path.c_str();
    if (level == 1) p.stiffness_table = k_path.c_str();
    Instance in(p);
    const double pitch = 2 * kPi / 57;
    for (int s = 0; s < 2 * rows; ++s) {
      // the rows themselves, then points between them, a few revolutions away
      const double phi1 = s < rows ? pitch * s / rows : pitch * (s - rows + 0.37) / rows + 3 * 2 * kPi;
      const double expected = sine_table_at(57, rows, 1e-6, phi1);
      const gm_result r = in.loaded(phi1, 0.0);
      EXPECT_EQ(r.normal_force, 0.0);
      EXPECT_NEAR(r.te, expected, s < rows ? 1e-15 : 1e-13) << "level " << level << " row " << s;
    }
  }
}

// Level 0 under load (quasi-static, 200 N m): the loaded TE is shifted by the excitation, and
// with prescribed spin angles the forces on flank A and flank B are those of a pair whose TE is
// shifted by -TE_exc (A) and +TE_exc (B): both flanks open by TE_exc.
TEST(UserTables, TeExcitationShiftsTheLoadedTeAndOpensBothFlanks) {
  const int rows = 24;
  const std::string te_path = write_temp("user_tables_sine_te_loaded.txt", sine_te_text(57, rows, 1.0));
  gm_model_params plain = paper();
  plain.quasi_static = 1;
  for (auto& g : plain.gear)  // keep the tip edges off the mate, as in test_forces
    for (auto& f : g.flank) {
      f.tip_relief = 40e-6;
      f.tip_relief_length = 0.05e-3;
    }
  gm_model_params excited = plain;
  excited.te_table = te_path.c_str();
  Instance a(plain), b(excited);
  const double pitch = 2 * kPi / 57, torque = 200;
  double largest = 0;
  for (int s = 0; s < 64; ++s) {
    const double phi1 = pitch * (s + 0.5) / 64;
    const double exc = sine_table_at(57, rows, 1e-6, phi1);
    const gm_result ra = a.loaded(phi1, torque), rb = b.loaded(phi1, torque);
    EXPECT_NEAR(rb.te - ra.te, exc, 1e-13) << s;
    EXPECT_NEAR(rb.normal_force, ra.normal_force, 1e-9 * ra.normal_force);
    EXPECT_EQ(rb.pairs_in_contact, ra.pairs_in_contact);
    largest = std::max(largest, std::fabs(exc));
  }
  EXPECT_GT(largest, 0.95e-6);

  gm_model_params fixed_plain = paper(), fixed_excited = paper();
  fixed_excited.te_table = te_path.c_str();
  Instance c(fixed_plain), d(fixed_excited);
  const double j = c.geo().j_bt;
  for (double phi1 : {0.001, 0.027, 0.08}) {
    const double exc = sine_table_at(57, rows, 1e-6, phi1);
    const gm_result fa = d.at(5e-6, phi1), fa_ref = c.at(5e-6 - exc, phi1);
    EXPECT_EQ(fa.flank, 1);
    EXPECT_NEAR(fa.normal_force, fa_ref.normal_force, 1e-9 * fa_ref.normal_force) << phi1;
    const gm_result fb = d.at(-j - 5e-6, phi1), fb_ref = c.at(-j - 5e-6 + exc, phi1);
    EXPECT_EQ(fb.flank, 2);
    EXPECT_NEAR(fb.normal_force, fb_ref.normal_force, 1e-9 * fb_ref.normal_force) << phi1;
    // and it acts: each pair in contact loses k b TE_exc
    EXPECT_NEAR(c.at(5e-6, phi1).normal_force - fa.normal_force, fa.pairs_in_contact * 1.5e10 * 0.023 * exc,
                1e-9 * fa.normal_force);
  }
}

// The excitation's rate enters the approach rate: damping sees d(TE_exc)/dt = slope omega_1.
TEST(UserTables, TeExcitationRateEntersTheDamping) {
  // rises by 1 um/deg from 0 to 3 deg, falls back to 0 over the rest of the pitch (360/57 deg)
  const std::string te_path = write_temp("user_tables_ramp_te.txt", "gearmesh-te-table 1\n0 0\n3 3\n");
  gm_model_params p = paper();
  p.damping = 2e4;
  gm_model_params q = p;
  q.te_table = te_path.c_str();
  Instance plain(p), excited(q);
  // at phi1 = 0.02 rad (two pairs in flank contact) the excitation rises by 1 um/deg; gear 1
  // turns at omega1, gear 2 with it (no approach rate from the spin angles)
  const double phi1 = 0.02, omega1 = 2.0, te = 8e-6, exc = phi1 / kDeg * kUm;
  gm_kinematics k{};
  k.phi[0] = phi1;
  k.phi[1] = (te - plain.rb(0) * phi1) / plain.rb(1);
  k.omega[0] = omega1;
  k.omega[1] = -omega1 * plain.rb(0) / plain.rb(1);
  const gm_result still = excited.eval(k);
  ASSERT_EQ(still.pairs_in_contact, 2);
  gm_kinematics k_ref = k;
  k_ref.phi[1] = (te - exc - plain.rb(0) * phi1) / plain.rb(1);  // the same approach, no excitation
  const gm_result ref = plain.eval(k_ref);
  const double rate = kUm / kDeg * omega1;  // d(TE_exc)/dt, m/s: the flanks open at this rate
  EXPECT_NEAR(ref.normal_force - still.normal_force, still.pairs_in_contact * 2e4 * 0.023 * rate,
              1e-6 * ref.normal_force);
}

}  // namespace
