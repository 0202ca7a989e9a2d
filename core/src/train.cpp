// A gear train's spins integrated over a step (train.hpp): the pair's TR-BDF2 (dynamics.cpp,
// whose constants and reasons this follows) on n free bodies.
#include "train.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <Eigen/Dense>

namespace gm {
namespace {

constexpr double kSqrt2 = 1.41421356237309504880;
constexpr double kGamma = 2.0 - kSqrt2;
constexpr double kD = kGamma / 2.0;
constexpr double kW = kSqrt2 / 4.0;
constexpr double kE1 = (1.0 - 4.0 * kW) / 3.0, kE2 = 1.0 / 3.0, kE3 = -2.0 * kD / 3.0;
constexpr int kMaxNewton = 10;
constexpr double kNewtonFraction = 1e-2;  // dynamics.cpp: after the forced first correction
constexpr double kEventFraction = 0.25;   // dynamics.cpp: contact lost or made, flank changed
constexpr double kStaleContraction = 0.05;
constexpr int kJacobianAge = 20;

using Vec = Eigen::VectorXd;
using Mat = Eigen::MatrixXd;

std::string number(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", x);
  return buf;
}

bool contact_changed(const gm_result& a, const gm_result& b) {
  return a.flank != b.flank || (a.pairs_in_contact == 0) != (b.pairs_in_contact == 0);
}

double step_factor(double fraction) {
  if (!(fraction > 0)) return 2.0;
  return std::clamp(0.9 * std::cbrt(1.0 / fraction), 0.2, 2.0);
}

}  // namespace

// A state of the free bodies with what the equations give there.
struct Train::Point {
  Vec phi, omega, accel;                 // free bodies
  std::vector<gm_result> res;            // per mesh
  std::vector<double> reaction;          // per body (fixed ones), N m
  std::vector<double> shaft_torque;      // per shaft
  double power_in = 0, power_out = 0, power_friction = 0, power_damping = 0, elastic = 0;
};

class Train::Stepper {
 public:
  Stepper(Train& t, const TrainInputs& in) : t_(t), in_(in) {
    const int n = int(t.free_.size());
    a_phi_ = Mat::Zero(n, n);
    a_omega_ = Mat::Zero(n, n);
  }

  // Every body's angle and speed from the free ones.
  void full(const Vec& phi, const Vec& omega, std::vector<double>& P, std::vector<double>& W) const {
    const int nb = int(t_.bodies_.size());
    P.assign(std::size_t(nb), 0.0);
    W.assign(std::size_t(nb), 0.0);
    for (int f = 0; f < int(t_.free_.size()); ++f) {
      P[std::size_t(t_.free_[std::size_t(f)])] = phi[f];
      W[std::size_t(t_.free_[std::size_t(f)])] = omega[f];
    }
  }

  gm_kinematics element_pose(const TrainMesh& me, const std::vector<double>& P, const std::vector<double>& W) const {
    gm_kinematics k{};
    const double pc = me.carrier >= 0 ? P[std::size_t(me.carrier)] : 0.0;
    const double wc = me.carrier >= 0 ? W[std::size_t(me.carrier)] : 0.0;
    for (int i = 0; i < 2; ++i) {
      k.phi[i] = P[std::size_t(me.gear[i])] - pc - me.orientation;
      k.omega[i] = W[std::size_t(me.gear[i])] - wc;
      k.u[i][0] = me.offset[i][0];
      k.u[i][1] = me.offset[i][1];
    }
    return k;
  }

