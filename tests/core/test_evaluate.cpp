// One evaluation through the C API: level-0 forces (docs/physics.md §9: F = k b Delta per pair),
// backlash, flank reversal, force and moment balance, and errors that name the culprit.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include "gearmesh/gearmesh.h"
#include "test_support.hpp"

namespace {

using namespace gm_test;

// The middle of the first run of poses (over one base pitch of gear 1) with `pairs` loaded
// pairs at the approach te; mid-run poses are away from the path ends, so no tip contact.
double pose_with_pairs(Instance& in, int pairs, double te) {
  const double step = in.geo().p_bt / in.rb(0) / 400;
  int first = -1, last = -1;
  for (int s = 0; s < 800 && (last < 0 || last == s - 1); ++s) {
    if (in.at(te, s * step).pairs_in_contact == pairs) {
      if (first < 0) first = s;
      last = s;
    }
  }
  if (first < 0) ADD_FAILURE() << "no pose with " << pairs << " loaded pairs";
  return 0.5 * (first + last) * step;
}

double single_contact_phi1(Instance& in, double te = 1e-6) { return pose_with_pairs(in, 1, te); }
double double_contact_phi1(Instance& in, double te = 1e-6) { return pose_with_pairs(in, 2, te); }

TEST(Evaluate, ForceIsStiffnessTimesWidthTimesApproach) {
  for (const gm_model_params& p : {paper(), ring()}) {
    Instance in(p);
    const double kb = p.user_stiffness * p.gear[0].face_width;
    const double delta = 7e-6;
    const gm_result single = in.at(delta, single_contact_phi1(in, delta));
    EXPECT_EQ(single.pairs_in_contact, 1);
    EXPECT_EQ(single.flank, 1);
    EXPECT_NEAR(single.normal_force, kb * delta, 1e-9 * kb * delta);
    EXPECT_NEAR(single.stiffness, kb, 1e-9 * kb);
    EXPECT_NEAR(single.max_line_load, p.user_stiffness * delta, 1e-6);
    EXPECT_EQ(single.max_load_share, 1.0);
    const gm_result dbl = in.at(delta, double_contact_phi1(in, delta));
    EXPECT_EQ(dbl.pairs_in_contact, 2);
    EXPECT_NEAR(dbl.normal_force, 2 * kb * delta, 1e-9 * kb * delta);
    EXPECT_NEAR(dbl.stiffness, 2 * kb, 1e-9 * kb);
    EXPECT_NEAR(dbl.max_load_share, 0.5, 1e-12);  // the same k b Delta on both pairs
    EXPECT_EQ(in.at(-1e-7, single_contact_phi1(in, delta)).max_load_share, 0.0);  // no contact
  }
}

// With a profile slope on gear 1 the two pairs of a double contact have different approaches
// Delta - g_j (level 0: F_j = k b (Delta - g_j)): the larger one's share from the pairs'
// forces, which the normal force and the single-pair line loads give. And from the slope's
// definition alone: the slope f_Halpha is the gap at the tip minus the gap at the start of
// active profile, linear in the roll distance over gear 1's active profile L = rho_a - rho_sap;
// the two contacts lie a base pitch apart on it, so their gaps differ by f_Halpha p_bt / L and
// the forces by k b f_Halpha p_bt / L: the larger share is 1/2 + k b f_Halpha p_bt / (2 L F), up
// to where the sloped flanks touch (docs/physics.md §3): each pair's approach grows by
// R' G'^2 / 2, about 2 nm here, differently at the two contacts (R' and the slope along the arc
// differ), which moves the share by 4e-5 of the 0.056 the slope gives
// (tests/core/test_detection_effects.cpp checks that growth).
TEST(Evaluate, LoadShareOfUnequalPairs) {
  gm_model_params p = paper();
  p.gear[0].flank[0].profile_slope = 3e-6;
  Instance in(p);
  const double delta = 8e-6, phi1 = double_contact_phi1(in, delta);
  const gm_result r = in.at(delta, phi1);
  ASSERT_EQ(r.pairs_in_contact, 2);
  const double larger = r.max_line_load * p.gear[0].face_width;  // one slice = one pair
  EXPECT_NEAR(r.max_load_share, larger / r.normal_force, 1e-12);
  const gm_gear_geometry& g1 = in.geo().gear[0];
  const double rho_sap = std::sqrt(0.25 * g1.d_sap * g1.d_sap - in.rb(0) * in.rb(0));
  const double gap_difference = p.gear[0].flank[0].profile_slope * in.geo().p_bt / (g1.rho_a - rho_sap);
  const double kb = p.user_stiffness * p.gear[0].face_width;
  EXPECT_NEAR(r.max_load_share, 0.5 + kb * gap_difference / (2 * r.normal_force), 1e-4);  // measured: 4.2e-5
  EXPECT_GT(r.max_load_share, 0.5 + 1e-3);
  EXPECT_LT(r.max_load_share, 1.0);
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
      // a mid-zone pose of flank A; its mirror (docs/physics.md §9) for flank B, so no tip contact
      const double phi_a = double_contact_phi1(in, 5e-6);
      const double theta0 = std::tan(in.geo().alpha_wt) - in.geo().alpha_wt - in.geo().gear[0].eta_b;
      const gm_result r = in.at(te, te > 0 ? phi_a : -phi_a - 2 * theta0);
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

// Forward/backward mirror (docs/physics.md §9): reflecting the pair about the centre line maps tooth
// angles theta -> -theta, so the pose (phi1, TE) on flank A mirrors to
// (-phi1 - 2 theta0_1, -TE - j_bt) on flank B, with theta0_1 = inv(alpha_wt) - eta_b1 the
// reference angle of tooth 0 (docs/physics.md §0). Same force magnitude, mirrored y, opposite moments.
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

// Spur, aligned: every slice sees the same approach, so the resultants do not depend on the
// slice count (issue 3).
TEST(Evaluate, SpurAlignedResultsDoNotDependOnTheSliceCount) {
  gm_model_params one = paper();
  gm_model_params many = paper();
  many.slices = 7;
  Instance a(one), b(many);
  for (double phi1 : {0.0, 0.013, 0.05}) {
    for (double te : {3e-6, 12e-6}) {
      const gm_result ra = a.at(te, phi1), rb = b.at(te, phi1);
      EXPECT_NEAR(rb.normal_force, ra.normal_force, 1e-9 * ra.normal_force);
      EXPECT_NEAR(rb.stiffness, ra.stiffness, 1e-9 * ra.stiffness);
      EXPECT_EQ(rb.pairs_in_contact, ra.pairs_in_contact);
      for (int g = 0; g < 2; ++g)
        for (int c = 0; c < 3; ++c) {
          EXPECT_NEAR(rb.force[g][c], ra.force[g][c], 1e-9 * ra.normal_force);
          EXPECT_NEAR(rb.moment[g][c], ra.moment[g][c], 1e-9 * ra.normal_force);
        }
    }
  }
}

// Helical: the normal force leans by beta_b out of the transverse plane, so the axial force
// is F_t tan(beta_b) and the spin moments are F_t r_b with F_t = F_n cos(beta_b) (ISO 6336-1
// force components); the level-0 stiffness is k' per unit face width on the transverse line of
// action, so F_t = k' b Delta_t for one full-width pair.
TEST(Evaluate, HelicalForceComponentsAndBalance) {
  gm_model_params p = paper();
  p.pair.helix_angle = 15 * kPi / 180;
  p.gear[0].profile_shift = p.gear[1].profile_shift = 0;
  p.pair.center_distance = 0.0026 / std::cos(p.pair.helix_angle) * 57 + 50e-6;
  p.slices = 12;
  // a short, deep tip relief keeps the tip edges off the mate (tip contact acts along other
  // normals; it is tested in test_detection_effects)
  for (auto& g : p.gear)
    for (auto& f : g.flank) {
      f.tip_relief = 30e-6;
      f.tip_relief_length = 0.3e-3;
    }
  Instance in(p);
  const double bb = in.geo().beta_b;
  for (double te : {4e-6, -in.geo().j_bt - 4e-6}) {
    const gm_result r = in.at(te, 0.011);
    const double Fn = r.normal_force, Ft = Fn * std::cos(bb);
    ASSERT_GT(Fn, 0);
    const double flank = te > 0 ? 1 : -1;
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(r.force[0][c], -r.force[1][c], 1e-9 * Fn);
    EXPECT_NEAR(std::fabs(r.force[1][2]), Ft * std::tan(bb), 1e-9 * Fn);
    EXPECT_NEAR(std::hypot(r.force[1][0], r.force[1][1]), Ft, 1e-9 * Fn);
    EXPECT_NEAR(r.moment[0][2], -flank * Ft * in.rb(0), 1e-9 * Fn);
    EXPECT_NEAR(r.moment[1][2], -flank * Ft * in.rb(1), 1e-9 * Fn);
    // k' b Delta_t summed over the contact lines, less what the relief takes near the tips
    const double approach_t = te > 0 ? te : -in.geo().j_bt - te;
    EXPECT_LE(Ft, r.stiffness * approach_t * (1 + 1e-9));
    EXPECT_GT(Ft, 0.8 * r.stiffness * approach_t);
  }
  // the hands: flank A of a right-hand gear 1 pushes gear 2 axially one way, flank B the other
  const gm_result a = in.at(4e-6, 0.011), b = in.at(-in.geo().j_bt - 4e-6, 0.011);
  EXPECT_LT(a.force[1][2] * b.force[1][2], 0);
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

TEST(Evaluate, TiltBeyondTheSmallTiltRangeIsRejected) {
  Instance in(paper());
  gm_kinematics k{};
  k.r[0][1] = 0.05;
  gm_result r{};
  EXPECT_EQ(gm_evaluate(in.m, in.d, &k, &r), GM_ERR_INPUT);
  EXPECT_NE(std::string(gm_data_message(in.d)).find("gear1.ry"), std::string::npos);
  k.r[0][1] = 1e-3;  // inside the range: evaluates
  EXPECT_EQ(gm_evaluate(in.m, in.d, &k, &r), GM_OK) << gm_data_message(in.d);
}

// Spin angles beyond GM_MAX_SPIN_ANGLE (1e7 rad) are refused by gm_evaluate and
// gm_directional_derivative alike, plain and quasi-static, whatever was evaluated before, with a
// message naming the input, the value and the range. (Before the range existed, 1e30 gave 2 MN
// of meaningless forces and 1e308 reached a float-to-int cast of NaN in detection.)
TEST(Evaluate, SpinAnglesOutsideTheirRangeAreRefused) {
  for (int quasi = 0; quasi < 2; ++quasi) {
    gm_model_params p = paper();
    p.quasi_static = quasi;
    Instance in(p);
    for (int gear = 0; gear < 2; ++gear) {
      for (double bad : {1e308, 1e30, 1e15, -1e30, 1.0000001e7}) {
        for (int before = 0; before < 2; ++before) {
          if (before) in.at(5e-6, 0.01);  // another call sequence: a good pose first
          gm_kinematics k{};
          k.phi[1] = 5e-6 / in.rb(1);
          k.load_torque = 100;
          k.phi[gear] = bad;
          gm_result r{};
          r.te = 42;
          EXPECT_EQ(gm_evaluate(in.m, in.d, &k, &r), GM_ERR_INPUT) << bad;
          EXPECT_EQ(r.te, 42);
          char name[40];
          std::snprintf(name, sizeof name, "gear%d.phi = %g rad", gear + 1, bad);
          const std::string msg = gm_data_message(in.d);
          EXPECT_NE(msg.find(name), std::string::npos) << msg;
          EXPECT_NE(msg.find("allowed range [-1e+07, 1e+07] rad"), std::string::npos) << msg;
          gm_kinematics seed{};
          seed.phi[0] = 1e-3;
          EXPECT_EQ(gm_directional_derivative(in.m, in.d, &k, &seed, &r), GM_ERR_INPUT) << bad;
          EXPECT_EQ(std::string(gm_data_message(in.d)), msg);
        }
      }
      gm_kinematics k{};  // the bound itself is inside (57/57: phi_2 = -phi_1 is TE 0)
      k.phi[gear] = gear == 0 ? GM_MAX_SPIN_ANGLE : -GM_MAX_SPIN_ANGLE;
      k.phi[1 - gear] = -k.phi[gear];
      k.load_torque = 100;
      gm_result r{};
      EXPECT_EQ(gm_evaluate(in.m, in.d, &k, &r), GM_OK) << gm_data_message(in.d);
    }
  }
}

// Large spins lose no precision: at phi_1 = 1e5 rad (and phi_2 near -1e5 rad) the forces are those
// of the angles reduced by whole tooth periods (in long double, exact to ~1e-14 rad here) to 1e-9
// relative; with
// per-tooth deviations, by whole turns (tooth identities kept). Quasi-static: gear 1 at 1e5 rad
// against its reduced angle, the solved TE included. Before the reduction by whole turns, the
// period split lost ~1e-11 rad at 1e5 rad, 9e-8 of the forces.
TEST(Evaluate, LargeSpinAnglesGiveTheForcesOfTheReducedAngles) {
  const auto reduce = [](double phi, long double period) {
    const long double x = phi;
    return static_cast<double>(x - period * std::floor(x / period));
  };
  const long double two_pi = 6.283185307179586476925286766559L;
  for (int c = 0; c < 3; ++c) {
    gm_model_params p = paper();
    p.stiffness_level = GM_STIFFNESS_ANALYTICAL;
    p.slices = 5;
    p.solver_tolerance = 1e-15;
    if (c == 1) {
      static const std::string dev = [] {
        std::string here = __FILE__;
        return here.substr(0, here.rfind("tests/core/")) + "scenarios/deviations_example.txt";
      }();
      p.gear[0].deviations = p.gear[1].deviations = dev.c_str();
    }
    p.quasi_static = c == 2;
    Instance in(p);
    for (double phi1 : {1e5, -123456.789}) {
      gm_kinematics big{};
      big.phi[0] = phi1;
      big.phi[1] = (6e-6 - in.rb(0) * phi1) / in.rb(1);
      big.load_torque = 300;
      big.omega[0] = 10;
      big.omega[1] = -10;
      gm_kinematics small = big;
      for (int i = 0; i < 2; ++i)
        small.phi[i] = reduce(big.phi[i], c == 1 ? two_pi : two_pi / p.gear[i].teeth);
      gm_result a{}, b{};
      for (int k = 0; k < 3; ++k) {  // quasi-static: the warm-started TE to its floor
        a = in.eval(big);
        b = in.eval(small);
      }
      ASSERT_GT(b.normal_force, 500);
      const double tol = 1e-9 * b.normal_force;
      for (int i = 0; i < 2; ++i)
        for (int x = 0; x < 3; ++x) EXPECT_NEAR(a.force[i][x], b.force[i][x], tol) << c << " " << phi1;
      EXPECT_NEAR(a.moment[0][2], b.moment[0][2], tol * in.rb(0)) << c << " " << phi1;
      EXPECT_NEAR(a.stiffness, b.stiffness, 1e-9 * b.stiffness);
      if (c == 2) EXPECT_NEAR(a.te, b.te, 1e-15);
    }
  }
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
      {"gear1.tip_relief", [](gm_model_params& p) { p.gear[0].flank[1].tip_relief = -1e-6; }},
      {"gear2.deviations", [](gm_model_params& p) { p.gear[1].deviations = "/nonexistent/dev.txt"; }},
      {"model.friction_coefficient", [](gm_model_params& p) { p.friction_coefficient = -0.1; }},
      {"gear1.compliance", [](gm_model_params& p) { p.stiffness_level = 5; }},
      {"gear2.compliance", [](gm_model_params& p) { p.compliance[1] = "/nonexistent/g2.gcdb"; }},
      {"model.quasi_static", [](gm_model_params& p) { p.quasi_static = 2; }},
      // static ranges (param_ranges.cpp) and the bounds that depend on other parameters
      {"gear2.teeth = 2001: allowed range [5, 2000]", [](gm_model_params& p) { p.gear[1].teeth = 2001; }},
      {"gear1.thickness_allowance = 1e-06 m: allowed range [-0.05, 0] m",
       [](gm_model_params& p) { p.gear[0].thickness_allowance = 1e-6; }},
      {"gear1.thickness_allowance = -0.002 m: allowed >= -0.0013 m",
       [](gm_model_params& p) { p.gear[0].thickness_allowance = -2e-3; }},
      {"pair.rack_dedendum = 1: allowed > pair.rack_addendum = 1", [](gm_model_params& p) { p.pair.rack_dedendum = 1; }},
      {"pair.rack_tip_radius = 0.39: allowed <= 0.38", [](gm_model_params& p) { p.pair.rack_tip_radius = 0.39; }},
      {"pair.helix_angle = 0.785398163 rad: allowed range (-0.785398163, 0.785398163) rad",
       [](gm_model_params& p) { p.pair.helix_angle = 45 * (3.14159265358979323846 / 180.0); }},
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
