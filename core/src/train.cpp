// A gear train's spins and centres integrated over a step (train.hpp): the pair's TR-BDF2
// (trbdf2.hpp: the method's constants and step rules, shared with dynamics.cpp) on its unknowns.
#include "train.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <Eigen/Dense>

#include "trbdf2.hpp"

namespace gm {
namespace {

using namespace trbdf2;  // the method's constants and step rules (trbdf2.hpp)
constexpr double kPi = 3.14159265358979323846;

using Vec = Eigen::VectorXd;
using Mat = Eigen::MatrixXd;

std::string number(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", x);
  return buf;
}

}  // namespace

// A state of the unknowns (train.hpp: spins, then centres) with what the equations give there.
struct Train::Point {
  Vec phi, omega, accel;                 // unknowns: positions, rates, accelerations
  std::vector<gm_result> res;            // per mesh
  std::vector<double> reaction;          // per body (fixed ones), N m
  std::vector<double> shaft_torque;      // per shaft
  double power_in = 0, power_out = 0, power_friction = 0, power_damping = 0, elastic = 0;
};

namespace {

// Rotations in the plane: R(-theta) a (housing to element frame) and z x a.
inline void to_element(double c, double s, const double a[2], double out[2]) {
  out[0] = c * a[0] + s * a[1];
  out[1] = -s * a[0] + c * a[1];
}
inline void to_housing(double c, double s, const double a[2], double out[2]) {
  out[0] = c * a[0] - s * a[1];
  out[1] = s * a[0] + c * a[1];
}
inline double cross(const double a[2], const double b[2]) { return a[0] * b[1] - a[1] * b[0]; }

}  // namespace

class Train::Stepper {
 public:
  Stepper(Train& t, const TrainInputs& in) : t_(t), in_(in) {
    const int n = int(t.dof_mass_.size());
    a_phi_ = Mat::Zero(n, n);
    a_omega_ = Mat::Zero(n, n);
  }

  // Every body's angle, speed, centre and centre speed from the unknowns.
  struct Full {
    std::vector<double> P, W, X, V;  // per body; X, V two per body
  };
  void full(const Vec& q, const Vec& qd, Full& f) const {
    const std::size_t nb = t_.bodies_.size();
    f.P.assign(nb, 0.0);
    f.W.assign(nb, 0.0);
    f.X.assign(2 * nb, 0.0);
    f.V.assign(2 * nb, 0.0);
    for (std::size_t b = 0; b < nb; ++b) {
      if (t_.slot_[b] >= 0) {
        f.P[b] = q[t_.slot_[b]];
        f.W[b] = qd[t_.slot_[b]];
      }
      if (t_.shift_[b] >= 0)
        for (int a = 0; a < 2; ++a) {
          f.X[2 * b + std::size_t(a)] = q[t_.shift_[b] + a];
          f.V[2 * b + std::size_t(a)] = qd[t_.shift_[b] + a];
        }
    }
  }

  // The element frame's angle in the housing: the carrier's angle and the mesh's orientation.
  static double frame_angle(const TrainMesh& me, const Full& f) {
    return (me.carrier >= 0 ? f.P[std::size_t(me.carrier)] : 0.0) + me.orientation;
  }

  gm_kinematics element_pose(const TrainMesh& me, const Full& f) const {
    gm_kinematics k{};
    const double pc = me.carrier >= 0 ? f.P[std::size_t(me.carrier)] : 0.0;
    const double wc = me.carrier >= 0 ? f.W[std::size_t(me.carrier)] : 0.0;
    const double th = frame_angle(me, f), c = std::cos(th), s = std::sin(th);
    for (int i = 0; i < 2; ++i) {
      const std::size_t b = std::size_t(me.gear[i]);
      k.phi[i] = f.P[b] - pc - me.orientation;
      k.omega[i] = f.W[b] - wc;
      k.u[i][0] = me.offset[i][0];
      k.u[i][1] = me.offset[i][1];
      if (t_.shift_[b] < 0) continue;
      // u = R(-theta) x, its rate in the turning element frame R(-theta) v - omega_c z x u
      double u[2], v[2];
      to_element(c, s, &f.X[2 * b], u);
      to_element(c, s, &f.V[2 * b], v);
      k.u[i][0] += u[0];
      k.u[i][1] += u[1];
      k.v[i][0] = v[0] + wc * u[1];
      k.v[i][1] = v[1] - wc * u[0];
    }
    return k;
  }