  gm_status evaluate_at(double t, const Vec& phi, const Vec& omega, Point& out, std::string& msg) {
    const int nb = int(t_.bodies_.size());
    std::vector<double>& P = angles_;  // scratch kept over the calls: no allocation once warm
    std::vector<double>& W = speeds_;
    std::vector<double>& torque = torques_;
    full(phi, omega, P, W);
    torque.assign(in_.torque.begin(), in_.torque.end());
    torque.resize(std::size_t(nb), 0.0);
    out.phi = phi;
    out.omega = omega;
    out.res.resize(t_.meshes_.size());
    out.shaft_torque.assign(t_.shafts_.size(), 0.0);
    out.power_in = out.power_out = out.power_friction = out.power_damping = out.elastic = 0;
    for (std::size_t m = 0; m < t_.meshes_.size(); ++m) {
      const TrainMesh& me = t_.meshes_[m];
      const gm_kinematics k = element_pose(me, P, W);
      if (gm_evaluate(me.model, me.data, &k, &out.res[m]) != GM_OK) {
        msg = "mesh " + std::to_string(m + 1) + ": " + gm_data_message(me.data);
        return GM_ERR_SOLVER;
      }
      const double M1 = out.res[m].moment[0][2], M2 = out.res[m].moment[1][2];
      torque[std::size_t(me.gear[0])] += M1;
      torque[std::size_t(me.gear[1])] += M2;
      if (me.carrier >= 0) torque[std::size_t(me.carrier)] -= M1 + M2;
      out.power_friction += out.res[m].friction_power;
      out.power_damping += out.res[m].damping_power;
      out.elastic += out.res[m].elastic_energy;
    }
    for (std::size_t s = 0; s < t_.shafts_.size(); ++s) {
      const TrainShaft& sh = t_.shafts_[s];
      const double far_phi = sh.other >= 0 ? P[std::size_t(sh.other)] : in_.far_phi[s] + in_.far_omega[s] * t;
      const double far_omega = sh.other >= 0 ? W[std::size_t(sh.other)] : in_.far_omega[s];
      const double twist = far_phi - P[std::size_t(sh.body)], slip = far_omega - W[std::size_t(sh.body)];
      const double tau = sh.stiffness * twist + sh.damping * slip;
      out.shaft_torque[s] = tau;
      torque[std::size_t(sh.body)] += tau;
      if (sh.other >= 0) torque[std::size_t(sh.other)] -= tau;
      else {
        const double port = tau * far_omega;  // power into the train at the far end (dynamics.cpp)
        (port > 0 ? out.power_in : out.power_out) += std::fabs(port);
      }
      out.power_damping += sh.damping * slip * slip;
      out.elastic += 0.5 * sh.stiffness * twist * twist;
    }
    out.reaction.assign(std::size_t(nb), 0.0);
    out.accel.resize(phi.size());
    for (int b = 0; b < nb; ++b) {
      const double port = (b < int(in_.torque.size()) ? in_.torque[std::size_t(b)] : 0.0) * W[std::size_t(b)];
      (port > 0 ? out.power_in : out.power_out) += std::fabs(port);
      const int f = t_.slot_[std::size_t(b)];
      if (f < 0) out.reaction[std::size_t(b)] = -torque[std::size_t(b)];
      else out.accel[f] = torque[std::size_t(b)] / t_.bodies_[std::size_t(b)].inertia;
    }
    return GM_OK;
  }

