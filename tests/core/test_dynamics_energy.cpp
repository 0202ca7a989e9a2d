// The large-step mode's energy account (docs/dynamics.md, "Energy account") against a balance the
// test keeps itself. energy.residual cannot see the contact element: energy.parametric is what
// the spins put into the mesh beyond its energy change, friction and damping, so any of the three
// booked wrong moves into energy.parametric and the residual stays. What can see them is the
// gear pair's own balance, from quantities the account does not compute.
#include <cmath>
#include <cstdio>

#include "gearmesh/gearmesh.h"
#include "test_support.hpp"

namespace {

using gm_test::Instance;
using gm_test::kPi;

// Prescribed centre motion: gear 2's centre in x and y and gear 1's in y, each a sine of 2 to
// 20 um at 450 to 700 Hz, their velocities the derivatives (the spins are set by the caller).
gm_kinematics pose_at(double t) {
  struct Motion {
    int gear, axis;
    double amplitude, hz, phase;
  };
  const Motion motions[] = {{1, 0, 20e-6, 600, 0.0}, {1, 1, 3e-6, 450, 1.0}, {0, 1, 2e-6, 700, 2.0}};
  gm_kinematics k{};
  for (const Motion& m : motions) {
    const double w = 2 * kPi * m.hz;
    k.u[m.gear][m.axis] = m.amplitude * std::sin(w * t + m.phase);
    k.v[m.gear][m.axis] = m.amplitude * w * std::cos(w * t + m.phase);
  }
  return k;
}

// What the test integrates itself over a run of communication steps of H, each with the pose
// of its start held (as gm_dynamics_advance holds it) and the next pose set at its end.
struct Balance {
  gm_dynamics_state s{};  // the account at the end
  double torque_work = 0;   // T_1 dphi_1 + T_2 dphi_2 (torques held)
  double mesh_in = 0;       // work the spins put into the mesh: torque_work - dKE
  double spin_elastic = 0;  // the mesh's elastic energy change over the steps (the poses held)
  double pose_jumps = 0;    // its change at the communication points, where the pose jumps
  double centre_work = 0;   // work of the contact's friction and damping forces on the centre velocities
  double friction = 0, damping = 0;  // gm_evaluate's friction_power and damping_power, trapezoidal
};

// Set A at level 0 on 5 slices (its mesh conservative: the elastic forces are the gradient of U)
// at 1000 rpm under 200 N m, the torques held, no shafts, started 1 um of TE above the static
// approach of a single pair (the mesh mode rings and the tooth changes excite it). mu: friction
// (v0 1 mm/s); ratio: mesh damping as a fraction of critical (gm_mesh_damping_for_ratio).
Balance run(double mu, double ratio, double H, double duration) {
  gm_model_params p = gm_test::paper();
  p.slices = 5;
  p.friction_coefficient = mu;
  p.friction_velocity = 1e-3;
  gm_dynamics_params dp;
  gm_dynamics_default_params(&dp);
  char msg[512] = "";
  if (ratio > 0) EXPECT_EQ(gm_mesh_damping_for_ratio(&p, dp.inertia, ratio, &p.damping, msg, sizeof msg), GM_OK) << msg;
  gm_model_params pc = p;  // the elastic forces alone
  pc.friction_coefficient = 0;
  pc.damping = 0;
  Instance inst(p), twin(p), elastic(pc);
  const double load = 200, rpm = 1000;
  gm_dynamics_inputs in{};
  in.torque[0] = load * inst.rb(0) / inst.rb(1);
  in.torque[1] = load * inst.sign();  // against gear 2's turning, loads flank A
  gm_kinematics k = pose_at(0);
  const double te = load / inst.rb(1) / (p.user_stiffness * p.gear[0].face_width) + 1e-6;
  k.phi[1] = te / (inst.sign() * inst.rb(1));
  k.omega[0] = rpm * 2 * kPi / 60;
  k.omega[1] = -inst.sign() * k.omega[0] * inst.rb(0) / inst.rb(1);
  Balance b;
  gm_result res{};
  EXPECT_EQ(gm_dynamics_start(inst.m, inst.d, &dp, &k, &in, &b.s, &res), GM_OK) << gm_data_message(inst.d);
  const double phi0[2] = {b.s.phi[0], b.s.phi[1]}, kinetic0 = b.s.kinetic;
  // the friction and damping forces' power on the centre velocities: the forces beyond the
  // elastic ones at the same state, times the centres' velocities (no tilt rates)
  const auto centre_power = [&](const gm_kinematics& at, const gm_result& r) {
    const gm_result e = elastic.eval(at);
    double power = 0;
    for (int i = 0; i < 2; ++i)
      for (int a = 0; a < 3; ++a) power += (r.force[i][a] - e.force[i][a]) * at.v[i][a];
    return power;
  };
  double end_elastic = res.elastic_energy;
  const int steps = static_cast<int>(std::lround(duration / H));
  for (int n = 0; n < steps; ++n) {
    gm_kinematics at = pose_at(n * H);  // the step's pose, at the spins it starts from
    for (int i = 0; i < 2; ++i) {
      at.phi[i] = b.s.phi[i];
      at.omega[i] = b.s.omega[i];
    }
    const gm_result r0 = twin.eval(at);
    b.pose_jumps += r0.elastic_energy - end_elastic;
    gm_result r1{};
    EXPECT_EQ(gm_dynamics_advance(inst.m, inst.d, &dp, &at, &in, H, &b.s, &r1), GM_OK) << gm_data_message(inst.d);
    gm_kinematics end = at;
    for (int i = 0; i < 2; ++i) {
      end.phi[i] = b.s.phi[i];
      end.omega[i] = b.s.omega[i];
    }
    b.spin_elastic += r1.elastic_energy - r0.elastic_energy;
    b.friction += 0.5 * H * (r0.friction_power + r1.friction_power);
    b.damping += 0.5 * H * (r0.damping_power + r1.damping_power);
    b.centre_work += 0.5 * H * (centre_power(at, r0) + centre_power(end, r1));
    end_elastic = r1.elastic_energy;
  }
  for (int i = 0; i < 2; ++i) b.torque_work += in.torque[i] * (b.s.phi[i] - phi0[i]);
  b.mesh_in = b.torque_work - (b.s.kinetic - kinetic0);
  return b;
}

// The balance, over 20 ms at communication steps of 1e-5 s, with friction alone (mu 0.1), mesh
// damping alone (0.05 of critical) and both. The spins' work on the mesh (from the held torques
// and the kinetic energy: exact) is the mesh's elastic energy change plus the losses plus the
// work of friction and damping on the prescribed centre velocities (the contact forces beyond
// the elastic ones, which a twin without friction and damping gives at the same states, times
// the centre velocities). So the account's friction + damping must be
//   mesh_in - spin_elastic - centre_work,
// none of which the account computes; and, the mesh being conservative, energy.parametric must
// be the centre work (docs/dynamics.md, "Interface choices and their limits"). Also: the
// account's friction and damping against gm_evaluate's powers integrated by the test (trapezoidal), its net work
// against the torques' and the poses' jumps, and a small residual. Each within 5e-3 of the
// case's losses (4.14, 0.297, 4.45 J), the net work to rounding. Measured: the losses within
// 2.3e-3 (damping alone; 3e-5 and 7e-5 with friction), the powers 1.4e-3, the parametric work
// 5e-4 (centre work -0.0096, 0.0011, -0.0086 J), the residual 1.8e-3, the net work 3e-12; at
// steps of 5e-6 s the differences shrink two- to fourfold (the test's trapezoid and the step).
// Planted in dynamics.cpp, each fails this test: friction or damping left out of
// energy.friction / energy.damping (the residual sees it too); and, with the residual
// unchanged, friction left out of the stage points' power (it moves into energy.parametric) or
// the contact damping left out of both energy.damping and the parametric balance (which the
// Dynamics tests did not see).
TEST(DynamicsEnergy, LargeStepAccountSeesFrictionAndDampingWithMovingPoses) {
  struct Case {
    const char* name;
    double mu, ratio;
  };
  for (const Case& c : {Case{"friction", 0.1, 0.0}, Case{"damping", 0.0, 0.05}, Case{"both", 0.1, 0.05}}) {
    SCOPED_TRACE(c.name);
    const Balance b = run(c.mu, c.ratio, 1e-5, 0.02);
    const gm_dynamics_state& s = b.s;
    const double losses = b.mesh_in - b.spin_elastic - b.centre_work;
    std::printf("%s: friction %.6g J (test %.6g), damping %.6g J (test %.6g), balance %.6g J; "
                "parametric %.4g J, centre work %.4g J; residual %.3g J; jumps %.4g J\n",
                c.name, s.friction, b.friction, s.damping, b.damping, losses, s.parametric, b.centre_work,
                s.residual, b.pose_jumps);
    if (c.mu == 0) EXPECT_EQ(s.friction, 0.0);
    if (c.ratio == 0) EXPECT_EQ(s.damping, 0.0);
    EXPECT_NEAR(s.friction + s.damping, losses, 5e-3 * losses);
    EXPECT_NEAR(s.friction, b.friction, 5e-3 * losses);
    EXPECT_NEAR(s.damping, b.damping, 5e-3 * losses);
    EXPECT_NEAR(s.parametric, b.centre_work, 5e-3 * losses);
    EXPECT_NEAR(s.work_in - s.work_out, b.torque_work + b.pose_jumps, 1e-9 * losses);
    EXPECT_LE(std::fabs(s.residual), 5e-3 * losses);
  }
}

}  // namespace
