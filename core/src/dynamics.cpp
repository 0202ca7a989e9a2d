// Large-step dynamics: TR-BDF2 over the two gear spins (the method and why: dynamics.hpp).
#include "dynamics.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "evaluate.hpp"
#include "mesh_orders.hpp"
#include "trbdf2.hpp"
#include "params.hpp"

namespace gm {
namespace {

using namespace trbdf2;  // the method's constants and step rules (trbdf2.hpp)
constexpr int kMaxExactNewton = 60;  // StepOptions::replay: Newton to rounding

// A state (spins) with what the equations give there, at time t into the call.
struct Point {
  double phi[2] = {0, 0}, omega[2] = {0, 0};
  double accel[2] = {0, 0};         // domega/dt, rad/s^2
  double shaft_torque[2] = {0, 0};  // N m
  double power_in = 0, power_out = 0;  // put in / taken out at the torques and far ends, W
  double power_friction = 0;        // W
  double power_damping = 0;         // contact and shaft dampers, W
  double elastic = 0;               // mesh + shafts, J
  gm_result res{};
};

struct Stepper {
  const gm_model& m;
  gm_data& d;
  const gm_dynamics_params& p;
  const gm_kinematics& pose;
  const gm_dynamics_inputs& in;
  double a_phi[2][2] = {}, a_omega[2][2] = {};  // d(accel)/d(phi), d(accel)/d(omega) at the step start
  double contraction = 0;  // the largest first Newton contraction of the stages since it was reset
  bool exact = false;      // Newton until it stops contracting (StepOptions::replay)

  double far_angle(int i, double t) const { return in.shaft_phi[i] + in.shaft_omega[i] * t; }

  gm_status evaluate_at(double t, const double phi[2], const double omega[2], Point& out) {
    gm_kinematics k = pose;
    for (int i = 0; i < 2; ++i) {
      k.phi[i] = phi[i];
      k.omega[i] = omega[i];
      out.phi[i] = phi[i];
      out.omega[i] = omega[i];
    }
    const gm_status st = gm::evaluate(m, d, k, out.res);
    if (st != GM_OK) return st;
    out.power_in = out.power_out = out.power_damping = out.elastic = 0;
    for (int i = 0; i < 2; ++i) {
      const double twist = far_angle(i, t) - phi[i], slip = in.shaft_omega[i] - omega[i];
      out.shaft_torque[i] = p.shaft_stiffness[i] * twist + p.shaft_damping[i] * slip;
      out.accel[i] = (in.torque[i] + out.shaft_torque[i] + out.res.moment[i][2]) / p.inertia[i];
      for (const double port : {in.torque[i] * omega[i], out.shaft_torque[i] * in.shaft_omega[i]})
        (port > 0 ? out.power_in : out.power_out) += std::fabs(port);
      out.power_damping += p.shaft_damping[i] * slip * slip;
      out.elastic += 0.5 * p.shaft_stiffness[i] * twist * twist;
    }
    out.power_friction = out.res.friction_power;
    out.power_damping += out.res.damping_power;
    out.elastic += out.res.elastic_energy;
    return GM_OK;
  }

  // The exact Jacobian of the accelerations at x (the mesh through gm_directional_derivative),
  // kept for the Newton matrix and the error filter.
  gm_status jacobian(const Point& x) { return jacobian_at(x, a_phi, a_omega); }

  gm_status jacobian_at(const Point& x, double (&a_phi)[2][2], double (&a_omega)[2][2]) {
    gm_kinematics at = pose;
    for (int i = 0; i < 2; ++i) {
      at.phi[i] = x.phi[i];
      at.omega[i] = x.omega[i];
    }
    // The mesh's moments depend on the speeds through friction and contact damping only
    // (Dynamics.MomentsDoNotDependOnSpeedsWithoutFrictionAndDamping): without both, the speed
    // directions are not evaluated.
    const bool speed_dependent = m.params.friction_coefficient != 0 || m.params.damping != 0;
    for (int j = 0; j < 2; ++j) {
      for (int which = 0; which < 2; ++which) {
        gm_result dr{};
        if (which == 0 || speed_dependent) {
          gm_kinematics seed{};
          (which == 0 ? seed.phi : seed.omega)[j] = 1.0;
          const gm_status st = gm::directional_derivative(m, d, at, seed, dr);
          if (st != GM_OK) return st;
        }
        for (int i = 0; i < 2; ++i) {
          const double own = i == j ? (which == 0 ? p.shaft_stiffness[i] : p.shaft_damping[i]) : 0.0;
          (which == 0 ? a_phi : a_omega)[i][j] = (dr.moment[i][2] - own) / p.inertia[i];
        }
      }
    }
    return GM_OK;
  }

