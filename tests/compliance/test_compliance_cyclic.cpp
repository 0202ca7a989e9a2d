// The cyclic shortcut (compliance_tool/src/compliance_build.hpp) against loading every tooth: on
// a solid (cyclic) body with a small tooth count (z = 12, m 2 mm, b 8 mm, x = 0.4, 2 x 2
// elements, n_c = 1), --every-tooth loads all 12 teeth (cyclic = 0, z tooth sets) in the one
// factorization. The cyclic database is tooth 0's set (the same mesh, loads and readings: the
// reference tooth's set of the every-tooth build IS what the cyclic build writes, checked below
// by a cyclic build of the same mesh); every other tooth's set must equal it within the mesh's
// non-cyclicity: the transverse mesh is unstructured, so each tooth's neighbourhood is meshed a
// little differently and the depth readings (interpolated inside elements of about the grid
// spacing) differ by a discretization error of the same kind as C_0's Maxwell-Betti asymmetry
// (2.2 % of the largest entry on the z = 20 mesh of test_compliance_build). The bound is 5 % of
// the largest entry, the same as that asymmetry bound; the measured value is printed.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>

#include "compliance_build.hpp"
#include "gearmesh/internal/compliance_db.hpp"
#include "gearmesh/gearmesh.h"

namespace {

struct Pair {
  gm_model_params p;
  gm::ctool::BuildOptions o;
};

Pair small12() {
  Pair s;
  gm_default_params(&s.p);
  s.p.pair.normal_module = 0.002;
  s.p.pair.helix_angle = 0;
  s.p.gear[0].teeth = 12;
  s.p.gear[1].teeth = 40;
  s.p.gear[0].profile_shift = 0.4;  // no undercut at z = 12
  s.p.gear[1].profile_shift = -0.4;
  for (int i = 0; i < 2; ++i) {
    s.p.gear[i].face_width = 0.008;
    s.p.gear[i].tip_diameter = 0;
  }
  s.p.pair.center_distance = 0.5 * 0.002 * 52;
  s.p.coupled_teeth = 1;
  s.o.mesh.elements_along_profile = 2;
  s.o.mesh.elements_across_width = 2;
  s.o.mesh.elements_in_fillet = 2;
  // Every tooth at the full element counts in both builds (the every-tooth build needs it and
  // sets it itself), so that both use the same mesh.
  s.o.mesh.fine_teeth = -1;
  s.o.depth = 0.5e-3;
  s.o.coupled = 1;
  return s;
}

TEST(ComplianceCyclic, EveryToothEqualsTheCyclicShortcut) {
  Pair s = small12();
  gm::ComplianceDb cyc, every;
  gm::ctool::BuildStats st_c, st_e;
  std::string msg;
  auto t0 = std::chrono::steady_clock::now();
  ASSERT_EQ(gm::ctool::build_compliance_db(s.p, 0, s.o, cyc, st_c, msg), GM_OK) << msg;
  const double sec_c = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  s.o.every_tooth = true;
  t0 = std::chrono::steady_clock::now();
  ASSERT_EQ(gm::ctool::build_compliance_db(s.p, 0, s.o, every, st_e, msg), GM_OK) << msg;
  const double sec_e = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("[cyclic] z = 12: %d nodes, grid %d; cyclic build %.2f s (%d solves), every tooth %.2f s "
              "(%d solves)\n", st_c.nodes, st_c.grid, sec_c, st_c.solves, sec_e, st_e.solves);
  ASSERT_EQ(cyc.cyclic, 1u);
  ASSERT_EQ(every.cyclic, 0u);
  ASSERT_EQ(every.mirror, 0u);
  ASSERT_EQ(every.blocks.size(), 12u * 2 * 3);
  ASSERT_EQ(st_e.tooth_sets, 12);
  const int nc = 1;
  double cmax = 0;
  for (const auto& B : cyc.blocks)
    for (double v : B) cmax = std::max(cmax, std::fabs(v));
  // Tooth 0's flank-A set is the cyclic database itself (same mesh, loads and readings; the
  // solves run in other right-hand-side batches, so equal to round-off, 1e-9 of the largest).
  for (int d = -nc; d <= nc; ++d)
    for (std::size_t i = 0; i < cyc.blocks[0].size(); ++i)
      ASSERT_NEAR(every.blocks[every.block_index(0, 0, d)][i], cyc.blocks[cyc.block_index(0, 0, d)][i],
                  1e-9 * cmax);
  // Every tooth, both flanks, against the cyclic set (flank B read as the core reads a mirrored
  // cyclic database: flank A's set with d -> -d).
  double worst = 0;
  int worst_t = -1;
  for (int t = 0; t < 12; ++t)
    for (int f = 0; f < 2; ++f)
      for (int d = -nc; d <= nc; ++d) {
        const auto& A = every.blocks[every.block_index(t, f, d)];
        const auto& R = cyc.blocks[cyc.block_index(0, 0, f ? -d : d)];
        for (std::size_t i = 0; i < A.size(); ++i) {
          const double e = std::fabs(A[i] - R[i]) / cmax;
          if (e > worst) worst = e, worst_t = t;
        }
      }
  // The same mesh's Maxwell-Betti asymmetry of C_0, for scale (a discretization error of the
  // depth readings of the same size).
  const std::size_t n = cyc.n_grid();
  double asym = 0;
  for (std::size_t k = 0; k < n; ++k)
    for (std::size_t j = 0; j < k; ++j)
      asym = std::max(asym, std::fabs(cyc.blocks[1][k * n + j] - cyc.blocks[1][j * n + k]) / cmax);
  std::printf("[cyclic] max |C(every tooth) - C(cyclic)| / max C = %.4f (tooth %d); this mesh's "
              "max |C0 - C0^T| / max C = %.4f\n", worst, worst_t, asym);
  EXPECT_LT(worst, 0.05);
}

// A user-supplied mesh end to end: the every-tooth build writes its body mesh (--write-mesh),
// a second build reads it back as a user mesh (--mesh: clamped and flank nodes found
// geometrically, taken as not cyclic, both flanks loaded explicitly). On the same mesh with the
// same load points the flank-A sets must agree to round-off; flank B, loaded here but mirrored
// there, within the mesh's non-cyclicity bound of the test above (5 %).
TEST(ComplianceCyclic, UserMeshRoundTripGivesTheSameDatabase) {
  Pair s = small12();
  s.o.every_tooth = true;
  s.o.write_mesh = ::testing::TempDir() + "gearmesh_user_mesh_z12.msh";
  gm::ComplianceDb every, user;
  gm::ctool::BuildStats st_e, st_u;
  std::string msg;
  ASSERT_EQ(gm::ctool::build_compliance_db(s.p, 0, s.o, every, st_e, msg), GM_OK) << msg;
  Pair u = small12();
  u.o.mesh.mesh_file = s.o.write_mesh;
  ASSERT_EQ(gm::ctool::build_compliance_db(u.p, 0, u.o, user, st_u, msg), GM_OK) << msg;
  ASSERT_EQ(user.cyclic, 0u);
  ASSERT_EQ(user.mirror, 0u);
  ASSERT_EQ(st_u.nodes, st_e.nodes);
  ASSERT_EQ(user.roll.size(), every.roll.size());
  ASSERT_EQ(user.face.size(), every.face.size());
  double cmax = 0;
  for (const auto& B : every.blocks)
    for (double v : B) cmax = std::max(cmax, std::fabs(v));
  double worst_a = 0, worst_b = 0;
  for (int t = 0; t < 12; ++t)
    for (int f = 0; f < 2; ++f)
      for (int d = -1; d <= 1; ++d) {
        const auto& U = user.blocks[user.block_index(t, f, d)];
        const auto& E = every.blocks[every.block_index(t, f, d)];
        for (std::size_t i = 0; i < U.size(); ++i)
          (f ? worst_b : worst_a) = std::max(f ? worst_b : worst_a, std::fabs(U[i] - E[i]) / cmax);
      }
  std::printf("[user mesh] %d nodes, %d solves; |user - generated| / max C: flank A %.3g, flank B "
              "%.4f\n", st_u.nodes, st_u.solves, worst_a, worst_b);
  EXPECT_LT(worst_a, 1e-9);
  EXPECT_LT(worst_b, 0.05);
}

}  // namespace
