// Level 4's tooth coupling (tooth_coupling.hpp) and its low-rank force solve
// (coupled_forces.hpp):
// * the table against held-out compliance_tool databases (tests/core/data/
//   tooth_coupling_check.csv: gears outside the fit, written by tools/gearmesh_dev/coupling_fit.py
//   from the databases, not from the core);
// * Maxwell-Betti: C_ij = C_ji between slices of any teeth, flanks and gears;
// * limits: one tooth pair alone carries exactly the uncoupled level 4's forces; the coupling
//   makes double contact more compliant; model.coupled_teeth = 0 switches it off;
// * the low-rank solve against the dense coupled solver (NlcpSolver over the assembled C, the
//   level-5 solver) at every pose of a pitch, plain and quasi-static, spur, helical and tilted.
#include <limits>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "dense_solve.hpp"
#include "model.hpp"
#include "pipeline.hpp"
#include "test_support.hpp"
#include "tooth_coupling.hpp"

namespace {

using namespace gm_test;

std::vector<std::vector<double>> read_check_csv() {
  const std::string here = __FILE__;  // .../tests/core/test_tooth_coupling.cpp
  std::ifstream in(here.substr(0, here.rfind('/')) + "/data/tooth_coupling_check.csv");
  EXPECT_TRUE(in.good()) << "tests/core/data/tooth_coupling_check.csv missing";
  std::vector<std::vector<double>> rows;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line[0] == 't') continue;
    std::vector<double> row;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) row.push_back(std::stod(cell));
    rows.push_back(row);
  }
  return rows;
}

// The surrogate reproduces held-out databases' kernels: worst error relative to the kernel's
// mean per (gear, d), and of the kernel's mean itself (what the load sharing sees most).
TEST(ToothCoupling, TableReproducesHeldOutDatabases) {
  const auto rows = read_check_csv();
  ASSERT_GE(rows.size(), 50u);
  struct Acc {
    double z = 0, b = 0;
    int d = 0;
    double sum_db = 0, sum_fit = 0, worst = 0;
    int count = 0;
  };
  std::vector<Acc> acc;
  for (const auto& r : rows) {
    ASSERT_EQ(r.size(), 7u);
    const double z = r[0], b = r[1], ha = r[4], hb = r[5], ek = r[6];
    const int d = int(r[3]);
    const gm::CouplingCoefficients k = gm::coupling_coefficients(z, b);
    EXPECT_FALSE(k.extrapolated) << z << " " << b;
    const double fit = gm::coupling_kernel(k, d, ha, hb);
    Acc* a = nullptr;
    for (auto& x : acc)
      if (x.z == z && x.b == b && x.d == d) a = &x;
    if (!a) {
      acc.push_back(Acc{z, b, d});
      a = &acc.back();
    }
    a->sum_db += ek;
    a->sum_fit += fit;
    a->worst = std::max(a->worst, std::fabs(fit - ek));
    ++a->count;
  }
  for (const auto& a : acc) {
    const double mean = a.sum_db / a.count;
    std::printf("z %g b/m %g d %+d: E k mean %.3f, surrogate %.3f (%+.2f %%), worst point %.2f %%\n",
                a.z, a.b, a.d, mean, a.sum_fit / a.count,
                100 * (a.sum_fit - a.sum_db) / a.sum_db, 100 * a.worst / mean);
    // measured: the mean within 1 % at x = 0 (b/m_n 6..16), 4.4 % at x = 0.3 (the table has
    // x = 0); every point within 5.8 %
    EXPECT_LT(std::fabs(a.sum_fit - a.sum_db) / a.sum_db, 0.05);  // the mean within 5 %
    EXPECT_LT(a.worst / mean, 0.08);                               // every point within 8 %
  }
}

// C_ij = C_ji (Maxwell-Betti) for slices of random teeth, flanks and rolls on both gears.
// Outside the validated range the model says so (gm_model_warnings): a helical pair with the
// coupling on (face-uniform kernel: the ripple is not corrected), a tooth count beyond the
// table; spur pairs inside it, and a helical pair without the coupling, carry no such warning.
TEST(ToothCoupling, WarnsOutsideItsValidatedRange) {
  const auto warnings = [](int coupled, double helix_deg, int teeth) {
    gm_model_params p = gm_test::paper();
    p.stiffness_level = GM_STIFFNESS_ANALYTICAL;
    p.coupled_teeth = coupled;
    if (helix_deg != 0) {
      p.pair.helix_angle = helix_deg * gm_test::kPi / 180;
      p.gear[0].profile_shift = p.gear[1].profile_shift = 0;
      p.pair.center_distance = 0.0026 / std::cos(p.pair.helix_angle) * 57 + 50e-6;
    }
    if (teeth != 57) {
      p = gm_test::spur_pair(teeth, teeth, 0.002, 0.002 * teeth + 40e-6, 0, 0, 0.02);
      p.stiffness_level = GM_STIFFNESS_ANALYTICAL;
      p.coupled_teeth = coupled;
    }
    gm_test::Instance I(p);
    return std::string(gm_model_warnings(I.m));
  };
  EXPECT_EQ(warnings(2, 0, 57).find("level 4's tooth coupling"), std::string::npos);
  const std::string helical = warnings(2, 15, 57);
  EXPECT_NE(helical.find("pair.helix_angle = 15 deg"), std::string::npos) << helical;
  EXPECT_NE(helical.find("not the TE ripple"), std::string::npos) << helical;
  EXPECT_EQ(warnings(0, 15, 57).find("helix_angle"), std::string::npos);
  const std::string large = warnings(2, 0, 200);
  EXPECT_NE(large.find("gear1.teeth = 200 outside"), std::string::npos) << large;
}

