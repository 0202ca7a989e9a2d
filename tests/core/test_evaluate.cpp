// One evaluation through the C API: level-0 forces (PHYSICS 9: F = k b Delta per pair),
// backlash, flank reversal, force and moment balance, and errors that name the culprit.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "gearmesh/gearmesh.h"

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Instance {
  gm_model* m = nullptr;
  gm_data* d = nullptr;
  explicit Instance(const gm_model_params& p) {
    char msg[256];
    // gtest reports an exception from a test body as a failure; a NULL model must not crash.
    if (gm_model_create(&p, &m, msg, sizeof msg) != GM_OK) throw std::runtime_error(msg);
    if (gm_data_create(m, &d) != GM_OK) throw std::runtime_error("gm_data_create failed");
  }
  ~Instance() {
    gm_data_free(d);
    gm_model_free(m);
  }
  const gm_pair_geometry& geo() const { return *gm_model_geometry(m); }
  double rb(int i) const { return 0.5 * geo().gear[i].d_b; }
  int sign() const { return gm_model_parameters(m)->pair.internal ? -1 : 1; }
  // Evaluate at TE te with gear 1 at phi1.
  gm_result at(double te, double phi1 = 0.0) {
    gm_kinematics k{};
    k.phi[0] = phi1;
    k.phi[1] = (te - rb(0) * phi1) / (sign() * rb(1));
    gm_result r{};
    EXPECT_EQ(gm_evaluate(m, d, &k, &r), GM_OK) << gm_data_message(d);
    return r;
  }
};

gm_model_params paper() {
  gm_model_params p;
  gm_default_params(&p);
  return p;
}

gm_model_params ring() {
  gm_model_params p = paper();
  p.pair.internal = 1;
  p.pair.normal_module = 0.002;
  p.gear[0].teeth = 21;
  p.gear[1].teeth = 62;
  p.gear[0].profile_shift = p.gear[1].profile_shift = 0;
  p.gear[0].thickness_allowance = p.gear[1].thickness_allowance = -30e-6;
  p.pair.center_distance = 0.041;
  return p;
}

// The middle of the first run of poses (over one base pitch of gear 1) with `pairs` loaded
// pairs, so that small changes of the approach keep the pair count.
double pose_with_pairs(Instance& in, int pairs) {
  const double step = in.geo().p_bt / in.rb(0) / 400;
  int first = -1, last = -1;
  for (int s = 0; s < 800 && (last < 0 || last == s - 1); ++s) {
    if (in.at(1e-6, s * step).pairs_in_contact == pairs) {
      if (first < 0) first = s;
      last = s;
    }
  }
  if (first < 0) ADD_FAILURE() << "no pose with " << pairs << " loaded pairs";
  return 0.5 * (first + last) * step;
}

double single_contact_phi1(Instance& in) { return pose_with_pairs(in, 1); }
double double_contact_phi1(Instance& in) { return pose_with_pairs(in, 2); }

TEST(Evaluate, ForceIsStiffnessTimesWidthTimesApproach) {
  for (const gm_model_params& p : {paper(), ring()}) {
    Instance in(p);
    const double kb = p.user_stiffness * p.gear[0].face_width;
    const double delta = 7e-6;
    const gm_result single = in.at(delta, single_contact_phi1(in));
    EXPECT_EQ(single.pairs_in_contact, 1);
    EXPECT_EQ(single.flank, 1);
    EXPECT_NEAR(single.normal_force, kb * delta, 1e-9 * kb * delta);
    EXPECT_NEAR(single.stiffness, kb, 1e-9 * kb);
    EXPECT_NEAR(single.max_line_load, p.user_stiffness * delta, 1e-6);
    const gm_result dbl = in.at(delta, double_contact_phi1(in));
    EXPECT_EQ(dbl.pairs_in_contact, 2);
    EXPECT_NEAR(dbl.normal_force, 2 * kb * delta, 1e-9 * kb * delta);
    EXPECT_NEAR(dbl.stiffness, 2 * kb, 1e-9 * kb);
  }
}

