// The C API of gear trains (gearmesh/train.h) over gm::Train (train.hpp).
#include "gearmesh/train.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <new>
#include <string>
#include <vector>

#include "train.hpp"

struct gm_train {
  std::vector<gm_data*> data;  // one per mesh, owned
  std::unique_ptr<gm::Train> train;
  gm::TrainState state;
  std::vector<gm_result> res;
  int shafts = 0;
  bool started = false;
  std::string message;
  ~gm_train() {
    train.reset();
    for (gm_data* d : data) gm_data_free(d);
  }
};

namespace {

void copy_message(const std::string& text, char* msg, size_t size) {
  if (!msg || size == 0) return;
  const size_t n = std::min(text.size(), size - 1);
  std::memcpy(msg, text.data(), n);
  msg[n] = '\0';
}

gm::TrainInputs inputs(const gm_train& t, const double* torque, const double* far_phi, const double* far_omega) {
  gm::TrainInputs in;
  in.torque.assign(torque, torque + t.train->body_count());
  if (t.shafts > 0) {
    in.far_phi.assign(far_phi, far_phi + t.shafts);
    in.far_omega.assign(far_omega, far_omega + t.shafts);
  }
  return in;
}

bool finite(const double* x, int n) {
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(x[i])) return false;
  return true;
}

}  // namespace