  // The exact Jacobian of the accelerations: each mesh through gm_directional_derivative along
  // its element's inputs, mapped to the bodies (Q D Q^T, Q the bodies' share of the element's
  // angles), the shafts' springs and dampers.
  gm_status jacobian(const Point& x, std::string& msg) {
    const int n = int(t_.free_.size());
    Mat dT_phi = Mat::Zero(n, n), dT_omega = Mat::Zero(n, n);
    std::vector<double> P, W;
    full(x.phi, x.omega, P, W);
    for (std::size_t m = 0; m < t_.meshes_.size(); ++m) {
      const TrainMesh& me = t_.meshes_[m];
      const gm_kinematics at = element_pose(me, P, W);
      const gm_model_params* mp = gm_model_parameters(me.model);
      const bool speed_dependent = mp->friction_coefficient != 0 || mp->damping != 0;
      // the bodies' shares of element input i: +1 on gear i, -1 on the carrier
      int body[2][2];
      double share[2][2];
      for (int i = 0; i < 2; ++i) {
        body[i][0] = t_.slot_[std::size_t(me.gear[i])];
        share[i][0] = 1.0;
        body[i][1] = me.carrier >= 0 ? t_.slot_[std::size_t(me.carrier)] : -1;
        share[i][1] = -1.0;
      }
      for (int which = 0; which < 2; ++which) {
        if (which == 1 && !speed_dependent) continue;
        for (int j = 0; j < 2; ++j) {
          gm_kinematics seed{};
          (which == 0 ? seed.phi : seed.omega)[j] = 1.0;
          gm_result dr{};
          if (gm_directional_derivative(me.model, me.data, &at, &seed, &dr) != GM_OK) {
            msg = "mesh " + std::to_string(m + 1) + ": " + gm_data_message(me.data);
            return GM_ERR_SOLVER;
          }
          // d(torque on each body) along element input j: M1 on gear 1, M2 on gear 2, -(M1+M2) on the carrier
          const double dM[2] = {dr.moment[0][2], dr.moment[1][2]};
          double dT_body[3];
          int to[3] = {t_.slot_[std::size_t(me.gear[0])], t_.slot_[std::size_t(me.gear[1])],
                       me.carrier >= 0 ? t_.slot_[std::size_t(me.carrier)] : -1};
          dT_body[0] = dM[0];
          dT_body[1] = dM[1];
          dT_body[2] = -(dM[0] + dM[1]);
          Mat& target = which == 0 ? dT_phi : dT_omega;
          for (int r = 0; r < 3; ++r) {
            if (to[r] < 0) continue;
            for (int c = 0; c < 2; ++c)
              if (body[j][c] >= 0) target(to[r], body[j][c]) += dT_body[r] * share[j][c];
          }
        }
      }
    }
    for (const TrainShaft& sh : t_.shafts_) {
      const int a = t_.slot_[std::size_t(sh.body)], b = sh.other >= 0 ? t_.slot_[std::size_t(sh.other)] : -1;
      if (a >= 0) {
        dT_phi(a, a) -= sh.stiffness;
        dT_omega(a, a) -= sh.damping;
      }
      if (sh.other >= 0 && b >= 0) {
        dT_phi(b, b) -= sh.stiffness;
        dT_omega(b, b) -= sh.damping;
        if (a >= 0) {
          dT_phi(a, b) += sh.stiffness;
          dT_phi(b, a) += sh.stiffness;
          dT_omega(a, b) += sh.damping;
          dT_omega(b, a) += sh.damping;
        }
      }
    }
    for (int f = 0; f < n; ++f) {
      const double J = t_.bodies_[std::size_t(t_.free_[std::size_t(f)])].inertia;
      a_phi_.row(f) = dT_phi.row(f) / J;
      a_omega_.row(f) = dT_omega.row(f) / J;
    }
    modes();
    lu_hd_ = NAN;  // the Newton matrix is refactored for the new Jacobian
    return GM_OK;
  }

  // The modes of the linearized train at the Jacobian: K v = lambda M v with K = -M A_phi
  // (symmetrized), mass-normalized; each mode's rim rate per unit modal speed (the largest TE
  // rate of a mesh and rim speed of a body it makes).
  void modes() {
    const int n = int(t_.free_.size());
    Vec mass(n);
    for (int f = 0; f < n; ++f) mass[f] = t_.bodies_[std::size_t(t_.free_[std::size_t(f)])].inertia;
    Mat K = -(mass.asDiagonal() * a_phi_);
    K = 0.5 * (K + K.transpose());
    Eigen::GeneralizedSelfAdjointEigenSolver<Mat> es(K, Mat(mass.asDiagonal()));
    mode_vectors_ = es.eigenvectors();  // V^T M V = I
    mode_frequency_ = es.eigenvalues().cwiseMax(0.0).cwiseSqrt();
    mass_ = mass;
    mode_rim_ = Vec::Zero(n);
    for (int k = 0; k < n; ++k) {
      const Vec v = mode_vectors_.col(k);
      double rim = 0;
      for (int f = 0; f < n; ++f) rim = std::max(rim, t_.scale_[std::size_t(t_.free_[std::size_t(f)])] * std::fabs(v[f]));
      for (const TrainMesh& me : t_.meshes_) {
        const double rb1 = 0.5 * gm_model_geometry(me.model)->gear[0].d_b;
        const double rb2 = 0.5 * gm_model_geometry(me.model)->gear[1].d_b;
        const double s = gm_model_parameters(me.model)->pair.internal ? -1.0 : 1.0;
        auto speed = [&](int body) { const int f = body >= 0 ? t_.slot_[std::size_t(body)] : -1; return f >= 0 ? v[f] : 0.0; };
        const double wc = speed(me.carrier);
        const double te_rate = rb1 * (speed(me.gear[0]) - wc) + s * rb2 * (speed(me.gear[1]) - wc);
        rim = std::max(rim, std::fabs(te_rate));
      }
      mode_rim_[k] = rim;
    }
  }