  // The mesh's forces on the bodies: M_i on gear i, R(theta) f_i on a translating gear, and on the
  // carrier -(M_1 + M_2) - u_i x f_i over its translating gears (train.hpp).
  void apply(const TrainMesh& me, const gm_kinematics& k, const gm_result& r, double th, std::vector<double>& T,
             std::vector<double>& F) const {
    const double c = std::cos(th), s = std::sin(th);
    double carrier = -(r.moment[0][2] + r.moment[1][2]);
    for (int i = 0; i < 2; ++i) {
      const std::size_t b = std::size_t(me.gear[i]);
      T[b] += r.moment[i][2];
      if (t_.shift_[b] < 0) continue;
      const double f[2] = {r.force[i][0], r.force[i][1]}, u[2] = {k.u[i][0], k.u[i][1]};
      double fh[2];
      to_housing(c, s, f, fh);
      F[2 * b] += fh[0];
      F[2 * b + 1] += fh[1];
      carrier -= cross(u, f);
    }
    if (me.carrier >= 0) T[std::size_t(me.carrier)] += carrier;
  }

  gm_status evaluate_at(double t, const Vec& q, const Vec& qd, Point& out, std::string& msg) {
    ++evaluations;
    const std::size_t nb = t_.bodies_.size();
    Full& f = full_;  // scratch kept over the calls: no allocation once warm
    full(q, qd, f);
    std::vector<double>& T = torques_;
    std::vector<double>& F = forces_;
    T.assign(in_.torque.begin(), in_.torque.end());
    T.resize(nb, 0.0);
    F.assign(2 * nb, 0.0);
    out.phi = q;
    out.omega = qd;
    out.res.resize(t_.meshes_.size());
    out.shaft_torque.assign(t_.shafts_.size(), 0.0);
    out.power_in = out.power_out = out.power_friction = out.power_damping = out.elastic = 0;
    for (std::size_t m = 0; m < t_.meshes_.size(); ++m) {
      const TrainMesh& me = t_.meshes_[m];
      const gm_kinematics k = element_pose(me, f);
      if (gm_evaluate(me.model, me.data, &k, &out.res[m]) != GM_OK) {
        msg = "mesh " + std::to_string(m + 1) + ": " + gm_data_message(me.data);
        return GM_ERR_SOLVER;
      }
      apply(me, k, out.res[m], frame_angle(me, f), T, F);
      out.power_friction += out.res[m].friction_power;
      out.power_damping += out.res[m].damping_power;
      out.elastic += out.res[m].elastic_energy;
    }
    for (std::size_t s = 0; s < t_.shafts_.size(); ++s) {
      const TrainShaft& sh = t_.shafts_[s];
      const double far_phi = sh.other >= 0 ? f.P[std::size_t(sh.other)] : in_.far_phi[s] + in_.far_omega[s] * t;
      const double far_omega = sh.other >= 0 ? f.W[std::size_t(sh.other)] : in_.far_omega[s];
      const double twist = far_phi - f.P[std::size_t(sh.body)], slip = far_omega - f.W[std::size_t(sh.body)];
      const double tau = sh.stiffness * twist + sh.damping * slip;
      out.shaft_torque[s] = tau;
      T[std::size_t(sh.body)] += tau;
      if (sh.other >= 0) T[std::size_t(sh.other)] -= tau;
      else {
        const double port = tau * far_omega;  // power into the train at the far end (dynamics.cpp)
        (port > 0 ? out.power_in : out.power_out) += std::fabs(port);
      }
      out.power_damping += sh.damping * slip * slip;
      out.elastic += 0.5 * sh.stiffness * twist * twist;
    }
    out.reaction.assign(nb, 0.0);
    out.accel.resize(q.size());
    for (std::size_t b = 0; b < nb; ++b) {
      const double port = (b < in_.torque.size() ? in_.torque[b] : 0.0) * f.W[b];
      (port > 0 ? out.power_in : out.power_out) += std::fabs(port);
      const int i = t_.slot_[b];
      if (i < 0) out.reaction[b] = -T[b];
      else out.accel[i] = T[b] / t_.dof_mass_[std::size_t(i)];
      const int j = t_.shift_[b];
      if (j < 0) continue;
      const TrainBody& body = t_.bodies_[b];
      for (int a = 0; a < 2; ++a) {
        const double x = f.X[2 * b + std::size_t(a)], v = f.V[2 * b + std::size_t(a)];
        out.accel[j + a] = (F[2 * b + std::size_t(a)] - body.bearing_stiffness * x - body.bearing_damping * v) / body.mass;
        out.elastic += 0.5 * body.bearing_stiffness * x * x;
        out.power_damping += body.bearing_damping * v * v;
      }
    }
    return GM_OK;
  }

