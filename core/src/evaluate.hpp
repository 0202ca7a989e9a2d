// One evaluation: inputs -> detection -> slice forces -> resultants and TE (docs/design.md,
// "core"). The stages are in pipeline.hpp; gm_evaluate in evaluate.cpp, its directional
// derivative in derivatives.cpp, the capability check of the levels in laws.hpp.
#pragma once

#include "laws.hpp"
#include "model.hpp"

namespace gm {

gm_status evaluate(const gm_model& m, gm_data& d, const gm_kinematics& kin, gm_result& res);

// gm_directional_derivative (gearmesh.h).
gm_status directional_derivative(const gm_model& m, gm_data& d, const gm_kinematics& at,
                                 const gm_kinematics& seed, gm_result& derivative);

}  // namespace gm
