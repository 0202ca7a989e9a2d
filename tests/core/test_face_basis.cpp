// Level 5's coupled solve on the reduced face basis (solver.face_shapes, face_basis.hpp) against
// the solve over every slice (solver.face_shapes = 0), on the synthetic databases of
// tests/core/fe_synthetic.hpp: quasi-static sweeps agree within 0.5 % in mean, peak-to-peak and
// mesh orders 1-3 of the TE (spur aligned and tilted), taking the reduced basis at most poses;
// where a slice unloads (a lead crowned pair, a heavy tilt) and on a helical pair the answer is
// the full solve's, bit for bit. (Directional derivatives with the reduced basis:
// test_jacobian.cpp, Level5FaceBasisMatchesCentralDifferences.)
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <functional>
#include <cstdio>
#include <string>
#include <vector>

#include "fe_compliance.hpp"
#include "fe_synthetic.hpp"
#include "gearmesh/gearmesh.h"
#include "model.hpp"
#include "test_support.hpp"

namespace {

using gm_test::kPi;

// p with level 5 on each gear's smooth synthetic database (tests/core/fe_synthetic.hpp), `edit`
// applied to each before it is written (once per call and gear).
void fe_level(gm_model_params& p, const std::function<void(gm::ComplianceDb&, int gear)>& edit = {}) {
  static std::vector<std::string> paths;
  p.stiffness_level = GM_STIFFNESS_FE;
  p.slices = 10;
  p.coupled_teeth = 2;
  p.compliance[0] = p.compliance[1] = nullptr;
  for (int g = 0; g < 2; ++g) {
    std::string msg;
    gm::ComplianceDb db = gm_test::smooth_db(p, g, gm_test::SmoothDbShape{}, msg);
    ASSERT_TRUE(msg.empty()) << msg;
    if (edit) edit(db, g);
    const std::string name = std::to_string(::getpid()) + "_face_basis_" + std::to_string(paths.size()) + ".gcdb";
    const std::string path = (std::filesystem::temp_directory_path() / name).string();
    ASSERT_EQ(gm::write_compliance_db(path.c_str(), db, msg), GM_OK) << msg;
    gm_test::written_files().paths.push_back(path);
    paths.push_back(path);
  }
  p.compliance[0] = (paths.end() - 2)->c_str();
  p.compliance[1] = paths.back().c_str();
}

gm_model_params helical(gm_model_params p) {
  p.pair.helix_angle = 15 * kPi / 180;
  p.gear[0].profile_shift = p.gear[1].profile_shift = 0;
  p.pair.center_distance = 0.0026 / std::cos(p.pair.helix_angle) * 57 + 50e-6;
  return p;
}

// The loaded TE over one pitch of gear 1 (N poses): mean, peak-to-peak and the amplitudes of
// mesh orders 1-3, and the share of poses solved on the reduced basis.
struct Sweep {
  double mean = 0, pp = 0, order[3] = {0, 0, 0}, reduced = 0;
};

Sweep sweep(gm_model_params p, int shapes, double torque, double tilt, int N = 40) {
  p.quasi_static = 1;
  p.solver_face_shapes = shapes;
  gm_test::Instance I(p);
  gm_kinematics k{};
  k.load_torque = torque;
  k.r[1][0] = k.r[1][1] = tilt;
  std::vector<double> te;
  Sweep s;
  for (int i = 0; i < N; ++i) {
    k.phi[0] = 2 * kPi / p.gear[0].teeth / N * i;
    gm_result r{};
    EXPECT_EQ(gm_evaluate(I.m, I.d, &k, &r), GM_OK) << gm_data_message(I.d);
    te.push_back(r.te);
    s.reduced += I.d->face.used ? 1.0 / N : 0.0;
  }
  const auto [lo, hi] = std::minmax_element(te.begin(), te.end());
  s.pp = *hi - *lo;
  for (double t : te) s.mean += t / N;
  for (int h = 1; h <= 3; ++h) {
    std::complex<double> c = 0;
    for (int j = 0; j < N; ++j) c += te[j] * std::polar(1.0, -2 * kPi * h * j / N);
    s.order[h - 1] = 2 * std::abs(c) / N;
  }
  return s;
}

void expect_close(const Sweep& full, const Sweep& red, const std::string& what) {
  const double tol = 0.005;
  EXPECT_NEAR(red.mean, full.mean, tol * std::fabs(full.mean)) << what << ": mean TE";
  EXPECT_NEAR(red.pp, full.pp, tol * full.pp) << what << ": peak-to-peak TE";
  for (int h = 0; h < 3; ++h)
    EXPECT_NEAR(red.order[h], full.order[h], tol * full.order[h]) << what << ": mesh order " << h + 1;
  std::printf("  %-40s mean %+.4f %%  p-p %+.4f %%  orders %+.4f %+.4f %+.4f %%  reduced at %.0f %% of the poses\n",
              what.c_str(), 100 * (red.mean / full.mean - 1), 100 * (red.pp / full.pp - 1),
              100 * (red.order[0] / full.order[0] - 1), 100 * (red.order[1] / full.order[1] - 1),
              100 * (red.order[2] / full.order[2] - 1), 100 * red.reduced);
}

TEST(FaceBasis, QuasiStaticSweepsAgreeWithTheFullSolve) {
  struct Scene {
    const char* name;
    gm_model_params p;
    double tilt;
    int shapes;
    double min_reduced[2];  // share of the poses that must take the reduced basis, 50 / 300 N m
    double max_reduced[2];  // share of the poses that may
  };
  gm_model_params spur = gm_test::paper();
  fe_level(spur);
  // one shape holds the zigzag of the face's load only near its line load (100 kN/m): at 50 N m
  // its slices' gaps are 1-3 % of the approach, beyond the acceptance (1 %), and the slices
  // answer; at 300 N m it holds 45 % of the poses (73 % when its samples at the path's ends left
  // out the tip corners' near field); up to three shapes are the uniform approach's responses
  // (face_shapes.cpp), a tilt takes a fourth; a tilt of 0.2 mrad opens a face end at 50 N m
  const Scene scenes[] = {
      {"spur, 1 shape", spur, 0, 1, {0, 0.4}, {0, 1}},
      {"spur, 2 shapes", spur, 0, 2, {0.95, 0.95}, {1, 1}},
      {"spur, 3 shapes", spur, 0, 3, {0.95, 0.95}, {1, 1}},
      {"spur tilted 0.2 mrad, 2 shapes", spur, 2e-4, 2, {0, 0}, {1, 1}},
      {"spur tilted 0.2 mrad, 3 shapes", spur, 2e-4, 3, {0, 0}, {1, 1}},
      {"spur tilted 0.2 mrad, 4 shapes", spur, 2e-4, 4, {0, 0.9}, {1, 1}},
  };
  for (const Scene& s : scenes)
    for (int t = 0; t < 2; ++t) {
      const double torque = t == 0 ? 50.0 : 300.0;
      const std::string what = std::string(s.name) + ", " + std::to_string(int(torque)) + " N m";
      const Sweep full = sweep(s.p, 0, torque, s.tilt), red = sweep(s.p, s.shapes, torque, s.tilt);
      EXPECT_EQ(full.reduced, 0.0);
      expect_close(full, red, what);
      EXPECT_GE(red.reduced, s.min_reduced[t]) << what << ": the reduced basis was hardly taken";
      EXPECT_LE(red.reduced, s.max_reduced[t] + 1e-9) << what << ": the reduced basis was taken beyond its acceptance";
    }
}

// A helical pair's contact lines end inside the face: the slices answer, without a reduced
// attempt first (on the synthetic databases two or three shapes were accepted at 2-50 % of the
// poses of a quasi-static sweep, mostly with slice gaps of 3-10 %, and moved mesh order 3 by 1 %).
TEST(FaceBasis, HelicalPairsAreSolvedOverTheSlices) {
  gm_model_params hel = helical(gm_test::paper());
  fe_level(hel);
  for (double torque : {50.0, 300.0}) {
    const Sweep full = sweep(hel, 0, torque, 0), red = sweep(hel, 2, torque, 0);
    EXPECT_EQ(red.reduced, 0.0) << torque;
    EXPECT_EQ(red.mean, full.mean) << torque;
    EXPECT_EQ(red.pp, full.pp) << torque;
  }
}

// Where a slice of a loaded pair unloads (lead crowning at a light load, a heavy tilt), the
// reduced answer would need a negative slice force or leave a slice penetrating: the solve over
// the slices answers instead, and the result is the full solve's bit for bit.
TEST(FaceBasis, AnUnloadingSliceIsSolvedOverTheSlices) {
  gm_model_params crowned = gm_test::paper();
  for (auto& g : crowned.gear)
    for (auto& f : g.flank) f.lead_crowning = 8e-6;
  fe_level(crowned);
  gm_model_params tilted = gm_test::paper();
  fe_level(tilted);
  struct Scene {
    const char* name;
    gm_model_params p;
    double tilt, te;
  } scenes[] = {{"lead crowned 8 um", crowned, 0, 8e-6}, {"tilted 1 mrad", tilted, 1e-3, 6e-6}};
  for (const Scene& s : scenes) {
    gm_model_params pr = s.p, pf = s.p;
    pr.solver_face_shapes = 2;
    pf.solver_face_shapes = 0;
    gm_test::Instance R(pr), F(pf);
    const double rb1 = R.rb(0), rb2 = R.rb(1);
    int unloading = 0, complete = 0;
    for (int i = 0; i < 20; ++i) {
      gm_kinematics k{};
      k.phi[0] = 2 * kPi / 57 / 20 * i;
      k.phi[1] = (s.te - rb1 * k.phi[0]) / rb2;
      k.r[1][0] = k.r[1][1] = s.tilt;
      gm_result rr{}, rf{};
      ASSERT_EQ(gm_evaluate(R.m, R.d, &k, &rr), GM_OK) << gm_data_message(R.d);
      ASSERT_EQ(gm_evaluate(F.m, F.d, &k, &rf), GM_OK) << gm_data_message(F.d);
      // a loaded tooth pair with fewer loaded slices than the face has: slices unloaded there
      int per_pair[8] = {};
      for (int a = 0; a < F.d->loaded_count; ++a) ++per_pair[F.d->loaded[a].pair & 7];
      bool partial = false;
      for (int q = 0; q < 8; ++q) partial = partial || (per_pair[q] > 0 && per_pair[q] < pf.slices);
      unloading += partial;
      if (!partial) continue;
      if (R.d->face.used) {
        // a pair with no more solved slices than shapes: the basis spans them, the answer is the
        // slices' own (to rounding)
        ++complete;
        EXPECT_NEAR(rr.normal_force, rf.normal_force, 1e-9 * rf.normal_force) << s.name << ", pose " << i;
        EXPECT_NEAR(rr.stiffness, rf.stiffness, 1e-9 * rf.stiffness) << s.name << ", pose " << i;
        EXPECT_NEAR(rr.max_line_load, rf.max_line_load, 1e-9 * rf.max_line_load) << s.name << ", pose " << i;
        continue;
      }
      EXPECT_EQ(rr.normal_force, rf.normal_force) << s.name << ", pose " << i;
      EXPECT_EQ(rr.stiffness, rf.stiffness) << s.name << ", pose " << i;
      EXPECT_EQ(rr.moment[0][2], rf.moment[0][2]) << s.name << ", pose " << i;
      EXPECT_EQ(rr.max_line_load, rf.max_line_load) << s.name << ", pose " << i;
    }
    EXPECT_GE(unloading, 10) << s.name << ": too few poses with an unloaded slice to test";
    std::printf("  %s: %d poses with an unloaded slice, %d of them on a complete basis\n", s.name, unloading, complete);
    EXPECT_GE(unloading - complete, 5) << s.name << ": too few poses the slices answered";
  }
}


// p at level 5 on synthetic databases whose blocks are not symmetric across the face:
// C_d[(a, m)][(b, n)] scaled by 1 + 0.2 s_d (z_m - z_n) / b with s_d = sign(d), 1 at d = 0.
// Between neighbour teeth this keeps Maxwell-Betti (C_-d[(b, n)][(a, m)] is the same value) and a
// chunk's V Phi and V^T Phi differ; a tooth's own block breaks it, as a real database's does a
// little (its displacements are read below the loaded surface), so that which triangle of it the
// assembly keeps shows.
void asymmetric_fe_level(gm_model_params& p) {
  fe_level(p, [&p](gm::ComplianceDb& db, int g) {
    const std::size_t nf = db.face.size(), ng = db.n_grid();
    const double b = p.gear[g].face_width;
    const int nc = int(db.n_coupled);
    for (int d = -nc; d <= nc; ++d) {
      std::vector<double>& block = db.blocks[std::size_t(d + nc)];
      for (std::size_t i = 0; i < ng; ++i)
        for (std::size_t j = 0; j < ng; ++j)
          block[i * ng + j] *= 1 + 0.2 * (d >= 0 ? 1 : -1) * (db.face[i % nf] - db.face[j % nf]) / b;
    }
  });
}

}  // namespace

