// Contact detection against involute geometry (docs/physics.md §3 and 9): conjugate action at any
// centre distance, the flank-B gap equal to the geometric backlash, contact-ratio counts.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "detection.hpp"
#include "dual.hpp"
#include "slice_merge.hpp"
#include "gearmesh/internal/geometry.hpp"
#include "params.hpp"
#include "test_support.hpp"

namespace {

using namespace gm_test;

gm_model_params paper_pair() { return paper(); }
gm_model_params internal_pair() { return ring(); }

struct Found {
  std::vector<gm::ContactSlice> slices;
};

Found detect(const gm::MeshLayout& L, const gm_kinematics& k) {
  Found f;
  f.slices.resize(gm::slice_capacity(L));
  std::string msg;
  const int n = gm::detect_contacts(L, k, f.slices.data(), static_cast<int>(f.slices.size()), msg);
  EXPECT_GE(n, 0) << msg;
  f.slices.resize(n < 0 ? 0 : n);
  return f;
}

// Over a revolution at a fixed TE, every flank-A candidate has approach TE + c(a) with the
// same c for all poses and pairs (involutes stay conjugate at any centre distance), and the
// flank-B candidates have approach -j_bt(a) - TE with j_bt from the geometry at that distance.
void check_conjugate(const gm_model_params& base, double da) {
  const Pair nominal = make_pair(base);
  gm_model_params moved = base;
  moved.pair.center_distance += da;
  const Pair at_da = make_pair(moved);  // geometry at the displaced centre distance
  const double te = 3e-6;
  double c_ref = NAN;
  int poses_with_b = 0;
  const int steps = 4 * base.gear[0].teeth;
  for (int s = 0; s < steps; ++s) {
    const double phi1 = 2 * kPi * s / steps + 0.123;
    gm_kinematics k{};
    k.u[1][0] = da;
    k.phi[0] = phi1;
    k.phi[1] = phi2_for(nominal.L, te, phi1);
    const Found f = detect(nominal.L, k);
    int pairs_a = 0;
    for (const auto& c : f.slices) {
      if (c.kind != gm::kFlankContact) continue;  // tip contacts: test_detection_effects
      if (c.flank > 0) {
        ++pairs_a;
        if (std::isnan(c_ref)) c_ref = c.approach - te;
        EXPECT_NEAR(c.approach - te, c_ref, 1e-12) << "pose " << s;
      } else {
        ++poses_with_b;
        EXPECT_NEAR(c.approach, -at_da.g.j_bt - te - c_ref, 1e-10) << "pose " << s;
      }
    }
    EXPECT_GE(pairs_a, 1);
    EXPECT_LE(pairs_a, 2);
  }
  EXPECT_GT(poses_with_b, 0);
  if (da == 0) {
    EXPECT_NEAR(c_ref, 0.0, 1e-12);
  }
  // Symmetric teeth: moving the centres apart opens both flanks equally, so flank A moves by
  // half the backlash change (independent of the detection's own formula).
  EXPECT_NEAR(c_ref, -(at_da.g.j_bt - nominal.g.j_bt) / 2, 1e-12);
}

TEST(Detection, ExternalSpurConjugateAtSeveralCentreDistances) {
  for (double da : {0.0, 20e-6, 100e-6, -2e-6}) check_conjugate(paper_pair(), da);
}

TEST(Detection, InternalSpurConjugateAtSeveralCentreDistances) {
  // a larger centre distance tightens an internal mesh: stay on the backlash side
  for (double da : {0.0, -30e-6, -150e-6, 10e-6}) check_conjugate(internal_pair(), da);
}

// At the reference pose with TE = 0 the flank-B gap is exactly the geometric backlash.
TEST(Detection, FlankBGapEqualsGeometricBacklash) {
  for (const gm_model_params& p : {paper_pair(), internal_pair()}) {
    const Pair pr = make_pair(p);
    ASSERT_GT(pr.g.j_bt, 0);
    gm_kinematics k{};
    const Found f = detect(pr.L, k);
    int b = 0;
    for (const auto& c : f.slices) {
      if (c.kind != gm::kFlankContact) continue;
      if (c.flank < 0) {
        EXPECT_NEAR(c.approach, -pr.g.j_bt, 1e-12);
        ++b;
      } else {
        EXPECT_NEAR(c.approach, 0.0, 1e-12);
      }
    }
    EXPECT_GT(b, 0);
  }
}

// Share of poses with two loaded pairs equals eps_alpha - 1 (spur, 1 < eps_alpha < 2).
TEST(Detection, DoubleContactShareEqualsContactRatioMinusOne) {
  const Pair pr = make_pair(paper_pair());
  const int per_pitch = 2000;
  const int steps = per_pitch * 3;
  int doubles = 0;
  for (int s = 0; s < steps; ++s) {
    const double phi1 = 3 * 2 * kPi / pr.p.gear[0].teeth * (s + 0.5) / steps;
    gm_kinematics k{};
    k.phi[0] = phi1;
    k.phi[1] = phi2_for(pr.L, 1e-6, phi1);
    int a = 0;
    for (const auto& c : detect(pr.L, k).slices) a += c.flank > 0 && c.kind == gm::kFlankContact;
    doubles += a == 2;
  }
  EXPECT_NEAR(static_cast<double>(doubles) / steps, pr.g.eps_alpha - 1, 2.0 / per_pitch);
}

// The unbounded spin angle keeps full precision after many revolutions.
TEST(Detection, LargeSpinAnglesKeepPrecision) {
  const Pair pr = make_pair(paper_pair());
  const double te = 5e-6;
  for (double revs : {0.0, 1e3, 1e5}) {
    const double phi1 = revs * 2 * kPi + 0.05;
    gm_kinematics k{};
    k.phi[0] = phi1;
    k.phi[1] = phi2_for(pr.L, te, phi1);
    for (const auto& c : detect(pr.L, k).slices) {
      if (c.flank > 0 && c.kind == gm::kFlankContact) {
        EXPECT_NEAR(c.approach, te, 1e-9 + 1e-13 * revs);
      }
    }
  }
}

// Normals are unit vectors along the lines of action, mirrored between the flanks; the
// contact points lie on the line tangent to both base circles.
TEST(Detection, NormalsAndPointsLieOnTheLinesOfAction) {
  for (const gm_model_params& p : {paper_pair(), internal_pair()}) {
    const Pair pr = make_pair(p);
    gm_kinematics k{};
    const double a = pr.p.pair.center_distance;
    for (const auto& c : detect(pr.L, k).slices) {
      if (c.kind != gm::kFlankContact) continue;
      EXPECT_NEAR(c.normal.norm(), 1.0, 1e-14);
      EXPECT_NEAR(std::fabs(c.normal.y()), std::cos(pr.g.alpha_wt), 1e-12);
      // distance of the line (point, normal) from each centre equals the base radius
      const Eigen::Vector2d q(c.point.x(), c.point.y()), n(c.normal.x(), c.normal.y());
      const auto dist = [&](Eigen::Vector2d o) {
        const Eigen::Vector2d r = q - o;
        return std::fabs(r.x() * n.y() - r.y() * n.x());
      };
      EXPECT_NEAR(dist({0, 0}), pr.L.base_radius[0], 1e-12);
      EXPECT_NEAR(dist({a, 0}), pr.L.base_radius[1], 1e-12);
    }
  }
}

TEST(Detection, PenetrationBeyondRangeIsAnError) {
  const Pair pr = make_pair(paper_pair());
  gm_kinematics k{};
  k.phi[1] = phi2_for(pr.L, 0.3 * pr.g.p_bt, 0.0);
  std::vector<gm::ContactSlice> buf(gm::slice_capacity(pr.L));
  std::string msg;
  EXPECT_EQ(gm::detect_contacts(pr.L, k, buf.data(), static_cast<int>(buf.size()), msg), -1);
  EXPECT_NE(msg.find("detection range"), std::string::npos) << msg;
}

TEST(Detection, SlicesSplitTheAxialOverlap) {
  gm_model_params p = paper_pair();
  p.slices = 4;
  p.gear[1].face_width = 0.030;
  p.gear[1].axial_offset = 0.010;  // gear 2 spans [-5, 25] mm, gear 1 [-11.5, 11.5] mm
  const Pair pr = make_pair(p);
  gm_kinematics k{};
  const Found f = detect(pr.L, k);
  ASSERT_FALSE(f.slices.empty());
  double total = 0;
  for (int i = 0; i < 4; ++i) total += f.slices[i].width;
  EXPECT_NEAR(total, 0.0165, 1e-15);
  EXPECT_NEAR(f.slices[0].point.z(), -0.005 + 0.0165 / 8, 1e-15);
  EXPECT_NEAR(f.slices[3].point.z(), 0.0115 - 0.0165 / 8, 1e-15);
}

// Detection's own merge of an aligned spur pair (merge_repeats, levels 0-4) against
// merge_repeated_slices (slice_merge.hpp) of the slice-by-slice detection: the same slices with
// the same values and, over dual numbers, derivatives (a seed moving every input, the axial
// positions included), at poses over a pitch with spin and translation rates. With a tilt rate
// between the gears (the contact velocities then vary over the face) or lead crowning (so do
// the approaches) detection merges nothing itself: the count before merge_repeated_slices is
// the slice-by-slice one.
std::pair<double, double> value_slope(double x) { return {x, 0.0}; }
std::pair<double, double> value_slope(const gm::Dual& x) { return {x.v, x.d}; }

template <class T>
void expect_same_slices(const std::vector<gm::ContactSliceT<T>>& a,
                        const std::vector<gm::ContactSliceT<T>>& b, const std::string& where) {
  ASSERT_EQ(a.size(), b.size()) << where;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const auto& x = a[i];
    const auto& y = b[i];
    EXPECT_EQ(x.flank, y.flank) << where;
    EXPECT_EQ(x.pair, y.pair) << where;
    EXPECT_EQ(x.tooth[0], y.tooth[0]) << where;
    EXPECT_EQ(x.tooth[1], y.tooth[1]) << where;
    const T fx[] = {x.approach, x.width, x.roll[0], x.roll[1], x.approach_rate,
                    x.sliding_velocity, x.te_gain, x.path_position, x.point.x(), x.point.y(),
                    x.point.z(), x.normal.x(), x.normal.y(), x.tangent.x(), x.tangent.y()};
    const T fy[] = {y.approach, y.width, y.roll[0], y.roll[1], y.approach_rate,
                    y.sliding_velocity, y.te_gain, y.path_position, y.point.x(), y.point.y(),
                    y.point.z(), y.normal.x(), y.normal.y(), y.tangent.x(), y.tangent.y()};
    for (std::size_t k = 0; k < sizeof fx / sizeof fx[0]; ++k) {
      const auto [vx, dx] = value_slope(fx[k]);
      const auto [vy, dy] = value_slope(fy[k]);
      EXPECT_NEAR(vx, vy, 1e-12 * std::abs(vy) + 1e-18) << where << " field " << k;
      EXPECT_NEAR(dx, dy, 1e-12 * std::abs(dy) + 1e-18) << where << " field " << k;
    }
  }
}