TEST(Evaluate, NoForceInsideTheBacklashAndFlankBBeyondIt) {
  for (const gm_model_params& p : {paper(), ring()}) {
    Instance in(p);
    const double j = in.geo().j_bt;
    ASSERT_GT(j, 1e-6);
    const double phi1 = single_contact_phi1(in);
    for (double f : {0.01, 0.5, 0.99}) {
      const gm_result r = in.at(-f * j, phi1);
      EXPECT_EQ(r.normal_force, 0.0) << f;
      EXPECT_EQ(r.flank, 0);
      EXPECT_EQ(r.pairs_in_contact, 0);
    }
    // Flank B closes at TE = -j_bt and then carries k b (-j_bt - TE) per pair in contact.
    const double kb = p.user_stiffness * p.gear[0].face_width;
    const gm_result b = in.at(-j - 4e-6, phi1);
    EXPECT_EQ(b.flank, 2);
    EXPECT_NEAR(b.normal_force, b.pairs_in_contact * kb * 4e-6, 1e-6 * kb * 4e-6);
  }
}

// Equal and opposite forces along the line of action; moments = force x base radius, with
// the sign of the flank: on flank A both gears feel -F r_b about +z for an external pair.
TEST(Evaluate, ForceAndMomentBalance) {
  for (const gm_model_params& p : {paper(), ring()}) {
    Instance in(p);
    const double j = in.geo().j_bt;
    const double aw = in.geo().alpha_wt;
    for (double te : {5e-6, -j - 5e-6}) {
      const gm_result r = in.at(te, 0.37);
      const double F = r.normal_force;
      ASSERT_GT(F, 0);
      for (int a = 0; a < 3; ++a) EXPECT_NEAR(r.force[0][a], -r.force[1][a], 1e-9 * F);
      EXPECT_NEAR(std::hypot(r.force[1][0], r.force[1][1]), F, 1e-9 * F);
      EXPECT_NEAR(std::fabs(r.force[1][1]), F * std::cos(aw), 1e-9 * F);
      EXPECT_EQ(r.force[1][2], 0.0);
      const double flank = te > 0 ? 1 : -1;
      // Flank A: gear 1 is braked (-F r_b1); gear 2 is driven clockwise for an external
      // pair (-F r_b2) and anticlockwise, with the pinion, for a ring (+F r_b2).
      EXPECT_NEAR(r.moment[0][2], -flank * F * in.rb(0), 1e-9 * F);
      EXPECT_NEAR(r.moment[1][2], -flank * in.sign() * F * in.rb(1), 1e-9 * F);
      EXPECT_NEAR(r.moment[0][0], 0.0, 1e-12 * F);
      EXPECT_NEAR(r.moment[0][1], 0.0, 1e-12 * F);
    }
  }
}

// Forward/backward mirror (PHYSICS 9): reflecting the pair about the centre line maps tooth
// angles theta -> -theta, so the pose (phi1, TE) on flank A mirrors to
// (-phi1 - 2 theta0_1, -TE - j_bt) on flank B, with theta0_1 = inv(alpha_wt) - eta_b1 the
// reference angle of tooth 0 (PHYSICS 0). Same force magnitude, mirrored y, opposite moments.
TEST(Evaluate, ForwardBackwardMirrorSymmetry) {
  Instance in(paper());
  const gm_pair_geometry& g = in.geo();
  const double theta0 = std::tan(g.alpha_wt) - g.alpha_wt - g.gear[0].eta_b;
  for (double phi1 : {0.0, 0.03, 0.071}) {
    for (double te : {2e-6, 9e-6}) {
      const gm_result a = in.at(te, phi1);
      const gm_result b = in.at(-te - g.j_bt, -phi1 - 2 * theta0);
      const double F = a.normal_force;
      ASSERT_GT(F, 0);
      EXPECT_EQ(a.flank, 1);
      EXPECT_EQ(b.flank, 2);
      EXPECT_EQ(a.pairs_in_contact, b.pairs_in_contact);
      EXPECT_NEAR(b.normal_force, F, 1e-6 * F);
      EXPECT_NEAR(b.force[1][0], a.force[1][0], 1e-6 * F);
      EXPECT_NEAR(b.force[1][1], -a.force[1][1], 1e-6 * F);
      EXPECT_NEAR(b.moment[0][2], -a.moment[0][2], 1e-6 * F);
      EXPECT_NEAR(b.moment[1][2], -a.moment[1][2], 1e-6 * F);
    }
  }
}

TEST(Evaluate, TransmissionErrorFromSpinAngles) {
  for (const gm_model_params& p : {paper(), ring()}) {
    Instance in(p);
    gm_kinematics k{};
    k.phi[0] = 0.3;
    k.phi[1] = -0.2;
    gm_result r{};
    ASSERT_EQ(gm_evaluate(in.m, in.d, &k, &r), GM_OK) << gm_data_message(in.d);
    const double te = in.rb(0) * 0.3 + in.sign() * in.rb(1) * -0.2;
    EXPECT_DOUBLE_EQ(r.te, te);
    EXPECT_DOUBLE_EQ(r.te_angle, te / in.rb(1));
  }
}

