// Level 0, user constant (docs/physics.md §5): one pair stiffness per unit face width for the
// whole mesh, model.user_stiffness. The level's parts: core/src/levels.hpp.
#pragma once

#include <string>

#include "model.hpp"

namespace gm {

struct UserConstantLevel {
  static constexpr LevelTraits traits{GM_STIFFNESS_USER_CONSTANT, "user constant", true, false, false};
  static gm_status check(const gm_model_params&, std::string&) { return GM_OK; }
  static gm_status build(const gm_model_params&, const gm_pair_geometry&, gm_model&, std::string&) { return GM_OK; }
  static bool coupled(const gm_model&) { return false; }
  template <class T>
  static T pair_stiffness(const gm_model& m, const ContactSliceT<T>&) {
    return T(m.params.user_stiffness);
  }
};

}  // namespace gm
