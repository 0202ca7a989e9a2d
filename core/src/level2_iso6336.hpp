// Level 2, ISO 6336-1 (docs/physics.md §5; core/src/stiffness_iso.hpp): ISO's single stiffness c'
// (load-corrected by model.rated_line_load) at the middle of the path of contact, falling
// parabolically towards its ends so that the mean mesh stiffness is ISO's
// c_gamma_alpha = c'(0.75 eps_alpha + 0.25). The level's parts: core/src/levels.hpp.
#pragma once

#include <cmath>
#include <string>

#include "model.hpp"

namespace gm {

struct Iso6336Level {
  static constexpr LevelTraits traits{GM_STIFFNESS_ISO6336, "ISO 6336-1", true, false, false};
  static gm_status check(const gm_model_params&, std::string&) { return GM_OK; }

  // c', c_gamma_alpha and the parabola: c'(1 - kappa (2u - 1)^2) over the path has the mean
  // c' (1 - kappa/3) eps_alpha over the mesh, ISO's c_gamma_alpha = c'(0.75 eps_alpha + 0.25)
  static gm_status build(const gm_model_params& p, const gm_pair_geometry& g, gm_model& m, std::string& text) {
    IsoStiffness iso{};
    const gm_status st = iso_stiffness(p, g, IsoGearBlank{}, iso, text);
    m.iso_c_prime = iso_single_stiffness_at(iso, p.rated_line_load);
    m.iso_c_gamma = iso_mesh_stiffness_at(iso, p.rated_line_load);
    m.iso_shape = 0.75 * (1 - 1 / g.eps_alpha);
    return st;
  }

  static bool coupled(const gm_model&) { return false; }

  template <class T>
  static T pair_stiffness(const gm_model& m, const ContactSliceT<T>& s) {
    using std::fmax;
    using std::fmin;
    const T u = fmin(fmax(s.path_position, T(0.0)), T(1.0)) * 2 - 1;
    return m.iso_c_prime * (1 - m.iso_shape * u * u);
  }
};

}  // namespace gm
