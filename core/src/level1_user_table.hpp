// Level 1, user tables (docs/physics.md §5; core/src/user_tables.hpp): the pair stiffness per unit
// face width from the user's table over gear 1's roll angle (model.stiffness_table). The level's
// parts: core/src/levels.hpp.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "model.hpp"
#include "params.hpp"

namespace gm {

struct UserTableLevel {
  static constexpr LevelTraits traits{GM_STIFFNESS_USER_VARIABLE, "user tables", true, false, false};

  static gm_status check(const gm_model_params& p, std::string& msg) {
    if (p.stiffness_table && *p.stiffness_table) return GM_OK;
    msg = std::string(GM_PARAM_NAME(stiffness_table)) + " = \"\": " + GM_PARAM_NAME(stiffness_level) +
          " = 1 (user tables) takes the pair stiffness from a stiffness table; allowed: the path of a "
          "stiffness table file ('gearmesh-stiffness-table 1'; in the FMU the name of a file inside resources/)";
    return GM_ERR_PARAMETER;
  }

  // The table, read and checked to reach gear 1's active profile.
  static gm_status build(const gm_model_params& p, const gm_pair_geometry& g, gm_model& m, std::string& text) {
    gm_status st = load_stiffness_table(p.stiffness_table, m.stiffness_table, text);
    if (st != GM_OK) {
      const std::string prefix = std::string(GM_PARAM_NAME(stiffness_table)) + ": ";
      if (text.rfind(prefix, 0) != 0) text = prefix + text;
      if (text.find("allowed") == std::string::npos)
        text += "; allowed: a readable GearMesh stiffness table (format 1)";
      return st;
    }
    // A table in another convention (radians, the roll angle of gear 2, a diameter) would be
    // held at one end value everywhere: its roll angles must reach gear 1's active profile.
    const StiffnessTable& table = m.stiffness_table;
    const gm_gear_geometry& g1 = g.gear[0];
    const double lo = std::sqrt(std::max(0.0, g1.d_sap * g1.d_sap - g1.d_b * g1.d_b)) / g1.d_b;
    const double hi = 2 * g1.rho_a / g1.d_b;
    if (table.roll_angle.back() < std::min(lo, hi) || table.roll_angle.front() > std::max(lo, hi)) {
      char buf[400];
      constexpr double deg = 180 / 3.14159265358979323846;
      std::snprintf(buf, sizeof buf,
                    "%s: %s: its roll angles %.6g .. %.6g deg miss gear 1's "
                    "active profile, %.6g .. %.6g deg; allowed: a table over gear 1's roll angle "
                    "(roll distance on gear 1's flank / r_b1, deg) that overlaps its active profile",
                    GM_PARAM_NAME(stiffness_table), p.stiffness_table, table.roll_angle.front() * deg,
                    table.roll_angle.back() * deg, std::min(lo, hi) * deg, std::max(lo, hi) * deg);
      text = buf;
      return GM_ERR_PARAMETER;
    }
    return GM_OK;
  }

  static bool coupled(const gm_model&) { return false; }

  // the table at gear 1's roll angle at the contact point; over dual numbers with the table's slope
  static double at(const StiffnessTable& t, double angle) { return stiffness_at(t, angle); }
  static Dual at(const StiffnessTable& t, const Dual& angle) {
    return {stiffness_at(t, angle.v), stiffness_slope_at(t, angle.v) * angle.d};
  }
  template <class T>
  static T pair_stiffness(const gm_model& m, const ContactSliceT<T>& s) {
    return at(m.stiffness_table, T(s.roll[0] / m.layout.base_radius[0]));
  }
};

}  // namespace gm
