// Flank micro-geometry (docs/physics.md §2): design modifications and measured deviations of
// one gear, as the material removed at a flank point (positive = gap, m, along the flank normal).
// Detection subtracts the gaps of both flanks at a contact point from the slice's approach.
//
// Coordinates of a flank point, both measured on the gear that owns the flank:
//   rho  roll distance from the base-circle tangency point, m (docs/physics.md §1: rho_y = sqrt(d_y^2 - d_b^2)/2);
//   y    face coordinate from the gear's mid-face, m, in [-b/2, b/2]; its positive direction is
//        the one the caller uses for the helix slope (gm_flank_modification.helix_slope).
// The active profile runs from the start of active profile (SAP) to the tip. On an internal ring
// the tip is the inner circle, so rho_tip < rho_start there; every profile term is written in the
// distance s = |rho - rho_start| measured towards the tip, so one set of formulas serves both.
//
// Design modifications (gm_flank_modification, SI), with L = |rho_tip - rho_start| the active
// profile length, s in [0, L] from the SAP towards the tip and b the face width:
//   profile crowning  C_alpha (2 s/L - 1)^2                 (0 mid-profile, C_alpha at both ends)
//   tip relief        C_a ((s - (L - L_a))/L_a)^n    for s > L - L_a, n = 1 linear / 2 parabolic
//   root relief       C_f ((L_f - s)/L_f)^n          for s < L_f
//   profile slope     f_Halpha (s/L - 1/2)                  (tip minus start = f_Halpha)
//   lead crowning     C_beta (2 y/b)^2                      (0 mid-face, C_beta at both ends)
//   helix slope       f_Hbeta y/b                           (y = +b/2 minus y = -b/2 = f_Hbeta)
//   end relief        C_I (|y| - (b/2 - L_I))/L_I    for |y| > b/2 - L_I, linear
// Outside the active profile and the face width the same expressions continue (detection may
// evaluate a point slightly beyond the tip or below the SAP, e.g. at a tip corner or when the
// centre distance moves the SAP); a relief keeps growing beyond its end, it is never clamped.
//
// Deviation file (one per gear, optional; scenarios/deviations_example.txt is a worked example):
//   Plain text, UTF-8 (an initial byte-order mark is skipped), '#' starts a comment that runs to
//   the end of the line, tokens are separated by spaces or tabs, numbers are read independently
//   of the locale (std::from_chars; a leading '+' is allowed). Units IN THE FILE: roll distance
//   and face position in mm, deviations in um. Lines, in this order where an order is stated:
//     gearmesh-deviations 1          first line: magic word and format version
//     teeth <z>                      tooth count of the gear this file describes (must match)
//     roll_mm r_1 ... r_n            measured profile points: roll distance from the base tangency
//                                    point, mm, strictly increasing, >= 0 (n >= 1)
//     face_mm y_1 ... y_m            measured face points from mid-face, mm, strictly increasing,
//                                    within [-b/2, b/2] (+ 0.001 mm) (m >= 1)
//     grid <tooth> <A|B> v_11 ... v_nm
//                                    measured deviation of that tooth and flank, um, n*m values
//                                    roll-major (v_ij at r_i, y_j: all face points of r_1 first);
//                                    the values may continue on the following lines (e.g. one line
//                                    per roll point) until n*m are read. Needs roll_mm and face_mm
//                                    before it. SIGN: + = material ADDED (as measuring machines
//                                    report), so the gap is -v. Between points: bilinear; outside
//                                    the measured area: the value at the nearest edge is held
//                                    (constant along an axis with a single point).
//     pitch <tooth> <A|B> <f_pt>     single pitch deviation of that tooth and flank, um; + = that
//                                    flank stands proud (material added) by f_pt relative to the
//                                    same flank of tooth - 1 (of tooth z-1 for tooth 0).
//   Teeth and flanks that are not listed have zero deviation. Each (tooth, flank) may have at
//   most one grid and one pitch line. Tooth indices run 0..z-1 in the detection's numbering
//   (tooth 0 is the reference tooth of docs/physics.md §0). The cumulative pitch deviation of tooth k is
//   F_p(k) = sum_{j=0..k} f_pt(j); the single pitch deviations of a flank must close around the
//   gear (|sum over all teeth| <= 0.001 um + 0.001 max |f_pt|), so F_p(z-1) = 0: the last tooth
//   is the datum, and a file that lists only the pitches around one proud tooth leaves every
//   other tooth at its nominal position. The gap of a tooth gets -F_p(k).
//   Limits: |deviation| <= 10000 um, roll and face values <= 100000 mm in magnitude, file size
//   <= 64 MiB. Every error names the file, the line and what is allowed.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "gearmesh/gearmesh.h"
#include "dual.hpp"

namespace gm {

// The active profile of a gear in roll distance (m) and its face width (m).
struct ActiveFlank {
  double rho_start = 0;   // roll distance of the start of active profile (SAP), m
  double rho_tip = 0;     // roll distance of the tip (ring: inner circle; rho_tip < rho_start), m
  double face_width = 0;  // b, m
};

// The parsed deviation file of one gear. Empty by default: no lookups, no cost.
class DeviationTable {
 public:
  bool empty() const { return grid_offset_.empty() && pitch_.empty(); }
  int teeth() const { return teeth_; }  // z of the gear (0 before a file was parsed)
  // Measured axes, m (empty without grids).
  const std::vector<double>& roll_axis() const { return roll_; }
  const std::vector<double>& face_axis() const { return face_; }
  bool has_grid(int tooth, int flank) const;
  bool has_pitch() const { return !pitch_.empty(); }

