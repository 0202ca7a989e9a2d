// Large-step dynamics: the two gears' spins integrated inside one call (gearmesh.h,
// gm_dynamics_*; docs/dynamics.md).
//
//   J_i domega_i/dt = T_i + k_i (theta_i(t) - phi_i) + c_i (Omega_i - omega_i) + M_i,z(phi, omega)
//   theta_i(t) = shaft_phi_i + Omega_i t   (the shaft's far end, first-order hold over the step)
//
// M_i,z is gm_evaluate's contact moment on gear i about +z, every other pose input held. The
// mesh is stiff (set A: ~2.5 kHz on 0.02 kg m^2 gears) and non-smooth (teeth entering and
// leaving, backlash, the friction reversal at the pitch point, tanh(v/v0) with v0 ~ 1e-5 m/s),
// while a master steps at 1e-3 ... 1e-2 s. Hence TR-BDF2 (Bank et al. 1985; as analysed by Hosea
// and Shampine 1996, MATLAB's ode23tb):
// * L-stable: an unresolved mesh mode is damped, not left ringing (the implicit midpoint rule
//   and the trapezoidal rule are only A-stable and ring at |R(inf)| = 1);
// * second order, one-step: no history to restart at events, after a state rollback, or when
//   the step size changes (unlike BDF2);
// * both implicit stages have the same diagonal coefficient d, so one Newton matrix (from the
//   exact Jacobian of gm_directional_derivative) serves the step;
// * an embedded third-order solution gives the local error, filtered through the Newton matrix
//   (Shampine) so that stiff components do not inflate it.
// A step is accepted when its error is within tolerance, and within a quarter of it when the
// contact changed over the step (flank, loaded tooth pairs): steps across contact and tooth
// changes are shortened until the change is resolved.
#pragma once

#include <vector>

#include "model.hpp"

namespace gm {

std::string check_dynamics(const gm_model& m, const gm_dynamics_params& p);

gm_status dynamics_start(const gm_model& m, gm_data& d, const gm_dynamics_params& p,
                         const gm_kinematics& pose, const gm_dynamics_inputs& in,
                         gm_dynamics_state& s, gm_result& res);

// What an advance does beyond the plain step: the step's sensitivity (gm_step_sensitivity), an
// observer of its internal steps (gm_advance_options), and
// for tests of its exactness, the internal steps it took and a replay of given steps.
struct StepOptions {
  gm_step_sensitivity* sensitivity = nullptr;  // written on GM_OK
  gm_internal_observer observer = nullptr;     // after each accepted internal step
  void* observer_context = nullptr;
  std::vector<double>* taken = nullptr;        // the accepted internal steps' sizes, s
  // Take exactly these internal steps (they must sum to the duration), accepted whatever their
  // error, each stage's Newton run until it stops contracting: the step as a smooth function
  // of its inputs, for central differences against the sensitivity.
  const std::vector<double>* replay = nullptr;
};

gm_status dynamics_advance(const gm_model& m, gm_data& d, const gm_dynamics_params& p,
                           const gm_kinematics& pose, const gm_dynamics_inputs& in, double duration,
                           gm_dynamics_state& s, gm_result& res, const StepOptions& options = {});

}  // namespace gm
