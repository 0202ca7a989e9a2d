// Gear trains (core/src/train.hpp): checked against the pair's own large-step mode, the Willis
// equation, the static torque balance of a planetary stage and the symmetry of its planets.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "test_support.hpp"
#include "gearmesh/train.h"
#include "train.hpp"

namespace {

using gm_test::Instance;
using gm_test::kPi;

// Set A at level 4 with 10 slices (as test_dynamics.cpp's drive).
gm_model_params set_a() {
  gm_model_params p = gm_test::paper();
  p.stiffness_level = GM_STIFFNESS_ANALYTICAL;
  p.slices = 10;
  return p;
}

// The pair's large-step mode and a train of its two gears on the same model: gear 1 on a shaft
// whose far end turns at 1000 rpm, gear 2 braked by 350 N m, started at the quasi-static
// equilibrium; 30 communication steps of 1 ms. Two integrations of the same equations with
// different error norms (the pair's mesh-mode split, the train's modes): their TE agrees within
// their own error at a tolerance of 1e-10 m, and the energy accounts agree.
TEST(Train, TwoBodiesAreThePairsLargeStepMode) {
  Instance pair(set_a());
  gm_data* data2 = nullptr;
  ASSERT_EQ(gm_data_create(pair.m, &data2), GM_OK);
  std::unique_ptr<gm_data, void (*)(gm_data*)> guard(data2, gm_data_free);
  const double w = 1000 * 2 * kPi / 60, k = 2e4, c = 100, load = 350;
  gm_model_params q = set_a();
  q.quasi_static = 1;
  Instance qs(q);
  const gm_result r0 = qs.loaded(0.0, load, w);
  const double ratio = pair.rb(0) / pair.rb(1);

  gm_dynamics_params dp;
  gm_dynamics_default_params(&dp);
  dp.shaft_stiffness[0] = k;
  dp.shaft_damping[0] = c;
  dp.tolerance = 1e-10;
  gm_dynamics_inputs din{};
  gm_kinematics pose{};
  pose.phi[1] = r0.te / pair.rb(1);
  pose.omega[0] = w;
  pose.omega[1] = -w * ratio;
  din.shaft_omega[0] = w;
  din.shaft_phi[0] = -r0.moment[0][2] / k;
  din.torque[1] = load;
  gm_dynamics_state ds{};
  gm_result res{};
  ASSERT_EQ(gm_dynamics_start(pair.m, pair.d, &dp, &pose, &din, &ds, &res), GM_OK);

  gm::TrainMesh mesh;
  mesh.model = pair.m;
  mesh.data = data2;
  mesh.gear[0] = 0;
  mesh.gear[1] = 1;
  gm::TrainParams tp;
  tp.tolerance = 1e-10;
  tp.max_step = dp.max_step;
  tp.min_step = dp.min_step;
  gm::Train train({{dp.inertia[0], false}, {dp.inertia[1], false}}, {mesh}, {{0, -1, k, c}}, tp);
  ASSERT_EQ(train.problem(), "");
  gm::TrainInputs tin;
  tin.torque = {0.0, load};
  tin.far_phi = {din.shaft_phi[0]};
  tin.far_omega = {w};
  gm::TrainState ts;
  std::vector<gm_result> tres;
  std::string msg;
  ASSERT_EQ(train.start({0.0, pose.phi[1]}, {w, pose.omega[1]}, tin, ts, tres, msg), GM_OK) << msg;
  const double H = 1e-3;
  double worst = 0;
  for (int i = 0; i < 30; ++i) {
    ASSERT_EQ(gm_dynamics_advance(pair.m, pair.d, &dp, &pose, &din, H, &ds, &res), GM_OK) << gm_data_message(pair.d);
    ASSERT_EQ(train.advance(tin, H, ts, tres, msg), GM_OK) << msg;
    din.shaft_phi[0] += w * H;
    tin.far_phi[0] += w * H;
    worst = std::max(worst, std::fabs(res.te - tres[0].te));
  }
  EXPECT_LT(worst, 5e-9);  // m: 50 tolerances
  EXPECT_NEAR(ts.phi[0], ds.phi[0], 1e-9);
  EXPECT_NEAR(ts.shaft_torque[0], ds.shaft_torque[0], 1e-3 * std::fabs(ds.shaft_torque[0]));
  EXPECT_NEAR(ts.work_in, ds.work_in, 1e-4 * ds.work_in);
  EXPECT_NEAR(ts.work_out, ds.work_out, 1e-4 * ds.work_out);
  EXPECT_LT(std::fabs(ts.residual), 1e-4 * ts.work_in);
}

// A planetary stage: sun 21, three planets 21, ring 63 held in the housing, m 2 mm, level 0 on
// one slice with contact damping; the sun on a shaft whose far end turns at 100 rad/s, the
// carrier loaded by 100 N m against its turning. Checked in the steady state (after 0.15 s, means
// over 0.1 s sampled every 0.1 ms) against closed forms: the Willis equation omega_c / omega_s = z_s / (z_s + z_r),
// the torque balance (sun z_s / (z_s + z_r) of the load, ring z_r / (z_s + z_r)), the planets'
// speed omega_p - omega_c = -(z_s / z_p)(omega_s - omega_c); and the symmetry: three planets
// spaced by 120 degrees with z_s and z_r multiples of 3 see the same mesh state, so their mesh
// forces are equal at every instant (load sharing exactly 1/3); with four planets (z_s = 21 not a
// multiple of 4) the sun meshes are out of phase, equal only on average.
struct Planetary {
  std::unique_ptr<Instance> sun_planet, planet_ring;
  std::vector<gm_data*> data;
  std::unique_ptr<gm::Train> train;
  gm::TrainInputs in;
  static constexpr int zs = 21, zp = 21, zr = 63;
  static constexpr int sun = 0;
  const int planets, ring, carrier;

