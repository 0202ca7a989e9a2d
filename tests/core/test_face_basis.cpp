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
#include <cstdio>
#include <string>
#include <vector>

#include "fe_synthetic.hpp"
#include "gearmesh/gearmesh.h"
#include "model.hpp"
#include "test_support.hpp"

namespace {

using gm_test::kPi;

// p with level 5 on each gear's smooth synthetic database (written once per gear set).
void fe_level(gm_model_params& p) {
  static std::vector<std::string> paths;
  p.stiffness_level = GM_STIFFNESS_FE;
  p.slices = 10;
  p.coupled_teeth = 2;
  p.compliance[0] = p.compliance[1] = nullptr;
  for (int g = 0; g < 2; ++g) {
    std::string msg;
    paths.push_back(gm_test::write_smooth_db(p, g, "face_basis_" + std::to_string(paths.size()) + ".gcdb", msg));
    EXPECT_FALSE(paths.back().empty()) << msg;
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
  // answer; a tilt of 0.2 mrad opens a face end at 50 N m
  const Scene scenes[] = {
      {"spur, 1 shape", spur, 0, 1, {0, 0.5}, {0, 1}},
      {"spur, 2 shapes", spur, 0, 2, {0.95, 0.95}, {1, 1}},
      {"spur, 3 shapes", spur, 0, 3, {0.95, 0.95}, {1, 1}},
      {"spur tilted 0.2 mrad, 2 shapes", spur, 2e-4, 2, {0, 0}, {1, 1}},
      {"spur tilted 0.2 mrad, 3 shapes", spur, 2e-4, 3, {0, 0.9}, {1, 1}},
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

}  // namespace
