// The levels' checks and builds at gm_model_create (levels.hpp).
#include "levels.hpp"

#include <memory>
#include <string>

#include "gearmesh/parameters.h"
#include "params.hpp"

namespace gm {

static_assert(UserConstantLevel::traits.id == 0 && UserTableLevel::traits.id == 1 && Iso6336Level::traits.id == 2 &&
                  ContactLineLevel::traits.id == 3 && AnalyticalLevel::traits.id == 4 && FeLevel::traits.id == 5,
              "with_level maps each level to its own struct");

namespace {

// "<level> (<name>)", e.g. "5 (FE)"; "1 (user tables) or 2 (ISO 6336-1)" for several.
std::string level_names(unsigned levels) {
  std::string out;
  for (int l = 0; l < GM_STIFFNESS_LEVELS; ++l) {
    if (!(levels & GM_LEVEL(l))) continue;
    if (!out.empty()) out += " or ";
    out += std::to_string(l) + " (" + with_level(l, [](auto level) { return decltype(level)::traits.name; }) + ")";
  }
  return out;
}

}  // namespace

gm_status check_level(const gm_model_params& p, std::string& msg) {
  size_t count;
  const gm_param_info* rows = gm_parameters(&count);
  for (size_t i = 0; i < count; ++i) {
    const gm_param_info& r = rows[i];
    if (!(r.flags & GM_PARAM_FILE) || r.where != GM_PARAM_IN_MODEL || (r.levels & GM_LEVEL(p.stiffness_level)))
      continue;
    const char* value = *reinterpret_cast<const char* const*>(reinterpret_cast<const char*>(&p) + r.offset);
    if (!value || !*value) continue;
    const std::string level = GM_PARAM_NAME(stiffness_level);
    msg = std::string(r.name) + " = \"" + value + "\": used at " + level + " = " + level_names(r.levels) +
          " only, this model has " + level + " = " + std::to_string(p.stiffness_level) +
          "; allowed: \"\" (none) at this level";
    return GM_ERR_PARAMETER;
  }
  return with_level(p.stiffness_level, [&](auto level) { return decltype(level)::check(p, msg); });
}

namespace {

// Whether a file row of the parameter table is read at this level alone (its data come from it).
bool reads_own_file(int level) {
  size_t count;
  const gm_param_info* rows = gm_parameters(&count);
  for (size_t i = 0; i < count; ++i)
    if ((rows[i].flags & GM_PARAM_FILE) && rows[i].levels == GM_LEVEL(level)) return true;
  return false;
}

}  // namespace

gm_status check_level_build(const gm_model_params& p, const gm_pair_geometry& g, std::string& msg) {
  if (reads_own_file(p.stiffness_level)) return GM_OK;
  std::unique_ptr<gm_model> scratch(new gm_model);
  scratch->params = p;
  return build_level(g, *scratch, msg);
}

gm_status build_level(const gm_pair_geometry& g, gm_model& m, std::string& msg) {
  return with_level(m.params.stiffness_level, [&](auto level) {
    using Level = decltype(level);
    m.level = Level::traits;
    const gm_status st = Level::build(m.params, g, m, msg);
    m.level.coupled = Level::coupled(m);
    return st;
  });
}

}  // namespace gm