extern "C" {

gm_status gm_train_create(const gm_train_body* bodies, int body_count, const gm_train_mesh* meshes, int mesh_count,
                          const gm_train_shaft* shafts, int shaft_count, double tolerance, double max_step,
                          double min_step, gm_train** out, char* msg, size_t msg_size) {
  if (!out || body_count < 1 || mesh_count < 0 || shaft_count < 0 || (!bodies && body_count) ||
      (!meshes && mesh_count) || (!shafts && shaft_count)) {
    copy_message("gm_train_create: bodies (>= 1), meshes and shafts with their counts", msg, msg_size);
    return GM_ERR_ARGUMENT;
  }
  *out = nullptr;
  try {
    auto t = std::make_unique<gm_train>();
    std::vector<gm::TrainBody> b;
    for (int i = 0; i < body_count; ++i) {
      gm::TrainBody body{bodies[i].inertia, bodies[i].fixed != 0};
      body.mass = bodies[i].mass;
      body.bearing_stiffness = bodies[i].bearing_stiffness;
      body.bearing_damping = bodies[i].bearing_damping;
      body.pin_error[0] = bodies[i].pin_error[0];
      body.pin_error[1] = bodies[i].pin_error[1];
      b.push_back(body);
    }
    std::vector<gm::TrainMesh> m;
    for (int i = 0; i < mesh_count; ++i) {
      gm::TrainMesh me;
      me.model = meshes[i].model;
      if (me.model) {
        gm_data* d = nullptr;
        if (gm_data_create(me.model, &d) != GM_OK) return GM_ERR_MEMORY;
        t->data.push_back(d);
        me.data = d;
      }
      me.gear[0] = meshes[i].gear[0];
      me.gear[1] = meshes[i].gear[1];
      me.carrier = meshes[i].carrier;
      me.orientation = meshes[i].orientation;
      m.push_back(me);
    }
    std::vector<gm::TrainShaft> s;
    for (int i = 0; i < shaft_count; ++i)
      s.push_back({shafts[i].body, shafts[i].other, shafts[i].stiffness, shafts[i].damping});
    gm::TrainParams p;
    p.tolerance = tolerance;
    p.max_step = max_step;
    p.min_step = min_step;
    t->train = std::make_unique<gm::Train>(std::move(b), std::move(m), std::move(s), p);
    t->shafts = shaft_count;
    if (!t->train->problem().empty()) {
      copy_message(t->train->problem(), msg, msg_size);
      return GM_ERR_PARAMETER;
    }
    copy_message("", msg, msg_size);
    *out = t.release();
    return GM_OK;
  } catch (const std::bad_alloc&) {
    return GM_ERR_MEMORY;
  }
}

void gm_train_free(gm_train* t) { delete t; }

gm_status gm_train_start(gm_train* t, const double* phi, const double* omega, const double* torque,
                         const double* far_phi, const double* far_omega) {
  if (!t || !phi || !omega || !torque || (t->shafts > 0 && (!far_phi || !far_omega))) return GM_ERR_ARGUMENT;
  const int nb = t->train->body_count();
  if (!finite(phi, nb) || !finite(omega, nb) || !finite(torque, nb) ||
      (t->shafts > 0 && (!finite(far_phi, t->shafts) || !finite(far_omega, t->shafts)))) {
    t->message = "gm_train_start: angles, speeds, torques and far ends must be finite";
    return GM_ERR_INPUT;
  }
  try {
    gm::TrainState s;
    std::vector<gm_result> res;
    const gm_status st = t->train->start(std::vector<double>(phi, phi + nb), std::vector<double>(omega, omega + nb),
                                         inputs(*t, torque, far_phi, far_omega), s, res, t->message);
    if (st != GM_OK) return st;
    t->state = std::move(s);
    t->res = std::move(res);
    t->started = true;
    t->message.clear();
    return GM_OK;
  } catch (const std::bad_alloc&) {
    return GM_ERR_MEMORY;
  }
}

gm_status gm_train_advance(gm_train* t, const double* torque, const double* far_phi, const double* far_omega,
                           double duration) {
  if (!t || !torque || (t->shafts > 0 && (!far_phi || !far_omega))) return GM_ERR_ARGUMENT;
  if (!t->started) {
    t->message = "gm_train_advance before gm_train_start";
    return GM_ERR_ARGUMENT;
  }
  if (!finite(torque, t->train->body_count()) ||
      (t->shafts > 0 && (!finite(far_phi, t->shafts) || !finite(far_omega, t->shafts)))) {
    t->message = "gm_train_advance: torques and far ends must be finite";
    return GM_ERR_INPUT;
  }
  try {
    gm::TrainState s = t->state;
    std::vector<gm_result> res;
    const gm_status st = t->train->advance(inputs(*t, torque, far_phi, far_omega), duration, s, res, t->message);
    if (st != GM_OK) return st;
    t->state = std::move(s);
    t->res = std::move(res);
    t->message.clear();
    return GM_OK;
  } catch (const std::bad_alloc&) {
    return GM_ERR_MEMORY;
  }
}

gm_status gm_train_static(gm_train* t, int held, double held_angle, const double* phi, const double* torque,
                          const double* far_phi) {
  if (!t || !torque || (t->shafts > 0 && !far_phi) || (!phi && !t->started)) return GM_ERR_ARGUMENT;
  const int nb = t->train->body_count();
  if (!finite(torque, nb) || !std::isfinite(held_angle) || (phi && !finite(phi, nb)) ||
      (t->shafts > 0 && !finite(far_phi, t->shafts))) {
    t->message = "gm_train_static: the held angle, start angles, torques and far ends must be finite";
    return GM_ERR_INPUT;
  }
  if (held < 0 || held >= nb) {
    t->message = "gm_train_static: held body " + std::to_string(held + 1) + "; allowed: 1.." + std::to_string(nb);
    return GM_ERR_ARGUMENT;
  }
  try {
    const std::vector<double> zero(std::size_t(std::max(t->shafts, 1)), 0.0);
    const gm::TrainInputs in = inputs(*t, torque, far_phi, zero.data());
    std::vector<double> angles = phi ? std::vector<double>(phi, phi + nb) : t->state.phi;
    std::vector<double> centre = t->started ? t->state.centre : std::vector<double>(2 * std::size_t(nb), 0.0);
    std::vector<gm_result> res;
    double holding = 0;
    gm_status st = t->train->static_state(held, held_angle, in, angles, res, t->message, &centre, &holding);
    if (st != GM_OK) return st;
    gm::TrainState s;
    const std::vector<double> rest(std::size_t(nb), 0.0), still(2 * std::size_t(nb), 0.0);
    st = t->train->start(angles, rest, in, s, res, t->message, &centre, &still);
    if (st != GM_OK) return st;
    s.reaction[std::size_t(held)] = holding;
    t->state = std::move(s);
    t->res = std::move(res);
    t->started = true;
    t->message.clear();
    return GM_OK;
  } catch (const std::bad_alloc&) {
    return GM_ERR_MEMORY;
  }
}

gm_status gm_train_body_centre(const gm_train* t, int body, double* x, double* y) {
  if (!t || !t->started || body < 0 || body >= t->train->body_count()) return GM_ERR_ARGUMENT;
  if (x) *x = t->state.centre[2 * std::size_t(body)];
  if (y) *y = t->state.centre[2 * std::size_t(body) + 1];
  return GM_OK;
}

gm_status gm_train_body_state(const gm_train* t, int body, double* phi, double* omega, double* holding_torque) {
  if (!t || !t->started || body < 0 || body >= t->train->body_count()) return GM_ERR_ARGUMENT;
  if (phi) *phi = t->state.phi[std::size_t(body)];
  if (omega) *omega = t->state.omega[std::size_t(body)];
  if (holding_torque) *holding_torque = t->state.reaction[std::size_t(body)];
  return GM_OK;
}

gm_status gm_train_shaft_torque(const gm_train* t, int shaft, double* torque) {
  if (!t || !t->started || shaft < 0 || shaft >= t->shafts || !torque) return GM_ERR_ARGUMENT;
  *torque = t->state.shaft_torque[std::size_t(shaft)];
  return GM_OK;
}

const gm_result* gm_train_mesh_result(const gm_train* t, int mesh) {
  if (!t || !t->started || mesh < 0 || mesh >= int(t->res.size())) return nullptr;
  return &t->res[std::size_t(mesh)];
}

gm_train_energy gm_train_energy_account(const gm_train* t) {
  gm_train_energy e{};
  if (!t || !t->started) return e;
  const gm::TrainState& s = t->state;
  e.kinetic = s.kinetic;
  e.elastic = s.elastic;
  e.initial = s.initial_energy;
  e.work_in = s.work_in;
  e.work_out = s.work_out;
  e.friction = s.friction;
  e.damping = s.damping;
  e.parametric = s.parametric;
  e.residual = s.residual;
  return e;
}

void gm_train_steps(const gm_train* t, int* accepted, int* rejected) {
  if (accepted) *accepted = t && t->started ? t->state.steps : 0;
  if (rejected) *rejected = t && t->started ? t->state.rejected : 0;
}

void gm_train_work(const gm_train* t, long* evaluations, long* derivatives) {
  if (evaluations) *evaluations = t && t->started ? t->state.evaluations : 0;
  if (derivatives) *derivatives = t && t->started ? t->state.derivatives : 0;
}

const char* gm_train_message(const gm_train* t) { return t ? t->message.c_str() : ""; }

namespace {

// The doubles of a state: per body phi, omega, reaction, centre x, y and their speeds; per shaft
// torque; the scalars.
constexpr int kPerBody = 7;
constexpr int kScalars = 10;  // kinetic, elastic, initial, work in/out, friction, damping, parametric, residual, step
std::size_t doubles_of(const gm_train* t) {
  return std::size_t(kPerBody * t->train->body_count() + t->shafts + kScalars);
}

}  // namespace

size_t gm_train_state_size(const gm_train* t) {
  if (!t) return 0;
  size_t size = sizeof(std::uint32_t) * 4 + doubles_of(t) * sizeof(double);
  for (std::size_t m = 0; m < t->data.size(); ++m)
    size += sizeof(gm_result) + sizeof(std::uint64_t) + gm_data_state_size(t->train->mesh_model(int(m)), t->data[m]);
  return size;
}

gm_status gm_train_state_save(const gm_train* t, void* buf, size_t size) {
  if (!t || !buf || size != gm_train_state_size(t)) return GM_ERR_ARGUMENT;
  unsigned char* p = static_cast<unsigned char*>(buf);
  const std::uint32_t head[4] = {std::uint32_t(t->train->body_count()), std::uint32_t(t->shafts),
                                 std::uint32_t(t->data.size()), std::uint32_t(t->started)};
  std::memcpy(p, head, sizeof head);
  p += sizeof head;
  std::vector<double> x;
  const gm::TrainState& s = t->state;
  const std::size_t nb = std::size_t(t->train->body_count());
  for (std::size_t b = 0; b < nb; ++b) {
    x.push_back(t->started ? s.phi[b] : 0.0);
    x.push_back(t->started ? s.omega[b] : 0.0);
    x.push_back(t->started ? s.reaction[b] : 0.0);
    for (int a = 0; a < 2; ++a) {
      x.push_back(t->started ? s.centre[2 * b + std::size_t(a)] : 0.0);
      x.push_back(t->started ? s.centre_speed[2 * b + std::size_t(a)] : 0.0);
    }
  }
  for (int i = 0; i < t->shafts; ++i) x.push_back(t->started ? s.shaft_torque[std::size_t(i)] : 0.0);
  for (double v : {s.kinetic, s.elastic, s.initial_energy, s.work_in, s.work_out, s.friction, s.damping,
                   s.parametric, s.residual, s.step})
    x.push_back(v);
  std::memcpy(p, x.data(), x.size() * sizeof(double));
  p += x.size() * sizeof(double);
  for (std::size_t m = 0; m < t->data.size(); ++m) {
    const gm_result r = t->started ? t->res[m] : gm_result{};
    std::memcpy(p, &r, sizeof r);
    p += sizeof r;
    const gm_model* model = t->train->mesh_model(int(m));
    const std::uint64_t n = gm_data_state_size(model, t->data[m]);
    std::memcpy(p, &n, sizeof n);
    p += sizeof n;
    if (gm_data_state_save(model, t->data[m], p, n) != GM_OK) return GM_ERR_ARGUMENT;
    p += n;
  }
  return GM_OK;
}

gm_status gm_train_state_load(gm_train* t, const void* buf, size_t size) {
  if (!t || !buf || size != gm_train_state_size(t)) return GM_ERR_ARGUMENT;
  const unsigned char* p = static_cast<const unsigned char*>(buf);
  std::uint32_t head[4];
  std::memcpy(head, p, sizeof head);
  p += sizeof head;
  if (head[0] != std::uint32_t(t->train->body_count()) || head[1] != std::uint32_t(t->shafts) ||
      head[2] != std::uint32_t(t->data.size()) || head[3] > 1)
    return GM_ERR_ARGUMENT;
  std::vector<double> x(doubles_of(t));
  std::memcpy(x.data(), p, x.size() * sizeof(double));
  p += x.size() * sizeof(double);
  // the meshes' memories first, into copies: nothing changes unless all of them load
  std::vector<std::vector<unsigned char>> blobs;
  std::vector<gm_result> res(t->data.size());
  for (std::size_t m = 0; m < t->data.size(); ++m) {
    std::memcpy(&res[m], p, sizeof(gm_result));
    p += sizeof(gm_result);
    std::uint64_t n;
    std::memcpy(&n, p, sizeof n);
    p += sizeof n;
    if (n != gm_data_state_size(t->train->mesh_model(int(m)), t->data[m])) return GM_ERR_ARGUMENT;
    blobs.emplace_back(p, p + n);
    p += n;
  }
  for (std::size_t m = 0; m < t->data.size(); ++m)
    if (gm_data_state_load(t->train->mesh_model(int(m)), t->data[m], blobs[m].data(), blobs[m].size()) != GM_OK)
      return GM_ERR_ARGUMENT;
  gm::TrainState s;
  const std::size_t nb = std::size_t(t->train->body_count());
  std::size_t k = 0;
  for (std::size_t b = 0; b < nb; ++b) {
    s.phi.push_back(x[k++]);
    s.omega.push_back(x[k++]);
    s.reaction.push_back(x[k++]);
    for (int a = 0; a < 2; ++a) {
      s.centre.push_back(x[k++]);
      s.centre_speed.push_back(x[k++]);
    }
  }
  for (int i = 0; i < t->shafts; ++i) s.shaft_torque.push_back(x[k++]);
  for (double* v : {&s.kinetic, &s.elastic, &s.initial_energy, &s.work_in, &s.work_out, &s.friction, &s.damping,
                    &s.parametric, &s.residual, &s.step})
    *v = x[k++];
  t->state = std::move(s);
  t->started = head[3] != 0;
  t->res = std::move(res);
  return GM_OK;
}

}  // extern "C"
