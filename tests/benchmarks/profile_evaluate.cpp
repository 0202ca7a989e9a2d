// A fixed workload for instruction counts (callgrind), not a timer: N gm_evaluate calls of the
// paper's set A at level 4, 10 slices, TE 5 um (plain) or 500 N m (quasi-static), over one pitch
// of gear 1. Instructions per evaluation (docs/model.md, "Tooth coupling at level 4", Cost):
//   valgrind --tool=callgrind --toggle-collect=gm_evaluate build/tests/profile_evaluate 2 0 1000
// and divide callgrind's "Collected" by N. Arguments: coupled teeth (0..3), quasi-static (0/1), N,
// and optionally a variant: "helical" (the 15 deg pair of tests/benchmarks/bench_evaluate.cpp) or
// "baseline" (that benchmark's baseline: the default parameters; COUPLED is then ignored).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "gearmesh/gearmesh.h"

int main(int argc, char** argv) {
  const int coupled = argc > 1 ? std::atoi(argv[1]) : 2;
  const int quasi = argc > 2 ? std::atoi(argv[2]) : 0;
  const int n = argc > 3 ? std::atoi(argv[3]) : 1000;
  const bool helical = argc > 4 && std::strcmp(argv[4], "helical") == 0;
  const bool baseline = argc > 4 && std::strcmp(argv[4], "baseline") == 0;
  if (coupled < 0 || coupled > 3 || (quasi != 0 && quasi != 1) || n < 1 ||
      (argc > 4 && !helical && !baseline)) {
    std::fprintf(stderr,
                 "usage: profile_evaluate COUPLED(0..3) QUASI(0|1) N(>=1) [helical|baseline]\n");
    return 2;
  }
  gm_model_params p;
  gm_default_params(&p);
  p.stiffness_level = GM_STIFFNESS_ANALYTICAL;
  p.slices = 10;
  p.coupled_teeth = coupled;
  p.quasi_static = quasi;
  if (baseline) {
    gm_default_params(&p);
    p.quasi_static = quasi;
  }
  if (helical) {
    p.pair.helix_angle = 15 * 3.14159265358979323846 / 180;
    p.gear[0].profile_shift = p.gear[1].profile_shift = 0;
    p.pair.center_distance = 0.0026 / std::cos(p.pair.helix_angle) * 57 + 50e-6;
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
  for (int i = 0; i < n; ++i) {
    k.phi[0] = pitch * i / n;
    k.phi[1] = (5e-6 - rb1 * k.phi[0]) / rb2;
    if (gm_evaluate(m, d, &k, &r) != GM_OK) {
      std::fprintf(stderr, "profile_evaluate: %s\n", gm_data_message(d));
      return 1;
    }
    sink += r.te + r.normal_force;
  }
  std::printf("%d evaluations, checksum %.9g\n", n, sink);
  gm_data_free(d);
  gm_model_free(m);
  return 0;
}