  // Solve (I - hd B) x = r in place, B = hd A_phi + A_omega (the stage Newton matrix). False if
  // singular.
  bool newton_solve(double hd, double r[2]) const { return solve_stage_matrix(hd, a_phi, a_omega, r); }

  static bool solve_stage_matrix(double hd, const double (&a_phi)[2][2], const double (&a_omega)[2][2],
                                 double r[2]) {
    double n[2][2];
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 2; ++j) n[i][j] = (i == j ? 1.0 : 0.0) - hd * (hd * a_phi[i][j] + a_omega[i][j]);
    const double det = n[0][0] * n[1][1] - n[0][1] * n[1][0];
    if (!(std::fabs(det) > 0) || !std::isfinite(det)) return false;
    const double x0 = (n[1][1] * r[0] - n[0][1] * r[1]) / det;
    const double x1 = (n[0][0] * r[1] - n[1][0] * r[0]) / det;
    r[0] = x0;
    r[1] = x1;
    return std::isfinite(x0) && std::isfinite(x1);
  }

  // One implicit stage at time t: z_omega - hd a(t, r_phi + hd z_omega, z_omega) = r_omega,
  // Newton from the guess in omega. GM_ERR_SOLVER if it does not converge (the step is retried
  // shorter).
  gm_status stage(double t, double hd, const double r_phi[2], const double r_omega[2],
                  double omega[2], Point& out) {
    const double* rb = m.layout.base_radius;
    double previous = INFINITY;
    for (int it = 0; it < (exact ? kMaxExactNewton : kMaxNewton); ++it) {
      double phi[2] = {r_phi[0] + hd * omega[0], r_phi[1] + hd * omega[1]};
      // a trial state out of detection's range fails the stage like a diverging Newton: the
      // step is retried shorter (the held inputs were checked at the step's start)
      if (evaluate_at(t, phi, omega, out) != GM_OK) break;
      double g[2], size = 0;
      for (int i = 0; i < 2; ++i) {
        g[i] = omega[i] - hd * out.accel[i] - r_omega[i];
        size = std::max(size, rb[i] * hd * std::fabs(g[i]));  // the residual as rim motion, m
      }
      if (!std::isfinite(size)) break;
      if (it == 1) contraction = std::max(contraction, size / previous);
      if (exact) {  // on until the residual stops shrinking (rounding)
        if (it > 1 && (size == 0 || size > 0.5 * previous))
          return size <= kNewtonFraction * p.tolerance ? GM_OK : GM_ERR_SOLVER;
        if (it + 1 == kMaxExactNewton) break;
        previous = size;
        // Newton's own: the Jacobian at the iterate (where tanh(v / v0) turns, the step start's
        // differs by orders of magnitude and a kept one stalls short of rounding)
        if (jacobian(out) != GM_OK || !newton_solve(hd, g)) break;
        omega[0] -= g[0];
        omega[1] -= g[1];
        continue;
      }
      if (it > 0 && size <= kNewtonFraction * p.tolerance) {
        if (it > 2) contraction = INFINITY;  // slow: the Jacobian is taken anew for the next step
        return GM_OK;
      }
      if (it >= 3 && size > 0.9 * previous) break;  // not contracting
      previous = size;
      if (!newton_solve(hd, g)) break;
      omega[0] -= g[0];
      omega[1] -= g[1];
    }
    return GM_ERR_SOLVER;
  }

  // The mesh mode at the step start: the speeds v = J^-1 g along which the gears move apart on
  // the line of action (g = d(TE)/d(phi) = (r_b1, s r_b2), TE rate g v), and its frequency from
  // the Jacobian, q'' = -omega_n^2 q along phi = v q (0 without contact).
  struct MeshMode {
    double g[2], v[2], gv, omega_n;
  };
  MeshMode mesh_mode() const {
    MeshMode mode;
    mode.g[0] = m.layout.base_radius[0];
    mode.g[1] = m.layout.sign * m.layout.base_radius[1];
    for (int i = 0; i < 2; ++i) mode.v[i] = mode.g[i] / p.inertia[i];
    mode.gv = mode.g[0] * mode.v[0] + mode.g[1] * mode.v[1];
    double stiffness = 0;  // -g A_phi v / g v
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 2; ++j) stiffness -= mode.g[i] * a_phi[i][j] * mode.v[j] / mode.gv;
    mode.omega_n = stiffness > 0 && std::isfinite(stiffness) ? std::sqrt(stiffness) : 0.0;
    return mode;
  }

