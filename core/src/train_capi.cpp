// The C API of gear trains (gearmesh/train.h) over gm::Train (train.hpp).
#include "gearmesh/train.h"

#include <algorithm>
#include <cmath>
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
    for (int i = 0; i < body_count; ++i) b.push_back({bodies[i].inertia, bodies[i].fixed != 0});
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

const char* gm_train_message(const gm_train* t) { return t ? t->message.c_str() : ""; }

}  // extern "C"
