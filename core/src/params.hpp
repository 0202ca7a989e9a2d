// Parameter defaults and range validation: the one place a bad parameter is named.
#pragma once

#include <cstddef>
#include <string>

#include "gearmesh/parameters.h"

namespace gm {

// Check every field of p against its static range (gearmesh/parameters.h) and the bounds that depend
// on other fields. On failure returns GM_ERR_PARAMETER and
// msg = "<fmu variable name> = <value> <unit>: <allowed range>". Geometric feasibility is
// checked afterwards by compute_pair_geometry.
gm_status validate_params(const gm_model_params& p, std::string& msg);

// True when v lies in the static range of FMU variable `name` (gearmesh/parameters.h); else false
// with msg = "<name> = <v> <unit>: allowed range [lo, hi] <unit>" (or, for a name without a
// range, a message saying so).
bool check_range(const char* name, double v, std::string& msg);

// The FMU name of the parameter whose field lies at `offset` in the struct of `where`
// (gm_model_params, gm_dynamics_params: its row of the parameter table), for the messages that
// name a parameter: GM_PARAM_NAME(stiffness_level) is "model.stiffness",
// GM_GEAR_PARAM_NAME(i, thickness_allowance) "gear<i + 1>.thickness_allowance",
// GM_PARAM_ELEMENT_NAME(compliance, i) "gear<i + 1>.compliance", GM_DYNAMICS_PARAM_NAME(tolerance)
// "dynamics.tolerance"; a HOST row's by its field as the table
// writes it: GM_HOST_PARAM_NAME(mesh_damping_ratio) is "dynamics.mesh_damping_ratio".
const char* parameter_name(gm_param_where where, size_t offset);
const char* host_parameter_name(const char* field);
#define GM_PARAM_NAME(field) ::gm::parameter_name(GM_PARAM_IN_MODEL, offsetof(gm_model_params, field))
#define GM_GEAR_PARAM_NAME(i, field)                                                                        \
  ::gm::parameter_name(GM_PARAM_IN_MODEL, offsetof(gm_model_params, gear) + (i) * sizeof(gm_gear_params) + \
                                              offsetof(gm_gear_params, field))
#define GM_PARAM_ELEMENT_NAME(field, i)                                                   \
  ::gm::parameter_name(GM_PARAM_IN_MODEL, offsetof(gm_model_params, field) + \
                                              (i) * sizeof(static_cast<gm_model_params*>(nullptr)->field[0]))
#define GM_DYNAMICS_PARAM_NAME(field) ::gm::parameter_name(GM_PARAM_IN_DYNAMICS, offsetof(gm_dynamics_params, field))
#define GM_HOST_PARAM_NAME(field) ::gm::host_parameter_name(#field)

// The one loop of the range checks: every row of the parameter table whose value lives in
// `values` (a gm_model_params for GM_PARAM_IN_MODEL, a gm_dynamics_params for
// GM_PARAM_IN_DYNAMICS) inside its static range, a Boolean 0 or 1 (a flank modification on both
// flanks), in table order; false with msg naming the first that is not.
bool check_rows(gm_param_where where, const void* values, std::string& msg);

}  // namespace gm