// FeAssembly::project (C Phi and Phi^T C Phi from the cached projections of the databases'
// chunks onto the model's fixed shapes) against the same products of the reference assembly
// (fe_assemble_reference, every entry straight from the databases) and the shapes, over two and a
// half pitches of an aligned spur pair with tooth pairs entering and leaving and an axial move
// (whose new face intervals the projection leaves to the full assembly); the databases' coupling
// blocks are not symmetric across the face (asymmetric_fe_level), so that each direction between
// two tooth pairs is checked.
TEST(FaceBasis, ProjectedAssemblyMatchesTheReferenceProjected) {
  for (int K : {2, 3}) {
    gm_model_params p = gm_test::paper();
    asymmetric_fe_level(p);
    p.solver_face_shapes = K;
    gm_test::Instance I(p);
    const gm_model& m = *I.m;
    ASSERT_FALSE(m.face_shapes.empty());
    const int cap = m.slice_capacity, S = p.slices;
    std::vector<gm::ContactSlice> slices(std::size_t(cap), gm::ContactSlice{});
    std::vector<int> index(std::size_t(cap), 0);
    Eigen::MatrixXd CP(cap, cap), PCP(cap, cap), Cr(cap, cap), Phi;
    gm::FeAssembly fe;
    int projected = 0, refused_after_move = 0, poses = 0;
    double worst = 0;
    const int steps = 120;
    for (int s = 0; s < steps; ++s) {
      gm_kinematics k{};
      k.phi[0] = 2.5 * 2 * kPi / 57 * s / steps;
      k.phi[1] = (3e-6 - I.rb(0) * k.phi[0]) / I.rb(1);
      if (s >= 60) k.u[1][2] = 20e-6;  // gear 2 moved axially: new face intervals at pose 60
      std::string msg;
      const int n = gm::detect_contacts(m.layout, k, slices.data(), cap, msg);
      ASSERT_GE(n, 0) << msg;
      int na = 0;
      for (int i = 0; i < n; ++i)
        if (slices[std::size_t(i)].flank > 0 && slices[std::size_t(i)].approach > -30e-6) index[std::size_t(na++)] = i;
      if (na == 0) continue;
      ++poses;
      const double uz[2] = {k.u[0][2], k.u[1][2]};
      int groups = 0;
      fe.prepare(gm::fe_view(m), slices.data(), index.data(), na, uz);
      if (!fe.project(gm::fe_view(m), slices.data(), index.data(), na, CP, PCP, groups)) {
        refused_after_move += s == 60;
        continue;
      }
      ++projected;
      ASSERT_EQ(na, groups * S);
      // Phi over the candidates: group q's slices carry the shapes in its K columns
      Phi.setZero(na, groups * K);
      for (int a = 0; a < na; ++a) {
        const int slice = slices[std::size_t(index[std::size_t(a)])].slice;
        for (int c = 0; c < K; ++c)
          Phi(a, (a / S) * K + c) = m.face_shapes[std::size_t(slice) * gm::FaceBasis::kMaxShapes + std::size_t(c)];
      }
      gm::fe_assemble_reference(gm::fe_view(m), slices.data(), index.data(), na, uz, Cr);
      const Eigen::MatrixXd RCP = Cr.topLeftCorner(na, na) * Phi, RPCP = Phi.transpose() * RCP;
      const double s1 = RCP.cwiseAbs().maxCoeff(), s2 = RPCP.cwiseAbs().maxCoeff();
      ASSERT_GT(s1, 0);
      worst = std::max(worst, (CP.topLeftCorner(na, groups * K) - RCP).cwiseAbs().maxCoeff() / s1);
      worst = std::max(worst, (PCP.topLeftCorner(groups * K, groups * K) - RPCP).cwiseAbs().maxCoeff() / s2);
    }
    std::printf("  %d shapes: %d of %d poses projected, worst difference %.3g of the largest entry\n", K, projected,
                poses, worst);
    EXPECT_LT(worst, 1e-13) << K;
    EXPECT_GE(projected, poses - 4) << K;  // all but the first call and the axial move's
    EXPECT_EQ(refused_after_move, 1) << K;
  }
}