  // The filtered error of a step of h from x1 over stages x2, x3, as a fraction of the tolerance.
  double error_fraction(double h, const Point& x1, const Point& x2, const Point& x3) const {
    const double* rb = m.layout.base_radius;
    double e_phi[2], e_omega[2];
    for (int i = 0; i < 2; ++i) {
      e_phi[i] = h * (kE1 * x1.omega[i] + kE2 * x2.omega[i] + kE3 * x3.omega[i]);
      e_omega[i] = h * (kE1 * x1.accel[i] + kE2 * x2.accel[i] + kE3 * x3.accel[i]);
    }
    // (I - hd J) e' = e with J = [[0, I], [A_phi, A_omega]]: e'_omega = N^-1 (e_omega + hd A_phi e_phi)
    const double hd = h * kD;
    double r[2];
    for (int i = 0; i < 2; ++i) r[i] = e_omega[i] + hd * (a_phi[i][0] * e_phi[0] + a_phi[i][1] * e_phi[1]);
    if (!newton_solve(hd, r)) return INFINITY;
    double fraction = 0;
    for (int i = 0; i < 2; ++i)
      fraction = std::max(fraction, rb[i] * std::fabs(e_phi[i] + hd * r[i]) / p.tolerance);
    // A speed error counts by the rim motion it makes, split by mode. In the mesh mode (the
    // gears moving apart on the line of action, speeds along v = J^-1 g, g = d(TE)/d(phi) =
    // (r_b1, s r_b2)) it becomes a TE oscillation of amplitude |g e| / omega_n, omega_n the
    // mode's frequency from the Jacobian: the error in the mode's energy norm. Where the step
    // does not resolve the mode (h > 1 / omega_n) the error is the slow motion's and counts over
    // the step (at 1 / omega_n alone, 0.5 mm of wedging, whose TE snaps through 170 um at tooth
    // events, came 0.06 um off the converged dynamics at tolerance 1e-9 m; docs/stability.md);
    // without contact, over the longest step. In the rest, the gears' common rotation, it
    // persists: the rim motion over the longest step. Counted over the longest step, the mesh
    // mode's speed error, not the TE error, would set the step.
    const MeshMode mode = mesh_mode();
    const double te_rate = mode.g[0] * r[0] + mode.g[1] * r[1];
    const double te_time = mode.omega_n > 0 ? std::min(p.max_step, std::max(h, 1.0 / mode.omega_n)) : p.max_step;
    fraction = std::max(fraction, std::fabs(te_rate) * te_time / p.tolerance);
    for (int i = 0; i < 2; ++i) {
      const double common = r[i] - te_rate / mode.gv * mode.v[i];
      fraction = std::max(fraction, rb[i] * std::fabs(common) * p.max_step / p.tolerance);
    }
    return std::isfinite(fraction) ? fraction : INFINITY;
  }

  // One TR-BDF2 step of h from x1 (evaluated at t). On GM_OK x3 is the end and *fraction its
  // error; GM_ERR_SOLVER: a stage did not converge.
  gm_status step(double t, double h, const Point& x1, Point& x2, Point& x3, double* fraction) {
    const double hd = h * kD;
    double r_phi[2], r_omega[2], omega[2];
    for (int i = 0; i < 2; ++i) {
      r_phi[i] = x1.phi[i] + hd * x1.omega[i];
      r_omega[i] = x1.omega[i] + hd * x1.accel[i];
      omega[i] = x1.omega[i] + kGamma * h * x1.accel[i];
    }
    gm_status st = stage(t + kGamma * h, hd, r_phi, r_omega, omega, x2);
    if (st != GM_OK) return st;
    for (int i = 0; i < 2; ++i) {
      r_phi[i] = x1.phi[i] + h * kW * (x1.omega[i] + x2.omega[i]);
      r_omega[i] = x1.omega[i] + h * kW * (x1.accel[i] + x2.accel[i]);
      omega[i] = x2.omega[i] + (1.0 - kGamma) * h * x2.accel[i];
    }
    st = stage(t + h, hd, r_phi, r_omega, omega, x3);
    if (st != GM_OK) return st;
    *fraction = error_fraction(h, x1, x2, x3);
    return GM_OK;
  }
};

