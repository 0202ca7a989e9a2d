// Normal slice forces from approaches (paper section 2.2; PHYSICS.md sections 5 and 6).
#pragma once

#include "detection.hpp"

namespace gm {

// Level 0, user constant stiffness: uncoupled linear slices, F_i = k' w_i max(Delta_i, 0),
// the exact solution of the complementarity problem with C = diag(1/(k' w_i)) and f = 0.
// Writes the force (N) and the tangent stiffness (N/m, 0 when open) of each slice.
void solve_user_constant(double stiffness_per_width, const ContactSlice* slices, int n,
                         double* forces, double* stiffness);

}  // namespace gm
