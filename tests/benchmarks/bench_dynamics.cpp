// Benchmark of the large-step mode (gm_dynamics_advance): the cost of one communication step
// for set A at level 4 and level 5, 10 slices, gear 1 on a shaft whose far end turns at the given
// speed, gear 2 braked by 350 N m, started at the quasi-static equilibrium. Level 5 reads the
// compliance_tool database given on the command line (set A's gears are alike: one database for
// both; `gearmesh compliance scenarios/fe/paper_setA_3U4U_fe.toml` builds it and prints its
// path), else the synthetic databases of tests/core/fe_synthetic.hpp, which are about twice as
// stiff as set A's and vary 2:1 over a mesh period, so that at 3000 rpm the pair loses contact:
// a harder dynamic case than set A's, not set A's cost. Per case: median and interquartile range
// of the time per communication step over 5 rounds of 0.2 s of simulated time each (after 0.1 s
// of settling), the internal steps and rejections per communication step, the ratio to one
// gm_evaluate of the same model measured in the same run, and the normal force's range at the
// communication points. Prints; never asserts on time. First the undamped case's energy figures
// (undamped(), below).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "fe_synthetic.hpp"
#include "gearmesh/gearmesh.h"

namespace {

using Clock = std::chrono::steady_clock;
constexpr double kPi = 3.14159265358979323846;

struct Setup {
  gm_model* m = nullptr;
  gm_data* d = nullptr;
  gm_dynamics_params dp{};
  gm_dynamics_inputs in{};
  gm_kinematics pose{};
  gm_dynamics_state s{};
};

// Level 5's databases: fe_database (a compliance_tool file, both gears) if given, else the
// synthetic ones (tests/core/fe_synthetic.hpp), written once per process.
std::string fe_database;
std::string fe_path[2];
double tolerance = 0;  // dynamics.tolerance, m (0: the default)
int face_shapes = -1;  // level 5's solver.face_shapes (-1: the default)

// Set A at `level` (4, or 5 with its databases and 2 coupled teeth), 10 slices.
gm_model_params params(double mu, int level = 4) {
  gm_model_params p;
  gm_default_params(&p);
  p.stiffness_level = static_cast<gm_stiffness_level>(level);
  p.slices = 10;
  p.friction_coefficient = mu;
  p.friction_velocity = 1e-5;
  if (level == GM_STIFFNESS_FE) {
    p.coupled_teeth = 2;
    if (face_shapes >= 0) p.solver_face_shapes = face_shapes;
    for (int g = 0; g < 2; ++g) {
      std::string msg;
      if (!fe_database.empty()) {
        fe_path[g] = fe_database;
      } else if (fe_path[g].empty()) {
        fe_path[g] = gm_test::write_smooth_db(p, g, "bench_dynamics_gear" + std::to_string(g + 1) + ".gcdb", msg);
      }
      if (fe_path[g].empty()) std::printf("gear%d database: %s\n", g + 1, msg.c_str());
      p.compliance[g] = fe_path[g].c_str();
    }
  }
  return p;
}

bool make(Setup& u, double mu, double rpm, int level) {
  char msg[512];
  gm_model_params p = params(mu, level);
  if (gm_model_create(&p, &u.m, msg, sizeof msg) != GM_OK || gm_data_create(u.m, &u.d) != GM_OK) {
    std::printf("%s\n", msg);
    return false;
  }
  const double w = rpm * 2 * kPi / 60, k = 2e4, load = 350;
  const double rb1 = 0.5 * gm_model_geometry(u.m)->gear[0].d_b, rb2 = 0.5 * gm_model_geometry(u.m)->gear[1].d_b;
  // the quasi-static equilibrium at phi1 = 0
  gm_model_params q = p;
  q.quasi_static = 1;
  gm_model* qm = nullptr;
  gm_data* qd = nullptr;
  gm_model_create(&q, &qm, msg, sizeof msg);
  gm_data_create(qm, &qd);
  gm_kinematics kq{};
  kq.omega[0] = w;
  kq.omega[1] = -w * rb1 / rb2;
  kq.load_torque = load;
  gm_result r0{};
  gm_evaluate(qm, qd, &kq, &r0);
  gm_data_free(qd);
  gm_model_free(qm);
  gm_dynamics_default_params(&u.dp);
  if (tolerance > 0) u.dp.tolerance = tolerance;
  u.dp.shaft_stiffness[0] = k;
  u.dp.shaft_damping[0] = 100;
  u.pose.phi[1] = r0.te / rb2;
  u.pose.omega[0] = w;
  u.pose.omega[1] = -w * rb1 / rb2;
  u.in.shaft_omega[0] = w;
  u.in.shaft_phi[0] = -r0.moment[0][2] / k;
  u.in.torque[1] = load;
  gm_result res;
  return gm_dynamics_start(u.m, u.d, &u.dp, &u.pose, &u.in, &u.s, &res) == GM_OK;
}

double evaluate_ns(Setup& u) {
  gm_kinematics k = u.pose;
  gm_result r{};
  const int n = 20000;
  const auto t0 = Clock::now();
  for (int i = 0; i < n; ++i) {
    k.phi[0] = 1e-4 * i;
    k.phi[1] = u.pose.phi[1] - 1e-4 * i;
    gm_evaluate(u.m, u.d, &k, &r);
  }
  return std::chrono::duration<double, std::nano>(Clock::now() - t0).count() / n;
}

void run(double mu, double rpm, double H, int level = 4) {
  Setup u;
  if (!make(u, mu, rpm, level)) return;
  gm_result res{};
  double force_lo = INFINITY, force_hi = 0;
  const auto advance = [&](double span, int* steps, int* rejected) {
    const int count = static_cast<int>(std::lround(span / H));
    for (int i = 0; i < count; ++i) {
      if (gm_dynamics_advance(u.m, u.d, &u.dp, &u.pose, &u.in, H, &u.s, &res) != GM_OK) {
        std::printf("failed: %s\n", gm_data_message(u.d));
        return -1;
      }
      u.in.shaft_phi[0] += u.in.shaft_omega[0] * H;
      *steps += u.s.steps;
      *rejected += u.s.rejected;
      force_lo = std::min(force_lo, res.normal_force);
      force_hi = std::max(force_hi, res.normal_force);
    }
    return count;
  };
  int steps = 0, rejected = 0, comm = 0;
  advance(0.1, &steps, &rejected);
  steps = rejected = 0;
  force_lo = INFINITY;
  force_hi = 0;
  std::vector<double> us;
  double base = 0;
  for (int round = 0; round < 5; ++round) {
    base += evaluate_ns(u) / 5;
    const auto t0 = Clock::now();
    const int c = advance(0.2, &steps, &rejected);
    if (c < 0) return;
    comm += c;
    us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count() / c);
  }
  std::sort(us.begin(), us.end());
  const int teeth = gm_model_parameters(u.m)->gear[0].teeth;
  const double mesh_period = 2 * kPi / (rpm * 2 * kPi / 60 * teeth), internal = double(steps) / comm;
  std::printf("level %d  mu %.1f  %5.0f rpm  H %-6g  %8.1f us per step (IQR %.1f-%.1f)  %7.2f internal steps, %6.2f rejected"
              "  = %6.0f x gm_evaluate (%.2f us); %5.1f x gm_evaluate per internal step (%4.1f per step tried, rejected"
              " ones included), %6.1f internal steps per mesh period, %6.3f s wall per s, normal force %.0f..%.0f N\n",
              level, mu, rpm, H, us[2], us[1], us[3], internal, double(rejected) / comm, us[2] * 1e3 / base, base * 1e-3,
              us[2] * 1e3 / base / internal, us[2] * 1e3 / base / (internal + double(rejected) / comm),
              internal * mesh_period / H, us[2] * 1e-6 / H, force_lo, force_hi);
  gm_data_free(u.d);
  gm_model_free(u.m);
}