  // The element inputs' rates along unknown j (a position when velocity is false, else a rate):
  // the seed of the mesh's directional derivative; dtheta: the element frame's turn along it.
  // False if the mesh does not depend on unknown j.
  bool seed_along(const TrainMesh& me, const Full& f, int j, bool velocity, gm_kinematics& seed, double& dtheta) const {
    seed = gm_kinematics{};
    dtheta = 0;
    bool touches = false;
    const double wc = me.carrier >= 0 ? f.W[std::size_t(me.carrier)] : 0.0;
    const double th = frame_angle(me, f), c = std::cos(th), s = std::sin(th);
    const bool carrier_spin = me.carrier >= 0 && t_.slot_[std::size_t(me.carrier)] == j;
    for (int i = 0; i < 2; ++i) {
      const std::size_t b = std::size_t(me.gear[i]);
      if (t_.slot_[b] == j) {
        (velocity ? seed.omega : seed.phi)[i] += 1.0;
        touches = true;
      }
      if (carrier_spin) {
        (velocity ? seed.omega : seed.phi)[i] -= 1.0;
        touches = true;
      }
      if (t_.shift_[b] < 0) continue;
      double u[2], v[2];
      to_element(c, s, &f.X[2 * b], u);
      to_element(c, s, &f.V[2 * b], v);
      if (carrier_spin) {
        if (!velocity) {
          // d/dtheta of u = R(-theta) x: -z x u; of the rate R(-theta) v - w z x u: -z x (R v) - w u
          seed.u[i][0] += u[1];
          seed.u[i][1] += -u[0];
          seed.v[i][0] += v[1] - wc * u[0];
          seed.v[i][1] += -v[0] - wc * u[1];
        } else {
          seed.v[i][0] += u[1];
          seed.v[i][1] += -u[0];
        }
      }
      for (int a = 0; a < 2; ++a) {
        if (t_.shift_[b] + a != j) continue;
        touches = true;
        const double e[2] = {a == 0 ? 1.0 : 0.0, a == 1 ? 1.0 : 0.0};
        double de[2];
        to_element(c, s, e, de);
        if (!velocity) {
          seed.u[i][0] += de[0];
          seed.u[i][1] += de[1];
          seed.v[i][0] += wc * de[1];
          seed.v[i][1] += -wc * de[0];
        } else {
          seed.v[i][0] += de[0];
          seed.v[i][1] += de[1];
        }
      }
    }
    if (carrier_spin && !velocity) dtheta = 1.0;
    return touches;
  }

