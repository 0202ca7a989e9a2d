// A fixed workload for instruction counts (callgrind), not a timer: N gm_evaluate calls of the
// paper's set A at level 4, 10 slices, TE 5 um (plain) or 500 N m (quasi-static), over one pitch
// of gear 1 (or P pitches, N per pitch). Instructions per evaluation (docs/model.md, "Tooth coupling at level 4", Cost;
// docs/performance.md, "Where level 5's time goes"):
//   valgrind --tool=callgrind --toggle-collect=gm_evaluate build/tests/profile_evaluate 2 0 1000
// and divide callgrind's "Collected" by N (times P). Arguments: coupled teeth (0..3), quasi-static (0/1), N,
// then optionally, in any order: "helical" (the 15 deg variant of
// tests/benchmarks/bench_evaluate.cpp), "fe" (level 5 with bench_evaluate's synthetic databases,
// written to the temporary directory), "baseline" (bench_evaluate's baseline: the default
// parameters at level 0 and one slice; COUPLED is then ignored), "shapesK" (level 5 with
// solver.face_shapes = K; without it the parameter's default), "pitchesP" (P pitches: level 5's
// cached database sums are made in the first; bench_evaluate runs about 175), "db=PATH" (level 5
// on a compliance_tool database for both gears, e.g. set A's from `gearmesh compliance
// scenarios/fe/paper_setA_3U4U_fe.toml`) and a slice count (default 10).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "fe_synthetic.hpp"
#include "gearmesh/gearmesh.h"

int main(int argc, char** argv) {
  const int coupled = argc > 1 ? std::atoi(argv[1]) : 2;
  const int quasi = argc > 2 ? std::atoi(argv[2]) : 0;
  const int n = argc > 3 ? std::atoi(argv[3]) : 1000;
  bool helical = false, fe = false, baseline = false, bad = false;
  const char* database = nullptr;  // "db=PATH": level 5 on a compliance_tool database (both gears)
  int slices = 10, shapes = -1, pitches = 1;  // shapes: -1, the default
  for (int a = 4; a < argc; ++a) {
    if (std::strncmp(argv[a], "shapes", 6) == 0)
      shapes = std::atoi(argv[a] + 6);
    else if (std::strncmp(argv[a], "pitches", 7) == 0)
      bad = bad || (pitches = std::atoi(argv[a] + 7)) < 1;
    else if (std::strcmp(argv[a], "helical") == 0)
      helical = true;
    else if (std::strcmp(argv[a], "fe") == 0)
      fe = true;
    else if (std::strncmp(argv[a], "db=", 3) == 0)
      fe = true, database = argv[a] + 3;
    else if (std::strcmp(argv[a], "baseline") == 0)
      baseline = true;
    else if ((slices = std::atoi(argv[a])) < 1)
      bad = true;
  }
  if (coupled < 0 || coupled > 3 || (quasi != 0 && quasi != 1) || n < 1 || bad) {
    std::fprintf(stderr, "usage: profile_evaluate COUPLED(0..3) QUASI(0|1) N(>=1) [helical] [fe] "
                         "[baseline] [db=PATH] [shapesK] [pitchesP] [SLICES]\n");
    return 2;
  }
  gm_model_params p;
  gm_default_params(&p);
  p.stiffness_level = fe ? GM_STIFFNESS_FE : GM_STIFFNESS_ANALYTICAL;
  p.slices = slices;
  p.coupled_teeth = coupled;
  p.quasi_static = quasi;
  if (shapes >= 0) p.solver_face_shapes = shapes;
  if (baseline) {  // bench_evaluate's time_case: the level-0, one-slice pair
    gm_default_params(&p);
    p.stiffness_level = GM_STIFFNESS_USER_CONSTANT;
    p.slices = 1;
    p.quasi_static = quasi;
  }
  if (helical) {
    p.pair.helix_angle = 15 * 3.14159265358979323846 / 180;
    p.gear[0].profile_shift = p.gear[1].profile_shift = 0;
    p.pair.center_distance = 0.0026 / std::cos(p.pair.helix_angle) * 57 + 50e-6;
  }
  std::string path[2];
  for (int g = 0; g < 2 && fe; ++g) {
    if (database) {
      p.compliance[g] = database;
      continue;
    }
    std::string err;
    path[g] = gm_test::write_smooth_db(
        p, g, "profile_evaluate_" + std::to_string(int(helical)) + "_gear" + std::to_string(g + 1) + ".gcdb", err);
    if (path[g].empty()) {
      std::fprintf(stderr, "profile_evaluate: %s\n", err.c_str());
      return 1;
    }
    p.compliance[g] = path[g].c_str();
  }
  char msg[512];
  gm_model* m = nullptr;
  gm_data* d = nullptr;
  if (gm_model_create(&p, &m, msg, sizeof msg) != GM_OK || gm_data_create(m, &d) != GM_OK) {
    std::fprintf(stderr, "profile_evaluate: %s\n", msg);
    return 1;
  }
  const double rb1 = 0.5 * gm_model_geometry(m)->gear[0].d_b;
  const double rb2 = 0.5 * gm_model_geometry(m)->gear[1].d_b;
  const double pitch = 2 * 3.14159265358979323846 / p.gear[0].teeth;
  gm_kinematics k{};
  gm_result r{};
  k.load_torque = 500;  // N m, quasi-static only
  double sink = 0;
  for (int i = 0; i < n * pitches; ++i) {
    k.phi[0] = pitch * i / n;
    k.phi[1] = (5e-6 - rb1 * k.phi[0]) / rb2;
    if (gm_evaluate(m, d, &k, &r) != GM_OK) {
      std::fprintf(stderr, "profile_evaluate: %s\n", gm_data_message(d));
      return 1;
    }
    sink += r.te + r.normal_force;
  }
  std::printf("%d evaluations, checksum %.9g\n", n * pitches, sink);
  gm_data_free(d);
  gm_model_free(m);
  return 0;
}
