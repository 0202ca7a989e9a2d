// User tables (docs/physics.md §5, "user variable stiffness ... optionally with a user TE table
// as excitation"): the pair stiffness of stiffness level 1 over gear 1's roll angle, and a
// kinematic TE excitation over gear 1's angle within one pitch, usable at every level.
//
// Both files (worked examples: scenarios/user_stiffness_example.txt, scenarios/user_te_example.txt):
//   Plain text, UTF-8 (an initial byte-order mark is skipped), '#' starts a comment that runs to
//   the end of the line, blank lines are ignored, tokens are separated by spaces or tabs, numbers
//   are read independently of the locale (std::from_chars; a leading '+' is allowed). The first
//   non-blank line is the header; every other line is one row of exactly two numbers. Limits:
//   file size <= 64 MiB. Every error names the file, the line and what is allowed.
//
// Stiffness table (model.stiffness_table, level 1):
//   gearmesh-stiffness-table 1
//   <roll angle deg> <pair stiffness N/(mm um)>
//   ...
//   Roll angle: the roll distance of the contact point on gear 1's flank divided by r_b1, in
//   degrees (= tan of the pressure angle there, as an angle), so it runs over gear 1's active
//   profile, e.g. about 17.7 .. 28.2 deg for the paper's set A. In [0, 360] deg, strictly
//   increasing, at least 2 rows. Pair stiffness: the stiffness of one tooth pair per unit face
//   width on the transverse line of action (ISO 6336-1's c', as model.user_stiffness), > 0 and
//   <= 1e5 N/(mm um). The same table serves flank A and flank B (each at its own roll angle on
//   gear 1). Between rows: linear; outside the table: the end value is held (no extrapolation).
//   At model creation the table's roll angles must overlap gear 1's active profile.
//
// TE excitation table (model.te_table, any level):
//   gearmesh-te-table 1
//   <gear 1 angle within one pitch, deg> <TE excitation, um>
//   ...
//   Angle: phi_1 modulo the angular pitch of gear 1, 360/z1 deg (phi_1 = 0: tooth 0 in mesh,
//   docs/physics.md §0), in [0, 360/z1) (the period itself is the first row again), strictly increasing,
//   at least 1 row (one row: a constant excitation). TE excitation TE_exc: |TE_exc| <= 1000 um.
//   Periodic over the pitch: linear between rows, and from the last row to the first row one
//   period later.
//   Meaning: a kinematic excitation that OPENS BOTH FLANKS by TE_exc: every slice, flank A and
//   flank B alike (tip-edge contacts too), gets a gap of TE_exc cos(beta_b) along its normal,
//   i.e. TE_exc along the transverse line of action, like a modification removed from both
//   flanks. An unloaded perfect pair then closes flank A at TE = TE_exc(phi_1) (its unloaded TE)
//   and flank B at TE = -j_bt - TE_exc(phi_1); a negative TE_exc closes both. The normal
//   approach rate gets -cos(beta_b) dTE_exc/dphi_1 omega_1 (damping). mesh.te stays the TE of the
//   spin angles (docs/physics.md §0): prescribed spin angles see the excitation in the forces, the
//   quasi-static mode in the solved TE.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "gearmesh/gearmesh.h"

namespace gm {

// A parsed stiffness table, SI. Empty by default (no level-1 table).
struct StiffnessTable {
  std::vector<double> roll_angle;  // gear 1's roll angle, rad, strictly increasing, >= 2 rows
  std::vector<double> stiffness;   // pair stiffness per unit face width, N/m^2, > 0
  bool empty() const { return roll_angle.empty(); }
};

// A parsed TE excitation table, SI. Empty by default (no excitation).
struct TeTable {
  double period = 0;          // angular pitch of gear 1, 2 pi / z1, rad
  std::vector<double> angle;  // phi_1 within the pitch, rad, in [0, period), strictly increasing
  std::vector<double> te;     // TE excitation, m
  bool empty() const { return angle.empty(); }
};

// The TE excitation and its slope at one gear-1 angle.
struct TeExcitation {
  double te = 0;     // m
  double slope = 0;  // dTE_exc/dphi_1, m/rad
};

// Parse a stiffness table's text (format above); name is used in messages (the path). On error
// returns GM_ERR_PARAMETER with msg = "<name>:<line>: <what>; allowed: <what is allowed>" and
// leaves out unchanged.
gm_status parse_stiffness_table(std::string_view text, const char* name, StiffnessTable& out,
                                std::string& msg);
// Read and parse a stiffness table file. A missing or unreadable file is GM_ERR_PARAMETER too.
gm_status load_stiffness_table(const char* path, StiffnessTable& out, std::string& msg);

// Parse a TE excitation table's text for a gear 1 of teeth1 teeth (the period is 360/teeth1 deg).
gm_status parse_te_table(std::string_view text, const char* name, int teeth1, TeTable& out,
                         std::string& msg);
// Read and parse a TE excitation table file.
gm_status load_te_table(const char* path, int teeth1, TeTable& out, std::string& msg);

// Pair stiffness per unit face width at gear 1's roll angle (rad), N/m^2: linear between rows,
// end values held outside. t must not be empty. Allocates nothing.
double stiffness_at(const StiffnessTable& t, double roll_angle);
// d stiffness_at/d roll_angle (0 outside the table, where the end values are held), N/m^2/rad.
double stiffness_slope_at(const StiffnessTable& t, double roll_angle);

// TE excitation at gear 1's spin angle phi1 (rad, any value; reduced modulo the pitch), periodic
// linear interpolation. t must not be empty. Allocates nothing.
TeExcitation te_excitation_at(const TeTable& t, double phi1);

}  // namespace gm