// Axial offset of the contact: the forces act at the overlap centre, which gives tilting
// moments about the gear centres, M = z x F.
TEST(Evaluate, AxialOffsetGivesTiltingMoments) {
  gm_model_params p = paper();
  p.gear[0].axial_offset = 0.004;
  p.gear[1].axial_offset = 0.004;
  Instance in(p);
  const gm_result r = in.at(5e-6, 0.1);
  EXPECT_NEAR(r.moment[0][0], -0.004 * r.force[0][1], 1e-9 * r.normal_force);
  EXPECT_NEAR(r.moment[0][1], 0.004 * r.force[0][0], 1e-9 * r.normal_force);
}

TEST(Evaluate, NonFiniteInputIsNamed) {
  Instance in(paper());
  gm_kinematics k{};
  k.v[1][2] = NAN;
  gm_result r{};
  r.te = 42;
  EXPECT_EQ(gm_evaluate(in.m, in.d, &k, &r), GM_ERR_INPUT);
  EXPECT_NE(std::string(gm_data_message(in.d)).find("gear2.vz"), std::string::npos);
  EXPECT_EQ(r.te, 42);  // result untouched
  k.v[1][2] = 0;        // the instance stays usable
  EXPECT_EQ(gm_evaluate(in.m, in.d, &k, &r), GM_OK);
}

TEST(Evaluate, TiltIsRejectedUntilMisalignmentLands) {
  Instance in(paper());
  gm_kinematics k{};
  k.r[0][1] = 1e-4;
  gm_result r{};
  EXPECT_EQ(gm_evaluate(in.m, in.d, &k, &r), GM_ERR_INPUT);
  EXPECT_NE(std::string(gm_data_message(in.d)).find("gear1.ry"), std::string::npos);
}

TEST(Evaluate, ParameterErrorsNameTheParameter) {
  struct Case {
    const char* name;
    void (*edit)(gm_model_params&);
  };
  const Case cases[] = {
      {"pair.center_distance", [](gm_model_params& p) { p.pair.center_distance = 0; }},
      {"pair.center_distance", [](gm_model_params& p) { p.pair.center_distance = 0.120; }},
      {"gear1.teeth", [](gm_model_params& p) { p.gear[0].teeth = 0; }},
      {"gear2.poisson_ratio", [](gm_model_params& p) { p.gear[1].poisson_ratio = 0.5; }},
      {"gear1.face_width", [](gm_model_params& p) { p.gear[0].face_width = NAN; }},
      {"model.slices", [](gm_model_params& p) { p.slices = 0; }},
      {"model.user_stiffness", [](gm_model_params& p) { p.user_stiffness = -1; }},
      {"pair.helix_angle", [](gm_model_params& p) { p.pair.helix_angle = 0.2; }},
      {"model.friction_coefficient", [](gm_model_params& p) { p.friction_coefficient = 0.1; }},
  };
  for (const Case& c : cases) {
    gm_model_params p = paper();
    c.edit(p);
    gm_model* m = reinterpret_cast<gm_model*>(&p);  // must be overwritten with NULL
    char msg[256] = "";
    EXPECT_EQ(gm_model_create(&p, &m, msg, sizeof msg), GM_ERR_PARAMETER) << c.name;
    EXPECT_EQ(m, nullptr);
    EXPECT_NE(std::string(msg).find(c.name), std::string::npos) << msg;
    EXPECT_NE(std::string(msg).find("allowed"), std::string::npos) << msg;
  }
}

TEST(Evaluate, StateBlobRoundTripAndForeignBlobRefused) {
  Instance a(paper());
  gm_model_params other = paper();
  other.slices = 3;
  Instance b(other);
  const size_t n = gm_data_state_size(a.m, a.d);
  ASSERT_GT(n, 0u);
  std::string blob(n, '\0');
  EXPECT_EQ(gm_data_state_save(a.m, a.d, blob.data(), n), GM_OK);
  EXPECT_EQ(gm_data_state_load(a.m, a.d, blob.data(), n), GM_OK);
  EXPECT_NE(gm_data_state_load(b.m, b.d, blob.data(), n), GM_OK);
  EXPECT_NE(gm_data_state_load(a.m, a.d, blob.data(), n - 1), GM_OK);
}

}  // namespace
