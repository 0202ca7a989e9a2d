// Forces of issue 4 against closed forms: the quasi-static loaded TE of a constant-stiffness
// spur pair and its mesh harmonics (docs/physics.md §9), the mean friction loss against Ohlendorf's H_V
// (docs/physics.md §7), damping without adhesion, zero and extreme loads, flank symmetry.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <stdexcept>
#include <string>
#include <vector>

#include "gearmesh/gearmesh.h"
#include "test_support.hpp"

namespace {

using namespace gm_test;

// A short, deep tip relief keeps the tip edges off the mate, as the closed forms assume (the
// flanks lose 0.05 mm of roll at each end of the path).
gm_model_params quasi_static_paper() {
  gm_model_params p = paper();
  p.quasi_static = 1;
  for (auto& g : p.gear)
    for (auto& f : g.flank) {
      f.tip_relief = 40e-6;
      f.tip_relief_length = 0.05e-3;
    }
  return p;
}

// docs/physics.md §9: loaded TE F/k_p in single contact and F/(2 k_p) in double contact; the n-th mesh
// harmonic (F/(n pi k_p)) |sin(n pi (2 - eps_alpha))|.
TEST(Forces, QuasiStaticLoadedTeOfAConstantStiffnessSpurPair) {
  Instance in(quasi_static_paper());
  const double kp = 1.5e10 * 0.023;  // k' b, N/m
  const double torque = 200;         // N m on gear 2
  const double F = torque / in.rb(1);
  const int n = 512;
  std::vector<double> te(n);
  int single = 0, dbl = 0, in_relief = 0;
  for (int s = 0; s < n; ++s) {
    const double phi1 = in.geo().p_bt / in.rb(0) * (s + 0.5) / n;
    const gm_result r = in.loaded(phi1, torque);
    te[s] = r.te;
    EXPECT_NEAR(r.normal_force, F, 1e-9 * F);  // spur, no friction: all along the line of action
    if (r.pairs_in_contact == 1) {
      ++single;
      EXPECT_NEAR(r.te, F / kp, 1e-9 * F / kp) << s;
    } else if (r.pairs_in_contact == 2) {
      ++dbl;
      // within 0.05 mm of the path ends the relief unloads the outgoing pair partly
      if (std::fabs(r.te - F / (2 * kp)) > 1e-9 * F / kp) {
        ++in_relief;
        EXPECT_GT(r.te, F / (2 * kp));
        EXPECT_LT(r.te, F / kp);
      }
    }
  }
  EXPECT_LE(in_relief, 2 * 0.05e-3 / in.geo().p_bt * n + 2);
  EXPECT_NEAR(static_cast<double>(dbl) / n, in.geo().eps_alpha - 1, 0.02);
  EXPECT_EQ(single + dbl, n);
  const double eps = in.geo().eps_alpha;
  for (int order : {1, 2, 3}) {
    std::complex<double> a(0, 0);
    for (int s = 0; s < n; ++s) a += te[s] * std::polar(1.0, -2 * kPi * order * (s + 0.5) / n);
    const double amplitude = 2 * std::abs(a) / n;
    const double closed = F / (order * kPi * kp) * std::fabs(std::sin(order * kPi * (2 - eps)));
    // the relief shortens the double-contact zones by 2 x 0.05 mm of 7.68 mm per pitch
    EXPECT_NEAR(amplitude, closed, 0.03 * F / kp) << "order " << order;
  }
}

TEST(Forces, ZeroLoadGivesTheUnloadedTeAndNoForce) {
  Instance in(quasi_static_paper());
  for (double phi1 : {0.0, 0.031, 0.07}) {
    const gm_result r = in.loaded(phi1, 0.0);
    EXPECT_EQ(r.normal_force, 0.0);
    EXPECT_NEAR(r.te, 0.0, 1e-12);  // perfect involutes touch at TE = 0 everywhere
  }
}

// Forward and backward: a negative load torque drives flank B; at the mirrored pose the TE is
// -j_bt minus the forward TE (docs/physics.md §9 symmetry), with the same force.
TEST(Forces, ReverseLoadMirrorsOntoFlankB) {
  Instance in(quasi_static_paper());
  const gm_pair_geometry& g = in.geo();
  const double theta0 = std::tan(g.alpha_wt) - g.alpha_wt - g.gear[0].eta_b;
  for (double phi1 : {0.01, 0.05}) {
    const gm_result a = in.loaded(phi1, 150);
    const gm_result b = in.loaded(-phi1 - 2 * theta0, -150);
    EXPECT_EQ(a.flank, 1);
    EXPECT_EQ(b.flank, 2);
    EXPECT_NEAR(b.te, -g.j_bt - a.te, 1e-12);
    EXPECT_NEAR(b.normal_force, a.normal_force, 1e-9 * a.normal_force);
  }
}

TEST(Forces, ExtremeLoadsStayWellPosed) {
  Instance in(quasi_static_paper());
  // 100 x the paper's highest torque: still one converged answer (level 0 is linear)
  const gm_result big = in.loaded(0.02, 35000);
  EXPECT_TRUE(std::isfinite(big.te));
  EXPECT_NEAR(big.moment[1][2], -35000, 1e-6 * 35000);  // the torque balance holds (tip edges load too)
  // a torque whose rigid approach passes a quarter base pitch is refused with a clear error
  bool refused = false;
  try {
    in.loaded(0.02, 1e7);
  } catch (const std::runtime_error& e) {
    refused = std::string(e.what()).find("detection range") != std::string::npos;
  }
  EXPECT_TRUE(refused);
  // and the instance is still usable
  EXPECT_GT(in.loaded(0.02, 100).normal_force, 0);
}

// Damping on the normal approach rate adds c L v on loaded slices and never pulls (docs/physics.md §7).
TEST(Forces, DampingAddsToLoadedSlicesWithoutAdhesion) {
  gm_model_params p;
  gm_default_params(&p);
  p.damping = 2e4;  // N s/m^2 per unit face width
  Instance in(p);
  gm_kinematics k{};
  k.phi[1] = 5e-6 / in.rb(1);  // TE = 5 um at phi1 = 0
  const gm_result still = in.eval(k);
  k.v[1][0] = -0.01;  // gear 2 moves towards gear 1: the approach grows
  const gm_result closing = in.eval(k);
  const double rate = 0.01 * std::sin(in.geo().alpha_wt);  // d(approach)/dt per loaded slice
  EXPECT_NEAR(closing.normal_force - still.normal_force,
              closing.pairs_in_contact * 2e4 * 0.023 * rate, 1e-6 * still.normal_force);
  k.v[1][0] = 100;  // separating fast: damping would pull; the force stops at zero
  const gm_result opening = in.eval(k);
  EXPECT_GE(opening.normal_force, 0.0);
  EXPECT_EQ(opening.normal_force, 0.0);
  for (int a = 0; a < 3; ++a) EXPECT_EQ(opening.force[1][a], 0.0);
}

// docs/physics.md §7: the mean friction loss of a slow revolution is P_in mu H_V, with Ohlendorf's
// H_V = pi (u + 1)/(z1 u cos beta_b) (1 - eps_alpha + eps_1^2 + eps_2^2); FZG C14: H_V = 0.1950.
TEST(Forces, MeanFrictionLossMatchesOhlendorf) {
  gm_model_params p;
  gm_default_params(&p);
  p.pair.normal_module = 4.5e-3;
  p.pair.center_distance = 91.5e-3;
  p.gear[0].teeth = 16;
  p.gear[1].teeth = 24;
  p.gear[0].profile_shift = 0.1817;
  p.gear[1].profile_shift = 0.1715;
  p.gear[0].tip_diameter = 82.457e-3;
  p.gear[1].tip_diameter = 118.365e-3;
  p.gear[0].face_width = p.gear[1].face_width = 14e-3;
  p.quasi_static = 1;
  const double mu = 0.05;
  p.friction_coefficient = mu;
  p.friction_velocity = 1e-5;
  for (auto& g : p.gear)
    for (auto& f : g.flank) {
      f.tip_relief = 40e-6;
      f.tip_relief_length = 0.05e-3;
    }
  Instance in(p);
  const gm_pair_geometry& g = in.geo();
  const double u = 24.0 / 16.0, aw = g.alpha_wt;
  const double e1 = 16 * (std::tan(std::acos(g.gear[0].d_b / g.gear[0].d_a)) - std::tan(aw)) / (2 * kPi);
  const double e2 = 24 * (std::tan(std::acos(g.gear[1].d_b / g.gear[1].d_a)) - std::tan(aw)) / (2 * kPi);
  const double hv = kPi * (u + 1) / (16 * u) * (1 - g.eps_alpha + e1 * e1 + e2 * e2);
  EXPECT_NEAR(hv, 0.1950, 5e-4);  // the formula as docs/physics.md §7 quotes it
  const double omega1 = 1.0;
  double loss = 0, input = 0;
  const int n = 800;
  for (int s = 0; s < n; ++s) {
    const double phi1 = g.p_bt / in.rb(0) * (s + 0.5) / n;
    const gm_result r = in.loaded(phi1, 300, omega1);
    loss += r.friction_power;
    input += -r.moment[0][2] * omega1;  // the drive balances the contact moment on gear 1
  }
  EXPECT_GT(loss, 0);
  EXPECT_NEAR(loss / input, mu * hv, 0.03 * mu * hv);
}

// Level 2 (ISO 6336-1 method B) for docs/physics.md §5's 57/57 pair (x 0.36139, E 206 GPa): the pair
// stiffness peaks at c' = 15.55 N/(mm um) mid-path, and the mesh stiffness averages to
// c_gamma_alpha = 23.58 N/(mm um) over a pitch. Level 3 averages to the same c_gamma_alpha.
gm_model_params iso_pair(int level) {
  gm_model_params p = quasi_static_paper();
  p.stiffness_level = level;
  p.gear[0].profile_shift = p.gear[1].profile_shift = 0.36139;
  p.gear[0].youngs_modulus = p.gear[1].youngs_modulus = 206e9;
  p.pair.center_distance = 0.150 + 1e-6;  // a hair of backlash (the shift sum is the tight one)
  return p;
}

TEST(Forces, IsoLevelsReproduceCPrimeAndCGammaAlpha) {
  for (int level : {GM_STIFFNESS_ISO6336, GM_STIFFNESS_CONTACT_LINE}) {
    Instance in(iso_pair(level));
    const double b = 0.023, to_si = 1e9;  // N/(mm um) -> N/m^2
    const int n = 600;
    double sum = 0, peak = 0;
    for (int s = 0; s < n; ++s) {
      const double phi1 = in.geo().p_bt / in.rb(0) * (s + 0.5) / n;
      const gm_result r = in.loaded(phi1, 20);  // light load: tip edges stay clear
      sum += r.stiffness;
      if (r.pairs_in_contact == 1) peak = std::max(peak, r.stiffness);
    }
    EXPECT_NEAR(sum / n / b / to_si, 23.58, 0.02 * 23.58) << "level " << level;
    if (level == GM_STIFFNESS_ISO6336) EXPECT_NEAR(peak / b / to_si, 15.55, 0.01 * 15.55);
  }
}

// Level 4 (analytical): the single-pair stiffness at the pitch point is of ISO's order (Weber
// models run 5-20 % below c'), and the local Hertz law stiffens the mesh with load (paper 2.2).
TEST(Forces, AnalyticalLevelStiffensWithLoad) {
  Instance in(iso_pair(GM_STIFFNESS_ANALYTICAL));
  double phi_single = NAN;
  for (int s = 0; s < 200 && std::isnan(phi_single); ++s) {
    const double phi1 = in.geo().p_bt / in.rb(0) * (s + 0.5) / 200;
    if (in.loaded(phi1, 300).pairs_in_contact == 1) phi_single = phi1 + 0.3 * in.geo().p_bt / in.rb(0) * (1 - (in.geo().eps_alpha - 1));
  }
  ASSERT_FALSE(std::isnan(phi_single));
  const gm_result light = in.loaded(phi_single, 50), heavy = in.loaded(phi_single, 350);
  ASSERT_EQ(light.pairs_in_contact, 1);
  ASSERT_EQ(heavy.pairs_in_contact, 1);
  EXPECT_GT(heavy.stiffness, light.stiffness * 1.02);           // stiffening
  EXPECT_LT(heavy.te / light.te, 350.0 / 50.0);                 // TE grows less than the load
  EXPECT_GT(heavy.solver_iterations, 0);
  const double c = heavy.stiffness / 0.023 / 1e9;                // N/(mm um)
  EXPECT_GT(c, 0.75 * 15.55);
  EXPECT_LT(c, 1.05 * 15.55);
}

// Wedging under load: below the tight-mesh centre distance both flanks of the teeth carry load;
// the quasi-static balance still converges (flank B slices have te_gain < 0) and the torque is
// balanced exactly.
TEST(Forces, WedgedMeshUnderLoadConverges) {
  for (int level : {GM_STIFFNESS_USER_CONSTANT, GM_STIFFNESS_ANALYTICAL}) {
    gm_model_params p = quasi_static_paper();
    p.stiffness_level = level;
    Instance in(p);
    gm_kinematics k{};
    k.u[1][0] = in.geo().a_tight - p.pair.center_distance - 5e-6;  // 5 um inside tight mesh
    // the preload of 2 x 5 um sin(alpha_w) interference is worth some 40 N m: below that both
    // flanks stay loaded, far above it flank B lifts off
    for (double torque : {0.0, 20.0, -20.0, 300.0}) {
      k.load_torque = torque;
      k.phi[0] = 0.013;
      const gm_result r = in.eval(k);
      EXPECT_TRUE(std::isfinite(r.te));
      EXPECT_EQ(r.flank, torque == 300.0 ? 1 : 3) << "level " << level << " torque " << torque;
      EXPECT_GT(r.normal_force, 0);
      EXPECT_NEAR(r.moment[1][2], -torque, 1e-6 * (std::fabs(torque) + 1));
    }
  }
}

// A stress sweep over random poses, loads, velocities, tilts and levels: every evaluation is
// either finite or a clear error (never NaN), and the instance stays usable.
TEST(Forces, RandomStressNeverGivesNaN) {
  unsigned seed = 12345;
  const auto uniform = [&](double lo, double hi) {
    seed = seed * 1664525u + 1013904223u;
    return lo + (hi - lo) * (seed >> 8) / 16777216.0;
  };
  int errors = 0, ok = 0;
  for (int level : {0, 2, 3, 4}) {
    for (int qs = 0; qs < 2; ++qs) {
      gm_model_params p;
      gm_default_params(&p);
      p.stiffness_level = level;
      p.quasi_static = qs;
      p.slices = 5;
      p.friction_coefficient = 0.3;
      p.damping = 500;
      Instance in(p);
      for (int i = 0; i < 300; ++i) {
        gm_kinematics k{};
        k.phi[0] = uniform(-100, 100);
        k.phi[1] = uniform(-100, 100);
        for (int g = 0; g < 2; ++g) {
          for (int a = 0; a < 3; ++a) {
            k.u[g][a] = uniform(-50e-6, 50e-6);
            k.v[g][a] = uniform(-1, 1);
          }
          for (int a = 0; a < 2; ++a) {
            k.r[g][a] = uniform(-2e-3, 2e-3);
            k.w[g][a] = uniform(-1, 1);
          }
          k.omega[g] = uniform(-300, 300);
        }
        k.load_torque = uniform(-2000, 2000);
        gm_result r{};
        const gm_status st = gm_evaluate(in.m, in.d, &k, &r);
        if (st != GM_OK) {
          ++errors;
          EXPECT_GT(std::string(gm_data_message(in.d)).size(), 10u);
          continue;
        }
        ++ok;
        const double values[] = {r.te, r.te_angle, r.normal_force, r.stiffness, r.friction_power,
                                 r.max_line_load, r.solver_residual, r.force[0][0], r.force[1][1],
                                 r.moment[0][2], r.moment[1][0]};
        for (double v : values) ASSERT_TRUE(std::isfinite(v)) << "level " << level << " i " << i;
        EXPECT_GE(r.normal_force, 0);
        EXPECT_GE(r.friction_power, 0);
      }
    }
  }
  EXPECT_GT(ok, 8 * 300 / 2);  // most poses are physical; the rest are named errors
}

}  // namespace