  // The exact Jacobian of the accelerations: each mesh through gm_directional_derivative along
  // the element inputs' rates per unknown, the forces' product rule (apply), the shafts' springs
  // and dampers, the bearings.
  gm_status jacobian(const Point& x, std::string& msg) {
    const int n = int(t_.dof_mass_.size());
    const std::size_t nb = t_.bodies_.size();
    Mat dQ_q = Mat::Zero(n, n), dQ_qd = Mat::Zero(n, n);
    Full f;
    full(x.phi, x.omega, f);
    std::vector<double> dT(nb), dF(2 * nb);
    for (std::size_t m = 0; m < t_.meshes_.size(); ++m) {
      const TrainMesh& me = t_.meshes_[m];
      const gm_kinematics at = element_pose(me, f);
      const gm_model_params* mp = gm_model_parameters(me.model);
      const bool speed_dependent = mp->friction_coefficient != 0 || mp->damping != 0;
      const double th = frame_angle(me, f), c = std::cos(th), s = std::sin(th);
      const gm_result& r = x.res[m];
      for (int which = 0; which < 2; ++which) {
        if (which == 1 && !speed_dependent) continue;
        for (int j = 0; j < n; ++j) {
          gm_kinematics seed;
          double dtheta;
          if (!seed_along(me, f, j, which == 1, seed, dtheta)) continue;
          gm_result dr{};
          ++derivatives;
          if (gm_directional_derivative(me.model, me.data, &at, &seed, &dr) != GM_OK) {
            msg = "mesh " + std::to_string(m + 1) + ": " + gm_data_message(me.data);
            return GM_ERR_SOLVER;
          }
          std::fill(dT.begin(), dT.end(), 0.0);
          std::fill(dF.begin(), dF.end(), 0.0);
          double carrier = -(dr.moment[0][2] + dr.moment[1][2]);
          for (int i = 0; i < 2; ++i) {
            const std::size_t b = std::size_t(me.gear[i]);
            dT[b] += dr.moment[i][2];
            if (t_.shift_[b] < 0) continue;
            const double fv[2] = {r.force[i][0], r.force[i][1]}, df[2] = {dr.force[i][0], dr.force[i][1]};
            const double u[2] = {at.u[i][0], at.u[i][1]}, du[2] = {seed.u[i][0], seed.u[i][1]};
            double a1[2], a2[2];
            to_housing(c, s, df, a1);
            to_housing(c, s, fv, a2);  // d R(theta) f / dtheta = z x R(theta) f
            dF[2 * b] += a1[0] - dtheta * a2[1];
            dF[2 * b + 1] += a1[1] + dtheta * a2[0];
            carrier -= cross(du, fv) + cross(u, df);
          }
          if (me.carrier >= 0) dT[std::size_t(me.carrier)] += carrier;
          Mat& target = which == 0 ? dQ_q : dQ_qd;
          for (std::size_t b = 0; b < nb; ++b) {
            if (t_.slot_[b] >= 0) target(t_.slot_[b], j) += dT[b];
            if (t_.shift_[b] >= 0)
              for (int a = 0; a < 2; ++a) target(t_.shift_[b] + a, j) += dF[2 * b + std::size_t(a)];
          }
        }
      }
    }
    for (const TrainShaft& sh : t_.shafts_) {
      const int a = t_.slot_[std::size_t(sh.body)], b = sh.other >= 0 ? t_.slot_[std::size_t(sh.other)] : -1;
      if (a >= 0) {
        dQ_q(a, a) -= sh.stiffness;
        dQ_qd(a, a) -= sh.damping;
      }
      if (sh.other >= 0 && b >= 0) {
        dQ_q(b, b) -= sh.stiffness;
        dQ_qd(b, b) -= sh.damping;
        if (a >= 0) {
          dQ_q(a, b) += sh.stiffness;
          dQ_q(b, a) += sh.stiffness;
          dQ_qd(a, b) += sh.damping;
          dQ_qd(b, a) += sh.damping;
        }
      }
    }
    for (std::size_t b = 0; b < nb; ++b)
      for (int a = 0; a < 2 && t_.shift_[b] >= 0; ++a) {
        dQ_q(t_.shift_[b] + a, t_.shift_[b] + a) -= t_.bodies_[b].bearing_stiffness;
        dQ_qd(t_.shift_[b] + a, t_.shift_[b] + a) -= t_.bodies_[b].bearing_damping;
      }
    for (int i = 0; i < n; ++i) {
      a_phi_.row(i) = dQ_q.row(i) / t_.dof_mass_[std::size_t(i)];
      a_omega_.row(i) = dQ_qd.row(i) / t_.dof_mass_[std::size_t(i)];
    }
    modes();
    lu_hd_ = NAN;  // the Newton matrix is refactored for the new Jacobian
    return GM_OK;
  }