  // Measured deviation at (rho, y), m, + = material added (file sign); 0 without a grid.
  double measured(int tooth, int flank, double rho, double y) const;
  // Cumulative pitch deviation F_p of the tooth and flank, m, + = proud (material added).
  double cumulative_pitch(int tooth, int flank) const;
  // Gap from the deviations at (rho, y), m: -(measured + cumulative pitch). tooth in [0, z).
  double gap(int tooth, int flank, double rho, double y) const;
  // measured() with its partial derivatives along rho and y (0 where the value is held).
  double measured_slope(int tooth, int flank, double rho, double y, double& d_rho,
                        double& d_y) const;

 private:
  friend gm_status parse_deviations(std::string_view, const char*, int, double, DeviationTable&,
                                    std::string&);
  int teeth_ = 0;
  std::vector<double> roll_;      // m, strictly increasing
  std::vector<double> face_;      // m, strictly increasing
  std::vector<int> grid_offset_;  // [2 tooth + flank]: offset into values_, -1 = no grid
  std::vector<double> values_;    // m, material added, roll-major per grid
  std::vector<double> pitch_;     // [2 tooth + flank]: F_p, m; empty = no pitch lines
};

// Parse a deviation file's text (format above). name is used in messages (the path).
// teeth and face_width (m) are the gear's. On error returns GM_ERR_PARAMETER with
// msg = "<name>:<line>: <what>; allowed: <what is allowed>" and leaves out unchanged.
gm_status parse_deviations(std::string_view text, const char* name, int teeth, double face_width,
                           DeviationTable& out, std::string& msg);

// Read and parse a deviation file. A missing or unreadable file is GM_ERR_PARAMETER too.
gm_status load_deviations(const char* path, int teeth, double face_width, DeviationTable& out,
                          std::string& msg);

// Everything flank_gap needs for one gear, built once at model creation.
struct GearMicrogeometry {
  gm_flank_modification flank[2]{};  // flank A [0], flank B [1]
  ActiveFlank active{};
  DeviationTable deviations;
  bool any = false;                   // false: every gap is 0, callers may skip flank_gap
  // Derived by make_microgeometry.
  double profile_dir = 1;             // +1 if rho_tip >= rho_start, -1 on a ring
  double profile_length = 0;          // L = |rho_tip - rho_start|, m
  double inv_profile_length = 0;      // 1/L, 1/m (0 if L = 0)
  bool profile_any[2] = {false, false};
  bool lead_any[2] = {false, false};
};

// Assemble the micro-geometry of gear g (g.flank must be validated) over its active profile.
GearMicrogeometry make_microgeometry(const gm_gear_params& g, const ActiveFlank& active,
                                     DeviationTable deviations);

// Material removed at a flank point, m, positive = gap, along the flank normal: the sum of the
// design modifications and the measured deviations (grid and cumulative pitch) of that tooth.
// flank 0 = A, 1 = B; tooth in [0, z) (others are reduced modulo z); rho, y in m (see top).
// Allocates nothing.
double flank_gap(const GearMicrogeometry& m, int flank, int tooth, double rho, double y);

// flank_gap and its partial derivatives along rho and y (for the Jacobian).
double flank_gap_slope(const GearMicrogeometry& m, int flank, int tooth, double rho, double y,
                       double& d_rho, double& d_y);

// The part of the flank's design gap that is smooth over the whole profile (profile crowning and
// profile slope; not the reliefs, which start at a point, nor measured deviations): its first and
// second derivatives along rho, d1 over the scalar type (where modified flanks touch:
// touch_point.hpp). Quadratic in rho, so d2 is a constant.
template <class T>
void smooth_profile_jet(const GearMicrogeometry& m, int flank, const T& rho, T& d1, double& d2) {
  const gm_flank_modification& d = m.flank[flank];
  const double du = m.profile_dir * m.inv_profile_length;  // du/drho
  const T u = (rho - m.active.rho_start) * du;              // 0 at the SAP, 1 at the tip
  d1 = (4.0 * d.profile_crowning * (2.0 * u - 1.0) + d.profile_slope) * du;
  d2 = 8.0 * d.profile_crowning * du * du;
}

// Check one flank's modification against the bounds that depend on the gear (its static ranges
// and shape flags are the parameter table's, checked by validate_params). prefix is the FMU name
// of the gear ("gear1"). On failure returns GM_ERR_PARAMETER and msg = "<prefix>.<parameter> =
// <value> m: allowed range ...": relief lengths > 0 when their relief is nonzero, tip + root <=
// the active profile length, end relief length <= b/2.
gm_status validate_modification(const char* prefix, const gm_flank_modification& mod,
                                const ActiveFlank& active, std::string& msg);

// Check that the measured roll range of a deviation table overlaps the active profile (a file
// written in diameters or roll angles instead of roll distances would otherwise be held at its
// edge everywhere). prefix as above; the message names "<prefix>.deviations".
gm_status validate_deviation_coverage(const char* prefix, const DeviationTable& table,
                                      const ActiveFlank& active, std::string& msg);

}  // namespace gm
