// The reduced face basis's shapes (solver.face_shapes = K > 0 at level 5; face_basis.hpp), made
// once per model: K columns over the slices across the face, each the response of a reference
// tooth pair to a smooth approach,
//   Phi_k = (C_ref + f'_k I)^-1 P_k,
// C_ref the coupled compliance C^1 + C^2 between the slices of tooth pair (0, 0) on flank A at the
// pitch point (both gears' roll distances r_b tan alpha_wt, no axial displacement; the reference
// assembly of fe_compliance.hpp), f'_k the slope of the local law there at column k's line load
// and P_k a Legendre polynomial of the slice's position (face_shape). Each column is scaled to a
// largest entry of 1. The shapes do not depend on the pose: the same for every tooth pair, roll
// position and call, so the projections of the databases onto them are cached with the
// databases' face sums (FeAssembly) and the basis has no derivative of its own.
#pragma once

#include <vector>

struct gm_model;

namespace gm {

// Per slice s (0 .. slices - 1) FaceBasis::kMaxShapes values, the first K used; empty where the
// reduced basis is not attempted (not level 5, K = 0, a helical pair, a reference block that is
// not positive definite).
std::vector<double> reference_face_shapes(const gm_model& m);

// Per slice of `shapes` (reference_face_shapes' table) the products phi_k phi_l, l <= k < K, in
// the reduced Newton matrix's order (FaceBasis::kOuter values; the first d (d + 1)/2 those of
// the first d shapes); empty where `shapes` is.
std::vector<double> face_shape_products(const std::vector<double>& shapes, int K);

}  // namespace gm