TEST(ToothCoupling, CompliancesAreReciprocal) {
  gm_model_params p = paper();
  p.stiffness_level = GM_STIFFNESS_ANALYTICAL;
  p.coupled_teeth = 3;
  Instance I(p);
  const gm::ToothCoupling& c = I.m->coupling;
  ASSERT_EQ(c.offsets, 3);
  unsigned seed = 7;
  const auto uniform = [&](double lo, double hi) {
    seed = seed * 1664525u + 1013904223u;
    return lo + (hi - lo) * (seed >> 8) / 16777216.0;
  };
  int nonzero = 0;
  for (int k = 0; k < 2000; ++k) {
    gm::ContactSlice a, b;
    a.flank = uniform(0, 1) < 0.5 ? 1 : -1;
    b.flank = uniform(0, 1) < 0.9 ? a.flank : -a.flank;
    a.tooth[0] = int(uniform(-60, 60));
    b.tooth[0] = a.tooth[0] + int(uniform(-4, 5));
    a.tooth[1] = int(uniform(-60, 60));
    b.tooth[1] = a.tooth[1] - (b.tooth[0] - a.tooth[0]);
    double ha[2], hb[2];
    for (int g = 0; g < 2; ++g) {
      a.roll[g] = uniform(0.015, 0.035);
      b.roll[g] = uniform(0.015, 0.035);
      ha[g] = gm::coupling_height(c.gear[g], a.roll[g]);
      hb[g] = gm::coupling_height(c.gear[g], b.roll[g]);
    }
    const double cab = gm::coupling_compliance(c, a, ha, b, hb);
    const double cba = gm::coupling_compliance(c, b, hb, a, ha);
    EXPECT_NEAR(cab, cba, 1e-14 * std::fabs(cab));
    const int d = std::abs(b.tooth[0] - a.tooth[0]);
    if (a.flank != b.flank || d == 0 || d > 3) {
      EXPECT_EQ(cab, 0.0);
    } else {
      EXPECT_GT(cab, 0.0);
      ++nonzero;
    }
  }
  EXPECT_GT(nonzero, 500);
}

// One pair in contact: the coupled level 4 is the uncoupled one; two pairs: the coupling makes
// the mesh more compliant (larger TE under load, less stiffness); coupled_teeth = 0: identical.
TEST(ToothCoupling, SinglePairIsUncoupledAndDoubleContactSoftens) {
  gm_model_params p = paper();
  p.stiffness_level = GM_STIFFNESS_ANALYTICAL;
  p.slices = 5;
  p.quasi_static = 1;
  gm_model_params p0 = p;
  p0.coupled_teeth = 0;
  Instance c(p), u(p0);
  int single = 0, two = 0;
  for (int s = 0; s < 40; ++s) {
    const double phi1 = c.geo().p_bt / c.rb(0) * (s + 0.5) / 40;
    const gm_result rc = c.loaded(phi1, 50), ru = u.loaded(phi1, 50);
    ASSERT_EQ(rc.pairs_in_contact >= 1, true);
    if (rc.pairs_in_contact == 1 && ru.pairs_in_contact == 1) {
      ++single;
      EXPECT_NEAR(rc.te, ru.te, 1e-12) << s;
      EXPECT_NEAR(rc.stiffness, ru.stiffness, 1e-9 * ru.stiffness) << s;
    } else if (rc.pairs_in_contact == 2 && ru.pairs_in_contact == 2) {
      ++two;
      EXPECT_GT(rc.te, ru.te + 0.05e-6) << s;
      EXPECT_LT(rc.stiffness, 0.95 * ru.stiffness) << s;
    }
  }
  EXPECT_GT(single, 3);
  EXPECT_GT(two, 10);
}