// The undamped case (docs/dynamics.md, "Undamped mesh"): set A at `level`, 10 slices, mu 0, no
// contact damping, free gears (no shafts) under balanced torques of +150 N m each, both turning
// at `rpm`, started with the teeth just touching; 1 s at H = 1 ms. Prints the TE range of the
// samples and the largest normal force in the first and the last 0.1 s, the energy residual
// (positive: lost) against the run's largest kinetic + elastic energy, the parametric work, and
// the internal steps per communication step.
void undamped(int level, double rpm) {
  char msg[512];
  gm_model_params p = params(0.0);
  p.stiffness_level = static_cast<gm_stiffness_level>(level);
  Setup u;
  if (gm_model_create(&p, &u.m, msg, sizeof msg) != GM_OK || gm_data_create(u.m, &u.d) != GM_OK) {
    std::printf("%s\n", msg);
    return;
  }
  const double rb1 = 0.5 * gm_model_geometry(u.m)->gear[0].d_b, rb2 = 0.5 * gm_model_geometry(u.m)->gear[1].d_b;
  const double w = rpm * 2 * kPi / 60, H = 1e-3;
  gm_dynamics_default_params(&u.dp);
  u.pose.omega[0] = w;
  u.pose.omega[1] = -w * rb1 / rb2;
  u.in.torque[0] = 150;
  u.in.torque[1] = 150 * rb2 / rb1;
  gm_result res{};
  if (gm_dynamics_start(u.m, u.d, &u.dp, &u.pose, &u.in, &u.s, &res) != GM_OK) return;
  double largest = u.s.initial_energy, lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
  double peak[2] = {0, 0};
  long steps = 0;
  const int count = 1000;
  for (int i = 1; i <= count; ++i) {
    if (gm_dynamics_advance(u.m, u.d, &u.dp, &u.pose, &u.in, H, &u.s, &res) != GM_OK) {
      std::printf("failed: %s\n", gm_data_message(u.d));
      return;
    }
    steps += u.s.steps;
    largest = std::max(largest, u.s.kinetic + u.s.elastic);
    const int part = i <= 100 ? 0 : i > count - 100 ? 1
                                                    : -1;
    if (part < 0) continue;
    lo[part] = std::min(lo[part], res.te);
    hi[part] = std::max(hi[part], res.te);
    peak[part] = std::max(peak[part], res.normal_force);
  }
  std::printf("level %d  %5.0f rpm  TE first 0.1 s %6.2f..%6.2f um, last %6.2f..%6.2f um  peak force %6.0f / %6.0f N"
              "  residual %+.3g J = %+.2g of the largest energy %.3g J  parametric %+.2g J  %.0f internal steps per step\n",
              level, rpm, lo[0] * 1e6, hi[0] * 1e6, lo[1] * 1e6, hi[1] * 1e6, peak[0], peak[1], u.s.residual,
              u.s.residual / largest, largest, u.s.parametric, double(steps) / count);
  gm_data_free(u.d);
  gm_model_free(u.m);
}

}  // namespace

