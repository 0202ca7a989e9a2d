// Compliance database builder (compliance_tool/src/compliance_build.hpp) on a small coarse gear
// (z = 20, m 2 mm, b 10 mm, n_c = 1): the written file reads back and matches the gear;
// Maxwell-Betti symmetry of C_0 (approximate: responses at depth h, loads on the surface);
// a uniform line load against the analytical tooth compliance; neighbour coupling; a load
// fraction of 0.6 against the full database; mesh convergence of the line-load compliance over
// three meshes; a lightweight body (thin web, 5 holes: not cyclic) against the solid one.
// One process: the builds are shared (about 40 s in all here).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "compliance_build.hpp"
#include "gearmesh/internal/compliance_db.hpp"
#include "gearmesh/gearmesh.h"
#include "gearmesh/internal/tooth_compliance.hpp"

namespace {

gm_model_params small_gear() {
  gm_model_params p;
  gm_default_params(&p);
  p.pair.normal_module = 0.002;
  p.pair.helix_angle = 0;
  p.gear[0].teeth = 20;
  p.gear[1].teeth = 40;
  for (int i = 0; i < 2; ++i) {
    p.gear[i].profile_shift = 0;
    p.gear[i].face_width = 0.010;
    p.gear[i].tip_diameter = 0;
  }
  p.pair.center_distance = 0.5 * 0.002 * 60;
  p.coupled_teeth = 1;
  return p;
}

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
    b.p = small_gear();
    char msg[512];
    EXPECT_EQ(gm_compute_geometry(&b.p, &b.g, msg, sizeof msg), GM_OK) << msg;
    b.o.mesh.elements_along_profile = 3;
    b.o.mesh.elements_across_width = 2;
    b.o.mesh.elements_in_fillet = 2;
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

// The same gear and mesh with other build options.
Built variant(const std::function<void(Built&)>& change, const char* what) {
  Built b;
  b.p = built().p;
  b.g = built().g;
  b.o = built().o;
  change(b);
  const auto t0 = std::chrono::steady_clock::now();
  std::string m;
  EXPECT_EQ(gm::ctool::build_compliance_db(b.p, 0, b.o, b.db, b.stats, m), GM_OK) << m;
  b.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("[build %s] %d nodes, %d elements, grid %d, %d tooth set(s), %d solves; factor %.2f s, "
              "solves %.2f s, total %.2f s\n", what, b.stats.nodes, b.stats.elements, b.stats.grid,
              b.stats.tooth_sets, b.stats.solves, b.stats.factor_seconds, b.stats.solve_seconds, b.seconds);
  return b;
}

// Line-load compliance at mid-profile (middle roll row) of tooth set t, m^2/N: a uniform line
// load q as nodal forces q * tributary width (the core's face strips), read at mid-face.
double line_load(const gm::ComplianceDb& db, std::size_t t = 0, int d = 0) {
  const std::size_t nf = db.face.size(), ir = db.roll.size() / 2, k = ir * nf + nf / 2;
  const std::vector<double>& Cd = db.blocks[db.block_index(t, 0, d)];
  double w = 0;
  for (std::size_t j = 0; j < nf; ++j) {
    const double lo = j == 0 ? db.face[0] : 0.5 * (db.face[j - 1] + db.face[j]);
    const double hi = j + 1 == nf ? db.face[nf - 1] : 0.5 * (db.face[j] + db.face[j + 1]);
    w += Cd[k * db.n_grid() + ir * nf + j] * (hi - lo);
  }
  return w;
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

// Load fraction 0.6: 21 of the 35 grid points loaded, the other columns from the reduction space
// (and, inside the profile, from the shifted roll neighbours): against the full database of the
// same mesh.
// The sparse solves (fe::Solver::solve_sparse: only the supernodes the loads reach and the
// readings need) give the database CHOLMOD's solves of the whole field give, to rounding.
TEST(ComplianceBuild, SparseSolvesMatchFullSolves) {
  const Built& sparse = built();
  const Built full = variant([](Built& b) { b.o.full_solves = true; }, "full solves");
  ASSERT_EQ(full.db.blocks.size(), sparse.db.blocks.size());
  double cmax = 0, worst = 0;
  for (const auto& B : full.db.blocks)
    for (double v : B) cmax = std::max(cmax, std::fabs(v));
  for (std::size_t bi = 0; bi < full.db.blocks.size(); ++bi) {
    ASSERT_EQ(full.db.blocks[bi].size(), sparse.db.blocks[bi].size());
    for (std::size_t i = 0; i < full.db.blocks[bi].size(); ++i)
      worst = std::max(worst, std::fabs(sparse.db.blocks[bi][i] - full.db.blocks[bi][i]));
  }
  std::printf("[sparse solves] max |C_sparse - C_full| / max |C| = %.2g over %zu blocks\n", worst / cmax,
              full.db.blocks.size());
  ASSERT_GT(cmax, 0);
  EXPECT_LT(worst / cmax, 1e-12);
}

TEST(ComplianceBuild, LoadFractionAgainstFullDatabase) {
  const Built& full = built();
  const Built f = variant([](Built& b) { b.o.load_fraction = 0.6; }, "fraction 0.6");
  ASSERT_FALSE(f.db.blocks.empty());
  EXPECT_EQ(f.stats.loaded, 21);
  const std::vector<int> L = gm::ctool::select_loaded(7, 5, 0.6);
  ASSERT_EQ(L.size(), 21u);
  double cmax = 0, worst = 0, worst_loaded = 0;
  for (const auto& B : full.db.blocks)
    for (double v : B) cmax = std::max(cmax, std::fabs(v));
  const std::size_t n = full.db.n_grid();
  std::vector<char> is(n, 0);
  for (int k : L) is[k] = 1;
  for (std::size_t bi = 0; bi < full.db.blocks.size(); ++bi)
    for (std::size_t k = 0; k < n; ++k)
      for (std::size_t j = 0; j < n; ++j) {
        const double e = std::fabs(f.db.blocks[bi][k * n + j] - full.db.blocks[bi][k * n + j]) / cmax;
        (is[j] ? worst_loaded : worst) = std::max(is[j] ? worst_loaded : worst, e);
      }
  const double w_full = line_load(full.db), w_f = line_load(f.db);
  std::printf("[fraction 0.6] max |C - C_full| / max C: unloaded columns %.4f, loaded columns %.2g; "
              "line-load compliance at mid-profile %+.4f relative; solves %d vs %d\n",
              worst, worst_loaded, w_f / w_full - 1, f.stats.solves, full.stats.solves);
  EXPECT_LT(worst_loaded, 1e-12);  // the loaded columns are the same solves
  EXPECT_LT(worst, 0.10);
  EXPECT_LT(std::fabs(w_f / w_full - 1), 0.03);
}

TEST(ComplianceBuild, SelectLoadedSpreadsThePoints) {
  // Fraction 1: every point; small fractions: at least one; the vertex lattice comes first.
  EXPECT_EQ(gm::ctool::select_loaded(7, 5, 1.0).size(), 35u);
  EXPECT_EQ(gm::ctool::select_loaded(7, 5, 1e-6).size(), 1u);
  const std::vector<int> L = gm::ctool::select_loaded(7, 5, 0.5);
  EXPECT_EQ(L.size(), 18u);
  for (int i = 0; i < 7; i += 2)
    for (int j = 0; j < 5; j += 2) EXPECT_NE(std::find(L.begin(), L.end(), i * 5 + j), L.end()) << i << " " << j;
}

// Face-averaged line-load compliance at mid-profile, m^2/N: the mean over the face (tributary
// weights) of the displacement under a uniform unit line load, sum_k sum_j w_k C_0[k][j] w_j / b
// over the middle roll row (symmetric in load and reading, so less sensitive to where the single
// mid-face reading sits in its element).
double mean_line_load(const gm::ComplianceDb& db) {
  const std::size_t nf = db.face.size(), ir = db.roll.size() / 2, n = db.n_grid();
  const std::vector<double>& C0 = db.blocks[db.block_index(0, 0, 0)];
  std::vector<double> w(nf);
  for (std::size_t j = 0; j < nf; ++j) {
    const double lo = j == 0 ? db.face[0] : 0.5 * (db.face[j - 1] + db.face[j]);
    const double hi = j + 1 == nf ? db.face[nf - 1] : 0.5 * (db.face[j] + db.face[j + 1]);
    w[j] = hi - lo;
  }
  double s = 0;
  for (std::size_t k = 0; k < nf; ++k)
    for (std::size_t j = 0; j < nf; ++j) s += w[k] * C0[(ir * nf + k) * n + ir * nf + j] * w[j];
  return s / (db.face.back() - db.face.front());
}

// Mesh convergence of the tooth compliance: the face-averaged line-load compliance at
// mid-profile over three uniformly refined meshes (profile x width elements 2 x 1, 3 x 2, 4 x 3,
// and the whole body, every tooth included, at the profile element size h_t: the default size
// field keeps the body at 4 m_n whatever the profile count, so its meshes are no refinement
// sequence), each change below 1 % of the finest value, the default graded mesh within 1 % of
// it; Richardson extrapolation with the observed order when the sequence is monotone; the
// finest (or extrapolated) value against Weber + Sainsot.
TEST(ComplianceBuild, LineLoadComplianceConvergesWithTheMesh) {
  // h_t: the involute's arc length from the form circle to the tip, (rho_a^2 - rho_Ff^2) / (2 r_b),
  // over the profile element count (gear_mesh.hpp)
  const gm_gear_geometry& gg = built().g.gear[0];
  const double involute = (gg.rho_a * gg.rho_a - gg.rho_Ff * gg.rho_Ff) / gg.d_b;
  auto uniform = [&](int n_profile, int n_width, const char* what) {
    return variant([&](Built& b) {
      b.o.mesh.elements_along_profile = n_profile;
      b.o.mesh.elements_across_width = n_width;
      b.o.mesh.fine_teeth = -1;
      b.o.mesh.body_size = involute / n_profile;
      b.o.coupled = 0;
    }, what);
  };
  const Built coarse = uniform(2, 1, "uniform 2 x 1");
  const Built mid = uniform(3, 2, "uniform 3 x 2");
  const Built fine = uniform(4, 3, "uniform 4 x 3");
  ASSERT_FALSE(coarse.db.blocks.empty());
  ASSERT_FALSE(fine.db.blocks.empty());
  const double w1 = mean_line_load(coarse.db), w2 = mean_line_load(mid.db), w3 = mean_line_load(fine.db);
  std::printf("[convergence] mid-face reading only (line_load): 2x1 %.5g, 3x2 %.5g, 4x3 %.5g m^2/N\n",
              line_load(coarse.db), line_load(mid.db), line_load(fine.db));
  // The mid-profile row is at the middle of the involute's length on every mesh.
  EXPECT_NEAR(coarse.db.roll[coarse.db.roll.size() / 2], fine.db.roll[fine.db.roll.size() / 2], 2e-6);
  const double d12 = w2 - w1, d23 = w3 - w2;
  // Richardson with the observed order for the refinement ratios 3/2 and 4/3 (element size
  // h ~ 1/n along the profile): w = w_inf + A h^p; solved for p by bisection.
  const double h1 = 1.0 / 2, h2 = 1.0 / 3, h3 = 1.0 / 4;
  auto resid = [&](double q) {
    return (w2 - w1) * (std::pow(h2, q) - std::pow(h3, q)) - (w3 - w2) * (std::pow(h1, q) - std::pow(h2, q));
  };
  double lo = 0.2, hi = 6, order = -1;
  if (resid(lo) * resid(hi) < 0) {
    for (int i = 0; i < 100; ++i) {
      const double m = 0.5 * (lo + hi);
      (resid(lo) * resid(m) <= 0 ? hi : lo) = m;
    }
    order = 0.5 * (lo + hi);
  }
  // Not monotone (no order found): no extrapolation, the finest value stands for the limit.
  const double q = order;
  const double w_inf = order > 0 ? w3 - (w3 - w2) / (std::pow(h3, q) - std::pow(h2, q)) * std::pow(h3, q) : w3;
  gm::ToothSection s;
  gm::ToothSectionOptions so;
  so.bore_radius = mid.db.bore_radius;
  std::string msg;
  ASSERT_EQ(gm::build_tooth_section(mid.p, mid.g, 0, so, s, msg), GM_OK) << msg;
  const double ana = gm::tooth_compliance(s, mid.db.roll[mid.db.roll.size() / 2]);
  std::printf("[convergence] face-averaged line-load compliance at mid-profile (m^2/N): 2x1 %.5g, 3x2 %.5g, 4x3 %.5g; "
              "differences %.3g, %.3g; observed order %.2f (-1: not monotone); Richardson %.5g (fine mesh "
              "%+.2f %% from it); "
              "analytical (Weber + Sainsot) %.5g, Richardson / analytical %.4f\n",
              w1, w2, w3, d12, d23, order, w_inf, 100 * (w3 / w_inf - 1), ana, w_inf / ana);
  // Converged: the quantity settles within 0.3 % already at 2 x 1 elements (measured: +0.02 %,
  // +0.28 %), so the successive changes are at the level of the depth readings' interpolation
  // noise and need not shrink monotonically; bounded instead: each change < 1 % of the finest
  // value. The default graded mesh (the shared 3 x 2 build: teeth at the profile size, the body
  // coarsening to 4 m_n) gives the same within 1 %.
  EXPECT_LT(std::fabs(d12), 0.01 * w3);
  EXPECT_LT(std::fabs(d23), 0.01 * w3);
  const double graded = mean_line_load(built().db);
  std::printf("[convergence] default graded 3 x 2 mesh %.5g m^2/N, %+.2f %% from the finest uniform\n",
              graded, 100 * (graded / w3 - 1));
  EXPECT_LT(std::fabs(graded / w3 - 1), 0.01);
  EXPECT_GT(w_inf / ana, 0.8);
  EXPECT_LT(w_inf / ana, 1.25);
}

// A lightweight body (thin web 3 mm of b = 10 mm between hub and rim, 5 lightening holes) is
// more compliant than the solid one with the same teeth, and couples the teeth more. Five holes
// on 20 teeth: symmetry order 5, so 4 distinct teeth are loaded, cyclic = 0.
TEST(ComplianceBuild, LightweightBodyIsMoreCompliantAndCouplesMore) {
  const Built& solid = built();
  const Built light = variant([](Built& b) {
    b.o.mesh.rim_inner_radius = 0.0140;
    b.o.mesh.hub_radius = 0.0095;
    b.o.mesh.web_thickness = 0.003;
    b.o.mesh.holes = 5;
    b.o.mesh.hole_radius = 0.0016;
    b.o.mesh.hole_circle_radius = 0.01175;
  }, "lightweight");
  ASSERT_FALSE(light.db.blocks.empty());
  const gm::ComplianceDb& L = light.db;
  EXPECT_EQ(L.cyclic, 0u);
  EXPECT_EQ(L.mirror, 0u);
  EXPECT_EQ(light.stats.symmetry, 5);
  EXPECT_EQ(light.stats.tooth_sets, 4);
  ASSERT_EQ(L.blocks.size(), 20u * 2 * 3);
  // Symmetric repeats are copies: tooth t and t + 4.
  EXPECT_EQ(L.blocks[L.block_index(1, 0, 1)], L.blocks[L.block_index(5, 0, 1)]);
  // Flank B of tooth t is flank A of tooth -t mirrored (d -> -d).
  EXPECT_EQ(L.blocks[L.block_index(1, 1, 1)], L.blocks[L.block_index(19, 0, -1)]);
  const std::size_t nf = L.face.size(), k = (L.roll.size() / 2) * nf + nf / 2;
  double worst_ratio = 1e9, max_coupling_light = 0;
  for (std::size_t t = 0; t < 4; ++t) {
    const double ratio = line_load(L, t) / line_load(solid.db);
    worst_ratio = std::min(worst_ratio, ratio);
    const std::vector<double>& c0 = L.blocks[L.block_index(t, 0, 0)];
    const std::vector<double>& cp = L.blocks[L.block_index(t, 0, 1)];
    const double coupling = cp[k * L.n_grid() + k] / c0[k * L.n_grid() + k];
    max_coupling_light = std::max(max_coupling_light, coupling);
    std::printf("[lightweight] tooth %zu: line-load compliance %.4g m^2/N = %.3f x solid; "
                "C+1/C0 at mid-profile mid-face %.3f\n", t, line_load(L, t), ratio, coupling);
  }
  const std::size_t nfs = solid.db.face.size(), ks = (solid.db.roll.size() / 2) * nfs + nfs / 2;
  const double solid_coupling = C(solid.db, 1, ks, ks) / C(solid.db, 0, ks, ks);
  std::printf("[lightweight] solid C+1/C0 %.3f; smallest compliance ratio light/solid %.3f\n",
              solid_coupling, worst_ratio);
  EXPECT_GT(worst_ratio, 1.0);
  for (std::size_t t = 0; t < 4; ++t) {
    const std::vector<double>& c0 = L.blocks[L.block_index(t, 0, 0)];
    const std::vector<double>& cp = L.blocks[L.block_index(t, 0, 1)];
    EXPECT_GT(cp[k * L.n_grid() + k] / c0[k * L.n_grid() + k], solid_coupling) << "tooth " << t;
  }
}

}  // namespace

// A helical body with many layers across the face: the form-circle edge is a helix whose
// mid-layer nodes sit on its chords, off the helix by a few um in roll near the form circle
// (beta 15 deg, 6 layers over 10 mm); the flank grid must still be recognized as the full
// n_roll x n_face lattice (it was refused as "not a lattice" with a 1 um tolerance).
TEST(ComplianceBuild, HelicalFlankGridWithManyLayers) {
  const Built helical = variant([](Built& b) {
    b.p.pair.helix_angle = 15 * std::acos(-1.0) / 180;
    b.p.pair.center_distance = 0.0622;  // a = m_n (z1 + z2) / (2 cos beta) = 62.12 mm, x = 0
    b.o.mesh.elements_along_profile = 2;
    b.o.mesh.elements_in_fillet = 1;
    b.o.mesh.elements_across_width = 6;
    b.o.coupled = 0;
  }, "helical 2 x 6");
  ASSERT_FALSE(helical.db.blocks.empty());
  EXPECT_EQ(helical.db.roll.size(), 5u);
  EXPECT_EQ(helical.db.face.size(), 13u);
  EXPECT_LT(helical.stats.max_roll_offset, 0.25);
  EXPECT_NEAR(helical.db.face.front(), -0.005, 1e-9);
  EXPECT_NEAR(helical.db.face.back(), 0.005, 1e-9);
}

// A helical body whose web is off mid-face has no mirror symmetry (the half turn that maps flank
// A onto flank B also moves the web to the other side), so flank B is loaded explicitly: the
// cyclic database has mirror = 0 and two flank sets. Independent check: that half turn maps the
// body with the web at +o onto the body with the web at -o, so flank B (offset d) of the first
// equals flank A (offset -d, face index reversed) of the second, within the meshes' asymmetry.
TEST(ComplianceBuild, HelicalOffCentreWebLoadsFlankB) {
  auto body = [](double offset, const char* what) {
    return variant([offset](Built& b) {
      b.p.pair.helix_angle = 15 * std::acos(-1.0) / 180;
      b.p.pair.center_distance = 0.0622;
      b.o.mesh.elements_along_profile = 2;
      b.o.mesh.elements_in_fillet = 1;
      b.o.mesh.elements_across_width = 4;
      b.o.mesh.rim_inner_radius = 0.0140;
      b.o.mesh.hub_radius = 0.0095;
      b.o.mesh.web_thickness = 0.004;
      b.o.mesh.web_offset = offset;
      b.o.coupled = 1;
    }, what);
  };
  const Built plus = body(0.002, "helical web +2 mm"), minus = body(-0.002, "helical web -2 mm");
  ASSERT_FALSE(plus.db.blocks.empty());
  ASSERT_FALSE(minus.db.blocks.empty());
  ASSERT_EQ(plus.db.cyclic, 1u);
  ASSERT_EQ(plus.db.mirror, 0u);
  ASSERT_EQ(plus.db.blocks.size(), 2u * 3u);
  const std::size_t n = plus.db.n_grid(), nf = plus.db.face.size();
  ASSERT_EQ(minus.db.n_grid(), n);
  auto flip = [&](std::size_t k) { return (k / nf) * nf + (nf - 1 - k % nf); };
  double cmax = 0, worst = 0, own = 0;
  for (const auto& B : plus.db.blocks)
    for (double v : B) cmax = std::max(cmax, std::fabs(v));
  for (int d = -1; d <= 1; ++d) {
    const auto& B = plus.db.blocks[plus.db.block_index(0, 1, d)];
    const auto& A = minus.db.blocks[minus.db.block_index(0, 0, -d)];
    const auto& Aown = plus.db.blocks[plus.db.block_index(0, 0, -d)];
    for (std::size_t k = 0; k < n; ++k)
      for (std::size_t j = 0; j < n; ++j) {
        worst = std::max(worst, std::fabs(B[k * n + j] - A[flip(k) * n + flip(j)]) / cmax);
        own = std::max(own, std::fabs(B[k * n + j] - Aown[flip(k) * n + flip(j)]) / cmax);
      }
  }
  std::printf("[off-centre web] flank B vs the mirrored body's flank A: %.4f of the largest entry; "
              "vs its own flank A mirrored (what mirror = 1 would give): %.4f\n", worst, own);
  // Measured: 0.054 (it was 0.26 when flank B's points were mirrored from flank A's opposite
  // face row, which is not flank B's own height on an asymmetric face grid); explicit flank B
  // against the mirror of flank A on a symmetric body of this mesh: 0.056, the meshes' own
  // asymmetry. Bound 8 %, and well below what mirror = 1 would have given (0.16).
  EXPECT_LT(worst, 0.08);
  EXPECT_LT(worst, 0.5 * own);
}
