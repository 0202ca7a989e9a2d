// Benchmark of gear trains (gearmesh/train.h): the two-stage reducer of scenarios/trains (19/57 then
// 23/61, set A's module, level 4, 10 slices) driven at 1000 and 3000 rpm against a 200 N m load,
// 1 ms communication steps. Per case: median and interquartile range of the time per communication
// step over 5 rounds of 0.1 s (after 0.1 s of settling), internal steps per communication step,
// and the ratio of the time per internal step to one evaluation of every mesh (their sum),
// measured in the same run: the train's "evaluation-equivalents per internal step", comparable
// with the pair's (bench_dynamics); and the train's overhead: the time per internal step over
// what the evaluations and directional derivatives it made (gm_train_work) cost alone, each
// timed in the same run. Prints; never asserts on time.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <vector>

#include "gearmesh/gearmesh.h"
#include "gearmesh/train.h"

namespace {

using Clock = std::chrono::steady_clock;
constexpr double kPi = 3.14159265358979323846;

gm_model* pair(int z1, int z2, double x, double a) {
  gm_model_params p;
  gm_default_params(&p);  // set A's module, rack, material; level 4, 10 slices
  p.gear[0].teeth = z1;
  p.gear[1].teeth = z2;
  p.gear[0].profile_shift = p.gear[1].profile_shift = x;
  p.pair.center_distance = a;
  p.damping = 4e5;
  gm_model* m = nullptr;
  char msg[512];
  if (gm_model_create(&p, &m, msg, sizeof msg) != GM_OK) std::printf("%s\n", msg);
  return m;
}

// One evaluation (derivative = false) or one directional derivative along gear 1's spin of each
// mesh at a loaded pose, ns (the sum over the meshes).
double evaluations_ns(gm_model* const* models, int n, bool derivative = false) {
  double total = 0;
  for (int i = 0; i < n; ++i) {
    gm_data* d = nullptr;
    gm_data_create(models[i], &d);
    const double rb2 = 0.5 * gm_model_geometry(models[i])->gear[1].d_b;
    gm_kinematics k{};
    gm_result r{};
    const int count = 20000;
    const auto t0 = Clock::now();
    for (int j = 0; j < count; ++j) {
      k.phi[0] = 1e-4 * j;
      k.phi[1] = 10e-6 / rb2 - 1e-4 * j * gm_model_geometry(models[i])->gear[0].d_b / (2 * rb2);
      if (derivative) {
        gm_kinematics seed{};
        seed.phi[0] = 1.0;
        gm_directional_derivative(models[i], d, &k, &seed, &r);
      } else {
        gm_evaluate(models[i], d, &k, &r);
      }
    }
    total += std::chrono::duration<double, std::nano>(Clock::now() - t0).count() / count;
    gm_data_free(d);
  }
  return total;
}

void run(double rpm) {
  gm_model* models[2] = {pair(19, 57, 0.35, 0.100564), pair(23, 61, 0.3, 0.110737)};
  const gm_train_body bodies[3] = {{0.002, 0}, {0.03, 0}, {0.05, 0}};
  const gm_train_mesh meshes[2] = {{models[0], {0, 1}, -1, 0.0}, {models[1], {1, 2}, -1, kPi / 2}};
  const gm_train_shaft shafts[1] = {{0, -1, 2e4, 5.0}};
  gm_train* t = nullptr;
  char msg[512];
  if (gm_train_create(bodies, 3, meshes, 2, shafts, 1, 1e-8, 1e-3, 1e-9, &t, msg, sizeof msg) != GM_OK) {
    std::printf("%s\n", msg);
    return;
  }
  const double w = rpm * 2 * kPi / 60, ratio = (57.0 / 19) * (61.0 / 23), load = 200, H = 1e-3;
  const double phi[3] = {0, 0, 0}, omega[3] = {w, -w * 19 / 57, w / ratio}, torque[3] = {0, 0, -load};
  double far_phi = load / ratio / 2e4;
  if (gm_train_start(t, phi, omega, torque, &far_phi, &w) != GM_OK) {
    std::printf("start: %s\n", gm_train_message(t));
    return;
  }
  long steps = 0, evaluations = 0, derivatives = 0;
  int comm = 0;
  const auto advance = [&](int count) {
    for (int i = 0; i < count; ++i) {
      if (gm_train_advance(t, torque, &far_phi, &w, H) != GM_OK) {
        std::printf("failed: %s\n", gm_train_message(t));
        return false;
      }
      far_phi += w * H;
      int a = 0, r = 0;
      gm_train_steps(t, &a, &r);
      steps += a;
      long e = 0, dd = 0;
      gm_train_work(t, &e, &dd);
      evaluations += e;
      derivatives += dd;
    }
    return true;
  };
  if (!advance(100)) return;
  steps = evaluations = derivatives = 0;
  std::vector<double> us;
  double base = 0, derivative = 0;
  for (int round = 0; round < 5; ++round) {
    base += evaluations_ns(models, 2) / 5;
    derivative += evaluations_ns(models, 2, true) / 5 / 2;  // one mesh's, on average
    const auto t0 = Clock::now();
    if (!advance(100)) return;
    comm += 100;
    us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count() / 100);
  }
  std::sort(us.begin(), us.end());
  const double internal = double(steps) / comm;
  const double e_per = double(evaluations) / steps, d_per = double(derivatives) / steps;
  const double alone_ns = e_per * base + d_per * derivative;  // the element's share of an internal step
  std::printf("two-stage reducer, level 4, %5.0f rpm in  H %g  %8.1f us per step (IQR %.1f-%.1f)  %6.2f internal steps"
              "  %5.2f x (one evaluation of each mesh, %.2f us) per internal step  %6.3f s wall per s\n"
              "    per internal step: %.2f train evaluations, %.2f mesh derivatives (%.2f us each); "
              "time / (their cost alone) = %.2f\n",
              rpm, H, us[2], us[1], us[3], internal, us[2] * 1e3 / internal / base, base * 1e-3, us[2] * 1e-6 / H,
              e_per, d_per, derivative * 1e-3, us[2] * 1e3 / internal / alone_ns);
  gm_train_free(t);
  for (gm_model* m : models) gm_model_free(m);
}

}  // namespace

int main() {
  for (double rpm : {1000.0, 3000.0}) run(rpm);
  return 0;
}
