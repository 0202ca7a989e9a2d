// Compliance database builder (compliance_tool/src/compliance_build.hpp) on a small coarse gear
// (z = 20, m 2 mm, b 10 mm, n_c = 1): the written file reads back and matches the gear;
// Maxwell-Betti symmetry of C_0 (approximate: responses at depth h, loads on the surface);
// a uniform line load against the analytical tooth compliance; neighbour coupling.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>

#include "compliance_build.hpp"
#include "compliance_db.hpp"
#include "gearmesh/gearmesh.h"
#include "tooth_compliance.hpp"

namespace {

struct Built {
  gm_model_params p;
  gm_pair_geometry g;
  gm::ctool::BuildOptions o;
  gm::ComplianceDb db;
  gm::ctool::BuildStats stats;
  double seconds = 0;
};

const Built& built() {
  static const Built B = [] {
    Built b;
    gm_default_params(&b.p);
    b.p.pair.normal_module = 0.002;
    b.p.pair.helix_angle = 0;
    b.p.gear[0].teeth = 20;
    b.p.gear[1].teeth = 40;
    for (int i = 0; i < 2; ++i) {
      b.p.gear[i].profile_shift = 0;
      b.p.gear[i].face_width = 0.010;
      b.p.gear[i].tip_diameter = 0;
    }
    b.p.pair.center_distance = 0.5 * 0.002 * 60;
    b.p.coupled_teeth = 1;
    char msg[512];
    EXPECT_EQ(gm_compute_geometry(&b.p, &b.g, msg, sizeof msg), GM_OK) << msg;
    b.o.mesh.elements_along_profile = 3;
    b.o.mesh.elements_across_width = 2;
    b.o.mesh.elements_in_fillet = 2;
    // (body_size only sizes the bore circle: the body fills at the flank element size, so the
    // element counts set the run time; CHOLMOD with the reference BLAS is the bulk of it)
    b.o.depth = 0.5e-3;
    b.o.coupled = 1;
    const auto t0 = std::chrono::steady_clock::now();
    std::string m;
    EXPECT_EQ(gm::ctool::build_compliance_db(b.p, 0, b.o, b.db, b.stats, m), GM_OK) << m;
    b.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("[build] %d nodes, %d elements, grid %d; mesh %.2f s, locate %.2f s, assembly %.2f s, "
                "factor %.2f s, solves %.2f s, total %.2f s; max roll offset %.3f spacing\n",
                b.stats.nodes, b.stats.elements, b.stats.grid, b.stats.mesh_seconds,
                b.stats.locate_seconds, b.stats.assembly_seconds, b.stats.factor_seconds,
                b.stats.solve_seconds, b.seconds, b.stats.max_roll_offset);
    return b;
  }();
  return B;
}

double C(const gm::ComplianceDb& db, int d, std::size_t k, std::size_t j) {
  return db.blocks[db.block_index(0, 0, d)][k * db.n_grid() + j];
}

TEST(ComplianceBuild, WritesReadsAndMatchesTheGear) {
  const Built& b = built();
  ASSERT_FALSE(b.db.blocks.empty());
  EXPECT_EQ(b.db.roll.size(), 7u);  // 2 * 3 + 1
  EXPECT_EQ(b.db.face.size(), 5u);  // 2 * 2 + 1
  EXPECT_NEAR(b.db.face.front(), -0.005, 1e-9);
  EXPECT_NEAR(b.db.face.back(), 0.005, 1e-9);
  EXPECT_NEAR(b.db.roll.front(), b.g.gear[0].rho_Ff, 2e-6);
  EXPECT_NEAR(b.db.roll.back(), b.g.gear[0].rho_a, 2e-6);
  const std::string path = ::testing::TempDir() + "gm_compliance_build_test.gcdb";
  std::string msg;
  ASSERT_EQ(gm::write_compliance_db(path.c_str(), b.db, msg), GM_OK) << msg;
  gm::ComplianceDb r;
  ASSERT_EQ(gm::read_compliance_db(path.c_str(), r, msg), GM_OK) << msg;
  EXPECT_EQ(gm::check_db_matches(r, b.p, 0, msg), GM_OK) << msg;
  EXPECT_EQ(r.blocks, b.db.blocks);
  EXPECT_EQ(r.roll, b.db.roll);
  EXPECT_EQ(r.n_coupled, 1u);
  EXPECT_EQ(r.cyclic, 1u);
  EXPECT_EQ(r.mirror, 1u);
  EXPECT_DOUBLE_EQ(r.depth, 0.5e-3);
  // Gear 2 of the same pair is another gear: refused.
  EXPECT_NE(gm::check_db_matches(r, b.p, 1, msg), GM_OK);
  std::remove(path.c_str());
}

TEST(ComplianceBuild, C0IsNearlySymmetric) {
  const gm::ComplianceDb& db = built().db;
  ASSERT_FALSE(db.blocks.empty());
  const std::size_t n = db.n_grid();
  double worst = 0, cmax = 0;
  for (std::size_t k = 0; k < n; ++k) cmax = std::max(cmax, std::fabs(C(db, 0, k, k)));
  // Relative asymmetry over the pairs whose entries are not tiny (> 10 % of the largest).
  double worst_rel = 0;
  for (std::size_t k = 0; k < n; ++k)
    for (std::size_t j = 0; j < k; ++j) {
      const double a = C(db, 0, k, j), c = C(db, 0, j, k);
      worst = std::max(worst, std::fabs(a - c) / cmax);
      if (std::max(std::fabs(a), std::fabs(c)) > 0.1 * cmax)
        worst_rel = std::max(worst_rel, std::fabs(a - c) / std::max(std::fabs(a), std::fabs(c)));
    }
  for (std::size_t k = 0; k < n; ++k) EXPECT_GT(C(db, 0, k, k), 0) << k;
  std::printf("[symmetry] max |C0 - C0^T| / max C0 = %.4f; max relative asymmetry (entries > 10 %% "
              "of max) = %.4f; max C0 = %.4g m/N\n", worst, worst_rel, cmax);
  EXPECT_LT(worst, 0.05);
}

TEST(ComplianceBuild, LineLoadMatchesAnalyticalToothCompliance) {
  const Built& b = built();
  const gm::ComplianceDb& db = b.db;
  ASSERT_FALSE(db.blocks.empty());
  gm::ToothSection s;
  gm::ToothSectionOptions so;
  so.bore_radius = db.bore_radius;
  std::string msg;
  ASSERT_EQ(gm::build_tooth_section(b.p, b.g, 0, so, s, msg), GM_OK) << msg;
  const std::size_t nf = db.face.size(), ir = db.roll.size() / 2, kf = nf / 2;
  const std::size_t k = ir * nf + kf;
  // Uniform line load q: nodal forces q * tributary width (trapezoid) at the same roll.
  double w = 0;
  for (std::size_t j = 0; j < nf; ++j) {
    const double lo = j == 0 ? db.face[0] : 0.5 * (db.face[j - 1] + db.face[j]);
    const double hi = j + 1 == nf ? db.face[nf - 1] : 0.5 * (db.face[j] + db.face[j + 1]);
    w += C(db, 0, k, ir * nf + j) * (hi - lo);
  }
  const double ana = gm::tooth_compliance(s, db.roll[ir]);
  const double ratio = w / ana;
  std::printf("[line load] roll %.4g mm: FE (depth %.2g mm) %.4g m^2/N, analytical %.4g m^2/N, "
              "ratio %.3f\n", db.roll[ir] * 1e3, db.depth * 1e3, w, ana, ratio);
  EXPECT_GT(ratio, 0.5);
  EXPECT_LT(ratio, 2.0);
}

TEST(ComplianceBuild, NeighbourCouplingIsSmallerAndPositive) {
  const gm::ComplianceDb& db = built().db;
  ASSERT_FALSE(db.blocks.empty());
  const std::size_t nf = db.face.size(), k = (db.roll.size() / 2) * nf + nf / 2;
  const double c0 = C(db, 0, k, k), cp = C(db, 1, k, k), cm = C(db, -1, k, k);
  std::printf("[neighbours] mid-profile mid-face: C0 %.4g, C+1 %.4g (%.3f), C-1 %.4g (%.3f) m/N\n",
              c0, cp, cp / c0, cm, cm / c0);
  EXPECT_GT(cp, 0);
  EXPECT_GT(cm, 0);
  EXPECT_LT(cp, c0);
  EXPECT_LT(cm, c0);
}

}  // namespace
