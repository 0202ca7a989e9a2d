// The transverse outline of one tooth of an external gear, sampled from the core's own tooth
// profile (core/internal/gearmesh/internal/tooth_compliance.hpp: tooth_fillet_station, tooth_involute_station and the
// ToothSection that build_tooth_section derives from the pair geometry). Nothing here re-derives
// the involute or the trochoid: every point comes from those two functions.
//
// Internal ring (gear 2 of an internal pair): the outline of one SPACE of the ring, which has the
// shape of an external tooth (the core's convention, geometry.cpp: eta_b of the ring is the
// space's half angle at the base circle). Involute: at radius R the flank lies at polar angle
// eta_b - inv(alpha_R) from the space's centre line, from the core's form circle d_Ff (the
// mirrored-rack approximation of geometry.cpp) inward to the tip circle d_a (the ring's inner
// circle). Root fillet: the circular arc tangent to the involute at the form circle and to the
// root circle d_f (centre in the space; radius (r_f^2 - r_Ff^2) / (2 (r_f - rho_Ff)), which in
// the rack limit z -> -infinity is exactly the basic rack's tip round rho_fP since the core's form
// circle is where that round meets the straight flank). A real ring cut by a pinion cutter has a
// slightly different (trochoidal) fillet; the arc is documented as an approximation.
//
// Frame of the tooth: x along the tooth centre line (radial), y across it. Flank A is the +y side
// (counter-clockwise side of the tooth; docs/physics.md §0: the flank that carries load when gear 1 turns
// in +phi and drives; by detection.hpp's rho_i = r_b (sigma (theta_c - ...) + eta + alpha_w) the
// same side for both gears of an external pair), flank B the -y side.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "gearmesh/gearmesh.h"
#include "gearmesh/internal/tooth_compliance.hpp"

namespace gm::mesh {

// One flank of the tooth, from the root circle to the tip circle, in the tooth frame, flank A
// (+y). Flank B is its mirror image (y -> -y).
struct ToothOutline {
  ToothSection section;               // external gears: the core's section (unused for a ring)
  bool ring = false;                  // internal ring: the outline of a space (see above)
  double base_radius = 0, root_radius = 0, form_radius = 0, tip_radius = 0;  // m
  double eta_b = 0;                   // half angle of the tooth (ring: space) at r_b, rad
  double fillet_radius = 0;           // ring: radius of the circular fillet, m
  std::vector<Eigen::Vector2d> fillet;    // root circle -> form circle (psi 0 .. fillet_end)
  std::vector<Eigen::Vector2d> involute;  // form circle -> tip circle (alpha_Ff .. alpha_a)
  double root_half_angle = 0;         // theta_f: polar angle of the fillet's start, rad
  double tip_half_angle = 0;          // polar angle of the involute's end on the tip circle, rad
  double tip_pressure_angle = 0;      // alpha_a, rad
};

// Sample the outline of gear `gear` with `fillet_points` and `involute_points` (>= 2) points per
// piece. Involute points are uniform in roll distance. Refuses what build_tooth_section refuses
// (undercut, rack round centre above the rolling line), pointed teeth, and for a ring a form
// circle at or beyond the root circle, fillets that overlap or ring teeth without a tip land.
gm_status build_tooth_outline(const gm_model_params& p, const gm_pair_geometry& g, int gear,
                              int fillet_points, int involute_points, ToothOutline& out,
                              std::string& msg);

}  // namespace gm::mesh