  // Solve (I - hd (hd A_phi + A_omega)) x = r in place; the factorization is kept while hd and
  // the Jacobian stay (both stages and the error filter of a step share it).
  bool newton_solve(double hd, Vec& r) const {
    if (!(hd == lu_hd_)) {
      const int n = int(r.size());
      lu_.compute(Mat::Identity(n, n) - hd * (hd * a_phi_ + a_omega_));
      lu_hd_ = hd;
    }
    r = lu_.solve(r);
    return r.allFinite();
  }

  gm_status stage(double t, double hd, const Vec& r_phi, const Vec& r_omega, Vec& omega, Point& out, std::string& msg) {
    double previous = INFINITY;
    for (int it = 0; it < kMaxNewton; ++it) {
      const Vec phi = r_phi + hd * omega;
      if (evaluate_at(t, phi, omega, out, msg) != GM_OK) break;
      Vec g = omega - hd * out.accel - r_omega;
      double size = 0;
      for (int f = 0; f < int(g.size()); ++f)
        size = std::max(size, t_.scale_[std::size_t(t_.free_[std::size_t(f)])] * hd * std::fabs(g[f]));
      if (!std::isfinite(size)) break;
      if (it == 1) contraction = std::max(contraction, size / previous);
      if (it > 0 && size <= kNewtonFraction * t_.params_.tolerance) {
        if (it > 2) contraction = INFINITY;
        return GM_OK;
      }
      if (it >= 3 && size > 0.9 * previous) break;
      previous = size;
      if (!newton_solve(hd, g)) break;
      omega -= g;
    }
    return GM_ERR_SOLVER;
  }

  double error_fraction(double h, const Point& x1, const Point& x2, const Point& x3) const {
    const Vec e_phi = h * (kE1 * x1.omega + kE2 * x2.omega + kE3 * x3.omega);
    const Vec e_omega = h * (kE1 * x1.accel + kE2 * x2.accel + kE3 * x3.accel);
    const double hd = h * kD;
    Vec r = e_omega + hd * (a_phi_ * e_phi);
    if (!newton_solve(hd, r)) return INFINITY;
    const double tol = t_.params_.tolerance;
    double fraction = 0;
    for (int f = 0; f < int(r.size()); ++f)
      fraction = std::max(fraction, t_.scale_[std::size_t(t_.free_[std::size_t(f)])] * std::fabs(e_phi[f] + hd * r[f]) / tol);
    // the speed error by mode (dynamics.cpp, error_fraction): a mode resolved by the step counts
    // over 1 / omega_k (its energy norm), one it does not over the step, a rigid one over the
    // longest step; each as the largest rim motion or TE it makes
    const Vec q = mode_vectors_.transpose() * (mass_.asDiagonal() * r);
    for (int k = 0; k < int(q.size()); ++k) {
      const double w = mode_frequency_[k];
      const double time = w > 0 ? std::min(t_.params_.max_step, std::max(h, 1.0 / w)) : t_.params_.max_step;
      fraction = std::max(fraction, std::fabs(q[k]) * mode_rim_[k] * time / tol);
    }
    return std::isfinite(fraction) ? fraction : INFINITY;
  }

  gm_status step(double t, double h, const Point& x1, Point& x2, Point& x3, double* fraction, std::string& msg) {
    const double hd = h * kD;
    Vec r_phi = x1.phi + hd * x1.omega;
    Vec r_omega = x1.omega + hd * x1.accel;
    Vec omega = x1.omega + kGamma * h * x1.accel;
    gm_status st = stage(t + kGamma * h, hd, r_phi, r_omega, omega, x2, msg);
    if (st != GM_OK) return st;
    r_phi = x1.phi + h * kW * (x1.omega + x2.omega);
    r_omega = x1.omega + h * kW * (x1.accel + x2.accel);
    omega = x2.omega + (1.0 - kGamma) * h * x2.accel;
    st = stage(t + h, hd, r_phi, r_omega, omega, x3, msg);
    if (st != GM_OK) return st;
    *fraction = error_fraction(h, x1, x2, x3);
    return GM_OK;
  }

