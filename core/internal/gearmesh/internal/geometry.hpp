// Involute gear and pair geometry (ISO 21771; docs/physics.md §1).
#pragma once

#include <string>

#include "gearmesh/gearmesh.h"

namespace gm {

// inv(alpha) = tan(alpha) - alpha.
double involute(double alpha);

// alpha with inv(alpha) = q, q >= 0, by Newton from alpha0 = (3q)^(1/3).
double inverse_involute(double q);

// Operating transverse pressure angle of the pair at centre distance a (m), from the base radii.
// External: cos(alpha) = (r_b1 + r_b2)/a; internal: (r_b2 - r_b1)/a. Returns NaN if no such angle.
double operating_pressure_angle(double r_b1, double r_b2, bool internal, double a);

// Compute the pair geometry of p at p.pair.center_distance, with the geometric feasibility
// checks (operating pressure angle exists, tip outside base circle, positive path of contact,
// ring larger than pinion, ...). Parameter ranges are checked before, in validate_params.
// Returns GM_OK, or GM_ERR_PARAMETER with msg naming the FMU variable at fault and what is allowed.
gm_status compute_pair_geometry(const gm_model_params& p, gm_pair_geometry& g, std::string& msg);

}  // namespace gm