// The check before a reduced attempt (face_basis_may_hold): a face whose approach is uniform is
// tried; one that varies beyond the acceptance in a way the shapes do not answer (a parabola,
// lead crowning; a line, a tilt, without tilt shapes) is not; a line is with K = 4.
TEST(FaceBasis, OnlyApproachesTheShapesAnswerAreTried) {
  const int S = 10;
  std::vector<gm::ContactSlice> slices(S);
  std::vector<int> index(S);
  std::vector<double> delta(S), table(std::size_t(S) * gm::FaceBasis::kMaxShapes, 1.0);
  for (int s = 0; s < S; ++s) {
    slices[std::size_t(s)].slice = s;
    index[std::size_t(s)] = s;
  }
  gm::FaceBasis w;
  w.reserve(S);
  const auto tried = [&](int K, double linear, double parabola) {
    for (int s = 0; s < S; ++s) {
      const double x = (s - 4.5) / 4.5;
      delta[std::size_t(s)] = 20e-6 * (1 + linear * x + parabola * (x * x - 0.5));
    }
    gm::FaceProblem p;
    p.n = S;
    p.index = index.data();
    p.slices = slices.data();
    p.delta = delta.data();
    p.shapes = K;
    p.shape_table = table.data();
    return gm::group_face_pairs(w, p) && gm::face_basis_may_hold(w, p);
  };
  EXPECT_TRUE(tried(2, 0, 0));
  EXPECT_TRUE(tried(3, 0.004, 0));   // within the acceptance (1 %)
  EXPECT_FALSE(tried(3, 0.02, 0));   // a tilt, no tilt shape
  EXPECT_TRUE(tried(4, 0.2, 0));     // a tilt shape answers the line
  EXPECT_FALSE(tried(4, 0.2, 0.05)); // lead crowning
  EXPECT_FALSE(tried(2, 0, 0.05));
  EXPECT_TRUE(tried(5, 0.2, 0.05));  // two tilt shapes: tried (the solve decides)
}