  explicit Planetary(int n) : planets(n), ring(n + 1), carrier(n + 2) {
    gm_model_params p = gm_test::paper();  // level 0, one slice
    p.pair.normal_module = 0.002;
    p.pair.center_distance = 0.042;
    p.damping = 2e5;
    for (auto& g : p.gear) {
      g.teeth = 21;
      g.profile_shift = 0;
      g.face_width = 0.02;
      g.thickness_allowance = -10e-6;
    }
    sun_planet = std::make_unique<Instance>(p);
    gm_model_params r = p;
    r.pair.internal = 1;
    r.gear[1].teeth = zr;
    planet_ring = std::make_unique<Instance>(r);
    std::vector<gm::TrainMesh> meshes;
    for (int k = 0; k < planets; ++k) {
      const double psi = 2 * kPi * k / planets;
      for (int which = 0; which < 2; ++which) {
        gm::TrainMesh me;
        me.model = which == 0 ? sun_planet->m : planet_ring->m;
        gm_data* d = nullptr;
        gm_data_create(me.model, &d);
        data.push_back(d);
        me.data = d;
        me.carrier = carrier;
        if (which == 0) {  // the sun (gear 1) at the carrier's axis, the planet (gear 2) at psi
          me.gear[0] = sun;
          me.gear[1] = 1 + k;
          me.orientation = psi;
        } else {  // the planet (gear 1), the ring (gear 2) centred on the axis: towards psi + pi
          me.gear[0] = 1 + k;
          me.gear[1] = ring;
          me.orientation = psi + kPi;
        }
        meshes.push_back(me);
      }
    }
    std::vector<gm::TrainBody> bodies(std::size_t(planets + 1), gm::TrainBody{2e-3, false});  // sun, planets
    bodies.push_back({0.0, true});                                                          // ring
    bodies.push_back({5e-2, false});                                                        // carrier
    gm::TrainParams tp;
    train = std::make_unique<gm::Train>(bodies, meshes, std::vector<gm::TrainShaft>{{sun, -1, 1e4, 10.0}}, tp);
  }
  ~Planetary() {
    train.reset();
    for (gm_data* d : data) gm_data_free(d);
  }
};

// The steady-state figures of a run of the stage with n planets.
struct SteadyState {
  double speed_ratio, planet_speed, sun_torque, ring_torque, residual_share;
  double instant_asymmetry;  // largest relative difference of the planets' sun-mesh forces
  std::vector<double> share; // each planet's mean share of the sun meshes' force
};

SteadyState run(Planetary& s, double ws, double load) {
  SteadyState out{};
  EXPECT_EQ(s.train->problem(), "");
  const double wc = ws * s.zs / (s.zs + s.zr), wp = wc - double(s.zs) / s.zp * (ws - wc);
  const std::size_t nb = std::size_t(s.carrier + 1);
  std::vector<double> phi(nb, 0.0), omega(nb, 0.0);
  omega[std::size_t(s.sun)] = ws;
  omega[std::size_t(s.carrier)] = wc;
  for (int k = 0; k < s.planets; ++k) {
    phi[std::size_t(1 + k)] = 2 * (2 * kPi * k / s.planets);  // sun-planet mesh at TE 0 (equal radii)
    omega[std::size_t(1 + k)] = wp;
  }
  s.in.torque.assign(nb, 0.0);
  s.in.torque[std::size_t(s.carrier)] = -load;
  s.in.far_phi = {load * s.zs / (s.zs + s.zr) / 1e4};
  s.in.far_omega = {ws};
  gm::TrainState st;
  std::vector<gm_result> res;
  std::string msg;
  EXPECT_EQ(s.train->start(phi, omega, s.in, st, res, msg), GM_OK) << msg;
  double sum_ws = 0, sum_wc = 0, sum_wp = 0, sum_shaft = 0, sum_ring = 0, total = 0;
  std::vector<double> force(std::size_t(s.planets), 0.0);
  int n = 0;
  // 150 steps of 1 ms to settle, then 1000 of 0.1 ms to average: the meshes' frequency is 251 Hz
  // here, and 1 ms samples (3.99 per period) would average a few fixed phases of it
  for (int i = 0; i < 1150; ++i) {
    const double H = i < 150 ? 1e-3 : 1e-4;
    if (s.train->advance(s.in, H, st, res, msg) != GM_OK) {
      ADD_FAILURE() << "step " << i << ": " << msg;
      return out;
    }
    s.in.far_phi[0] += ws * H;
    if (i < 150) continue;
    const double f0 = res[0].normal_force;
    for (int k = 0; k < s.planets; ++k) {
      const double f = res[std::size_t(2 * k)].normal_force;
      out.instant_asymmetry = std::max(out.instant_asymmetry, std::fabs(f - f0) / std::max(f0, 1.0));
      force[std::size_t(k)] += f;
      total += f;
    }
    sum_ws += st.omega[std::size_t(s.sun)];
    sum_wc += st.omega[std::size_t(s.carrier)];
    sum_wp += st.omega[1];
    sum_shaft += st.shaft_torque[0];
    sum_ring += st.reaction[std::size_t(s.ring)];
    ++n;
  }
  out.speed_ratio = sum_wc / sum_ws;
  out.planet_speed = sum_wp / n;
  out.sun_torque = sum_shaft / n;
  out.ring_torque = sum_ring / n;
  for (double f : force) out.share.push_back(f / total);
  out.residual_share = std::fabs(st.residual) / st.work_in;
  return out;
}

TEST(Train, PlanetaryStageKeepsWillisTorqueBalanceAndEqualPlanets) {
  for (int planets : {3, 4}) {
    SCOPED_TRACE(std::to_string(planets) + " planets");
    Planetary s(planets);
    const double ws = 100.0, load = 100.0;
    const double wc = ws * s.zs / (s.zs + s.zr), wp = wc - double(s.zs) / s.zp * (ws - wc);
    const SteadyState r = run(s, ws, load);
    EXPECT_NEAR(r.speed_ratio, double(s.zs) / (s.zs + s.zr), 1e-4);
    EXPECT_NEAR(r.planet_speed, wp, 1e-3 * std::fabs(wp));
    EXPECT_NEAR(r.sun_torque, load * s.zs / (s.zs + s.zr), 1e-2 * load);
    // the torque that holds the ring: the load's share z_r / (z_s + z_r)
    EXPECT_NEAR(r.ring_torque, load * s.zr / (s.zs + s.zr), 1e-2 * load);
    for (double share : r.share) EXPECT_NEAR(share, 1.0 / planets, 1e-2 / planets);
    if (planets == 3) {
      // z_s and z_r multiples of 3: every planet's meshes in the same state at every instant
      EXPECT_LT(r.instant_asymmetry, 1e-6);
    } else {
      // z_s = 21 over 4 planets: the sun meshes a quarter of a tooth apart (sequential phasing),
      // so the forces differ instant by instant while their means are equal
      EXPECT_GT(r.instant_asymmetry, 1e-2);
    }
    EXPECT_LT(r.residual_share, 1e-3);
  }
}

// The C API (gearmesh/train.h) runs the C++ train: the same two-body drive through both gives
// the same state bit for bit; bad input is refused and named, and the train stays usable; the
// state saved and restored continues bit for bit.
TEST(Train, CApiIsTheTrainAndNamesBadInput) {
  Instance pair(set_a());
  gm_data* data2 = nullptr;
  ASSERT_EQ(gm_data_create(pair.m, &data2), GM_OK);
  std::unique_ptr<gm_data, void (*)(gm_data*)> guard(data2, gm_data_free);
  const double w = 300 * 2 * kPi / 60, k = 2e4, c = 100;
  gm::TrainMesh mesh;
  mesh.model = pair.m;
  mesh.data = data2;
  mesh.gear[0] = 0;
  mesh.gear[1] = 1;
  gm::Train train({{0.02, false}, {0.02, false}}, {mesh}, {{0, -1, k, c}}, {});
  gm::TrainInputs tin;
  tin.torque = {0.0, 200.0};
  tin.far_phi = {0.0};
  tin.far_omega = {w};
  gm::TrainState ts;
  std::vector<gm_result> tres;
  std::string msg;
  ASSERT_EQ(train.start({0.0, 0.0}, {w, -w}, tin, ts, tres, msg), GM_OK) << msg;

  const gm_train_body bodies[2] = {{0.02, 0}, {0.02, 0}};
  const gm_train_mesh meshes[1] = {{pair.m, {0, 1}, -1, 0.0}};
  const gm_train_shaft shafts[1] = {{0, -1, k, c}};
  gm_train* t = nullptr;
  char text[256];
  ASSERT_EQ(gm_train_create(bodies, 2, meshes, 1, shafts, 1, 1e-8, 1e-3, 1e-9, &t, text, sizeof text), GM_OK) << text;
  std::unique_ptr<gm_train, void (*)(gm_train*)> tguard(t, gm_train_free);
  const double phi[2] = {0.0, 0.0}, omega[2] = {w, -w}, torque[2] = {0.0, 200.0};
  double far_phi = 0.0;
  ASSERT_EQ(gm_train_start(t, phi, omega, torque, &far_phi, &w), GM_OK) << gm_train_message(t);
  for (int i = 0; i < 10; ++i) {
    ASSERT_EQ(train.advance(tin, 1e-3, ts, tres, msg), GM_OK) << msg;
    ASSERT_EQ(gm_train_advance(t, torque, &far_phi, &w, 1e-3), GM_OK) << gm_train_message(t);
    tin.far_phi[0] += w * 1e-3;
    far_phi += w * 1e-3;
  }
  for (int b = 0; b < 2; ++b) {
    double p = 0, v = 0, hold = 0;
    ASSERT_EQ(gm_train_body_state(t, b, &p, &v, &hold), GM_OK);
    EXPECT_EQ(p, ts.phi[std::size_t(b)]);
    EXPECT_EQ(v, ts.omega[std::size_t(b)]);
  }
  EXPECT_EQ(gm_train_mesh_result(t, 0)->te, tres[0].te);
  EXPECT_EQ(gm_train_energy_account(t).residual, ts.residual);
  double tau = 0;
  ASSERT_EQ(gm_train_shaft_torque(t, 0, &tau), GM_OK);
  EXPECT_EQ(tau, ts.shaft_torque[0]);

  // bad input: named, the state unchanged, the train usable
  const double nan_torque[2] = {0.0, NAN};
  EXPECT_EQ(gm_train_advance(t, nan_torque, &far_phi, &w, 1e-3), GM_ERR_INPUT);
  EXPECT_NE(std::string(gm_train_message(t)).find("finite"), std::string::npos);
  EXPECT_EQ(gm_train_advance(t, torque, &far_phi, &w, -1.0), GM_ERR_ARGUMENT);
  EXPECT_NE(std::string(gm_train_message(t)).find("allowed: finite and > 0"), std::string::npos);
  EXPECT_EQ(gm_train_advance(t, torque, &far_phi, &w, 1e-3), GM_OK) << gm_train_message(t);
  EXPECT_EQ(gm_train_mesh_result(t, 1), nullptr);
  // the state: saved, run on, restored, run again: the same bits; a blob of another size is
  // refused and changes nothing
  std::vector<unsigned char> blob(gm_train_state_size(t));
  ASSERT_EQ(gm_train_state_save(t, blob.data(), blob.size()), GM_OK);
  const auto run_on = [&]() {
    double fp = far_phi;
    for (int i = 0; i < 5; ++i, fp += w * 1e-3) EXPECT_EQ(gm_train_advance(t, torque, &fp, &w, 1e-3), GM_OK);
    double p = 0, v = 0;
    gm_train_body_state(t, 1, &p, &v, nullptr);
    return std::vector<double>{p, v, gm_train_mesh_result(t, 0)->te, gm_train_energy_account(t).residual};
  };
  const std::vector<double> first = run_on();
  ASSERT_EQ(gm_train_state_load(t, blob.data(), blob.size()), GM_OK);
  EXPECT_EQ(run_on(), first);
  std::vector<unsigned char> later(gm_train_state_size(t));
  ASSERT_EQ(gm_train_state_save(t, later.data(), later.size()), GM_OK);
  EXPECT_EQ(gm_train_state_load(t, blob.data(), blob.size() - 1), GM_ERR_ARGUMENT);
  std::vector<unsigned char> now(gm_train_state_size(t));
  ASSERT_EQ(gm_train_state_save(t, now.data(), now.size()), GM_OK);
  EXPECT_EQ(now, later);

  const gm_train_mesh loop[1] = {{pair.m, {0, 0}, -1, 0.0}};
  gm_train* bad = nullptr;
  EXPECT_EQ(gm_train_create(bodies, 2, loop, 1, nullptr, 0, 1e-8, 1e-3, 1e-9, &bad, text, sizeof text), GM_ERR_PARAMETER);
  EXPECT_EQ(bad, nullptr);
  EXPECT_NE(std::string(text).find("mesh 1"), std::string::npos) << text;
}

// Through the C API, a set-A pair whose gear 1 sits on a bearing (2 kg, 1e8 N/m): the static
// state (gm_train_static, gear 1 held, 200 N m on gear 2) puts gear 1's centre where its
// bearing takes the whole mesh force (k |x| = the normal force, frictionless: a closed form), at
// right angles to the centres' line, up to the pressure angle: along the line of action; the
// dynamics from there keeps its state bit for bit through save and load, centres included.
TEST(Train, CApiBearingStaticAndState) {
  Instance pair(set_a());
  gm_train_body bodies[2] = {{0.02, 0}, {0.02, 0}};
  bodies[0].mass = 2.0;
  bodies[0].bearing_stiffness = 1e8;
  bodies[0].bearing_damping = 500.0;
  const gm_train_mesh meshes[1] = {{pair.m, {0, 1}, -1, 0.0}};
  const gm_train_shaft shafts[1] = {{0, -1, 2e4, 20.0}};
  gm_train* t = nullptr;
  char text[256];
  ASSERT_EQ(gm_train_create(bodies, 2, meshes, 1, shafts, 1, 1e-8, 1e-3, 1e-9, &t, text, sizeof text), GM_OK) << text;
  std::unique_ptr<gm_train, void (*)(gm_train*)> guard(t, gm_train_free);
  const double phi[2] = {0.0, 0.0}, torque[2] = {0.0, 200.0}, far_phi = 0.0;
  ASSERT_EQ(gm_train_static(t, 0, 0.0, phi, torque, &far_phi), GM_OK) << gm_train_message(t);
  double x = 0, y = 0;
  ASSERT_EQ(gm_train_body_centre(t, 0, &x, &y), GM_OK);
  const gm_result* r = gm_train_mesh_result(t, 0);
  ASSERT_NE(r, nullptr);
  EXPECT_GT(r->normal_force, 1000.0);
  EXPECT_NEAR(1e8 * std::hypot(x, y), r->normal_force, 1e-6 * r->normal_force);
  const double alpha = gm_model_geometry(pair.m)->alpha_wt;  // the line of action's angle to y
  EXPECT_NEAR(std::fabs(std::atan2(std::fabs(x), std::fabs(y))), alpha, 1e-6);
  double hold = 0;
  ASSERT_EQ(gm_train_body_state(t, 0, nullptr, nullptr, &hold), GM_OK);
  EXPECT_NEAR(std::fabs(hold), 200.0 * pair.rb(0) / pair.rb(1), 1e-6 * 200);  // the held pinion's torque

  // the dynamics from the static state, saved, run on, restored, run again
  const double w = 50.0;
  double fp = 0.0;
  double omega[2] = {w, -w * pair.rb(0) / pair.rb(1)}, angles[2];
  for (int b = 0; b < 2; ++b) gm_train_body_state(t, b, &angles[b], nullptr, nullptr);
  ASSERT_EQ(gm_train_start(t, angles, omega, torque, &fp, &w), GM_OK) << gm_train_message(t);
  for (int i = 0; i < 5; ++i, fp += w * 1e-3) ASSERT_EQ(gm_train_advance(t, torque, &fp, &w, 1e-3), GM_OK);
  std::vector<unsigned char> blob(gm_train_state_size(t));
  ASSERT_EQ(gm_train_state_save(t, blob.data(), blob.size()), GM_OK);
  const auto run_on = [&]() {
    double f = fp;
    for (int i = 0; i < 5; ++i, f += w * 1e-3) EXPECT_EQ(gm_train_advance(t, torque, &f, &w, 1e-3), GM_OK);
    double cx = 0, cy = 0;
    gm_train_body_centre(t, 0, &cx, &cy);
    return std::vector<double>{cx, cy, gm_train_mesh_result(t, 0)->te, gm_train_energy_account(t).residual};
  };
  const std::vector<double> first = run_on();
  EXPECT_NE(first[0], x);  // the centre moves on
  ASSERT_EQ(gm_train_state_load(t, blob.data(), blob.size()), GM_OK);
  EXPECT_EQ(run_on(), first);
  EXPECT_EQ(gm_train_static(t, 2, 0.0, phi, torque, &far_phi), GM_ERR_ARGUMENT);
  EXPECT_NE(std::string(gm_train_message(t)).find("held body 3; allowed: 1..2"), std::string::npos);
}

// The quasi-static train (Train::static_state) on the planetary stage with the sun held, the
// carrier loaded by 100 N m and the ring in the housing, 3 planets:
// * without pin errors each planet carries a third of the sun's force, and the torques are the
//   closed forms (the sun holds z_s / (z_s + z_r) of the load, the ring z_r / (z_s + z_r));
// * with planet 1's pin 20 um off tangentially its share moves away from a third, the shares
//   still add up to one;
// * the Newton answer is where the damped dynamics settles with the sun held (on a stiff
//   shaft) at the same angle: two independent ways to the same equilibrium.
TEST(Train, PlanetaryStaticStateSharesTheLoad) {
  for (double pin_error : {0.0, 20e-6}) {
    SCOPED_TRACE("pin error " + std::to_string(pin_error));
    Planetary s(3);
    // the pin error: planet 1's centre moved along the carrier's tangent, in both of its meshes'
    // element frames (sun-planet: x towards the planet, so the tangent is +y; planet-ring: x
    // towards the ring's centre, the tangent is -y)
    s.train.reset();
    std::vector<gm::TrainMesh> meshes;
    for (int k = 0; k < s.planets; ++k) {
      const double psi = 2 * kPi * k / s.planets;
      for (int which = 0; which < 2; ++which) {
        gm::TrainMesh me;
        me.model = which == 0 ? s.sun_planet->m : s.planet_ring->m;
        me.data = s.data[std::size_t(2 * k + which)];
        me.carrier = s.carrier;
        me.gear[0] = which == 0 ? s.sun : 1 + k;
        me.gear[1] = which == 0 ? 1 + k : s.ring;
        me.orientation = which == 0 ? psi : psi + kPi;
        if (k == 0) {
          if (which == 0) me.offset[1][1] = pin_error;
          else me.offset[0][1] = -pin_error;
        }
        meshes.push_back(me);
      }
    }
    std::vector<gm::TrainBody> bodies(std::size_t(s.planets + 1), gm::TrainBody{2e-3, false});
    bodies.push_back({0.0, true});
    bodies.push_back({5e-2, false});
    const double k_sun = 1e6, load = 100.0;
    s.train = std::make_unique<gm::Train>(bodies, meshes, std::vector<gm::TrainShaft>{{s.sun, -1, k_sun, 50.0}},
                                          gm::TrainParams{});
    ASSERT_EQ(s.train->problem(), "");
    const std::size_t nb = std::size_t(s.carrier + 1);
    // a start in contact: every mesh 1 um into its loaded flank (sun-planet flank A, planet-ring
    // flank B), so that Newton starts on the contact's stiffness
    const gm_pair_geometry& gsp = s.sun_planet->geo();
    const gm_pair_geometry& gpr = s.planet_ring->geo();
    const double rs = 0.5 * gsp.gear[0].d_b, rp = 0.5 * gsp.gear[1].d_b, rr = 0.5 * gpr.gear[1].d_b;
    const double closure = 1e-6;
    const double delta = -(gpr.j_bt + 2 * closure) / (rs + rr), beta = delta + (rs * delta + closure) / rp;
    std::vector<double> phi(nb, 0.0), omega(nb, 0.0);
    phi[std::size_t(s.carrier)] = delta;
    for (int k = 0; k < s.planets; ++k) phi[std::size_t(1 + k)] = 2 * (2 * kPi * k / s.planets) + beta;
    // the dynamics, settled with the sun on a stiff shaft to a held far end
    gm::TrainInputs in;
    in.torque.assign(nb, 0.0);
    in.torque[std::size_t(s.carrier)] = -load;
    in.far_phi = {0.0};
    in.far_omega = {0.0};
    gm::TrainState st;
    std::vector<gm_result> dyn;
    std::string msg;
    ASSERT_EQ(s.train->start(phi, omega, in, st, dyn, msg), GM_OK) << msg;
    for (int i = 0; i < 400; ++i) ASSERT_EQ(s.train->advance(in, 1e-3, st, dyn, msg), GM_OK) << msg;
    // the static state with the sun held where the dynamics left it
    std::vector<double> phi_static = phi;
    std::vector<gm_result> res;
    ASSERT_EQ(s.train->static_state(s.sun, st.phi[std::size_t(s.sun)], in, phi_static, res, msg), GM_OK) << msg;
    double total = 0;
    for (int k = 0; k < s.planets; ++k) total += res[std::size_t(2 * k)].normal_force;
    double sum = 0;
    for (int k = 0; k < s.planets; ++k) {
      const double share = res[std::size_t(2 * k)].normal_force / total;
      sum += share;
      if (pin_error == 0) EXPECT_NEAR(share, 1.0 / 3, 1e-9);
      // the dynamics settled to the same equilibrium
      EXPECT_NEAR(dyn[std::size_t(2 * k)].normal_force, res[std::size_t(2 * k)].normal_force,
                  1e-4 * res[std::size_t(2 * k)].normal_force);
      EXPECT_NEAR(st.phi[std::size_t(1 + k)], phi_static[std::size_t(1 + k)], 1e-7);
    }
    EXPECT_NEAR(sum, 1.0, 1e-12);
    if (pin_error != 0) EXPECT_GT(std::fabs(res[0].normal_force / total - 1.0 / 3), 0.01);
    // the sun's torque: what its mesh moments sum to (the held body's balance), a closed form
    double sun_torque = 0;
    for (int k = 0; k < s.planets; ++k) sun_torque -= res[std::size_t(2 * k)].moment[0][2];
    EXPECT_NEAR(sun_torque, load * s.zs / (s.zs + s.zr), 1e-6 * load);
  }
}

// The planetary stage of Planetary (the sun held, 500 N m on the carrier, the ring in the
// housing) with planet 1's pin `pin_error` off tangentially and the sun floating (mass 1 kg on no
// bearing: held only by its meshes) or fixed: the static state (Train::static_state) and, for
// the comparison below, each mesh's evaluation there and the state's unknowns.
struct StageStatics {
  std::vector<gm_result> res;
  std::vector<double> phi, centre;
};

std::unique_ptr<gm::Train> make_stage(Planetary& s, const gm::TrainBody& sun, double pin_error, double shaft_damping) {
  std::vector<gm::TrainMesh> meshes;
  for (int k = 0; k < s.planets; ++k) {
    const double psi = 2 * kPi * k / s.planets;
    for (int which = 0; which < 2; ++which) {
      gm::TrainMesh me;
      me.model = which == 0 ? s.sun_planet->m : s.planet_ring->m;
      me.data = s.data[std::size_t(2 * k + which)];
      me.carrier = s.carrier;
      me.gear[0] = which == 0 ? s.sun : 1 + k;
      me.gear[1] = which == 0 ? 1 + k : s.ring;
      me.orientation = which == 0 ? psi : psi + kPi;
      meshes.push_back(me);
    }
  }
  std::vector<gm::TrainBody> bodies(std::size_t(s.planets + 1), gm::TrainBody{2e-3, false});
  bodies[std::size_t(s.sun)] = sun;
  bodies[1].pin_error[0] = pin_error;
  bodies.push_back({0.0, true});
  bodies.push_back({5e-2, false});
  auto train = std::make_unique<gm::Train>(bodies, meshes, std::vector<gm::TrainShaft>{{s.sun, -1, 1e6, shaft_damping}},
                                           gm::TrainParams{});
  return train;
}

StageStatics stage_statics(Planetary& s, bool floating, double pin_error, const std::vector<double>* start = nullptr) {
  gm::TrainBody sun{2e-3, false};
  if (floating) sun.mass = 1.0;
  const std::unique_ptr<gm::Train> train = make_stage(s, sun, pin_error, 50.0);
  EXPECT_EQ(train->problem(), "");
  const std::size_t nb = std::size_t(s.carrier + 1);
  StageStatics out;
  if (start) out.phi = *start;
  else {  // every mesh 1 um into its loaded flank (PlanetaryStaticStateSharesTheLoad)
    const gm_pair_geometry& gsp = s.sun_planet->geo();
    const gm_pair_geometry& gpr = s.planet_ring->geo();
    const double rs = 0.5 * gsp.gear[0].d_b, rp = 0.5 * gsp.gear[1].d_b, rr = 0.5 * gpr.gear[1].d_b;
    const double delta = -(gpr.j_bt + 2e-6) / (rs + rr), beta = delta + (rs * delta + 1e-6) / rp;
    out.phi.assign(nb, 0.0);
    out.phi[std::size_t(s.carrier)] = delta;
    for (int k = 0; k < s.planets; ++k) out.phi[std::size_t(1 + k)] = 2 * (2 * kPi * k / s.planets) + beta;
  }
  out.centre.assign(2 * nb, 0.0);
  gm::TrainInputs in;
  in.torque.assign(nb, 0.0);
  in.torque[std::size_t(s.carrier)] = -500.0;
  in.far_phi = {0.0};
  in.far_omega = {0.0};
  std::string msg;
  EXPECT_EQ(train->static_state(s.sun, 0.0, in, out.phi, out.res, msg, &out.centre), GM_OK) << msg;
  return out;
}

std::vector<double> sun_mesh_shares(const Planetary& s, const std::vector<gm_result>& res) {
  double total = 0;
  for (int k = 0; k < s.planets; ++k) total += res[std::size_t(2 * k)].normal_force;
  std::vector<double> share;
  for (int k = 0; k < s.planets; ++k) share.push_back(res[std::size_t(2 * k)].normal_force / total);
  return share;
}

// An independent linear lumped-parameter static model of the stage (written here, not from the
// train's code): each mesh a spring k_m (the element's tangent stiffness at the pin-error-free
// equilibrium) along its deflection delta_m, whose gradient g_m over the coordinates (the sun's
// spin (held), each planet's spin, the carrier's spin, the sun's centre x, y in the housing)
// is read off the element's forces there: a mesh's force on a coordinate is -F_m g_m (moments
// about the gears' centres on the spins; the forces on the gears carried, taken by the carrier
// at their arm; the force on the sun's centre turned into the housing). A pin error e moves the
// planet's centre: delta_m changes by -f_planet . e / F_m. Solved K dq = -sum k_m g_m de_m, the
// change of each sun mesh's force is k_m (g_m . dq + de_m); returned: the shares with the pin
// error (the equilibrium's forces plus the changes).
std::vector<double> lumped_shares(const Planetary& s, const StageStatics& eq, bool floating, double pin_error) {
  const int np = s.planets;
  const int n = 2 + np + 2;  // sun spin, planets, carrier, sun x, sun y
  const int carrier = 1 + np, sx = 2 + np;
  const double arm = gm_model_parameters(s.sun_planet->m)->pair.center_distance;  // the planets' orbit
  const double pc = eq.phi[std::size_t(s.carrier)];
  std::vector<std::vector<double>> g;
  std::vector<double> k, de, force;
  for (int m = 0; m < 2 * np; ++m) {
    const int planet = m / 2;
    const bool sun_mesh = m % 2 == 0;
    const gm_result& r = eq.res[std::size_t(m)];
    const double F = r.normal_force;
    const double th = pc + 2 * kPi * planet / np + (sun_mesh ? 0.0 : kPi);  // the element frame's angle
    const double c = std::cos(th), sn = std::sin(th);
    std::vector<double> gm_(std::size_t(n), 0.0);
    const int pi = sun_mesh ? 1 : 0;  // the planet's gear in the element
    // spins: the element's moment on each gear, relative to the carrier
    gm_[std::size_t(1 + planet)] = -r.moment[pi][2] / F;
    // the planet's centre relative to the carrier's axis, in the element frame: the sun mesh's
    // frame has the sun (on the axis) at 0 and the planet at +a; the ring mesh's frame has the
    // planet at 0 and the ring's centre (the axis) at +a
    const double fp[2] = {r.force[pi][0], r.force[pi][1]};
    const double radial = sun_mesh ? 1.0 : -1.0;
    const double carrier_moment = radial * arm * fp[1];  // (radial a, 0) x f
    if (sun_mesh) {
      gm_[0] = -r.moment[0][2] / F;
      // the sun's centre force in the housing
      const double fs[2] = {c * r.force[0][0] - sn * r.force[0][1], sn * r.force[0][0] + c * r.force[0][1]};
      if (floating) {
        gm_[std::size_t(sx)] = -fs[0] / F;
        gm_[std::size_t(sx + 1)] = -fs[1] / F;
      }
    }
    // the carrier's spin moves the planet's centre on its orbit: its force's moment about the axis
    gm_[std::size_t(carrier)] = -carrier_moment / F;
    // the pin error: tangential (z x radial of the planet's position) in the element frame
    const double e[2] = {0.0, radial * pin_error};
    g.push_back(gm_);
    k.push_back(r.stiffness);
    de.push_back(planet == 0 ? -(fp[0] * e[0] + fp[1] * e[1]) / F : 0.0);
    force.push_back(F);
  }
  // unknowns: every coordinate but the held sun spin (and the sun's centre when fixed)
  std::vector<int> unknown;
  for (int i = 1; i < n; ++i)
    if (floating || i < sx) unknown.push_back(i);
  const int u = int(unknown.size());
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(u, u);
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(u);
  for (std::size_t m = 0; m < g.size(); ++m)
    for (int a = 0; a < u; ++a) {
      rhs[a] -= k[m] * g[m][std::size_t(unknown[std::size_t(a)])] * de[m];
      for (int b = 0; b < u; ++b)
        K(a, b) += k[m] * g[m][std::size_t(unknown[std::size_t(a)])] * g[m][std::size_t(unknown[std::size_t(b)])];
    }
  const Eigen::VectorXd dq = K.fullPivLu().solve(rhs);
  std::vector<double> sun_force;
  double total = 0;
  for (int p = 0; p < np; ++p) {
    const std::size_t m = std::size_t(2 * p);
    double d = de[m];
    for (int a = 0; a < u; ++a) d += g[m][std::size_t(unknown[std::size_t(a)])] * dq[a];
    sun_force.push_back(force[m] + k[m] * d);
    total += sun_force.back();
  }
  for (double& f : sun_force) f /= total;
  return sun_force;
}

// Load sharing under a planet's pin error (2 um tangential on planet 1), the sun floating or
// fixed, against the independent lumped model:
// * three planets and a floating sun share the load equally whatever the pin error (the
//   statically determinate stage: the sun's force balance alone fixes the three forces);
// * with the sun fixed, or with four planets, the shares move; the change of every share agrees
//   with the lumped model within 10 % of the largest change.
TEST(Train, FloatingSunAndPinErrorsAgainstALumpedModel) {
  const double pin_error = 2e-6;
  for (int planets : {3, 4})
    for (bool floating : {true, false}) {
      SCOPED_TRACE(std::to_string(planets) + " planets, sun " + (floating ? "floating" : "fixed"));
      Planetary s(planets);
      const StageStatics ref = stage_statics(s, floating, 0.0);
      const StageStatics off = stage_statics(s, floating, pin_error, &ref.phi);
      const std::vector<double> before = sun_mesh_shares(s, ref.res), after = sun_mesh_shares(s, off.res);
      const std::vector<double> lumped = lumped_shares(s, ref, floating, pin_error);
      double largest = 0;
      for (int k = 0; k < planets; ++k) largest = std::max(largest, std::fabs(after[std::size_t(k)] - before[std::size_t(k)]));
      for (int k = 0; k < planets; ++k) {
        const double change = after[std::size_t(k)] - before[std::size_t(k)];
        const double lumped_change = lumped[std::size_t(k)] - before[std::size_t(k)];
        EXPECT_NEAR(change, lumped_change, 0.1 * largest + 1e-4) << "planet " << k + 1;
        if (planets == 3 && floating) EXPECT_NEAR(after[std::size_t(k)], 1.0 / 3, 2e-4) << "planet " << k + 1;
      }
      if (!(planets == 3 && floating)) EXPECT_GT(largest, 0.02);
      if (floating) {  // the sun moved, and balances its mesh forces alone
        EXPECT_GT(std::hypot(off.centre[0], off.centre[1]), 1e-7);
      }
    }
}

// The sun on a bearing (0.5 kg, 1e8 N/m, 2000 N s/m), planet 1's pin 2 um off: the damped
// dynamics with the sun's far end held settles where the static state (Newton on the same
// equations, a different path) puts the sun's centre and the mesh forces; then the stage run
// up to speed keeps its energy account (the bearing's and the meshes' work through the centre's
// motion, booked in the element's frame, against the bodies' forces in the housing's).
// The static state found from a start in the backlash (the planets at twice their position
// angles, the carrier at 0: the ring meshes open by their backlash), where Newton alone has no
// stiffness to work with: the same equilibrium as from a start in contact.
TEST(Train, StaticStateCrossesTheBacklash) {
  for (bool floating : {false, true}) {
    Planetary s(3);
    const StageStatics near = stage_statics(s, floating, 0.0);
    std::vector<double> open(std::size_t(s.carrier + 1), 0.0);
    for (int k = 0; k < s.planets; ++k) open[std::size_t(1 + k)] = 2 * (2 * kPi * k / s.planets);
    const StageStatics far = stage_statics(s, floating, 0.0, &open);
    for (std::size_t b = 0; b < near.phi.size(); ++b) EXPECT_NEAR(far.phi[b], near.phi[b], 1e-9) << "body " << b + 1;
    for (std::size_t m = 0; m < near.res.size(); ++m)
      EXPECT_NEAR(far.res[m].normal_force, near.res[m].normal_force, 1e-6 * near.res[m].normal_force);
  }
}

TEST(Train, SunOnABearingSettlesToItsStaticStateAndKeepsItsEnergyAccount) {
  Planetary s(3);
  gm::TrainBody sun{2e-3, false};
  sun.mass = 0.5;
  sun.bearing_stiffness = 1e8;
  sun.bearing_damping = 2e3;
  const std::unique_ptr<gm::Train> train = make_stage(s, sun, 2e-6, 50.0);
  ASSERT_EQ(train->problem(), "");
  const StageStatics nominal = stage_statics(s, true, 0.0);  // a start in contact: the floating sun's state
  const StageStatics start = stage_statics(s, true, 2e-6, &nominal.phi);
  const std::size_t nb = std::size_t(s.carrier + 1);
  gm::TrainInputs in;
  in.torque.assign(nb, 0.0);
  in.torque[std::size_t(s.carrier)] = -500.0;
  in.far_phi = {0.0};
  in.far_omega = {0.0};
  gm::TrainState st;
  std::vector<gm_result> dyn;
  std::string msg;
  ASSERT_EQ(train->start(start.phi, std::vector<double>(nb, 0.0), in, st, dyn, msg), GM_OK) << msg;
  for (int i = 0; i < 300; ++i) ASSERT_EQ(train->advance(in, 1e-3, st, dyn, msg), GM_OK) << msg;
  std::vector<double> phi = st.phi, centre(2 * nb, 0.0);
  std::vector<gm_result> res;
  ASSERT_EQ(train->static_state(s.sun, st.phi[std::size_t(s.sun)], in, phi, res, msg, &centre), GM_OK) << msg;
  EXPECT_GT(std::hypot(centre[0], centre[1]), 1e-8);  // the bearing carries the sun's unbalance
  EXPECT_NEAR(st.centre[0], centre[0], 1e-10);
  EXPECT_NEAR(st.centre[1], centre[1], 1e-10);
  for (std::size_t m = 0; m < res.size(); ++m)
    EXPECT_NEAR(dyn[m].normal_force, res[m].normal_force, 1e-5 * res[m].normal_force) << "mesh " << m + 1;

  // run up: the far end at 100 rad/s, 0.1 s
  in.far_omega = {100.0};
  in.far_phi = {st.phi[std::size_t(s.sun)]};
  for (int i = 0; i < 100; ++i) {
    ASSERT_EQ(train->advance(in, 1e-3, st, dyn, msg), GM_OK) << msg;
    in.far_phi[0] += 100.0 * 1e-3;
  }
  EXPECT_GT(st.omega[std::size_t(s.carrier)], 10.0);
  EXPECT_GT(st.work_in, 100.0);
  EXPECT_LT(std::fabs(st.residual), 1e-4 * st.work_in) << "residual " << st.residual << " J of " << st.work_in;
}

// A translating body that cannot translate, or a pin error where no carrier is, is named.
TEST(Train, TranslationsAndPinErrorsAreNamedWhereTheyDoNotBelong) {
  Planetary s(3);
  gm::TrainBody sun{2e-3, false};
  sun.bearing_stiffness = 1e8;  // without a mass
  const auto massless = make_stage(s, sun, 0.0, 50.0);
  EXPECT_NE(massless->problem().find("body 1: a bearing stiffness or damping without a mass"), std::string::npos)
      << massless->problem();
  sun.mass = -1;
  EXPECT_NE(make_stage(s, sun, 0.0, 50.0)->problem().find("body 1: mass"), std::string::npos);
  Instance pair(set_a());
  gm::TrainMesh me;
  me.model = pair.m;
  me.data = pair.d;
  me.gear[0] = 0;
  me.gear[1] = 1;
  gm::TrainBody pinned{0.02, false};
  pinned.pin_error[0] = 1e-6;
  gm::Train housing({pinned, {0.02, false}}, {me}, {}, {});
  EXPECT_NE(housing.problem().find("body 1: a pin error, but its mesh 1 is on the housing"), std::string::npos)
      << housing.problem();
}

TEST(Train, BadTopologyIsNamed) {
  Instance pair(set_a());
  gm::TrainMesh me;
  me.model = pair.m;
  me.data = pair.d;
  me.gear[0] = 0;
  me.gear[1] = 0;
  gm::Train same({{0.02, false}, {0.02, false}}, {me}, {}, {});
  EXPECT_NE(same.problem().find("mesh 1"), std::string::npos) << same.problem();
  me.gear[1] = 1;
  gm::Train massless({{0.02, false}, {0.0, false}}, {me}, {}, {});
  EXPECT_NE(massless.problem().find("body 2: inertia = 0"), std::string::npos) << massless.problem();
  gm::Train idle({{0.02, false}, {0.02, false}, {0.02, false}}, {me}, {}, {});
  EXPECT_NE(idle.problem().find("body 3 is in no mesh"), std::string::npos) << idle.problem();
  gm::Train ok({{0.02, false}, {0.02, false}}, {me}, {}, {});
  EXPECT_EQ(ok.problem(), "");
}

}  // namespace
