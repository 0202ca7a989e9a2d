// Benchmark of one gm_evaluate (detection + level-0 forces + resultants) for the paper's 57/57
// pair, per scene feature, to show that a scene pays only for what it uses: median and
// interquartile range of the time per evaluation over samples of 1000 evaluations at
// advancing spin angles, with the ratio to the baseline (spur, aligned, one slice) measured in
// the same run (five interleaved rounds). Prints; never asserts on time.
//
// Level 5 (FE, issue 6: target <= 10 us for 10 slices and +-2 coupled teeth): both gears with a
// synthetic database shaped like a compliance_tool output (tests/core/fe_synthetic.hpp: the
// gear's flank grid of 17 roll x 13 face nodes, n_c = 2, smooth symmetric blocks), written to
// the temporary directory; its rows also print the ratio to level 4 (analytical + Hertz, the
// same slices) measured in the same run.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <vector>

#include "fe_synthetic.hpp"
#include "gearmesh/gearmesh.h"

namespace {

using Clock = std::chrono::steady_clock;
constexpr double kPi = 3.14159265358979323846;

struct Case {
  const char* name;
  std::function<void(gm_model_params&)> edit;
  double tilt;  // rad, on gear 2 about x and y
};

struct Stats {
  double median, q1, q3;
};

Stats time_case(const Case& c) {
  gm_model_params p;
  gm_default_params(&p);
  p.stiffness_level = GM_STIFFNESS_USER_CONSTANT;  // the cases edit the level-0, one-slice pair
  p.slices = 1;
  c.edit(p);
  char msg[512];
  gm_model* m = nullptr;
  gm_data* d = nullptr;
  if (gm_model_create(&p, &m, msg, sizeof msg) != GM_OK || gm_data_create(m, &d) != GM_OK) {
    std::printf("%s: %s\n", c.name, msg);
    return {NAN, NAN, NAN};
  }
  const double rb1 = 0.5 * gm_model_geometry(m)->gear[0].d_b;
  const double rb2 = 0.5 * gm_model_geometry(m)->gear[1].d_b;
  gm_kinematics k{};
  k.r[1][0] = k.r[1][1] = c.tilt;
  k.load_torque = 500;  // N m, quasi-static cases only
  gm_result r{};
  const int per_sample = 1000, samples = 15;
  std::vector<double> ns;
  double phi = 0, sink = 0;
  for (int s = 0; s < samples + 2; ++s) {  // two warm-up samples
    const auto t0 = Clock::now();
    for (int i = 0; i < per_sample; ++i) {
      phi += 2 * kPi / 57 / 97;  // about 97 poses per pitch
      k.phi[0] = phi;
      k.phi[1] = (5e-6 - rb1 * phi) / rb2;
      gm_evaluate(m, d, &k, &r);
      sink += r.normal_force;
    }
    const double t = std::chrono::duration<double, std::nano>(Clock::now() - t0).count();
    if (s >= 2) ns.push_back(t / per_sample);
  }
  gm_data_free(d);
  gm_model_free(m);
  if (sink == 42) std::printf(" ");
  std::sort(ns.begin(), ns.end());
  return {ns[ns.size() / 2], ns[ns.size() / 4], ns[3 * ns.size() / 4]};
}

void helical(gm_model_params& p) {
  p.pair.helix_angle = 15 * kPi / 180;
  p.gear[0].profile_shift = p.gear[1].profile_shift = 0;
  p.pair.center_distance = 0.0026 / std::cos(p.pair.helix_angle) * 57 + 50e-6;
}

void crowned(gm_model_params& p) {
  for (auto& g : p.gear)
    for (auto& f : g.flank) {
      f.profile_crowning = 5e-6;
      f.lead_crowning = 8e-6;
      f.tip_relief = 10e-6;
      f.tip_relief_length = 2e-3;
    }
}

// Level 5 with each gear's synthetic database (written once per process and gear set: spur 0,
// helical 1).
std::string fe_path[2][2];

void fe_level(gm_model_params& p) {
  p.slices = 10;
  p.coupled_teeth = 2;
  p.stiffness_level = GM_STIFFNESS_FE;
  const int set = p.pair.helix_angle != 0;
  for (int g = 0; g < 2; ++g) {
    std::string& path = fe_path[set][g];
    if (path.empty()) {
      std::string msg;
      path = gm_test::write_smooth_db(
          p, g, "bench_evaluate_" + std::to_string(set) + "_gear" + std::to_string(g + 1) + ".gcdb", msg);
      if (path.empty()) std::printf("gear%d database: %s\n", g + 1, msg.c_str());
    }
    p.compliance[g] = path.c_str();
  }
}

// Issue 16's sweep: one quasi-static revolution of the 57/57 pair at level 5 (the synthetic
// databases) at 7 load torques, 40 poses per pitch, each torque's revolution started cold from a
// new gm_data as a sweep of the tooling does: seconds for the whole sweep (57 x 40 x 7 = 15,960
// evaluations), median and range over `repeats`.
void time_revolution(int repeats) {
  gm_model_params p;
  gm_default_params(&p);
  fe_level(p);
  p.quasi_static = 1;
  char msg[512];
  gm_model* m = nullptr;
  if (gm_model_create(&p, &m, msg, sizeof msg) != GM_OK) {
    std::printf("revolution: %s\n", msg);
    return;
  }
  const double torques[7] = {50, 100, 150, 200, 250, 300, 350};
  std::vector<double> seconds;
  double sink = 0;
  for (int rep = 0; rep < repeats; ++rep) {
    const auto t0 = Clock::now();
    for (double torque : torques) {
      gm_data* d = nullptr;
      gm_data_create(m, &d);
      gm_kinematics k{};
      k.load_torque = torque;
      gm_result r{};
      for (int i = 0; i < 57 * 40; ++i) {
        k.phi[0] = 2 * kPi / 57 / 40 * i;
        gm_evaluate(m, d, &k, &r);
        sink += r.te;
      }
      gm_data_free(d);
    }
    seconds.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
  }
  gm_model_free(m);
  if (sink == 42) std::printf(" ");
  std::sort(seconds.begin(), seconds.end());
  std::printf("%-52s %10.3f s (%.3f..%.3f over %d runs; %.1f us per evaluation)\n",
              "level 5 quasi-static revolution x 7 torques", seconds[seconds.size() / 2], seconds.front(),
              seconds.back(), repeats, seconds[seconds.size() / 2] / (57 * 40 * 7) * 1e6);
}

}  // namespace

