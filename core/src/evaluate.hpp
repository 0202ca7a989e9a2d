// One evaluation: inputs -> detection -> slice forces -> resultants and TE (docs/design.md, "core").
#pragma once

#include "model.hpp"

namespace gm {

// Check that m can be evaluated by this build (levels and effects implemented so far);
// returns GM_ERR_PARAMETER with msg naming the parameter otherwise.
gm_status check_capabilities(const gm_model_params& p, std::string& msg);

gm_status evaluate(const gm_model& m, gm_data& d, const gm_kinematics& kin, gm_result& res);

// gm_directional_derivative (gearmesh.h).
gm_status directional_derivative(const gm_model& m, gm_data& d, const gm_kinematics& at,
                                 const gm_kinematics& seed, gm_result& derivative);

}  // namespace gm
