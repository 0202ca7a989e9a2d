// Compliance database builder of compliance_tool (docs/physics.md §5, FE level; docs/design.md "compliance_tool"):
// one gear of validated parameters -> gear-body mesh (gear_mesh.hpp) -> bore clamped -> TET10
// stiffness, one CHOLMOD factorization (fe_elasticity.hpp) -> unit normal loads on the flank grid
// of the reference tooth -> normal displacements at depth h on that tooth and its +-n_c
// neighbours -> ComplianceDb (core/internal/gearmesh/internal/compliance_db.hpp).
//
// Definitions (all in the gear's body frame of gear_mesh.hpp):
// * Flank grid: the nodes of tooth 0's flank A (gear_mesh's involute surface, form circle to tip,
//   full face width). With quadratic elements and a layered extrusion they form an
//   n_roll x n_face lattice (n_roll = 2 elements_along_profile + 1, n_face = 2
//   elements_across_width + 1). The roll values are those of the nodes at the first face level,
//   the face values those of the nodes on the form-circle edge (clustered within 1 um). The
//   quadratic nodes in the middle of the layers' quad diagonals lie on the curved (twisted) flank
//   a little off the mid-edge roll and face values; each node takes the nearest grid value (the
//   offset is reported in BuildStats, > 1/4 spacing is an error).
//   A node set that is not a full lattice is an error.
// * Normal n at a grid node P (inward, into the tooth): in the transverse plane the involute's
//   normal is the line from P to its base-circle tangency point T (polar angle of P minus the
//   pressure angle at |P| for flank A), outward = (P - T)/|P - T|; in 3-D the helicoid's normal is
//   the cross product of the profile tangent and the helix tangent (hand * tan(beta_b)/r_b * R
//   e_theta + e_z), i.e. (cos beta_b n_t, -hand sin beta_b) outward; n = -outward. Spur: beta_b = 0.
// * Load case j: unit force (1 N) at grid node j along n_j. Response at grid point k of tooth d:
//   the FE displacement at Q_k,d = Rot(2 pi d / z) (P_k + h n_k), interpolated with the TET10
//   shape functions of the element containing Q (found by bounding box, then Newton on the
//   element's quadratic map), projected on Rot(2 pi d / z) n_k. Helical gears: n has an axial
//   component, so at the face ends P_k + h n_k is pulled back onto the end face (z clamped). C_d[k][j] = that, m/N. By the
//   cyclic symmetry of the body (the mesh itself is not exactly cyclic: the interpolation makes the
//   neighbour responses mesh-independent to discretization order) this is the tooth-offset-d block.
// * Bore: clamped (all its nodes' displacements zero). With the gear centre held fixed, tying the
//   bore rigidly to the centre (an RBE2 spider) is the same constraint: a rigid bore whose centre
//   does not move cannot move at all. So there is no separate "rigid tie" option.
// * Symmetry (docs/physics.md §5; paper 2.2): a generated body without lightening holes is cyclic per
//   tooth; with N equally spaced holes (hole 0 on tooth 0's centre line) its rotational symmetry
//   order is g = gcd(z, N), a user-supplied mesh is taken as g = 1. If g = z (and every_tooth is
//   not set) tooth 0's flank A is loaded and the database is cyclic = 1, mirror = 1 (flank B =
//   flank A mirrored; for a helical gear that mirror also flips the face coordinate and the hand,
//   which the reader has to apply). Otherwise the z/g distinct teeth 0 .. z/g - 1 are loaded
//   (every_tooth: all z) in the same factorization, and the database is cyclic = 0, mirror = 0
//   with all z tooth sets (tooth t's set is a copy of tooth t mod (z/g)'s). Load and reading
//   points of tooth t are tooth 0's grid points turned by 2 pi t / z; a load off a node is
//   distributed with the TET10 shape functions (the transpose of a reading). Flank B: the body's
//   mirror symmetry (spur: y -> -y through tooth 0's centre plane; helical: the half turn about
//   tooth 0's radial centre line at mid-face, which flips the face index) gives flank B of tooth t,
//   offset d, as flank A of tooth -t, offset -d, without solves; a helical body whose web is off
//   mid-face and a user mesh load flank B explicitly (a cyclic body then has mirror = 0 and two
//   flank sets).
// * Load fraction F < 1 (the paper's 50-70 %): only select_loaded()'s ceil(F n_grid) points are
//   loaded. The other columns come from the reduction space Psi spanned by the loaded solves
//   (the paper's Psi): u_j ~ Psi a_j with Psi^T K Psi a_j = Psi^T f_j (Galerkin), where
//   Psi^T K Psi is the surface compliance among the loaded points and Psi^T f_j the loaded
//   solves' surface readings at point j, so no extra solve is needed. That space carries the
//   global shapes but not the local field under point j (the error sits on j's own diagonal), so
//   where both roll neighbours of j are loaded the column is the mean of theirs shifted by one
//   roll row (the local field moves with the load; second order along the profile), for the
//   receivers off the grid's first and last rows. Measured on the test gear at F = 0.6: max error
//   6.8 % of the largest entry (12.5 % with the reduction space alone, 29 % shifting face
//   neighbours too), line-load compliance 1.3 %.
// * The FE computation runs in mm, N, MPa (better conditioned); the database is in SI.
#pragma once