// Optional arguments: a case-name filter (cases whose name contains it, plus the baseline and
// level 4 for the ratios) and the number of rounds (default 5), e.g. for a profiler run:
//   bench_evaluate "level 5 (FE" 1
int main(int argc, char** argv) {
  const std::string filter = argc > 1 ? argv[1] : "";
  const int rounds = argc > 2 ? std::max(1, std::atoi(argv[2])) : 5;
  const Case cases[] = {
      {"spur, aligned, 1 slice (baseline)", [](gm_model_params&) {}, 0},
      {"spur, aligned, 10 slices", [](gm_model_params& p) { p.slices = 10; }, 0},
      {"spur, aligned, 10 slices, micro-geometry", [](gm_model_params& p) { p.slices = 10; crowned(p); }, 0},
      {"spur, tilted 0.2 mrad, 10 slices", [](gm_model_params& p) { p.slices = 10; }, 2e-4},
      {"helical 15 deg, aligned, 10 slices", [](gm_model_params& p) { p.slices = 10; helical(p); }, 0},
      {"helical 15 deg, tilted, 10 slices, micro-geometry",
       [](gm_model_params& p) { p.slices = 10; helical(p); crowned(p); }, 2e-4},
      {"spur, 10 slices, level 2 (ISO 6336-1 method B)",
       [](gm_model_params& p) { p.slices = 10; p.stiffness_level = 2; }, 0},
      {"spur, 10 slices, level 3 (contact-line-length)",
       [](gm_model_params& p) { p.slices = 10; p.stiffness_level = 3; }, 0},
      {"spur, 10 slices, level 4 (analytical + Hertz)",
       [](gm_model_params& p) { p.slices = 10; p.stiffness_level = 4; }, 0},
      {"spur, 10 slices, level 4 uncoupled (coupled_teeth 0)",
       [](gm_model_params& p) { p.slices = 10; p.stiffness_level = 4; p.coupled_teeth = 0; }, 0},
      {"helical 15 deg, 10 slices, level 4 (tooth coupling)",
       [](gm_model_params& p) { helical(p); p.slices = 10; p.stiffness_level = 4; }, 0},
      {"spur, 10 slices, level 4, quasi-static 500 N m",
       [](gm_model_params& p) { p.slices = 10; p.stiffness_level = 4; p.quasi_static = 1; }, 0},
      {"spur, 10 slices, level 4, friction + damping",
       [](gm_model_params& p) {
         p.slices = 10;
         p.stiffness_level = 4;
         p.friction_coefficient = 0.4;
         p.damping = 1e3;
       },
       0},
      {"spur, 10 slices, level 5 (FE, +-2 coupled teeth)", fe_level, 0},
      {"spur, 20 slices, level 5 (FE, +-2 coupled teeth)",
       [](gm_model_params& p) { fe_level(p); p.slices = 20; }, 0},
      {"helical 15 deg, 10 slices, level 5 (FE, +-2 teeth)",
       [](gm_model_params& p) { helical(p); fe_level(p); }, 0},
      {"spur, 10 slices, level 5, quasi-static 500 N m",
       [](gm_model_params& p) { fe_level(p); p.quasi_static = 1; }, 0},
      {"spur, 10 slices, level 5, every slice an unknown",
       [](gm_model_params& p) { fe_level(p); p.solver_face_shapes = 0; }, 0},
      {"spur, 20 slices, level 5, every slice an unknown",
       [](gm_model_params& p) { fe_level(p); p.slices = 20; p.solver_face_shapes = 0; }, 0},
      {"spur, 10 slices, level 5, quasi-static, every slice",
       [](gm_model_params& p) { fe_level(p); p.quasi_static = 1; p.solver_face_shapes = 0; }, 0},
  };
  std::printf("gm_evaluate, 57/57 pair of the paper at TE = 5 um (time per evaluation)\n");
  std::printf("%-52s %10s %18s %8s\n", "case", "median ns", "IQR ns", "ratio");
  // Rounds (five by default) over all cases, so that every case sees the machine in the same states; each
  // figure is the median over the rounds of the per-round median, and the IQR is the widest
  // per-round IQR.
  constexpr int kCases = sizeof cases / sizeof cases[0];
  const std::string kLevel4 = "spur, 10 slices, level 4 (analytical + Hertz)";
  bool chosen[kCases];
  for (int c = 0; c < kCases; ++c)
    chosen[c] = c == 0 || cases[c].name == kLevel4 ||
                std::string(cases[c].name).find(filter) != std::string::npos;
  std::vector<Stats> runs[kCases];
  for (int round = 0; round < rounds; ++round)
    for (int c = 0; c < kCases; ++c)
      if (chosen[c]) runs[c].push_back(time_case(cases[c]));
  double base = NAN, level4 = NAN;
  for (int c = 0; c < kCases; ++c) {
    if (!chosen[c]) continue;
    std::vector<double> med;
    double q1 = INFINITY, q3 = 0;
    for (const Stats& s : runs[c]) {
      med.push_back(s.median);
      q1 = std::min(q1, s.q1);
      q3 = std::max(q3, s.q3);
    }
    std::sort(med.begin(), med.end());
    const double m = med[med.size() / 2];
    if (std::isnan(base)) base = m;
    if (cases[c].name == kLevel4) level4 = m;
    std::printf("%-52s %10.0f %8.0f..%-8.0f %8.2f", cases[c].name, m, q1, q3, m / base);
    if (std::string(cases[c].name).find("level 5") != std::string::npos)
      std::printf("   %.2f x level 4", m / level4);
    std::printf("\n");
  }
  if (filter.empty() || std::string("level 5 quasi-static revolution").find(filter) != std::string::npos)
    time_revolution(std::max(3, rounds));
  return 0;
}