// The step's sensitivity (gm_step_sensitivity), carried over the accepted internal steps. With
// S = (P, W) = d(phi, omega)/d(column) and the accelerations' derivative along a column at stage
// k, da_k = A_phi,k P_k + A_omega,k W_k + a_u(t_k) (A at the stage point itself, not the Newton
// matrix's kept one), the stage equations of TrBdf2 differentiate to
//   stage 2: (I - hd (hd A_phi,2 + A_omega,2)) W_2 = W_1 + hd da_1 + hd A_phi,2 (P_1 + hd W_1) + hd a_u(t_2),
//            P_2 = P_1 + hd (W_1 + W_2);
//   stage 3: (I - hd (hd A_phi,3 + A_omega,3)) W_3 = W_1 + hw (da_1 + da_2) + hd A_phi,3 (P_1 + hw (W_1 + W_2))
//            + hd a_u(t_3),  P_3 = P_1 + hw (W_1 + W_2) + hd W_3,
// hd = d h, hw = w h: one 2x2 solve per stage and column. a_u: the inputs' direct part,
// d(accel_i) = (dT_i + k_i (dshaft_phi_i + t dshaft_omega_i) + c_i dshaft_omega_i) / J_i.
struct Sensitivity {
  double P[2][GM_SENS_COLUMNS] = {}, W[2][GM_SENS_COLUMNS] = {};
  double a1_phi[2][2] = {}, a1_omega[2][2] = {};  // the Jacobian at the current point

  gm_status start(Stepper& st, const Point& x1) {
    for (int i = 0; i < 2; ++i) {
      P[i][GM_SENS_PHI1 + i] = 1.0;
      W[i][GM_SENS_OMEGA1 + i] = 1.0;
    }
    return st.jacobian_at(x1, a1_phi, a1_omega);
  }

  // d(accel_i)/d(column c) from the inputs directly, at time t into the call
  static double direct(const gm_dynamics_params& p, int i, int c, double t) {
    if (c == GM_SENS_TORQUE1 + i) return 1.0 / p.inertia[i];
    if (c == GM_SENS_SHAFT_PHI1 + i) return p.shaft_stiffness[i] / p.inertia[i];
    if (c == GM_SENS_SHAFT_OMEGA1 + i) return (p.shaft_stiffness[i] * t + p.shaft_damping[i]) / p.inertia[i];
    return 0.0;
  }

  // Over an accepted step of h at t through the stage points x2, x3.
  gm_status advance(Stepper& st, double t, double h, const Point& x2, const Point& x3) {
    double a2_phi[2][2], a2_omega[2][2], a3_phi[2][2], a3_omega[2][2];
    gm_status status = st.jacobian_at(x2, a2_phi, a2_omega);
    if (status == GM_OK) status = st.jacobian_at(x3, a3_phi, a3_omega);
    if (status != GM_OK) return status;
    const double hd = h * kD, hw = h * kW, t2 = t + kGamma * h, t3 = t + h;
    const gm_dynamics_params& p = st.p;
    for (int c = 0; c < GM_SENS_COLUMNS; ++c) {
      double p1[2], w1[2], da1[2], p2[2], w2[2], da2[2], r[2];
      for (int i = 0; i < 2; ++i) {
        p1[i] = P[i][c];
        w1[i] = W[i][c];
      }
      for (int i = 0; i < 2; ++i)
        da1[i] = a1_phi[i][0] * p1[0] + a1_phi[i][1] * p1[1] + a1_omega[i][0] * w1[0] + a1_omega[i][1] * w1[1] +
                 direct(p, i, c, t);
      for (int i = 0; i < 2; ++i)
        r[i] = w1[i] + hd * da1[i] +
               hd * (a2_phi[i][0] * (p1[0] + hd * w1[0]) + a2_phi[i][1] * (p1[1] + hd * w1[1])) +
               hd * direct(p, i, c, t2);
      if (!Stepper::solve_stage_matrix(hd, a2_phi, a2_omega, r)) return GM_ERR_SOLVER;
      for (int i = 0; i < 2; ++i) {
        w2[i] = r[i];
        p2[i] = p1[i] + hd * (w1[i] + w2[i]);
      }
      for (int i = 0; i < 2; ++i)
        da2[i] = a2_phi[i][0] * p2[0] + a2_phi[i][1] * p2[1] + a2_omega[i][0] * w2[0] + a2_omega[i][1] * w2[1] +
                 direct(p, i, c, t2);
      double base[2];  // P_1 + hw (W_1 + W_2)
      for (int i = 0; i < 2; ++i) base[i] = p1[i] + hw * (w1[i] + w2[i]);
      for (int i = 0; i < 2; ++i)
        r[i] = w1[i] + hw * (da1[i] + da2[i]) + hd * (a3_phi[i][0] * base[0] + a3_phi[i][1] * base[1]) +
               hd * direct(p, i, c, t3);
      if (!Stepper::solve_stage_matrix(hd, a3_phi, a3_omega, r)) return GM_ERR_SOLVER;
      for (int i = 0; i < 2; ++i) {
        W[i][c] = r[i];
        P[i][c] = base[i] + hd * r[i];
      }
    }
    std::copy(&a3_phi[0][0], &a3_phi[0][0] + 4, &a1_phi[0][0]);
    std::copy(&a3_omega[0][0], &a3_omega[0][0] + 4, &a1_omega[0][0]);
    return GM_OK;
  }