#include <functional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "gearmesh/internal/compliance_db.hpp"
#include "gear_mesh.hpp"
#include "gearmesh/gearmesh.h"

namespace gm::ctool {

struct BuildOptions {
  mesh::GearBodyOptions mesh;  // body and element counts (bore_radius 0 = 0.4 r_f)
  double depth = 0.5e-3;       // h, m, > 0
  int coupled = -1;            // n_c; < 0 = the parameters' coupled_teeth
  int batch = 80;              // most load cases per CHOLMOD solve call (one dense block of
                               // right-hand sides, BLAS-3; split evenly: 153 cases = 77 + 76).
                               // Its memory, 3 x 8 bytes x dofs x batch (B, X and CHOLMOD's
                               // workspace), stays below the factor's on set A (350 MB vs 650)
  bool every_tooth = false;    // load every distinct tooth even on a cyclic body (cyclic = 0)
  bool plane_strain = false;   // hold every node's axial displacement: the body becomes a
                               // plane-strain slab, the database comparable with a plane model
                               // (tests/python/test_compliance_db_fe.py); not for the product
  double load_fraction = 1.0;  // share of the flank grid loaded, (0, 1]; the rest from the
                               // reduction space (see the header comment)
  bool full_solves = false;    // CHOLMOD's solves of the whole field instead of the sparse ones
                               // (fe::Solver::solve_sparse): the reference the tests compare with
  std::string note;            // appended to the database note
  std::string write_mesh;      // if set: the body mesh used is also written there (gmsh .msh),
                               // e.g. to inspect it or to edit it and feed it back as mesh_file
  // Progress messages (meshing, assembly, factorization, solves i/N); may be empty.
  std::function<void(const std::string&)> progress;
};

struct BuildStats {
  int nodes = 0, elements = 0, dofs = 0, grid = 0;
  int tooth_sets = 0;   // distinct tooth sets loaded (1 on a cyclic body)
  int symmetry = 0;     // rotational symmetry order of the body g (z: cyclic per tooth)
  int loaded = 0;       // loaded grid points per tooth set and flank
  int solves = 0;       // load cases solved in all
  double mesh_seconds = 0, assembly_seconds = 0, factor_seconds = 0, solve_seconds = 0;
  double locate_seconds = 0;
  double max_roll_offset = 0;  // largest |roll or face - its grid value| of a flank node / spacing
};

// The grid points loaded for a load fraction F (0 < F <= 1): ceil(F n) points of the
// n_roll x n_face grid (index i_roll n_face + i_face), ascending: the element vertices' lattice
// (even indices both ways) first, then greedily the point farthest from every loaded one.
std::vector<int> select_loaded(int n_roll, int n_face, double fraction);

// Compute the database of gear `gear` (0 = gear 1, 1 = gear 2) of p (validated here).
gm_status build_compliance_db(const gm_model_params& p, int gear, const BuildOptions& options,
                              ComplianceDb& out, BuildStats& stats, std::string& msg);

}  // namespace gm::ctool