  double contraction = 0;
  // d(torque)/d(phi) of the free bodies at the last jacobian(): J A_phi
  Mat torque_stiffness() const {
    Mat K = a_phi_;
    for (int f = 0; f < int(t_.free_.size()); ++f) K.row(f) *= t_.bodies_[std::size_t(t_.free_[std::size_t(f)])].inertia;
    return K;
  }

 private:
  Train& t_;
  const TrainInputs& in_;
  Mat a_phi_, a_omega_, mode_vectors_;
  Vec mode_frequency_, mode_rim_, mass_;
  mutable Eigen::PartialPivLU<Mat> lu_;
  mutable double lu_hd_ = NAN;
  std::vector<double> angles_, speeds_, torques_;
};

Train::Train(std::vector<TrainBody> bodies, std::vector<TrainMesh> meshes, std::vector<TrainShaft> shafts,
             TrainParams params)
    : bodies_(std::move(bodies)), meshes_(std::move(meshes)), shafts_(std::move(shafts)), params_(params) {
  const int nb = int(bodies_.size());
  auto body_ok = [nb](int b) { return b >= 0 && b < nb; };
  slot_.assign(std::size_t(nb), -1);
  scale_.assign(std::size_t(nb), 0.0);
  for (int b = 0; b < nb; ++b) {
    if (bodies_[std::size_t(b)].fixed) continue;
    if (!(bodies_[std::size_t(b)].inertia > 0 && std::isfinite(bodies_[std::size_t(b)].inertia))) {
      problem_ = "body " + std::to_string(b + 1) + ": inertia = " + number(bodies_[std::size_t(b)].inertia) +
                 " kg m^2; allowed: finite and > 0 (or the body fixed)";
      return;
    }
    slot_[std::size_t(b)] = int(free_.size());
    free_.push_back(b);
  }
  if (free_.empty()) {
    problem_ = "every body is fixed: nothing turns";
    return;
  }
  std::vector<int> meshes_of(std::size_t(nb), 0);
  for (std::size_t m = 0; m < meshes_.size(); ++m) {
    const TrainMesh& me = meshes_[m];
    const std::string name = "mesh " + std::to_string(m + 1);
    if (!me.model || !me.data) {
      problem_ = name + ": no model";
      return;
    }
    if (!body_ok(me.gear[0]) || !body_ok(me.gear[1]) || me.gear[0] == me.gear[1] ||
        (me.carrier >= 0 && (!body_ok(me.carrier) || me.carrier == me.gear[0] || me.carrier == me.gear[1]))) {
      problem_ = name + ": gears " + std::to_string(me.gear[0] + 1) + ", " + std::to_string(me.gear[1] + 1) +
                 ", carrier " + std::to_string(me.carrier + 1) + ": allowed: two different bodies 1.." +
                 std::to_string(nb) + " and a third (or 0: the housing)";
      return;
    }
    const gm_pair_geometry* g = gm_model_geometry(me.model);
    for (int i = 0; i < 2; ++i) {
      scale_[std::size_t(me.gear[i])] = std::max(scale_[std::size_t(me.gear[i])], 0.5 * g->gear[i].d_b);
      ++meshes_of[std::size_t(me.gear[i])];
    }
    if (me.carrier >= 0)
      scale_[std::size_t(me.carrier)] =
          std::max(scale_[std::size_t(me.carrier)], gm_model_parameters(me.model)->pair.center_distance);
  }
  for (std::size_t s = 0; s < shafts_.size(); ++s) {
    const TrainShaft& sh = shafts_[s];
    const std::string name = "shaft " + std::to_string(s + 1);
    if (!body_ok(sh.body) || (sh.other >= 0 && (!body_ok(sh.other) || sh.other == sh.body))) {
      problem_ = name + ": bodies " + std::to_string(sh.body + 1) + ", " + std::to_string(sh.other + 1) +
                 ": allowed: a body 1.." + std::to_string(nb) + " and another (or 0: a far end)";
      return;
    }
    if (!(sh.stiffness >= 0 && sh.damping >= 0 && std::isfinite(sh.stiffness) && std::isfinite(sh.damping))) {
      problem_ = name + ": stiffness and damping must be finite and >= 0";
      return;
    }
    for (int b : {sh.body, sh.other})
      if (b >= 0 && scale_[std::size_t(b)] == 0) scale_[std::size_t(b)] = 0.05;  // a shaft-only body: 50 mm
  }
  for (int b = 0; b < nb; ++b)
    if (!bodies_[std::size_t(b)].fixed && scale_[std::size_t(b)] == 0) {
      problem_ = "body " + std::to_string(b + 1) + " is in no mesh and on no shaft";
      return;
    }
  if (!(params_.tolerance > 0 && params_.max_step > 0 && params_.min_step > 0 && params_.min_step <= params_.max_step))
    problem_ = "tolerance, max_step and min_step must be > 0 with min_step <= max_step";
}

gm_status Train::static_state(int held, double held_angle, const TrainInputs& in, std::vector<double>& phi,
                              std::vector<gm_result>& res, std::string& msg) {
  if (!problem_.empty()) {
    msg = problem_;
    return GM_ERR_PARAMETER;
  }
  const int nb = int(bodies_.size());
  if (held < 0 || held >= nb || slot_[std::size_t(held)] < 0 || int(phi.size()) != nb) {
    msg = "static_state: the held body must be a free body, and one angle per body";
    return GM_ERR_ARGUMENT;
  }
  // the free bodies but the held one are the unknowns; the held one is a free body whose
  // acceleration is not asked to vanish (its torque is the input torque the load needs)
  TrainInputs still = in;
  still.far_omega.assign(in.far_phi.size(), 0.0);
  Stepper st(*this, still);
  const int n = int(free_.size());
  std::vector<int> unknown;
  for (int f = 0; f < n; ++f)
    if (free_[std::size_t(f)] != held) unknown.push_back(f);
  Vec p(n), w = Vec::Zero(n);
  for (int f = 0; f < n; ++f) p[f] = free_[std::size_t(f)] == held ? held_angle : phi[std::size_t(free_[std::size_t(f)])];
  Point x;
  const auto residual = [&](const Vec& q, double* size) -> gm_status {
    const gm_status s = st.evaluate_at(0.0, q, w, x, msg);
    if (s != GM_OK) return s;
    double worst = 0;
    for (int f : unknown) worst = std::max(worst, std::fabs(x.accel[f] * bodies_[std::size_t(free_[std::size_t(f)])].inertia));
    *size = worst;
    return GM_OK;
  };
  double size = 0;
  gm_status s = residual(p, &size);
  if (s != GM_OK) return s;
  // converged when every torque is below 1e-9 of the largest input torque (or 1e-9 N m)
  double scale = 1.0;
  for (double t : in.torque) scale = std::max(scale, std::fabs(t));
  const double tol = 1e-9 * scale;
  for (int it = 0; it < 100 && size > tol; ++it) {
    if ((s = st.jacobian(x, msg)) != GM_OK) return s;
    const Mat K = st.torque_stiffness();
    const int m = int(unknown.size());
    Mat A(m, m);
    Vec r(m);
    for (int i = 0; i < m; ++i) {
      r[i] = x.accel[unknown[std::size_t(i)]] * bodies_[std::size_t(free_[std::size_t(unknown[std::size_t(i)])])].inertia;
      for (int j = 0; j < m; ++j) A(i, j) = K(unknown[std::size_t(i)], unknown[std::size_t(j)]);
    }
    const Vec d = A.fullPivLu().solve(-r);
    if (!d.allFinite()) break;
    // halve the Newton step until the residual falls (contact is one-sided: a full step may open it)
    double lambda = 1.0, trial_size = INFINITY;
    Vec trial = p;
    for (int half = 0; half < 30; ++half, lambda *= 0.5) {
      trial = p;
      for (int i = 0; i < m; ++i) trial[unknown[std::size_t(i)]] += lambda * d[i];
      if (residual(trial, &trial_size) == GM_OK && trial_size < size) break;
    }
    if (!(trial_size < size)) break;
    p = trial;
    size = trial_size;
  }
  if ((s = residual(p, &size)) != GM_OK) return s;
  if (!(size <= tol)) {
    msg = "static_state: no equilibrium found (largest torque left " + number(size) +
          " N m); start nearer contact";
    return GM_ERR_SOLVER;
  }
  for (int f = 0; f < n; ++f) phi[std::size_t(free_[std::size_t(f)])] = p[f];
  res = x.res;
  return GM_OK;
}

gm_status Train::start(const std::vector<double>& phi, const std::vector<double>& omega, const TrainInputs& in,
                       TrainState& s, std::vector<gm_result>& res, std::string& msg) {
  if (!problem_.empty()) {
    msg = problem_;
    return GM_ERR_PARAMETER;
  }
  const int nb = int(bodies_.size());
  if (int(phi.size()) != nb || int(omega.size()) != nb) {
    msg = "start: one angle and one speed per body";
    return GM_ERR_ARGUMENT;
  }
  Vec p(free_.size()), w(free_.size());
  for (std::size_t f = 0; f < free_.size(); ++f) {
    p[Eigen::Index(f)] = phi[std::size_t(free_[f])];
    w[Eigen::Index(f)] = omega[std::size_t(free_[f])];
  }
  Stepper st(*this, in);
  Point x;
  const gm_status status = st.evaluate_at(0.0, p, w, x, msg);
  if (status != GM_OK) return status;
  TrainState out;
  out.phi.assign(std::size_t(nb), 0.0);
  out.omega.assign(std::size_t(nb), 0.0);
  for (std::size_t f = 0; f < free_.size(); ++f) {
    out.phi[std::size_t(free_[f])] = p[Eigen::Index(f)];
    out.omega[std::size_t(free_[f])] = w[Eigen::Index(f)];
    out.kinetic += 0.5 * bodies_[std::size_t(free_[f])].inertia * w[Eigen::Index(f)] * w[Eigen::Index(f)];
  }
  out.reaction = x.reaction;
  out.shaft_torque = x.shaft_torque;
  out.elastic = x.elastic;
  out.initial_energy = out.kinetic + out.elastic;
  out.step = std::min(params_.max_step, 1e-5);
  s = out;
  res = x.res;
  return GM_OK;
}

gm_status Train::advance(const TrainInputs& in, double duration, TrainState& s_io, std::vector<gm_result>& res,
                         std::string& msg) {
  if (!problem_.empty()) {
    msg = problem_;
    return GM_ERR_PARAMETER;
  }
  if (!(duration > 0 && std::isfinite(duration))) {
    msg = "train: step of " + number(duration) + " s; allowed: finite and > 0";
    return GM_ERR_ARGUMENT;
  }
  const double longest = GM_DYNAMICS_MAX_INTERNAL_STEPS * params_.max_step;
  if (!(duration <= longest)) {
    msg = "train: step of " + number(duration) + " s needs more than " +
          std::to_string(GM_DYNAMICS_MAX_INTERNAL_STEPS) + " internal steps; allowed: at most " + number(longest) + " s";
    return GM_ERR_SOLVER;
  }
  TrainState s = s_io;
  Stepper st(*this, in);
  const int n = int(free_.size());
  Vec p(n), w(n);
  for (int f = 0; f < n; ++f) {
    p[f] = s.phi[std::size_t(free_[std::size_t(f)])];
    w[f] = s.omega[std::size_t(free_[std::size_t(f)])];
  }
  Point x1, x2, x3;
  gm_status status = st.evaluate_at(0.0, p, w, x1, msg);
  if (status != GM_OK) return status;
  const double jump = x1.elastic - s.elastic;
  (jump > 0 ? s.work_in : s.work_out) += std::fabs(jump);
  s.steps = s.rejected = 0;
  double t = 0, h = std::clamp(s.step, params_.min_step, params_.max_step);
  bool jacobian_current = false, after_rejection = false;
  int jacobian_age = 0;
  while (t < duration) {
    if (s.steps + s.rejected >= GM_DYNAMICS_MAX_INTERNAL_STEPS) {
      msg = "train: " + std::to_string(GM_DYNAMICS_MAX_INTERNAL_STEPS) + " internal steps reached " + number(t) +
            " s of a step of " + number(duration) + " s; retry with a shorter communication step";
      return GM_ERR_SOLVER;
    }
    const double remaining = duration - t;
    double h_try = h;
    if (h_try >= remaining) h_try = remaining;
    else if (2 * h_try > remaining) h_try = 0.5 * remaining;
    if (!jacobian_current) {
      if ((status = st.jacobian(x1, msg)) != GM_OK) return status;
      jacobian_current = true;
      jacobian_age = 0;
    }
    st.contraction = 0;
    double fraction = INFINITY;
    status = st.step(t, h_try, x1, x2, x3, &fraction, msg);
    bool event = false;
    if (status == GM_OK)
      for (std::size_t m = 0; m < meshes_.size(); ++m) event = event || contact_changed(x1.res[m], x3.res[m]);
    const double allowed = event ? kEventFraction : 1.0;
    if (status == GM_OK && fraction <= allowed) {
      // the energy account (dynamics.cpp, account): powers with the method's weights, each
      // mesh's work along the step's path through its stage points in element angles
      const auto integral = [&](double Point::*power) { return h_try * (kW * (x1.*power + x2.*power) + kD * x3.*power); };
      s.work_in += integral(&Point::power_in);
      s.work_out += integral(&Point::power_out);
      s.friction += integral(&Point::power_friction);
      s.damping += integral(&Point::power_damping);
      std::vector<double> P1, W1, P2, W2, P3, W3;
      st.full(x1.phi, x1.omega, P1, W1);
      st.full(x2.phi, x2.omega, P2, W2);
      st.full(x3.phi, x3.omega, P3, W3);
      for (std::size_t m = 0; m < meshes_.size(); ++m) {
        const TrainMesh& me = meshes_[m];
        const gm_kinematics k1 = st.element_pose(me, P1, W1), k2 = st.element_pose(me, P2, W2),
                            k3 = st.element_pose(me, P3, W3);
        double work = 0;
        for (int i = 0; i < 2; ++i) {
          work -= 0.5 * (x1.res[m].moment[i][2] + x2.res[m].moment[i][2]) * (k2.phi[i] - k1.phi[i]);
          work -= 0.5 * (x2.res[m].moment[i][2] + x3.res[m].moment[i][2]) * (k3.phi[i] - k2.phi[i]);
        }
        const double fr = h_try * (kW * (x1.res[m].friction_power + x2.res[m].friction_power) + kD * x3.res[m].friction_power);
        const double da = h_try * (kW * (x1.res[m].damping_power + x2.res[m].damping_power) + kD * x3.res[m].damping_power);
        s.parametric += work - fr - da - (x3.res[m].elastic_energy - x1.res[m].elastic_energy);
      }
      t = h_try >= remaining ? duration : t + h_try;
      x1 = x3;
      ++jacobian_age;
      jacobian_current = st.contraction <= kStaleContraction && jacobian_age < kJacobianAge;
      ++s.steps;
      const double growth = std::min(after_rejection ? 1.0 : 2.0, step_factor(fraction / allowed));
      h = std::min(params_.max_step, std::max(h, h_try) * growth);
      after_rejection = false;
      continue;
    }
    ++s.rejected;
    after_rejection = true;
    jacobian_current = jacobian_current && jacobian_age == 0;
    const bool newton_failed = status != GM_OK;
    h = h_try * (newton_failed ? 0.25 : std::min(0.5, step_factor(fraction / allowed)));
    if (h < params_.min_step) {
      msg = "train: the internal step fell below min_step = " + number(params_.min_step) + " s at " + number(t) +
            " s into a step of " + number(duration) + " s (" +
            (newton_failed ? "Newton did not converge" : "local error " + number(fraction) + " x tolerance") +
            "); retry with a shorter communication step or a larger tolerance";
      return GM_ERR_SOLVER;
    }
  }
  s.step = h;
  s.kinetic = 0;
  for (int f = 0; f < n; ++f) {
    s.phi[std::size_t(free_[std::size_t(f)])] = x1.phi[f];
    s.omega[std::size_t(free_[std::size_t(f)])] = x1.omega[f];
    s.kinetic += 0.5 * bodies_[std::size_t(free_[std::size_t(f)])].inertia * x1.omega[f] * x1.omega[f];
  }
  s.reaction = x1.reaction;
  s.shaft_torque = x1.shaft_torque;
  s.elastic = x1.elastic;
  s.residual = s.work_in - s.work_out - (s.kinetic + s.elastic - s.initial_energy) - s.friction - s.damping - s.parametric;
  s_io = s;
  res = x1.res;
  return GM_OK;
}

}  // namespace gm
