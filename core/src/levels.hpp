// The stiffness levels (docs/design.md, "Add a level"): one file each, core/src/level<k>_<name>.hpp, and
// the one dispatch point from model.stiffness to them. Static: the level's struct is a type, so
// that its law inlines into the laws stage over double and dual numbers alike.
#pragma once

#include <string>
#include <type_traits>

#include "level0_user_constant.hpp"
#include "level1_user_table.hpp"
#include "level2_iso6336.hpp"
#include "level3_contact_line.hpp"
#include "level4_analytical.hpp"
#include "level5_fe.hpp"

namespace gm {

// f(Level{}) for the level `level` (validated: 0 ... GM_STIFFNESS_LEVELS - 1).
template <class F>
decltype(auto) with_level(int level, F&& f) {
  static_assert(GM_STIFFNESS_LEVELS == 6, "a level's struct is missing from with_level");
  switch (level) {
    case GM_STIFFNESS_USER_CONSTANT:
      return f(UserConstantLevel{});
    case GM_STIFFNESS_USER_VARIABLE:
      return f(UserTableLevel{});
    case GM_STIFFNESS_ISO6336:
      return f(Iso6336Level{});
    case GM_STIFFNESS_CONTACT_LINE:
      return f(ContactLineLevel{});
    case GM_STIFFNESS_ANALYTICAL:
      return f(AnalyticalLevel{});
    default:
      return f(FeLevel{});
  }
}

// What the level requires of p at gm_model_create (after the ranges): a file parameter read at
// other levels only (gearmesh/parameters.h) is refused, then the level's own check.
gm_status check_level(const gm_model_params& p, std::string& msg);

// The level's data of m (m.params set) and its traits in m.level.
gm_status build_level(const gm_pair_geometry& g, gm_model& m, std::string& msg);

// gm_model_check's part of the build: the level's build on a scratch model where the level reads no
// file of its own (a file row of the parameter table that this level alone reads: level 1's table,
// level 5's databases), so that what it checks there (level 2's q'_min, level 4's tooth sections and
// coupled teeth) is said as gm_model_create says it; GM_OK for the levels that read their files.
gm_status check_level_build(const gm_model_params& p, const gm_pair_geometry& g, std::string& msg);

}  // namespace gm