// bench_dynamics tolerance: the level-4 rows at 1 ms, mu 0, 1000 and 3000 rpm, over
// dynamics.tolerance (internal steps go as tolerance^(-1/3): a second-order method).
int sweep(const std::string& what) {
  if (what == "tolerance") {
    for (double tol : {1e-9, 1e-8, 3e-8, 1e-7, 3e-7, 1e-6}) {
      tolerance = tol;
      std::printf("dynamics.tolerance %g m\n", tol);
      for (double rpm : {1000.0, 3000.0}) run(0.0, rpm, 1e-3);
    }
    return 0;
  }
  std::printf("usage: bench_dynamics [DATABASE | tolerance | MU RPM STEP [LEVEL [DATABASE]]]\n");
  return 2;
}

int main(int argc, char** argv) {
  if (argc > 3) {  // one row: MU RPM STEP [LEVEL [DATABASE [FACE_SHAPES]]]
    if (argc > 5) fe_database = argv[5];
    if (argc > 6) face_shapes = std::atoi(argv[6]);
    run(std::atof(argv[1]), std::atof(argv[2]), std::atof(argv[3]), argc > 4 ? std::atoi(argv[4]) : 4);
    return 0;
  }
  if (argc > 1 && std::string(argv[1]).find(".gcdb") == std::string::npos) return sweep(argv[1]);
  if (argc > 1) fe_database = argv[1];
  std::printf("undamped free gears, set A, 10 slices, +150 N m on each, teeth touching at the start, H 1 ms, 1 s\n");
  for (int level : {0, 4})
    for (double rpm : {10.0, 1000.0}) undamped(level, rpm);
  std::printf("large-step mode, set A at level 4 (and 5: %s, 2 coupled teeth), 10 slices, 350 N m: "
              "cost per communication step\n",
              fe_database.empty() ? "synthetic databases" : fe_database.c_str());
  for (double mu : {0.0, 0.4})
    for (double rpm : {10.0, 1000.0, 3000.0, 6000.0})
      for (double H : {1e-4, 1e-3, 1e-2}) run(mu, rpm, H);
  for (double mu : {0.0, 0.4})
    for (double rpm : {1000.0, 3000.0, 6000.0}) run(mu, rpm, 1e-3, GM_STIFFNESS_FE);
  return 0;
}