// The low-rank solve (gm_evaluate's) against the dense coupled solver on the same candidates.
void compare_with_dense(gm_model_params p, const char* what) {
  p.stiffness_level = GM_STIFFNESS_ANALYTICAL;
  p.solver_tolerance = 1e-15;  // both solvers to their floor
  Instance I(p);
  gm_model& m = *I.m;
  gm_data& d = *I.d;
  ASSERT_GT(m.coupling.offsets, 0);
  double worst_f = 0, worst_k = 0, worst_l = 0;
  int multi = 0;
  for (int s = 0; s < 30; ++s) {
    gm_kinematics k{};
    k.phi[0] = I.geo().p_bt / I.rb(0) * (s + 0.25) / 30;
    k.phi[1] = (12e-6 - I.rb(0) * k.phi[0]) / I.rb(1);
    k.r[1][0] = p.gear[0].flank[0].tip_relief > 0 ? 1e-4 : 0.0;  // tilted case
    k.load_torque = 300;
    gm::ForceProblem problem;
    problem.pose = &k;
    problem.all = problem.quasi = p.quasi_static != 0;
    problem.load = 300 / I.rb(1);
    const gm::PassResult pass = gm::solve_pass(m, d, problem);
    ASSERT_EQ(pass.status, GM_OK) << d.message;
    const int n = pass.n;
    const gm::ForceSolve& fs = pass.solve;
    const std::vector<double> F(d.forces.begin(), d.forces.begin() + n),
        K(d.slice_stiffness.begin(), d.slice_stiffness.begin() + n);
    const double lambda = fs.lambda;
    int loaded_pairs = 0, last = std::numeric_limits<int>::min();  // no tooth index
    for (int i = 0; i < n; ++i)
      if (F[i] > 0 && d.slices[i].tooth[0] != last) {
        ++loaded_pairs;
        last = d.slices[i].tooth[0];
      }
    multi += loaded_pairs > 1;
    // the dense solve on the same prepared candidates
    for (int i = 0; i < n; ++i) d.approach[i] = d.slices[i].approach;
    problem.n = n;
    const gm::ForceSolve dense = gm::solve_dense(m, d, problem);
    ASSERT_TRUE(dense.converged) << dense.message;
    double fmax = 0;
    for (int i = 0; i < n; ++i) fmax = std::max(fmax, F[i]);
    for (int i = 0; i < n; ++i) {
      worst_f = std::max(worst_f, std::fabs(F[i] - d.forces[i]) / fmax);
      if (F[i] > 0) worst_k = std::max(worst_k, std::fabs(K[i] - d.slice_stiffness[i]) /
                                                    std::fabs(d.slice_stiffness[i]));
    }
    if (problem.quasi) worst_l = std::max(worst_l, std::fabs(lambda - dense.lambda));
  }
  std::printf("%s: low-rank - dense: forces %.2g of the largest, slice stiffness %.2g, "
              "rigid approach %.2g m; %d of 30 poses with several loaded pairs\n",
              what, worst_f, worst_k, worst_l, multi);
  EXPECT_GT(multi, 5);
  EXPECT_LT(worst_f, 1e-9);
  EXPECT_LT(worst_k, 1e-7);
  EXPECT_LT(worst_l, 1e-15);
}

// Quasi-static under load the low-rank solve takes the flank the load closes alone, and every
// candidate when the other closes too (gear 2 moved towards gear 1 until both flanks touch:
// wedging). Either way the answer is the plain solve's at the solved TE: the same flanks in
// contact, forces, moments and stiffness.
TEST(ToothCoupling, QuasiStaticAgreesWithThePlainSolveAtItsTeOpenAndWedged) {
  gm_model_params p = paper();
  p.stiffness_level = GM_STIFFNESS_ANALYTICAL;
  p.slices = 10;
  p.quasi_static = 1;
  gm_test::expect_quasi_static_equals_plain_at_its_te(p);
}

TEST(ToothCoupling, LowRankSolveEqualsTheDenseSolver) {
  gm_model_params p = paper();
  p.slices = 10;
  compare_with_dense(p, "spur, plain");
  p.quasi_static = 1;
  compare_with_dense(p, "spur, quasi-static");
  gm_model_params h = paper();
  h.slices = 10;
  h.pair.helix_angle = 15 * kPi / 180;
  h.gear[0].profile_shift = h.gear[1].profile_shift = 0;
  h.pair.center_distance = 0.0026 / std::cos(h.pair.helix_angle) * 57 + 50e-6;
  compare_with_dense(h, "helical, plain");
  h.quasi_static = 1;
  compare_with_dense(h, "helical, quasi-static");
  gm_model_params t = paper();
  t.slices = 10;
  t.gear[0].flank[0].tip_relief = 1e-6;  // marks the tilted case in compare_with_dense
  t.gear[0].flank[0].tip_relief_length = 0.05e-3;
  compare_with_dense(t, "spur tilted, plain");
}

}  // namespace
