// fuzz_gcdb.h over the synthetic database of the core tests (tests/core/fe_synthetic.hpp).
#include "fuzz_gcdb.h"

#include <cstdio>
#include <cstdlib>
#include <string>

#include "fe_synthetic.hpp"

void fuzz_set_a_level5(gm_model_params* p, int coupled_teeth) {
  gm_default_params(p);
  p->stiffness_level = GM_STIFFNESS_FE;
  p->slices = 3;
  p->coupled_teeth = coupled_teeth;
}

void fuzz_write_set_a_gcdb(const char* path, int n_roll, int n_face, int n_coupled) {
  gm_model_params p;
  fuzz_set_a_level5(&p, n_coupled);
  gm_test::SmoothDbShape shape;
  shape.n_roll = n_roll;
  shape.n_face = n_face;
  shape.n_coupled = n_coupled;
  std::string msg;
  const gm::ComplianceDb db = gm_test::smooth_db(p, 0, shape, msg);
  if (gm::write_compliance_db(path, db, msg) != GM_OK) {
    std::fprintf(stderr, "fuzz_write_set_a_gcdb: %s\n", msg.c_str());
    std::abort();
  }
}
