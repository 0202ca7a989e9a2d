// Level 4, analytical (docs/physics.md §4, §5): both teeth's Weber/Sainsot compliance and the
// exact local Hertz law (laws.hpp's tooth law), the neighbouring teeth coupled through the fitted
// table of core/src/tooth_coupling.hpp (model.coupled_teeth; 0: each slice on its own). The
// level's parts: core/src/levels.hpp.
#pragma once

#include <string>

#include "model.hpp"
#include "params.hpp"

namespace gm {

struct AnalyticalLevel {
  static constexpr LevelTraits traits{GM_STIFFNESS_ANALYTICAL, "analytical", true, true, false};
  static gm_status check(const gm_model_params&, std::string&) { return GM_OK; }

  // The tooth sections and the tooth coupling (its warning becomes the model's).
  static gm_status build(const gm_model_params& p, const gm_pair_geometry& g, gm_model& m, std::string& text) {
    gm_status st = GM_OK;
    for (int i = 0; i < 2 && st == GM_OK; ++i)
      st = build_tooth_section(p, g, i, ToothSectionOptions{}, m.tooth[i], text);
    if (st != GM_OK) {
      text = std::string(GM_PARAM_NAME(stiffness_level)) + " = 4 (analytical): " + text;
      return st;
    }
    return build_tooth_coupling(p, g, m.coupling, m.warnings, text);
  }

  // coupled through the tooth-coupling table (coupled_forces.cpp, the dense solve where it cannot)
  static bool coupled(const gm_model& m) { return m.coupling.offsets > 0; }
};

}  // namespace gm
