// Shared by the core tests: a model and its data through the C API, the gear pairs the tests
// use, the detection layout of a pair, and compliance databases written to the test folder.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <utility>

#include "gearmesh/internal/compliance_db.hpp"
#include "detection.hpp"
#include "fe_synthetic.hpp"
#include "gearmesh/gearmesh.h"
#include "gearmesh/internal/geometry.hpp"
#include "microgeometry.hpp"
#include "params.hpp"

namespace gm_test {

constexpr double kPi = 3.14159265358979323846;

// A model and its data. Creation errors throw: gtest reports an exception from a test body as
// a failure, and a NULL model never reaches the C API.
struct Instance {
  gm_model* m = nullptr;
  gm_data* d = nullptr;
  explicit Instance(const gm_model_params& p) {
    char msg[512];
    if (gm_model_create(&p, &m, msg, sizeof msg) != GM_OK) throw std::runtime_error(msg);
    if (gm_data_create(m, &d) != GM_OK) throw std::runtime_error("gm_data_create failed");
  }
  ~Instance() {
    gm_data_free(d);
    gm_model_free(m);
  }
  Instance(const Instance&) = delete;
  Instance& operator=(const Instance&) = delete;
  const gm_pair_geometry& geo() const { return *gm_model_geometry(m); }
  double rb(int i) const { return 0.5 * geo().gear[i].d_b; }
  int sign() const { return gm_model_parameters(m)->pair.internal ? -1 : 1; }
  // Evaluate; an error throws with the core's message.
  gm_result eval(gm_kinematics k) {
    gm_result r{};
    if (gm_evaluate(m, d, &k, &r) != GM_OK) throw std::runtime_error(gm_data_message(d));
    return r;
  }
  // Prescribed spin angles: TE te with gear 1 at phi1 (docs/physics.md §0).
  gm_result at(double te, double phi1 = 0.0) {
    gm_kinematics k{};
    k.phi[0] = phi1;
    k.phi[1] = (te - rb(0) * phi1) / (sign() * rb(1));
    return eval(k);
  }
  // Quasi-static mode: gear 1 at phi1 turning at omega1, gear 2 loaded by torque.
  gm_result loaded(double phi1, double torque, double omega1 = 0) {
    gm_kinematics k{};
    k.phi[0] = phi1;
    k.omega[0] = omega1;
    k.omega[1] = -sign() * omega1 * rb(0) / rb(1);
    k.load_torque = torque;
    return eval(k);
  }
};

// Quasi-static mode under 300 N m agrees with the plain solve at its solved TE: the same flanks
// in contact, forces, moments and stiffness, at four positions over a pitch, with the flank
// the load closes alone in contact (open) and with gear 2 moved 100 um towards gear 1 so that
// both flanks touch (wedged). p: a quasi-static model.
inline void expect_quasi_static_equals_plain_at_its_te(const gm_model_params& p) {
  gm_model_params pp = p;
  pp.quasi_static = 0;
  Instance quasi(p), plain(pp);
  for (const double shift : {0.0, 100e-6}) {
    for (int s = 0; s < 4; ++s) {
      gm_kinematics k{};
      k.phi[0] = quasi.geo().p_bt / quasi.rb(0) * (s + 0.5) / 4;
      k.u[1][0] = -shift;
      k.load_torque = 300;
      const gm_result rq = quasi.eval(k);
      k.load_torque = 0;
      k.phi[1] = (rq.te - quasi.rb(0) * k.phi[0]) / quasi.rb(1);
      const gm_result rp = plain.eval(k);
      EXPECT_EQ(rq.flank, shift == 0 ? 1 : 3) << s;
      EXPECT_EQ(rp.flank, rq.flank) << s;
      EXPECT_LT(rq.solver_residual, p.solver_tolerance) << s;
      const double f = std::fabs(rq.normal_force);
      EXPECT_NEAR(rp.normal_force, rq.normal_force, 1e-7 * f) << s;
      for (int a = 0; a < 3; ++a) {
        EXPECT_NEAR(rp.force[1][a], rq.force[1][a], 1e-7 * f) << s << " " << a;
        EXPECT_NEAR(rp.moment[1][a], rq.moment[1][a], 1e-7 * f * quasi.rb(1)) << s << " " << a;
      }
      EXPECT_NEAR(rp.stiffness, rq.stiffness, 1e-6 * rq.stiffness) << s;
    }
  }
}

// The paper's gear set A (the core's defaults) at level 0 on one slice.
inline gm_model_params paper() {
  gm_model_params p;
  gm_default_params(&p);
  // the tests' baseline: level 0 (a constant stiffness per unit face width) on one slice, whose
  // answers have closed forms (the defaults are level 4 with 10 slices)
  p.stiffness_level = GM_STIFFNESS_USER_CONSTANT;
  p.slices = 1;
  return p;
}

// An internal pair: pinion 21 in ring 62, m 2 mm, backlash from the thickness allowances.
inline gm_model_params ring() {
  gm_model_params p = paper();
  p.pair.internal = 1;
  p.pair.normal_module = 0.002;
  p.gear[0].teeth = 21;
  p.gear[1].teeth = 62;
  p.gear[0].profile_shift = p.gear[1].profile_shift = 0;
  p.gear[0].thickness_allowance = p.gear[1].thickness_allowance = -30e-6;
  p.pair.center_distance = 0.041;
  return p;
}

// A spur pair on ISO 53 profile A, steel (E 206 GPa), centred faces.
inline gm_model_params spur_pair(int z1, int z2, double m_n, double a, double x1, double x2,
                                 double b) {
  gm_model_params p = paper();
  p.pair.center_distance = a;
  p.pair.normal_module = m_n;
  const int z[2] = {z1, z2};
  const double x[2] = {x1, x2};
  for (int i = 0; i < 2; ++i) {
    p.gear[i].teeth = z[i];
    p.gear[i].profile_shift = x[i];
    p.gear[i].face_width = b;
    p.gear[i].youngs_modulus = 206e9;
  }
  return p;
}

// Validated parameters, their geometry and the detection layout (with micro-geometry).
struct Pair {
  gm_model_params p;
  gm_pair_geometry g;
  gm::MeshLayout L;
};

inline Pair make_pair(const gm_model_params& p) {
  Pair out{p, {}, {}};
  std::string msg;
  EXPECT_EQ(gm::validate_params(p, msg), GM_OK) << msg;
  EXPECT_EQ(gm::compute_pair_geometry(p, out.g, msg), GM_OK) << msg;
  gm::GearMicrogeometry micro[2];
  for (int i = 0; i < 2; ++i) {
    const gm_gear_geometry& gi = out.g.gear[i];
    const gm::ActiveFlank active{0.5 * std::sqrt(gi.d_sap * gi.d_sap - gi.d_b * gi.d_b), gi.rho_a,
                                 p.gear[i].face_width};
    micro[i] = gm::make_microgeometry(p.gear[i], active, {});
  }
  out.L = gm::make_mesh_layout(p, out.g, std::move(micro[0]), std::move(micro[1]));
  return out;
}

// phi_2 that holds the transmission error at te for a given phi_1 (docs/physics.md §0).
inline double phi2_for(const gm::MeshLayout& L, double te, double phi1) {
  return (te - L.base_radius[0] * phi1) / (L.sign * L.base_radius[1]);
}

// Write a compliance database into the test's temporary folder (name prefixed with the process id,
// removed at the process's end: fe_synthetic.hpp); its path.
inline std::string write_db(const std::string& name, const gm::ComplianceDb& db) {
  const std::string path = ::testing::TempDir() + std::to_string(::getpid()) + "_" + name;
  std::string msg;
  EXPECT_EQ(gm::write_compliance_db(path.c_str(), db, msg), GM_OK) << msg;
  written_files().paths.push_back(path);
  return path;
}

// A text file in the test's temporary directory (name prefixed with "gearmesh_"); its path.
inline std::string write_temp(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + "gearmesh_" + name;
  std::FILE* f = std::fopen(path.c_str(), "wb");
  EXPECT_NE(f, nullptr) << path;
  if (f) {
    std::fwrite(text.data(), 1, text.size(), f);
    std::fclose(f);
  }
  return path;
}

}  // namespace gm_test
