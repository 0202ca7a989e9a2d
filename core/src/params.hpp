// Parameter defaults and range validation: the one place a bad parameter is named.
#pragma once

#include <string>

#include "gearmesh/gearmesh.h"

namespace gm {

// Check every field of p against its allowed range. On failure returns GM_ERR_PARAMETER and
// msg = "<fmu variable name> = <value> <unit>: <allowed range>". Geometric feasibility is
// checked afterwards by compute_pair_geometry.
gm_status validate_params(const gm_model_params& p, std::string& msg);

}  // namespace gm