// Every allowed shape count at few slices (fewer slices than shapes included) makes a model whose
// quasi-static evaluations answer, and agree with the full solve within the 0.5 % of the sweep test.
TEST(FaceBasis, EveryShapeCountWorksAtFewSlices) {
  for (int slices : {1, 2, 3}) {
    gm_model_params p = gm_test::paper();
    fe_level(p);
    p.slices = slices;
    p.quasi_static = 1;
    p.solver_face_shapes = 0;
    gm_test::Instance F(p);
    for (int K = 1; K <= gm::FaceBasis::kMaxShapes; ++K) {
      p.solver_face_shapes = K;
      gm_test::Instance R(p);
      for (int i = 0; i < 5; ++i) {
        gm_kinematics k{};
        k.load_torque = 200;
        k.phi[0] = 2 * kPi / 57 / 5 * i;
        gm_result rr{}, rf{};
        ASSERT_EQ(gm_evaluate(R.m, R.d, &k, &rr), GM_OK) << gm_data_message(R.d) << ", K " << K;
        ASSERT_EQ(gm_evaluate(F.m, F.d, &k, &rf), GM_OK) << gm_data_message(F.d);
        EXPECT_NEAR(rr.te, rf.te, 5e-3 * std::fabs(rf.te)) << slices << " slices, K " << K << ", pose " << i;
      }
    }
  }
}
