// An independent integration of the undamped case of bench_dynamics (docs/dynamics.md,
// "Undamped mesh"): the same free gears on gm_evaluate, integrated by the classical explicit
// Runge-Kutta method at a fixed step far below the mesh mode's period (0.2 us against ~330 us),
// with none of the large-step mode's code. Prints the TE range over every step of each tenth of
// the run, and the run's energy balance (kinetic + elastic against the torques' work), whose
// drift bounds the reference's own error.
//
//   build/tests/reference_undamped LEVEL RPM OFFSET_M [DURATION_S] [STEP_S]
//
// OFFSET_M: the start's TE above the static TE under the torques, m; negative: the teeth just
// touching (TE 0), as bench_dynamics starts.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "gearmesh/gearmesh.h"

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: reference_undamped LEVEL RPM OFFSET_M [DURATION_S] [STEP_S]\n");
    return 2;
  }
  const int level = std::atoi(argv[1]);
  const double rpm = std::atof(argv[2]), offset = std::atof(argv[3]);
  const double duration = argc > 4 ? std::atof(argv[4]) : 1.0, h = argc > 5 ? std::atof(argv[5]) : 2e-7;
  const double torque = 150, inertia = 0.02, kPi = 3.14159265358979323846;
  gm_model_params p;
  gm_default_params(&p);
  p.stiffness_level = static_cast<gm_stiffness_level>(level);
  p.slices = 10;
  char msg[512];
  gm_model* m = nullptr;
  gm_data* d = nullptr;
  if (gm_model_create(&p, &m, msg, sizeof msg) != GM_OK || gm_data_create(m, &d) != GM_OK) {
    std::fprintf(stderr, "%s\n", msg);
    return 1;
  }
  const double rb1 = 0.5 * gm_model_geometry(m)->gear[0].d_b, rb2 = 0.5 * gm_model_geometry(m)->gear[1].d_b;
  const double torques[2] = {torque, torque * rb2 / rb1};
  gm_kinematics k{};
  const double w1 = rpm * 2 * kPi / 60;
  k.omega[0] = w1;
  k.omega[1] = -w1 * rb1 / rb2;
  double te0 = 0;
  if (offset >= 0) {  // the static TE under the torques, by bisection on the normal force
    double lo = 0, hi = 1e-4;
    for (int i = 0; i < 80; ++i) {
      gm_kinematics q = k;
      q.phi[1] = 0.5 * (lo + hi) / rb2;
      gm_result r{};
      gm_evaluate(m, d, &q, &r);
      (r.normal_force > torque / rb1 ? hi : lo) = 0.5 * (lo + hi);
    }
    te0 = 0.5 * (lo + hi) + offset;
  }
  k.phi[1] = te0 / rb2;
  const auto rate = [&](const double y[4], double dy[4], gm_result* out) {
    gm_kinematics q = k;
    q.phi[0] = y[0];
    q.phi[1] = y[1];
    q.omega[0] = y[2];
    q.omega[1] = y[3];
    gm_result r{};
    if (gm_evaluate(m, d, &q, &r) != GM_OK) {
      std::fprintf(stderr, "%s\n", gm_data_message(d));
      std::exit(1);
    }
    dy[0] = y[2];
    dy[1] = y[3];
    dy[2] = (torques[0] + r.moment[0][2]) / inertia;
    dy[3] = (torques[1] + r.moment[1][2]) / inertia;
    if (out) *out = r;
  };
  double y[4] = {k.phi[0], k.phi[1], k.omega[0], k.omega[1]};
  const long n = std::lround(duration / h), report = std::max(1L, n / 10);
  double lo = INFINITY, hi = -INFINITY, energy0 = NAN, work = 0;
  std::printf("level %d, %g rpm, start TE %.3f um, RK4 at %g s\n", level, rpm, te0 * 1e6, h);
  for (long i = 1; i <= n; ++i) {
    double k1[4], k2[4], k3[4], k4[4], t[4];
    gm_result r{};
    rate(y, k1, &r);
    const double energy = 0.5 * inertia * (y[2] * y[2] + y[3] * y[3]) + r.elastic_energy;
    if (std::isnan(energy0)) energy0 = energy;
    lo = std::min(lo, r.te);
    hi = std::max(hi, r.te);
    const double phi0[2] = {y[0], y[1]};
    for (int j = 0; j < 4; ++j) t[j] = y[j] + 0.5 * h * k1[j];
    rate(t, k2, nullptr);
    for (int j = 0; j < 4; ++j) t[j] = y[j] + 0.5 * h * k2[j];
    rate(t, k3, nullptr);
    for (int j = 0; j < 4; ++j) t[j] = y[j] + h * k3[j];
    rate(t, k4, nullptr);
    for (int j = 0; j < 4; ++j) y[j] += h / 6 * (k1[j] + 2 * k2[j] + 2 * k3[j] + k4[j]);
    if (i % report == 0) {  // the energy at this step's start against the work up to it
      std::printf("t %.3f s  TE %7.2f .. %7.2f um  energy - initial - work %+.3g J\n", i * h, lo * 1e6, hi * 1e6,
                  energy - energy0 - work);
      lo = INFINITY;
      hi = -INFINITY;
    }
    work += torques[0] * (y[0] - phi0[0]) + torques[1] * (y[1] - phi0[1]);
  }
  gm_data_free(d);
  gm_model_free(m);
  return 0;
}