  void write(gm_step_sensitivity& out) const {
    for (int i = 0; i < 2; ++i)
      for (int c = 0; c < GM_SENS_COLUMNS; ++c) {
        out.phi[i][c] = P[i][c];
        out.omega[i][c] = W[i][c];
      }
  }
};

// The energy account of an accepted step of h over x1, x2, x3: the powers integrated with the
// method's own weights (w, w, d).
void account(double h, const Point& x1, const Point& x2, const Point& x3, gm_dynamics_state& s) {
  const auto integral = [&](double Point::* power) {
    return h * (kW * (x1.*power + x2.*power) + kD * x3.*power);
  };
  s.work_in += integral(&Point::power_in);
  s.work_out += integral(&Point::power_out);
  s.friction += integral(&Point::power_friction);
  s.damping += integral(&Point::power_damping);
  // What the spins put into the mesh beyond its energy change, friction and contact damping.
  // The spins' work on the mesh is integrated along the path the step took through its stage
  // points (the trapezoidal rule in angle, x1 -> x2 -> x3), not with the time weights: for a
  // mesh whose moments are the gradient of its elastic energy and vary linearly over the step,
  // that is exactly the energy change, so a conservative mesh books no parametric work and the
  // integrator's own error stays in the residual. With the time weights the quadrature error of
  // an oscillation would split into a parametric gain and an equal and opposite residual
  // (Dynamics.UndampedMeshDoesNotGainEnergy fails on level 0's parametric work).
  const auto chord_work = [](const Point& a, const Point& b) {
    double w = 0;
    for (int i = 0; i < 2; ++i) w -= 0.5 * (a.res.moment[i][2] + b.res.moment[i][2]) * (b.phi[i] - a.phi[i]);
    return w;
  };
  const double mesh_work = chord_work(x1, x2) + chord_work(x2, x3);
  const double mesh_damping = h * (kW * (x1.res.damping_power + x2.res.damping_power) + kD * x3.res.damping_power);
  s.parametric += mesh_work - integral(&Point::power_friction) - mesh_damping -
                  (x3.res.elastic_energy - x1.res.elastic_energy);
}

