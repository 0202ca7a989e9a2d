// docs/design.md's "Add an output" recipe followed end to end (tests/recipe/recipe_output.h: one
// row and its computation, compiled into a copy of the core): the output is in gm_result, its
// value is what it computes, its directional derivative comes with it in plain and quasi-static
// mode, and the FMU's variable table lists it.
#include <gtest/gtest.h>

#include "gearmesh/gearmesh.h"

extern "C" int recipe_fmu_row_ok(void);

namespace {

void check_mode(int quasi_static, int level) {
  gm_model_params p;
  gm_default_params(&p);
  p.stiffness_level = level;
  p.quasi_static = quasi_static;
  p.damping = 1e3;
  char msg[512];
  gm_model* m = nullptr;
  gm_data* d = nullptr;
  ASSERT_EQ(gm_model_create(&p, &m, msg, sizeof msg), GM_OK) << msg;
  ASSERT_EQ(gm_data_create(m, &d), GM_OK);
  const double rb = 0.5 * gm_model_geometry(m)->gear[0].d_b;
  gm_kinematics k{};
  k.phi[0] = 0.01;
  k.phi[1] = -0.01 + 5e-6 / rb;
  k.omega[0] = 100;
  k.omega[1] = -100;
  k.load_torque = 300;
  gm_result r{};
  ASSERT_EQ(gm_evaluate(m, d, &k, &r), GM_OK) << gm_data_message(d);
  EXPECT_GT(r.normal_force, 0);
  EXPECT_EQ(r.recipe_force, r.normal_force);  // the same sum in the same order
  gm_kinematics seed{};
  seed.phi[0] = 1e-4;
  seed.u[1][0] = 1e-6;
  seed.load_torque = 10;
  gm_result dr{};
  ASSERT_EQ(gm_directional_derivative(m, d, &k, &seed, &dr), GM_OK) << gm_data_message(d);
  EXPECT_NE(dr.normal_force, 0);
  EXPECT_EQ(dr.recipe_force, dr.normal_force);
  gm_data_free(d);
  gm_model_free(m);
}

TEST(Recipe, AnAddedOutputHasItsValueDerivativeAndFmuRow) {
  for (int level : {GM_STIFFNESS_USER_CONSTANT, GM_STIFFNESS_ANALYTICAL})
    for (int quasi : {0, 1}) check_mode(quasi, level);
  EXPECT_TRUE(recipe_fmu_row_ok());
}

}  // namespace
