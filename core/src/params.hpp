// Parameter defaults and range validation: the one place a bad parameter is named.
#pragma once

#include <string>

#include "gearmesh/gearmesh.h"

namespace gm {

// Check every field of p against its static range (param_ranges.cpp) and the bounds that depend
// on other fields. On failure returns GM_ERR_PARAMETER and
// msg = "<fmu variable name> = <value> <unit>: <allowed range>". Geometric feasibility is
// checked afterwards by compute_pair_geometry.
gm_status validate_params(const gm_model_params& p, std::string& msg);

// True when v lies in the static range of FMU variable `name` (param_ranges.cpp); else false
// with msg = "<name> = <v> <unit>: allowed range [lo, hi] <unit>" (or, for a name without a
// range, a message saying so).
bool check_range(const char* name, double v, std::string& msg);

}  // namespace gm