// The step's aggregates (gm_step_aggregates): sums over the accepted internal steps of h times the
// method's weights (w, w, d) on the stage points x1, x2, x3 (the weights the spins' update uses, so
// the impulses balance the momentum), divided by the duration at the end; the TE's extremes over
// the stage points.
struct Aggregator {
  gm_step_aggregates a{};
  double te2 = 0;
  void start(const Point& x) {
    a = gm_step_aggregates{};
    te2 = 0;
    a.te_min = a.te_max = x.res.te;
  }
  void add(double h, const Point& x1, const Point& x2, const Point& x3) {
    const double w1 = h * kW, w2 = h * kW, w3 = h * kD;
    for (int i = 0; i < 2; ++i) {
      for (int k = 0; k < 3; ++k) {
        a.force_mean[i][k] += w1 * x1.res.force[i][k] + w2 * x2.res.force[i][k] + w3 * x3.res.force[i][k];
        a.moment_mean[i][k] += w1 * x1.res.moment[i][k] + w2 * x2.res.moment[i][k] + w3 * x3.res.moment[i][k];
      }
      a.shaft_torque_mean[i] += w1 * x1.shaft_torque[i] + w2 * x2.shaft_torque[i] + w3 * x3.shaft_torque[i];
    }
    a.normal_force_mean += w1 * x1.res.normal_force + w2 * x2.res.normal_force + w3 * x3.res.normal_force;
    a.te_mean += w1 * x1.res.te + w2 * x2.res.te + w3 * x3.res.te;
    te2 += w1 * x1.res.te * x1.res.te + w2 * x2.res.te * x2.res.te + w3 * x3.res.te * x3.res.te;
    for (const Point* x : {&x2, &x3}) {
      a.te_min = std::min(a.te_min, x->res.te);
      a.te_max = std::max(a.te_max, x->res.te);
    }
    a.duration += h;
  }
  gm_step_aggregates finish() const {
    gm_step_aggregates out = a;
    const double inv = out.duration > 0 ? 1.0 / out.duration : 0.0;
    for (int i = 0; i < 2; ++i) {
      for (int k = 0; k < 3; ++k) {
        out.force_mean[i][k] *= inv;
        out.moment_mean[i][k] *= inv;
      }
      out.shaft_torque_mean[i] *= inv;
    }
    out.normal_force_mean *= inv;
    out.te_mean *= inv;
    out.te_rms = std::sqrt(std::max(0.0, te2 * inv));
    return out;
  }
};

// The mesh orders' trajectory over a step: its stage points x1 -> x2 -> x3 (mesh_orders.hpp).
void add_orders(const gm_model& m, int n, const Point& x1, const Point& x2, const Point& x3,
                gm_mesh_orders& orders) {
  const auto point = [](const Point& x) { return OrderPoint{x.phi[0], {x.res.te, x.res.normal_force}}; };
  const int z1 = m.params.gear[0].teeth;
  orders_add(orders, z1, n, point(x1), point(x2));
  orders_add(orders, z1, n, point(x2), point(x3));
}

// The aggregates of a state alone (gm_dynamics_start): its values.
gm_step_aggregates point_aggregates(const Point& x) {
  gm_step_aggregates a;
  gm_point_aggregates(&x.res, x.shaft_torque, &a);
  return a;
}

void finish_state(const gm_dynamics_params& p, const Point& x, gm_dynamics_state& s) {
  s.kinetic = 0;
  for (int i = 0; i < 2; ++i) {
    s.phi[i] = x.phi[i];
    s.omega[i] = x.omega[i];
    s.shaft_torque[i] = x.shaft_torque[i];
    s.kinetic += 0.5 * p.inertia[i] * x.omega[i] * x.omega[i];
  }
  s.elastic = x.elastic;
  s.residual = s.work_in - s.work_out - (s.kinetic + s.elastic - s.initial_energy) - s.friction - s.damping -
               s.parametric;
}

std::string number(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", x);
  return buf;
}

}  // namespace

std::string check_dynamics(const gm_model& m, const gm_dynamics_params& p) {
  if (m.params.quasi_static)
    return std::string(GM_PARAM_NAME(quasi_static)) +
           " = true with the large-step dynamics: the dynamics integrate gear 2's spin themselves; allowed: one of "
           "the two";
  std::string msg;
  if (!check_rows(GM_PARAM_IN_DYNAMICS, &p, msg)) return msg;
  if (!(p.min_step <= p.max_step))
    return std::string(GM_DYNAMICS_PARAM_NAME(min_step)) + " = " + number(p.min_step) + " s: allowed <= " +
           GM_DYNAMICS_PARAM_NAME(max_step) + " = " + number(p.max_step) + " s";
  return "";
}

