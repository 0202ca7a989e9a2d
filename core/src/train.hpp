// A gear train: rigid bodies turning about parallel axes (gears, carriers), torsional shafts
// between them or to a far end, and meshes, each a full GearMesh element (its own gm_model:
// level, slices, micro-geometry, friction, databases) between two of the bodies. The bodies'
// spins are integrated over a step as the pair's large-step mode integrates its two gears
// (TR-BDF2, the exact Jacobian assembled from the meshes' directional derivatives, error
// control, the energy account; core/src/dynamics.hpp gives the method and its reasons).
//
//   J_b domega_b/dt = T_b + sum of shaft torques on b + sum of mesh moments on b
//
// A mesh sits on a carrier body c (a planetary stage's meshes) or on the housing (c = -1). Its
// element sees the gears in the carrier's frame, turned by the mesh's orientation psi (the
// direction from the element's gear 1 to its gear 2): phi_el,i = phi_{g_i} - phi_c - psi and
// omega_el,i = omega_{g_i} - omega_c. The element's moments M_1, M_2 act on its gears, and
// -(M_1 + M_2) on the carrier: that is the moment about the carrier's axis of the force the
// carrier's bearings take from the gears it carries (the element's internal forces have no net
// moment, M_1 + M_2 + sum r_i x f_i = 0). The planets' centres are fixed in the carrier (their
// orbital mass belongs in the carrier's inertia, m_p r_p^2), each off by its pin error; with their
// axes parallel to the carrier's there is no gyroscopic moment, and the centrifugal force loads
// the planet bearings only, radially, which the planets' rigid pins do not pass on.
//
// Bearing translations: a body on the housing's axis (a sun, a ring, a gear of a parallel stage)
// with a mass may move in the housing's plane on its bearing (stiffness and damping per axis; 0:
// a floating sun, held only by its meshes):
//
//   m_b d^2x_b/dt^2 = -k_b x_b - c_b dx_b/dt + sum over its meshes of R(theta) f_i
//
// with theta = phi_c + psi the element frame's angle in the housing (phi_c = 0 on the housing)
// and f_i the element's force on the body's gear; the element sees the centre's displacement
// u_i = R(-theta) x_b and its rate in the element's frame. The carrier then takes
// -(M_1 + M_2) - u_i x f_i: the moment of the forces on the gears it carries, the on-axis gear's
// force going to its own bearing. Carriers and planets do not translate.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "gearmesh/gearmesh.h"

namespace gm {

struct TrainBody {
  double inertia = 0;  // kg m^2 about its axis; ignored when fixed
  bool fixed = false;  // held at angle 0 (a ring in the housing); its reaction is reported
  double mass = 0;     // kg: > 0 lets the centre translate on its bearing (on the housing's axis)
  double bearing_stiffness = 0, bearing_damping = 0;  // N/m, N s/m per axis of the housing's plane
  double pin_error[2] = {0, 0};  // a planet's centre off its nominal place in the carrier: tangential
                                 // (along the carrier's turning), radial (outwards), m
};

struct TrainMesh {
  const gm_model* model = nullptr;
  gm_data* data = nullptr;
  int gear[2] = {-1, -1};  // bodies of the element's gear 1 and gear 2
  int carrier = -1;        // body carrying the mesh, -1: the housing
  double orientation = 0;  // psi, rad, in the carrier's frame
  double offset[2][2] = {{0, 0}, {0, 0}};  // static centre displacement of each gear in the
                                           // element's frame (x towards gear 2), m; the bodies'
                                           // pin errors are added to it (the other gear of a
                                           // planet's mesh on the carrier's axis)
};

struct TrainShaft {
  int body = -1;   // the body the shaft turns
  int other = -1;  // the body at its other end, -1: a far end (a port: angle and speed in)
  double stiffness = 0, damping = 0;  // N m/rad, N m s/rad
};

struct TrainParams {
  double tolerance = 1e-8;  // local error of the rim motion per internal step, m
  double max_step = 1e-3, min_step = 1e-9;  // s
};

struct TrainInputs {
  std::vector<double> torque;               // per body, N m about +z, held over the step
  std::vector<double> far_phi, far_omega;   // per shaft (used where other = -1), rad, rad/s
};

struct TrainState {
  std::vector<double> phi, omega;           // per body, rad, rad/s (fixed bodies: 0)
  std::vector<double> centre, centre_speed; // per body x, y in the housing, m, m/s (0 unless it translates)
  std::vector<double> reaction;             // per body: the torque that holds a fixed body, N m
  std::vector<double> shaft_torque;         // per shaft: its torque on `body`, N m
  double kinetic = 0, elastic = 0, initial_energy = 0;
  double work_in = 0, work_out = 0, friction = 0, damping = 0, parametric = 0, residual = 0;
  double step = 0;                          // internal step to try first, s
  int steps = 0, rejected = 0;              // of the last advance
  long evaluations = 0, derivatives = 0;    // of the last advance: of the whole train (every mesh
                                            // once), and single meshes' directional derivatives
};

class Train {
 public:
  Train(std::vector<TrainBody> bodies, std::vector<TrainMesh> meshes, std::vector<TrainShaft> shafts,
        TrainParams params);
  // "" or what is wrong with the train (an index out of range, a fixed body driven by a shaft to
  // a port, a body without inertia, a mesh whose gears coincide, ...).
  const std::string& problem() const { return problem_; }

