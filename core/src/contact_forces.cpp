#include "contact_forces.hpp"

namespace gm {

void solve_user_constant(double stiffness_per_width, const ContactSlice* slices, int n,
                         double* forces, double* stiffness) {
  for (int i = 0; i < n; ++i) {
    const double k = stiffness_per_width * slices[i].width;
    const bool loaded = slices[i].approach > 0;
    forces[i] = loaded ? k * slices[i].approach : 0.0;
    stiffness[i] = loaded ? k : 0.0;
  }
}

}  // namespace gm