gm_status dynamics_start(const gm_model& m, gm_data& d, const gm_dynamics_params& p,
                         const gm_kinematics& pose, const gm_dynamics_inputs& in,
                         gm_dynamics_state& s, gm_result& res) {
  if ((d.message = check_dynamics(m, p)).size()) return GM_ERR_PARAMETER;
  Stepper st{m, d, p, pose, in};
  Point x;
  const gm_status status = st.evaluate_at(0.0, pose.phi, pose.omega, x);
  if (status != GM_OK) return status;
  gm_dynamics_state out{};
  finish_state(p, x, out);
  out.initial_energy = out.kinetic + out.elastic;
  out.residual = 0;
  out.step = std::min(p.max_step, 1e-5);
  out.step_aggregates = point_aggregates(x);
  s = out;
  res = x.res;
  d.message.clear();
  return GM_OK;
}

gm_status dynamics_advance(const gm_model& m, gm_data& d, const gm_dynamics_params& p,
                           const gm_kinematics& pose, const gm_dynamics_inputs& in, double duration,
                           gm_dynamics_state& s_io, gm_result& res, const StepOptions& options) {
  if ((d.message = check_dynamics(m, p)).size()) return GM_ERR_PARAMETER;
  if (!(duration > 0 && std::isfinite(duration))) {
    d.message = "large-step dynamics: step of " + number(duration) + " s; allowed: finite and > 0";
    return GM_ERR_ARGUMENT;
  }
  // A bound on the work of one call: a master's step of 1e308 s would otherwise never end.
  const double longest = GM_DYNAMICS_MAX_INTERNAL_STEPS * p.max_step;
  if (!(duration <= longest)) {
    d.message = "large-step dynamics: step of " + number(duration) + " s needs more than " +
                std::to_string(GM_DYNAMICS_MAX_INTERNAL_STEPS) + " internal steps of " +
                GM_DYNAMICS_PARAM_NAME(max_step) + " = " +
                number(p.max_step) + " s; allowed: at most " + number(longest) +
                " s per step; retry with a shorter communication step";
    return GM_ERR_SOLVER;
  }
  for (int i = 0; i < 2; ++i) {
    if (!std::isfinite(in.torque[i]) || !std::isfinite(in.shaft_phi[i]) || !std::isfinite(in.shaft_omega[i])) {
      d.message = "gear" + std::to_string(i + 1) + ".torque, .shaft_phi, .shaft_omega must be finite";
      return GM_ERR_INPUT;
    }
  }
  gm_dynamics_state s = s_io;
  Stepper st{m, d, p, pose, in};
  st.exact = options.replay != nullptr;
  Point x1, x2, x3;
  gm_status status = st.evaluate_at(0.0, s.phi, s.omega, x1);
  if (status != GM_OK) return status;
  Sensitivity sensitivity;
  if (options.sensitivity && (status = sensitivity.start(st, x1)) != GM_OK) return status;
  if (options.taken) options.taken->clear();
  std::size_t replayed = 0;  // internal steps of options.replay taken
  // Inputs that jumped between steps (a far end set elsewhere than where this FMU moved it, a
  // new pose) changed the stored elastic energy without motion of the spins: their work.
  const double jump = x1.elastic - s.elastic;
  (jump > 0 ? s.work_in : s.work_out) += std::fabs(jump);
  s.steps = s.rejected = 0;
  Aggregator aggregates;
  aggregates.start(x1);
  double t = 0, h = std::clamp(s.step, p.min_step, p.max_step);
  // The Jacobian is kept over the steps tried while trbdf2::keep_jacobian says so.
  bool jacobian_current = false;
  int jacobian_age = 0;  // accepted steps since it was taken
  // The step after a rejected one does not grow (Hairer, Norsett and Wanner, Solving ODEs I,
  // II.4): grown at once, it was often rejected again (bench_dynamics, level 4, 6000 rpm, mu 0:
  // 29 rejected internal steps per 1 ms step with the growth, 21 without).
  bool after_rejection = false;
  while (t < duration) {
    if (s.steps + s.rejected >= GM_DYNAMICS_MAX_INTERNAL_STEPS) {
      d.message = "large-step dynamics: " + std::to_string(GM_DYNAMICS_MAX_INTERNAL_STEPS) +
                  " internal steps (" + std::to_string(s.rejected) + " rejected) reached " + number(t) +
                  " s of a step of " + number(duration) + " s; allowed: at most " +
                  std::to_string(GM_DYNAMICS_MAX_INTERNAL_STEPS) +
                  " internal steps per step; retry with a shorter communication step";
      return GM_ERR_SOLVER;
    }
    const double remaining = duration - t;
    double h_try = step_to_try(h, remaining);
    if (options.replay) {
      if (replayed == options.replay->size()) {
        d.message = "large-step dynamics: the replayed internal steps end before the step's duration";
        return GM_ERR_ARGUMENT;
      }
      h_try = replayed + 1 == options.replay->size() ? remaining : (*options.replay)[replayed];
      jacobian_current = false;  // a Newton from the stage's own Jacobian: it converges to rounding
    }
    if (!jacobian_current) {
      if ((status = st.jacobian(x1)) != GM_OK) return status;
      jacobian_current = true;
      jacobian_age = 0;
    }
    st.contraction = 0;
    double fraction = INFINITY;
    status = st.step(t, h_try, x1, x2, x3, &fraction);
    if (status == GM_ERR_INPUT) return status;
    const bool event = status == GM_OK && contact_changed(x1.res, x3.res);
    const double allowed = event ? kEventFraction : 1.0;
    if (status == GM_OK && (fraction <= allowed || options.replay)) {
      if (options.sensitivity && (status = sensitivity.advance(st, t, h_try, x2, x3)) != GM_OK) return status;
      if (options.taken) options.taken->push_back(h_try);
      ++replayed;
      account(h_try, x1, x2, x3, s);
      aggregates.add(h_try, x1, x2, x3);
      add_orders(m, p.mesh_orders, x1, x2, x3, s.orders);
      t = h_try == remaining ? duration : t + h_try;
      if (options.observer) {
        const gm_internal_point point{t,
                                      {x3.phi[0], x3.phi[1]},
                                      {x3.omega[0], x3.omega[1]},
                                      {x3.shaft_torque[0], x3.shaft_torque[1]},
                                      &x3.res};
        options.observer(options.observer_context, &point);
      }
      x1 = x3;
      ++jacobian_age;
      jacobian_current = keep_jacobian(true, st.contraction, jacobian_age);
      ++s.steps;
      const double growth = std::min(after_rejection ? 1.0 : 2.0, step_factor(fraction / allowed));
      h = std::min(p.max_step, std::max(h, h_try) * growth);
      after_rejection = false;
      continue;
    }
    if (options.replay) {
      d.message = "large-step dynamics: a replayed internal step did not converge";
      return GM_ERR_SOLVER;
    }
    ++s.rejected;
    after_rejection = true;
    jacobian_current = jacobian_current && keep_jacobian(status == GM_OK, st.contraction, jacobian_age);
    const bool newton_failed = status != GM_OK;
    h = h_try * (newton_failed ? 0.25 : std::min(0.5, step_factor(fraction / allowed)));
    if (h < p.min_step) {
      const std::string tolerance = GM_DYNAMICS_PARAM_NAME(tolerance);
      d.message = "large-step dynamics: the internal step fell below " + std::string(GM_DYNAMICS_PARAM_NAME(min_step)) +
                  " = " + number(p.min_step) + " s at " + number(t) + " s into a step of " + number(duration) + " s (" +
                  (newton_failed ? "Newton did not converge: " + (d.message.empty() ? std::string("no contraction")
                                                                                    : d.message)
                                 : "local error " + number(fraction) + " x " + tolerance) +
                  "); retry with a shorter communication step or a larger " + tolerance;
      return GM_ERR_SOLVER;
    }
  }
  s.step = h;
  finish_state(p, x1, s);
  s.step_aggregates = aggregates.finish();
  orders_publish(s.orders, p.order_cycles, p.mesh_orders);
  if (options.sensitivity) sensitivity.write(*options.sensitivity);
  s_io = s;
  res = x1.res;
  d.message.clear();
  return GM_OK;
}

}  // namespace gm

extern "C" void gm_point_aggregates(const gm_result* r, const double* shaft_torque, gm_step_aggregates* out) {
  gm_step_aggregates a{};
  for (int i = 0; i < 2; ++i) {
    for (int k = 0; k < 3; ++k) {
      a.force_mean[i][k] = r->force[i][k];
      a.moment_mean[i][k] = r->moment[i][k];
    }
    a.shaft_torque_mean[i] = shaft_torque ? shaft_torque[i] : 0.0;
  }
  a.normal_force_mean = r->normal_force;
  a.te_mean = a.te_min = a.te_max = r->te;
  a.te_rms = std::fabs(r->te);
  *out = a;
}
