// Level 3, contact-line length (docs/physics.md §5): a constant stiffness per unit length of
// contact line, ISO 6336-1's c_gamma_alpha / eps_alpha, so that the mesh stiffness follows the
// length of the lines in contact. The level's parts: core/src/levels.hpp.
#pragma once

#include <string>

#include "level2_iso6336.hpp"

namespace gm {

struct ContactLineLevel {
  static constexpr LevelTraits traits{GM_STIFFNESS_CONTACT_LINE, "contact-line length", true, false, false};
  static gm_status check(const gm_model_params&, std::string&) { return GM_OK; }
  // ISO's c_gamma_alpha (level 2's build)
  static gm_status build(const gm_model_params& p, const gm_pair_geometry& g, gm_model& m, std::string& text) {
    return Iso6336Level::build(p, g, m, text);
  }
  static bool coupled(const gm_model&) { return false; }
  template <class T>
  static T pair_stiffness(const gm_model& m, const ContactSliceT<T>&) {
    return T(m.iso_c_gamma / m.geometry.eps_alpha);
  }
};

}  // namespace gm