  // The state at phi, omega (per body; fixed bodies must be 0) and the centres (x, y per body; NULL:
  // all at their nominal places, at rest), energies zeroed; res per mesh.
  gm_status start(const std::vector<double>& phi, const std::vector<double>& omega, const TrainInputs& in,
                  TrainState& s, std::vector<gm_result>& res, std::string& msg,
                  const std::vector<double>* centre = nullptr, const std::vector<double>* centre_speed = nullptr);
  // Advance s by duration with the inputs held; res: each mesh's evaluation at the end. On an
  // error s and res are unchanged.
  gm_status advance(const TrainInputs& in, double duration, TrainState& s, std::vector<gm_result>& res,
                    std::string& msg);

  // Static equilibrium (the quasi-static train): the angles of the free bodies where every
  // body's torque balances, body `held` fixed at angle `held_angle` (the input), speeds zero,
  // the torques of `in` applied (a load on the output); phi (per body) is the start of the
  // search and the answer. Shafts to far ends hold their far ends at in.far_phi. res: each
  // mesh's evaluation there. centre (x, y per body; NULL: from the nominal places): the
  // start of the translating bodies' centres and their answer. held_torque: the torque that holds
  // the held body there (minus the sum of the others on it), N m. GM_ERR_SOLVER if Newton does not
  // converge (a start in the backlash: start nearer contact).
  gm_status static_state(int held, double held_angle, const TrainInputs& in, std::vector<double>& phi,
                         std::vector<gm_result>& res, std::string& msg, std::vector<double>* centre = nullptr,
                         double* held_torque = nullptr);

  const gm_model* mesh_model(int m) const { return meshes_[std::size_t(m)].model; }

  int body_count() const { return int(bodies_.size()); }
  bool translates(int b) const { return shift_[std::size_t(b)] >= 0; }
  int mesh_count() const { return int(meshes_.size()); }

 private:
  struct Point;
  class Stepper;
  void unpack(const Eigen::VectorXd& q, const Eigen::VectorXd& qd, TrainState& s) const;
  void pack(const std::vector<double>& phi, const std::vector<double>& omega, const std::vector<double>* centre,
            const std::vector<double>* centre_speed, Eigen::VectorXd& q, Eigen::VectorXd& qd) const;
  std::vector<TrainBody> bodies_;
  std::vector<TrainMesh> meshes_;
  std::vector<TrainShaft> shafts_;
  TrainParams params_;
  // The unknowns: the free bodies' spins, then x and y of each translating body.
  std::vector<int> free_;     // free body -> body index (the first unknowns)
  std::vector<int> slot_;     // body -> its spin's unknown, -1 if fixed
  std::vector<int> shift_;    // body -> the unknown of its x (y the next), -1 if it does not translate
  std::vector<double> scale_; // per body: its rim radius for the error (largest base radius or orbit)
  std::vector<double> dof_mass_, dof_scale_;  // per unknown: inertia or mass; rim radius or 1
  std::vector<double> dof_lever_;             // per unknown: 1 (torque) or the rim radius (force)
  double finest_pitch_ = 0;                   // the smallest base pitch of the meshes' gears, m
  std::string problem_;
};

}  // namespace gm
