// TR-BDF2 as both large-step integrators use it: the pair's (dynamics.cpp, two gear spins) and
// the train's (train.cpp, every body's spin and centre). One place for the method's constants
// and its step-size rules; why each value is what it is stands here.
#pragma once

#include <algorithm>
#include <cmath>

#include "gearmesh/gearmesh.h"

namespace gm::trbdf2 {

// TR-BDF2 as an ESDIRK (Hosea and Shampine 1996): stage 1 at t (the step's start), stage 2 the
// trapezoidal rule to t + gamma h, stage 3 BDF2 to t + h; both implicit stages have the diagonal
// coefficient d. The solution is stage 3 (stiffly accurate); its quadrature weights (w, w, d)
// also integrate the powers of the energy account.
constexpr double kSqrt2 = 1.41421356237309504880;
constexpr double kGamma = 2.0 - kSqrt2;
constexpr double kD = kGamma / 2.0;
constexpr double kW = kSqrt2 / 4.0;
// the embedded third-order solution minus the solution, per unit h, on (f1, f2, f3)
constexpr double kE1 = (1.0 - 4.0 * kW) / 3.0, kE2 = 1.0 / 3.0, kE3 = -2.0 * kD / 3.0;
constexpr int kMaxNewton = 10;
// Newton stops after at least one correction, once the stage residual (as rim motion) is within
// this fraction of the tolerance. The forced correction is what matters: a stage stopped at its
// explicit predictor keeps part of an explicit step, and an explicit step puts energy into an
// undamped oscillation until the teeth rattle (Dynamics.UndampedMeshDoesNotGainEnergy fails
// without it). Tighter (1e-4) costs a third more evaluations per internal step and moves neither
// the TE (Dynamics.ToothChangesAtSpeedConvergeWithTheTolerance) nor the undamped energy.
constexpr double kNewtonFraction = 1e-2;
// Error allowed over a step where the contact was lost or made, or changed flank. The estimate
// is unreliable across the kink; at the full tolerance the undamped mesh gains energy at its
// contact losses again (Dynamics.UndampedMeshDoesNotGainEnergy: level 0 peak force 7.2 -> 9.5
// kN, gearmesh stability's undamped_10rpm fails). A tooth pair entering or leaving a loaded
// mesh needs no such margin (Dynamics.ToothChangesAtSpeedConvergeWithTheTolerance, the same TE
// as with it), and holding every tooth change to it cost a third of all steps in rejections.
constexpr double kEventFraction = 0.25;
constexpr double kStaleContraction = 0.05;  // a first Newton contraction above this: new Jacobian
constexpr int kJacobianAge = 20;            // accepted steps on one Jacobian at most

// Whether the Jacobian (Newton matrix and error filter) is kept for the next step tried, after a
// step tried on it, accepted or rejected: kept unless it is kJacobianAge accepted steps old, the
// step's Newton failed, or its first Newton correction left more than kStaleContraction of the
// residual (with a current Jacobian little more than the stage's nonlinearity is left; a stale
// one, e.g. from before a tooth pair entered, costs a Newton iteration per stage). Kept with
// none of these, a stale one let the filtered error pass steps across the friction reversal at
// the pitch point (A_omega changes there by orders of magnitude), 0.14 um off the quasi-static
// p-p TE at mu 0.4 (Dynamics.PitchPointReversalConvergesWithTheTolerance). Taking it anew before
// every retry of a rejected step as well cost a fifth of all work (bench_dynamics, set A at 3000
// rpm: level 5 7.4 -> 5.9 evaluations per internal step, level 4 at mu 0.4 6.2 -> 5.2), with the
// same internal steps and rejections.
inline bool keep_jacobian(bool newton_converged, double contraction, int age) {
  return newton_converged && contraction <= kStaleContraction && age < kJacobianAge;
}

// Contact lost or made, or moved to the other flank (not a tooth pair entering a loaded mesh).
inline bool contact_changed(const gm_result& a, const gm_result& b) {
  return a.flank != b.flank || (a.pairs_in_contact == 0) != (b.pairs_in_contact == 0);
}

// The internal step to try with `remaining` of the communication step left: all of it once h
// reaches it within a master's rounding (1e-9 of h: a 1 ms step counted in nanoseconds, as
// libcosim counts, is then one internal step and not two halves that change the whole sequence),
// half of it where h would leave a sliver, else h.
inline double step_to_try(double h, double remaining) {
  if (h * (1.0 + 1e-9) >= remaining) return remaining;
  if (2.0 * h > remaining) return 0.5 * remaining;
  return h;
}

// The next step from the error fraction of the last (order 2: local error ~ h^3).
inline double step_factor(double fraction) {
  if (!(fraction > 0)) return 2.0;
  return std::clamp(0.9 * std::cbrt(1.0 / fraction), 0.2, 2.0);
}

}  // namespace gm::trbdf2
