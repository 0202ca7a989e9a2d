// Level 5, FE (docs/physics.md §5, §6; core/src/fe_compliance.hpp): the coupled compliance of
// the candidates from each gear's compliance database (made by compliance_tool), the local Hertz
// law at the database's depth (laws.hpp's tooth law), always the coupled force solve. Each slice
// is located on the databases' flank grid: repeated slices are not merged. The level's parts:
// core/src/levels.hpp.
#pragma once

#include <string>

#include "model.hpp"
#include "params.hpp"

namespace gm {

struct FeLevel {
  static constexpr LevelTraits traits{GM_STIFFNESS_FE, "FE", false, true, true};

  static gm_status check(const gm_model_params& p, std::string& msg) {
    for (int g = 0; g < 2; ++g) {
      if (p.compliance[g] && *p.compliance[g]) continue;
      msg = std::string(GM_PARAM_ELEMENT_NAME(compliance, g)) + " = \"\": " + GM_PARAM_NAME(stiffness_level) +
            " = 5 (FE) takes each gear's compliance from its compliance database; allowed: the path of a .gcdb "
            "file made by compliance_tool for this gear (in the FMU the name of a file inside resources/)";
      return GM_ERR_PARAMETER;
    }
    return GM_OK;
  }

  // Both databases, read and checked to be this pair's gears.
  static gm_status build(const gm_model_params& p, const gm_pair_geometry&, gm_model& m, std::string& text) {
    gm_status st = GM_OK;
    for (int i = 0; i < 2 && st == GM_OK; ++i) {
      st = read_compliance_db(p.compliance[i], m.compliance[i], text);
      if (st != GM_OK) text = "gear" + std::to_string(i + 1) + ".compliance: " + text;
      if (st == GM_OK) st = check_db_matches(m.compliance[i], p, i, text);
      if (st == GM_OK) st = check_db_values(m.compliance[i], i, text);
    }
    return st;
  }

  static bool coupled(const gm_model&) { return true; }
};

}  // namespace gm
