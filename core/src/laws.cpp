// The capability check of the stiffness levels; the laws themselves are templates over the
// scalar type in laws.hpp (defined there so that the evaluation inlines them).
#include "laws.hpp"

#include <string>

namespace gm {

gm_status check_capabilities(const gm_model_params& p, std::string& msg) {
  const int level = p.stiffness_level;
  for (int g = 0; g < 2; ++g) {
    const bool given = p.compliance[g] && *p.compliance[g];
    const std::string name = "gear" + std::to_string(g + 1) + ".compliance";
    if (level == GM_STIFFNESS_FE && !given) {
      msg = name + " = \"\": model.stiffness = 5 (FE) takes each gear's compliance from its "
            "compliance database; allowed: the path of a .gcdb file made by compliance_tool for "
            "this gear (in the FMU the name of a file inside resources/)";
      return GM_ERR_PARAMETER;
    }
    if (level != GM_STIFFNESS_FE && given) {
      msg = name + " = \"" + p.compliance[g] + "\": a compliance database is used at "
            "model.stiffness = 5 (FE) only; allowed: \"\" at this level";
      return GM_ERR_PARAMETER;
    }
  }
  if (level == GM_STIFFNESS_USER_VARIABLE && !(p.stiffness_table && *p.stiffness_table)) {
    msg = "model.stiffness_table = \"\": model.stiffness = 1 (user tables) takes the pair "
          "stiffness from a stiffness table; allowed: the path of a stiffness table file "
          "('gearmesh-stiffness-table 1'; in the FMU the name of a file inside resources/)";
    return GM_ERR_PARAMETER;
  }
  return GM_OK;
}

}  // namespace gm
