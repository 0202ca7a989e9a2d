// The parameter table (gearmesh/parameters.h): every row reaches its own field through the name
// setter, names are unique, a value outside a row's range is refused by gm_model_create (or the
// dynamics check) naming the row, and a file parameter at a level that does not read it is refused.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <set>
#include <string>

#include "gearmesh/parameters.h"

namespace {

TEST(Parameters, EveryRowSetsItsOwnField) {
  size_t count = 0;
  const gm_param_info* rows = gm_parameters(&count);
  ASSERT_GT(count, 50u);
  std::set<std::string> names;
  char msg[256];
  for (size_t i = 0; i < count; ++i) {
    const gm_param_info& r = rows[i];
    EXPECT_TRUE(names.insert(r.name).second) << r.name << " twice";
    EXPECT_EQ(gm_parameter_find(r.name), &r);
    if (r.where == GM_PARAM_IN_HOST || r.type == GM_PARAM_String) {
      gm_model_params p;
      gm_dynamics_params dp;
      EXPECT_EQ(gm_parameter_set(&p, &dp, r.name, 1, msg, sizeof msg), GM_ERR_ARGUMENT) << r.name;
      continue;
    }
    // a value no default has, written through the name and found at the row's field only
    gm_model_params p, p0;
    gm_dynamics_params dp, dp0;
    std::memset(&p, 0, sizeof p);
    std::memset(&dp, 0, sizeof dp);
    p0 = p;
    dp0 = dp;
    ASSERT_EQ(gm_parameter_set(&p, &dp, r.name, 3, msg, sizeof msg), GM_OK) << msg;
    const void* field = gm_parameter_field(&r, &p, &dp);
    ASSERT_NE(field, nullptr) << r.name;
    if (r.type == GM_PARAM_Real) EXPECT_EQ(*static_cast<const double*>(field), 3.0) << r.name;
    else EXPECT_EQ(*static_cast<const int*>(field), 3) << r.name;
    const size_t changed = (std::memcmp(&p, &p0, sizeof p) != 0) + (std::memcmp(&dp, &dp0, sizeof dp) != 0);
    EXPECT_EQ(changed, 1u) << r.name;
    if (r.type != GM_PARAM_Real)
      EXPECT_EQ(gm_parameter_set(&p, &dp, r.name, 2.5, msg, sizeof msg), GM_ERR_ARGUMENT) << r.name;
  }
  EXPECT_EQ(gm_parameter_set(nullptr, nullptr, "no.such", 1, msg, sizeof msg), GM_ERR_ARGUMENT);
  EXPECT_NE(std::string(msg).find("no.such"), std::string::npos) << msg;
}

// Just above each model row's upper bound (or below its lower one), on either flank of a flank
// modification: gm_model_create refuses it and names the row.
TEST(Parameters, ModelCreationRefusesEveryRowOutsideItsRange) {
  size_t count = 0;
  const gm_param_info* rows = gm_parameters(&count);
  int checked = 0;
  for (size_t i = 0; i < count; ++i) {
    const gm_param_info& r = rows[i];
    if (r.where != GM_PARAM_IN_MODEL || r.calculated || (!r.has_range && r.type != GM_PARAM_Boolean)) continue;
    for (int flank = 0; flank < ((r.flags & GM_PARAM_FLANK) ? 2 : 1); ++flank) {
      gm_model_params p;
      gm_default_params(&p);
      void* field = static_cast<char*>(gm_parameter_field(&r, &p, nullptr)) + flank * sizeof(gm_flank_modification);
      // just outside: past the upper bound, or below the lower one where there is no upper
      double bad = 2;  // a Boolean
      if (r.type != GM_PARAM_Boolean && std::isfinite(r.hi))
        bad = r.hi_open ? r.hi : r.type == GM_PARAM_Real ? r.hi + 1e-6 * std::fabs(r.hi) + 1e-300
                                                         : r.hi + 1;
      else if (r.type != GM_PARAM_Boolean)
        bad = r.lo_open ? r.lo : r.lo - 1;
      if (r.type == GM_PARAM_Real) *static_cast<double*>(field) = bad;
      else *static_cast<int*>(field) = int(bad);
      gm_model* m = nullptr;
      char msg[512] = "";
      EXPECT_EQ(gm_model_create(&p, &m, msg, sizeof msg), GM_ERR_PARAMETER) << r.name;
      EXPECT_EQ(std::string(msg).rfind(std::string(r.name) + " = ", 0), 0u) << r.name << ": " << msg;
      gm_model_free(m);
      ++checked;
    }
  }
  EXPECT_GT(checked, 40);
}

TEST(Parameters, AFileAtALevelThatDoesNotReadItIsRefused) {
  gm_model_params p;
  gm_default_params(&p);
  p.stiffness_level = GM_STIFFNESS_ANALYTICAL;
  p.compliance[1] = "gear2.gcdb";
  gm_model* m = nullptr;
  char msg[512];
  EXPECT_EQ(gm_model_create(&p, &m, msg, sizeof msg), GM_ERR_PARAMETER);
  EXPECT_EQ(std::string(msg).rfind("gear2.compliance = \"gear2.gcdb\": used at model.stiffness = 5 (FE) only", 0), 0u)
      << msg;
  p.compliance[1] = nullptr;
  p.stiffness_table = "k.txt";
  EXPECT_EQ(gm_model_create(&p, &m, msg, sizeof msg), GM_ERR_PARAMETER);
  EXPECT_NE(std::string(msg).find("model.stiffness = 1 (user tables) only"), std::string::npos) << msg;
}

}  // namespace
