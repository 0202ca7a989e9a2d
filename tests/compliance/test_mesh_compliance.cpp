// Mesher-level FE checks through the whole compliance build (compliance_tool/src/gear_mesh.hpp,
// compliance_build.hpp), small gears and coarse element counts:
// * the size field (coarse body, far teeth) leaves the tooth compliance of the loaded tooth and
//   its neighbour coupling within a stated bound of a uniformly fine mesh;
// * internal rings: the line-load compliance of a ring tooth approaches that of an external tooth
//   of the same basic rack as |z| grows (both tend to the rack tooth), and a thin rim is more
//   compliant than a thick one.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "compliance_build.hpp"
#include "gearmesh/gearmesh.h"

namespace {

struct Result {
  gm::ComplianceDb db;
  gm::ctool::BuildStats stats;
  double line = 0;  // line-load compliance at mid-profile, m^2/N
  double c0 = 0, c1 = 0;  // point compliances at mid-profile mid-face, tooth 0 and +1, m/N
};

double C(const gm::ComplianceDb& db, int d, std::size_t k, std::size_t j) {
  return db.blocks[db.block_index(0, 0, d)][k * db.n_grid() + j];
}

// Build and evaluate: a uniform line load q across the face at mid-profile (nodal forces q times
// the tributary widths), displacement at depth at mid-face, / q.
Result build(const gm_model_params& p, int gear, const gm::ctool::BuildOptions& o) {
  Result r;
  std::string msg;
  EXPECT_EQ(gm::ctool::build_compliance_db(p, gear, o, r.db, r.stats, msg), GM_OK) << msg;
  if (r.db.blocks.empty()) return r;
  const auto& db = r.db;
  const std::size_t nf = db.face.size(), ir = db.roll.size() / 2, k = ir * nf + nf / 2;
  for (std::size_t j = 0; j < nf; ++j) {
    const double lo = j == 0 ? db.face[0] : 0.5 * (db.face[j - 1] + db.face[j]);
    const double hi = j + 1 == nf ? db.face[nf - 1] : 0.5 * (db.face[j] + db.face[j + 1]);
    r.line += C(db, 0, k, ir * nf + j) * (hi - lo);
  }
  r.c0 = C(db, 0, k, k);
  if (db.n_coupled > 0) r.c1 = C(db, 1, k, k);
  return r;
}

gm_model_params spur(int z1, int z2, double m, double b) {
  gm_model_params p;
  gm_default_params(&p);
  p.pair.normal_module = m;
  p.pair.helix_angle = 0;
  p.gear[0].teeth = z1;
  p.gear[1].teeth = z2;
  for (int i = 0; i < 2; ++i) {
    p.gear[i].profile_shift = 0;
    p.gear[i].face_width = b;
    p.gear[i].tip_diameter = 0;
  }
  p.pair.center_distance = 0.5 * m * (z1 + z2);
  p.coupled_teeth = 1;
  return p;
}

// The profile element size h_t the mesher uses for these options.
double coarse_profile_size(const gm_model_params& p, const gm::mesh::GearBodyOptions& o) {
  gm_pair_geometry g;
  char buf[512];
  EXPECT_EQ(gm_compute_geometry(&p, &g, buf, sizeof buf), GM_OK) << buf;
  gm::mesh::GearBodyOptions c = o;
  c.elements_across_width = 1;
  c.body_size = 0.01;
  gm::mesh::GearBodyMesh m;
  std::string msg;
  EXPECT_EQ(gm::mesh::build_gear_body(p, g, 0, c, m, msg), GM_OK) << msg;
  return m.profile_size;
}

TEST(MeshCompliance, SizeFieldKeepsTheToothCompliance) {
  const gm_model_params p = spur(20, 40, 0.002, 0.010);
  gm::ctool::BuildOptions o;
  o.mesh.elements_along_profile = 5;
  o.mesh.elements_across_width = 2;
  o.mesh.elements_in_fillet = 2;
  o.mesh.bore_radius = 0.006;
  o.coupled = 1;
  const Result coarse = build(p, 0, o);  // defaults: body 1.5 m_n, fine teeth +-3
  // Uniformly fine: every tooth at the profile counts, body at the profile size.
  gm::ctool::BuildOptions f = o;
  f.mesh.fine_teeth = -1;
  f.mesh.body_size = coarse_profile_size(p, o.mesh);
  const Result fine = build(p, 0, f);
  ASSERT_GT(fine.line, 0);
  ASSERT_GT(coarse.line, 0);
  const double dl = coarse.line / fine.line - 1, d0 = coarse.c0 / fine.c0 - 1, d1 = coarse.c1 / fine.c1 - 1;
  std::printf("[size field] nodes %d (coarsened) vs %d (uniform); line-load compliance %.5g vs %.5g "
              "m^2/N (%+.3f %%); C0 %+.3f %%, C+1 %+.3f %%\n",
              coarse.stats.nodes, fine.stats.nodes, coarse.line, fine.line, 100 * dl, 100 * d0, 100 * d1);
  // Bounds: the FE tooth compliance at these counts is itself within about 2 % of the analytical
  // one (test_compliance_build); the coarsening must stay well inside that: 1 % on the line load
  // and the point compliance, 3 % on the (6 x smaller) neighbour coupling.
  EXPECT_LT(coarse.stats.nodes, fine.stats.nodes / 2);
  EXPECT_LT(std::fabs(dl), 0.01);
  EXPECT_LT(std::fabs(d0), 0.01);
  EXPECT_LT(std::fabs(d1), 0.03);
}

// An internal pair whose ring (gear 2) has n teeth, pinion n - 12, x = 0, m 2 mm, b 4 mm.
gm_model_params internal_pair(int n) {
  gm_model_params p = spur(n - 12, n, 0.002, 0.004);
  p.pair.internal = 1;
  p.pair.center_distance = 0.5 * 0.002 * 12;
  for (int i = 0; i < 2; ++i) p.gear[i].thickness_allowance = -30e-6;
  return p;
}

gm::ctool::BuildOptions ring_options() {
  gm::ctool::BuildOptions o;
  o.mesh.elements_along_profile = 4;
  o.mesh.elements_across_width = 1;
  o.mesh.elements_in_fillet = 2;
  o.coupled = 0;
  return o;
}

// As |z| grows an internal and an external tooth of the same basic rack both tend to the rack
// tooth, so their line-load compliances (same rim thickness t = 3 m behind the root circle:
// external bore r_f - t, ring rim r_f + t) must approach each other.
TEST(MeshCompliance, RingToothApproachesExternalToothAtLargeZ) {
  const int ns[2] = {45, 135};
  double gap[2] = {0, 0};
  for (int i = 0; i < 2; ++i) {
    const int n = ns[i];
    const gm_model_params pr = internal_pair(n);
    gm_model_params pe = spur(n, n, 0.002, 0.004);
    pe.gear[0].thickness_allowance = -30e-6;
    gm_pair_geometry gr, ge;
    char buf[512];
    ASSERT_EQ(gm_compute_geometry(&pr, &gr, buf, sizeof buf), GM_OK) << buf;
    ASSERT_EQ(gm_compute_geometry(&pe, &ge, buf, sizeof buf), GM_OK) << buf;
    gm::ctool::BuildOptions o = ring_options();
    o.mesh.outer_radius = 0.5 * gr.gear[1].d_f + 0.006;
    const Result ring = build(pr, 1, o);
    o = ring_options();
    o.mesh.bore_radius = 0.5 * ge.gear[0].d_f - 0.006;
    const Result ext = build(pe, 0, o);
    ASSERT_GT(ring.line, 0);
    ASSERT_GT(ext.line, 0);
    gap[i] = ring.line / ext.line - 1;
    std::printf("[ring vs external] |z| = %d: line-load compliance ring %.5g, external %.5g m^2/N, "
                "ring/external - 1 = %+.2f %% (nodes %d, %d)\n",
                n, ring.line, ext.line, 100 * gap[i], ring.stats.nodes, ext.stats.nodes);
  }
  // The finite-|z| difference is of order 1/|z| (curvature of the root circle): tripling |z| must
  // at least halve it.
  EXPECT_LT(std::fabs(gap[1]), 0.5 * std::fabs(gap[0]));
}

// The ring is clamped on its outer cylinder, so the rim is the elastic layer between the
// clamp and the tooth root: the tooth's compliance grows with the rim thickness (1.5, 3, 6 m)
// and saturates as the clamp moves away (smaller increase for the second step, twice as long).
// (A thin rim is the more compliant one only when the rim is not clamped all round, e.g. held
// by a web or a few bolts; that support is not modelled here.)
TEST(MeshCompliance, RingCompliancePerRimThickness) {
  const gm_model_params p = internal_pair(60);
  gm_pair_geometry g;
  char buf[512];
  ASSERT_EQ(gm_compute_geometry(&p, &g, buf, sizeof buf), GM_OK) << buf;
  const double t[3] = {0.003, 0.006, 0.012};
  double c[3];
  for (int i = 0; i < 3; ++i) {
    gm::ctool::BuildOptions o = ring_options();
    o.mesh.outer_radius = 0.5 * g.gear[1].d_f + t[i];
    c[i] = build(p, 1, o).line;
  }
  std::printf("[ring rim] line-load compliance for rims of 1.5, 3, 6 m: %.5g, %.5g, %.5g m^2/N\n",
              c[0], c[1], c[2]);
  EXPECT_GT(c[1], c[0]);
  EXPECT_GT(c[2], c[1]);
  EXPECT_LT(c[2] - c[1], c[1] - c[0]);
}

}  // namespace
