// The transverse outline of one tooth of an external gear, sampled from the core's own tooth
// profile (core/src/tooth_compliance.hpp: tooth_fillet_station, tooth_involute_station and the
// ToothSection that build_tooth_section derives from the pair geometry). Nothing here re-derives
// the involute or the trochoid: every point comes from those two functions.
//
// Frame of the tooth: x along the tooth centre line (radial), y across it. Flank A is the +y side
// (counter-clockwise side of the tooth; PHYSICS 0: the flank that carries load when gear 1 turns
// in +phi and drives; by detection.hpp's rho_i = r_b (sigma (theta_c - ...) + eta + alpha_w) the
// same side for both gears of an external pair), flank B the -y side.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "gearmesh/gearmesh.h"
#include "tooth_compliance.hpp"

namespace gm::mesh {

// One flank of the tooth, from the root circle to the tip circle, in the tooth frame, flank A
// (+y). Flank B is its mirror image (y -> -y).
struct ToothOutline {
  ToothSection section;               // the core's section (radii, eta_b, rack tip round)
  std::vector<Eigen::Vector2d> fillet;    // root circle -> form circle (psi 0 .. fillet_end)
  std::vector<Eigen::Vector2d> involute;  // form circle -> tip circle (alpha_Ff .. alpha_a)
  double root_half_angle = 0;         // theta_f: polar angle of the fillet's start, rad
  double tip_half_angle = 0;          // polar angle of the involute's end on the tip circle, rad
  double tip_pressure_angle = 0;      // alpha_a, rad
};

// Sample the outline of gear `gear` with `fillet_points` and `involute_points` (>= 2) points per
// piece. Involute points are uniform in roll distance. Refuses what build_tooth_section refuses
// (internal ring, undercut, rack round centre above the rolling line) and pointed teeth.
gm_status build_tooth_outline(const gm_model_params& p, const gm_pair_geometry& g, int gear,
                              int fillet_points, int involute_points, ToothOutline& out,
                              std::string& msg);

}  // namespace gm::mesh