template <class T, class K>
std::vector<gm::ContactSliceT<T>> detected(const gm::MeshLayout& L, const K& k, bool merge,
                                           int& before) {
  std::vector<gm::ContactSliceT<T>> out(gm::slice_capacity(L));
  std::string msg;
  before = gm::detect_contacts(L, k, out.data(), static_cast<int>(out.size()), msg, -gm::kEmitAll,
                               merge);
  EXPECT_GE(before, 0) << msg;
  out.resize(std::size_t(gm::merge_repeated_slices(out.data(), std::max(before, 0))));
  return out;
}

void check_detection_merge(const gm_model_params& p, bool tilt_rate, bool merges) {
  const Pair pr = make_pair(p);
  const int steps = 7;
  for (int s = 0; s < steps; ++s) {
    gm_kinematics k{};
    k.phi[0] = 2 * kPi / p.gear[0].teeth * s / steps + 0.01;
    k.phi[1] = phi2_for(pr.L, 4e-6, k.phi[0]);
    k.omega[0] = 150;
    k.omega[1] = -150 * pr.g.gear[0].d_b / pr.g.gear[1].d_b;
    k.v[0][0] = 0.02;
    k.v[1][1] = -0.01;
    k.u[1][2] = 1e-5;
    if (tilt_rate) k.w[0][0] = 0.5;
    const std::string where = "pose " + std::to_string(s);
    int by_slice = 0, by_pair = 0;
    const auto ref = detected<double>(pr.L, k, false, by_slice);
    const auto one = detected<double>(pr.L, k, true, by_pair);
    expect_same_slices(one, ref, where);
    EXPECT_EQ(by_pair < by_slice, merges) << where;
    gm::KinematicsT<gm::Dual> kd;
    for (int g = 0; g < 2; ++g) {
      for (int a = 0; a < 3; ++a) {
        kd.u[g][a] = gm::Dual(k.u[g][a], 1e-6 * (a + 1));
        kd.v[g][a] = gm::Dual(k.v[g][a], 0.1 * (g + 1));
      }
      for (int a = 0; a < 2; ++a) {
        kd.r[g][a] = gm::Dual(k.r[g][a], 0.0);  // a tilt would make the slices differ
        kd.w[g][a] = gm::Dual(k.w[g][a], 0.3 * (a + 1));
      }
      kd.phi[g] = gm::Dual(k.phi[g], 1e-3 * (g + 1));
      kd.omega[g] = gm::Dual(k.omega[g], 2.0 * (g + 1));
    }
    kd.load_torque = gm::Dual(0.0);
    const auto ref_d = detected<gm::Dual>(pr.L, kd, false, by_slice);
    const auto one_d = detected<gm::Dual>(pr.L, kd, true, by_pair);
    expect_same_slices(one_d, ref_d, where + " (dual)");
  }
}

TEST(Detection, MergedAlignedSpurPairsMatchTheSliceBySliceMerge) {
  gm_model_params p = paper_pair();
  p.slices = 10;
  check_detection_merge(p, false, true);
  check_detection_merge(p, true, false);  // a tilt rate between the gears
  for (auto& g : p.gear)
    for (auto& f : g.flank) f.lead_crowning = 5e-6;
  check_detection_merge(p, false, false);
}

}  // namespace
