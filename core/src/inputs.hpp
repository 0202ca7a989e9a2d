// The input stage of the evaluation (evaluate.cpp, derivatives.cpp): checks of the kinematics
// and the whole-turn-reduced pose that detection sees.
#pragma once

#include <string>

#include "detection.hpp"
#include "gearmesh/gearmesh.h"

namespace gm {

// Name the first non-finite input in msg (FMU variable names); false if there is one.
bool inputs_finite(const gm_kinematics& k, std::string& msg);

// The input checks of gm_evaluate and gm_directional_derivative (at `at`), in this order:
// finite, spins within GM_MAX_SPIN_ANGLE, tilts within the two-step detection's range.
bool inputs_valid(const gm_kinematics& k, std::string& msg);

// The pose detection sees: both spins reduced by whole turns; quasi-static mode's gear 2 spin
// offset in *phi2_offset (when not null; inputs.cpp derives it).
gm_kinematics reduced_pose(const MeshLayout& L, const gm_kinematics& in, double* phi2_offset);

}  // namespace gm