  // The modes of the linearized train at the Jacobian: K v = lambda M v with K = -M A_phi
  // (symmetrized), mass-normalized; each mode's rim rate per unit modal speed (the largest TE
  // rate of a mesh's spins and rim or centre speed of a body it makes).
  void modes() {
    const int n = int(t_.dof_mass_.size());
    const Vec mass = Eigen::Map<const Vec>(t_.dof_mass_.data(), n);
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
      for (int i = 0; i < n; ++i) rim = std::max(rim, t_.dof_scale_[std::size_t(i)] * std::fabs(v[i]));
      for (const TrainMesh& me : t_.meshes_) {
        const double rb1 = 0.5 * gm_model_geometry(me.model)->gear[0].d_b;
        const double rb2 = 0.5 * gm_model_geometry(me.model)->gear[1].d_b;
        const double s = gm_model_parameters(me.model)->pair.internal ? -1.0 : 1.0;
        auto speed = [&](int body) { const int i = body >= 0 ? t_.slot_[std::size_t(body)] : -1; return i >= 0 ? v[i] : 0.0; };
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
        size = std::max(size, t_.dof_scale_[std::size_t(f)] * hd * std::fabs(g[f]));
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
      fraction = std::max(fraction, t_.dof_scale_[std::size_t(f)] * std::fabs(e_phi[f] + hd * r[f]) / tol);
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
  long evaluations = 0, derivatives = 0;  // calls so far
  // d(generalized force)/d(unknowns) at the last jacobian(): M A_phi
  Mat force_stiffness() const {
    Mat K = a_phi_;
    for (int i = 0; i < int(K.rows()); ++i) K.row(i) *= t_.dof_mass_[std::size_t(i)];
    return K;
  }
  Full full_;

 private:
  Train& t_;
  const TrainInputs& in_;
  Mat a_phi_, a_omega_, mode_vectors_;
  Vec mode_frequency_, mode_rim_, mass_;
  mutable Eigen::PartialPivLU<Mat> lu_;
  mutable double lu_hd_ = NAN;
  std::vector<double> torques_, forces_;
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
  if (!(params_.tolerance > 0 && params_.max_step > 0 && params_.min_step > 0 && params_.min_step <= params_.max_step)) {
    problem_ = "tolerance, max_step and min_step must be > 0 with min_step <= max_step";
    return;
  }
  // bearing translations and pin errors (train.hpp)
  std::vector<bool> carrier(std::size_t(nb), false), carried(std::size_t(nb), false);
  for (const TrainMesh& me : meshes_)
    if (me.carrier >= 0) carrier[std::size_t(me.carrier)] = true;
  shift_.assign(std::size_t(nb), -1);
  for (int b = 0; b < nb; ++b) {
    const TrainBody& body = bodies_[std::size_t(b)];
    const std::string name = "body " + std::to_string(b + 1);
    const bool pinned = body.pin_error[0] != 0 || body.pin_error[1] != 0;
    if (!(std::isfinite(body.mass) && body.mass >= 0 && std::isfinite(body.bearing_stiffness) &&
          body.bearing_stiffness >= 0 && std::isfinite(body.bearing_damping) && body.bearing_damping >= 0 &&
          std::isfinite(body.pin_error[0]) && std::isfinite(body.pin_error[1]))) {
      problem_ = name + ": mass, bearing stiffness and bearing damping must be finite and >= 0, pin errors finite";
      return;
    }
    if (body.mass == 0 && (body.bearing_stiffness != 0 || body.bearing_damping != 0)) {
      problem_ = name + ": a bearing stiffness or damping without a mass; allowed: mass > 0 (the centre translates) "
                        "or all three 0";
      return;
    }
    if (body.mass > 0 && (carrier[std::size_t(b)] || pinned)) {
      problem_ = name + (pinned ? ": a pin error on a translating body" : ": a carrier that translates") +
                 "; allowed: translations for bodies on the housing's axis that carry no mesh (a sun, a ring)";
      return;
    }
    if (pinned && carrier[std::size_t(b)]) {
      problem_ = name + ": a pin error on a carrier; allowed: on the planets it carries";
      return;
    }
  }
  // a pin error moves a planet's centre in each of its meshes on a carrier: radially away from the
  // mesh's other gear (on the carrier's axis), tangentially z x radial
  for (std::size_t m = 0; m < meshes_.size(); ++m) {
    TrainMesh& me = meshes_[m];
    for (int i = 0; i < 2; ++i) {
      const TrainBody& body = bodies_[std::size_t(me.gear[i])];
      if (body.pin_error[0] == 0 && body.pin_error[1] == 0) continue;
      if (me.carrier < 0) {
        problem_ = "body " + std::to_string(me.gear[i] + 1) + ": a pin error, but its mesh " + std::to_string(m + 1) +
                   " is on the housing; allowed: planets (meshes on a carrier)";
        return;
      }
      const double radial = i == 1 ? 1.0 : -1.0;  // gear 2 lies at +x from gear 1
      me.offset[i][0] += radial * body.pin_error[1];
      me.offset[i][1] += radial * body.pin_error[0];
    }
  }
  finest_pitch_ = INFINITY;
  for (const TrainMesh& me : meshes_)
    for (int i = 0; i < 2; ++i)
      finest_pitch_ = std::min(finest_pitch_, kPi * gm_model_geometry(me.model)->gear[i].d_b /
                                                  gm_model_parameters(me.model)->gear[i].teeth);
  if (!std::isfinite(finest_pitch_)) finest_pitch_ = 1e-3;
  for (int f : free_) {
    dof_mass_.push_back(bodies_[std::size_t(f)].inertia);
    dof_scale_.push_back(scale_[std::size_t(f)]);
    dof_lever_.push_back(1.0);
  }
  for (int b = 0; b < nb; ++b) {
    if (!(bodies_[std::size_t(b)].mass > 0)) continue;
    shift_[std::size_t(b)] = int(dof_mass_.size());
    for (int a = 0; a < 2; ++a) {
      dof_mass_.push_back(bodies_[std::size_t(b)].mass);
      dof_scale_.push_back(1.0);
      dof_lever_.push_back(std::max(scale_[std::size_t(b)], 1e-3));
    }
  }
}

gm_status Train::static_state(int held, double held_angle, const TrainInputs& in, std::vector<double>& phi,
                              std::vector<gm_result>& res, std::string& msg, std::vector<double>* centre,
                              double* held_torque) {
  if (!problem_.empty()) {
    msg = problem_;
    return GM_ERR_PARAMETER;
  }
  const int nb = int(bodies_.size());
  if (held < 0 || held >= nb || slot_[std::size_t(held)] < 0 || int(phi.size()) != nb ||
      (centre && int(centre->size()) != 2 * nb)) {
    msg = "static_state: the held body must be a free body, one angle per body (and two centre coordinates)";
    return GM_ERR_ARGUMENT;
  }
  // every unknown but the held body's spin; the held one is a free body whose acceleration is
  // not asked to vanish (its torque is the input torque the load needs)
  TrainInputs still = in;
  still.far_omega.assign(in.far_phi.size(), 0.0);
  Stepper st(*this, still);
  const int n = int(dof_mass_.size());
  const int held_dof = slot_[std::size_t(held)];
  std::vector<int> unknown;
  for (int i = 0; i < n; ++i)
    if (i != held_dof) unknown.push_back(i);
  Vec p = Vec::Zero(n), w = Vec::Zero(n);
  for (int b = 0; b < nb; ++b) {
    if (slot_[std::size_t(b)] >= 0) p[slot_[std::size_t(b)]] = b == held ? held_angle : phi[std::size_t(b)];
    if (shift_[std::size_t(b)] >= 0 && centre)
      for (int a = 0; a < 2; ++a) p[shift_[std::size_t(b)] + a] = (*centre)[2 * std::size_t(b) + std::size_t(a)];
  }
  Point x;
  // the generalized force on unknown i, a force times the body's rim radius (N m either way)
  const auto load = [&](int i) { return x.accel[i] * dof_mass_[std::size_t(i)] * dof_lever_[std::size_t(i)]; };
  // the largest of them, and the potential energy (the elastic energy less the work of the held
  // torques), whose minimum the equilibrium is; converged when every torque is below 1e-9 of the
  // largest torque in the train (input, mesh or shaft; at least 1 N m): a locked-in torque counts
  double scale = 1.0;
  for (double t : in.torque) scale = std::max(scale, std::fabs(t));
  double energy = 0, tol = 0;
  const auto residual = [&](const Vec& q, double* size, double* potential, double* limit) -> gm_status {
    const gm_status s = st.evaluate_at(0.0, q, w, x, msg);
    if (s != GM_OK) return s;
    double worst = 0, inside = scale;
    for (int i : unknown) worst = std::max(worst, std::fabs(load(i)));
    for (const gm_result& r : x.res) inside = std::max({inside, std::fabs(r.moment[0][2]), std::fabs(r.moment[1][2])});
    for (double t : x.shaft_torque) inside = std::max(inside, std::fabs(t));
    *size = worst;
    *limit = 1e-9 * inside;
    *potential = x.elastic;
    for (int b = 0; b < nb; ++b)
      if (slot_[std::size_t(b)] >= 0 && std::size_t(b) < in.torque.size())
        *potential -= in.torque[std::size_t(b)] * q[slot_[std::size_t(b)]];
    return GM_OK;
  };
  double size = 0;
  gm_status s = residual(p, &size, &energy, &tol);
  if (s != GM_OK) return s;
  // Newton, turned into Levenberg-Marquardt where it does not reduce the residual: (A - mu S) d =
  // -r (A = dr/dq) with S the stiffness diagonal (floored, so that a body in its backlash, which no mesh
  // holds, moves by r / (mu s), down the potential energy, and closes its contact in growing
  // steps); a step is kept when the potential energy or the largest torque falls
  const int m = int(unknown.size());
  Mat A(m, m);
  Vec r(m), S(m);
  double mu = 0;
  bool fresh = false;
  for (int it = 0; it < 300 && size > tol; ++it) {
    if (!fresh) {
      if ((s = st.jacobian(x, msg)) != GM_OK) return s;
      const Mat K = st.force_stiffness();
      double largest = 0;
      for (int i = 0; i < m; ++i) {
        r[i] = x.accel[unknown[std::size_t(i)]] * dof_mass_[std::size_t(unknown[std::size_t(i)])];
        for (int j = 0; j < m; ++j) A(i, j) = K(unknown[std::size_t(i)], unknown[std::size_t(j)]);
        const double lever = dof_lever_[std::size_t(unknown[std::size_t(i)])];
        largest = std::max(largest, std::fabs(A(i, i)) * lever * lever);
      }
      for (int i = 0; i < m; ++i) {
        const double lever = dof_lever_[std::size_t(unknown[std::size_t(i)])];
        // and where nothing is in contact yet, a mesh-like 1e8 N/m at the rim
        const double rim = dof_scale_[std::size_t(unknown[std::size_t(i)])];
        S[i] = std::max({std::fabs(A(i, i)), 1e-3 * largest / (lever * lever), 1e8 * rim * rim});
      }
      fresh = true;
    }
    Mat B = A;  // d(force)/dq: negative where stable, so the damping is subtracted
    B.diagonal() -= mu * S;
    Vec d = B.fullPivLu().solve(-r);
    // no step moves a rim by more than a tenth of the finest base pitch: the meshes repeat with
    // every tooth, and a longer step could land on the same mesh states a few teeth on
    double reach = 0;
    for (int i = 0; i < m; ++i) reach = std::max(reach, std::fabs(d[i]) * dof_scale_[std::size_t(unknown[std::size_t(i)])]);
    if (reach > 0.1 * finest_pitch_) d *= 0.1 * finest_pitch_ / reach;
    Vec trial = p;
    double trial_size = INFINITY, trial_energy = INFINITY, trial_tol = 0;
    if (d.allFinite()) {
      for (int i = 0; i < m; ++i) trial[unknown[std::size_t(i)]] += d[i];
      if (residual(trial, &trial_size, &trial_energy, &trial_tol) != GM_OK) trial_size = trial_energy = INFINITY;
    }
    if (trial_size < size || trial_energy < energy) {
      p = trial;
      size = trial_size;
      energy = trial_energy;
      tol = trial_tol;
      mu = mu > 1e-8 ? mu / 4 : 0.0;
      fresh = false;
      continue;
    }
    mu = std::max(1e-6, 4 * mu);
    if (mu > 1e12) break;
  }
  if ((s = residual(p, &size, &energy, &tol)) != GM_OK) return s;
  if (!(size <= tol)) {
    msg = "static_state: no equilibrium found (largest torque left " + number(size) +
          " N m); start nearer contact";
    return GM_ERR_SOLVER;
  }
  for (int b = 0; b < nb; ++b) {
    if (slot_[std::size_t(b)] >= 0) phi[std::size_t(b)] = p[slot_[std::size_t(b)]];
    if (shift_[std::size_t(b)] >= 0 && centre)
      for (int a = 0; a < 2; ++a) (*centre)[2 * std::size_t(b) + std::size_t(a)] = p[shift_[std::size_t(b)] + a];
  }
  if (held_torque) *held_torque = -x.accel[held_dof] * dof_mass_[std::size_t(held_dof)];
  res = x.res;
  return GM_OK;
}

// The state's per-body vectors from the unknowns, with its kinetic energy.
void Train::unpack(const Vec& q, const Vec& qd, TrainState& s) const {
  const std::size_t nb = bodies_.size();
  s.phi.assign(nb, 0.0);
  s.omega.assign(nb, 0.0);
  s.centre.assign(2 * nb, 0.0);
  s.centre_speed.assign(2 * nb, 0.0);
  s.kinetic = 0;
  for (std::size_t b = 0; b < nb; ++b) {
    if (slot_[b] >= 0) {
      s.phi[b] = q[slot_[b]];
      s.omega[b] = qd[slot_[b]];
    }
    if (shift_[b] >= 0)
      for (int a = 0; a < 2; ++a) {
        s.centre[2 * b + std::size_t(a)] = q[shift_[b] + a];
        s.centre_speed[2 * b + std::size_t(a)] = qd[shift_[b] + a];
      }
  }
  for (int i = 0; i < int(q.size()); ++i) s.kinetic += 0.5 * dof_mass_[std::size_t(i)] * qd[i] * qd[i];
}

// The unknowns of a state (per-body vectors; centres absent: nominal, at rest).
void Train::pack(const std::vector<double>& phi, const std::vector<double>& omega, const std::vector<double>* centre,
                 const std::vector<double>* centre_speed, Vec& q, Vec& qd) const {
  const int n = int(dof_mass_.size());
  q = Vec::Zero(n);
  qd = Vec::Zero(n);
  for (std::size_t b = 0; b < bodies_.size(); ++b) {
    if (slot_[b] >= 0) {
      q[slot_[b]] = phi[b];
      qd[slot_[b]] = omega[b];
    }
    if (shift_[b] >= 0)
      for (int a = 0; a < 2; ++a) {
        if (centre && centre->size() == 2 * bodies_.size()) q[shift_[b] + a] = (*centre)[2 * b + std::size_t(a)];
        if (centre_speed && centre_speed->size() == 2 * bodies_.size())
          qd[shift_[b] + a] = (*centre_speed)[2 * b + std::size_t(a)];
      }
  }
}

gm_status Train::start(const std::vector<double>& phi, const std::vector<double>& omega, const TrainInputs& in,
                       TrainState& s, std::vector<gm_result>& res, std::string& msg, const std::vector<double>* centre,
                       const std::vector<double>* centre_speed) {
  if (!problem_.empty()) {
    msg = problem_;
    return GM_ERR_PARAMETER;
  }
  const int nb = int(bodies_.size());
  if (int(phi.size()) != nb || int(omega.size()) != nb || (centre && int(centre->size()) != 2 * nb) ||
      (centre_speed && int(centre_speed->size()) != 2 * nb)) {
    msg = "start: one angle and one speed per body (and two centre coordinates and speeds)";
    return GM_ERR_ARGUMENT;
  }
  Vec p, w;
  pack(phi, omega, centre, centre_speed, p, w);
  Stepper st(*this, in);
  Point x;
  const gm_status status = st.evaluate_at(0.0, p, w, x, msg);
  if (status != GM_OK) return status;
  TrainState out;
  unpack(p, w, out);
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
  Vec p, w;
  pack(s.phi, s.omega, &s.centre, &s.centre_speed, p, w);
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
    const double h_try = step_to_try(h, remaining);
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
      Stepper::Full f1, f2, f3;
      st.full(x1.phi, x1.omega, f1);
      st.full(x2.phi, x2.omega, f2);
      st.full(x3.phi, x3.omega, f3);
      for (std::size_t m = 0; m < meshes_.size(); ++m) {
        const TrainMesh& me = meshes_[m];
        const gm_kinematics k1 = st.element_pose(me, f1), k2 = st.element_pose(me, f2), k3 = st.element_pose(me, f3);
        // the element's work in its own frame: moments along its spins, forces along its centres
        double work = 0;
        for (int i = 0; i < 2; ++i) {
          work -= 0.5 * (x1.res[m].moment[i][2] + x2.res[m].moment[i][2]) * (k2.phi[i] - k1.phi[i]);
          work -= 0.5 * (x2.res[m].moment[i][2] + x3.res[m].moment[i][2]) * (k3.phi[i] - k2.phi[i]);
          for (int a = 0; a < 2; ++a) {
            work -= 0.5 * (x1.res[m].force[i][a] + x2.res[m].force[i][a]) * (k2.u[i][a] - k1.u[i][a]);
            work -= 0.5 * (x2.res[m].force[i][a] + x3.res[m].force[i][a]) * (k3.u[i][a] - k2.u[i][a]);
          }
        }
        const double fr = h_try * (kW * (x1.res[m].friction_power + x2.res[m].friction_power) + kD * x3.res[m].friction_power);
        const double da = h_try * (kW * (x1.res[m].damping_power + x2.res[m].damping_power) + kD * x3.res[m].damping_power);
        s.parametric += work - fr - da - (x3.res[m].elastic_energy - x1.res[m].elastic_energy);
      }
      t = h_try == remaining ? duration : t + h_try;
      x1 = x3;
      ++jacobian_age;
      jacobian_current = keep_jacobian(true, st.contraction, jacobian_age);
      ++s.steps;
      const double growth = std::min(after_rejection ? 1.0 : 2.0, step_factor(fraction / allowed));
      h = std::min(params_.max_step, std::max(h, h_try) * growth);
      after_rejection = false;
      continue;
    }
    ++s.rejected;
    after_rejection = true;
    jacobian_current = jacobian_current && keep_jacobian(status == GM_OK, st.contraction, jacobian_age);
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
  s.evaluations = st.evaluations;
  s.derivatives = st.derivatives;
  unpack(x1.phi, x1.omega, s);
  s.reaction = x1.reaction;
  s.shaft_torque = x1.shaft_torque;
  s.elastic = x1.elastic;
  s.residual = s.work_in - s.work_out - (s.kinetic + s.elastic - s.initial_energy) - s.friction - s.damping - s.parametric;
  s_io = s;
  res = x1.res;
  return GM_OK;
}

}  // namespace gm
