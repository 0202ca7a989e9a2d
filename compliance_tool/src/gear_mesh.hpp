// Gear-body mesher of compliance_tool (DESIGN.md "compliance_tool"; PHYSICS 1 and 5): one gear of
// a scene -> gmsh model of the whole gear -> 3-D quadratic tetrahedral mesh plus the node sets the
// FE stage needs (bore surface; per tooth and flank the flank surface nodes with their roll
// distance and face coordinate).
//
// Geometry (body frame of the gear): z along the gear axis, z = 0 at mid-face (the face
// coordinate of PHYSICS 1 and the core's micro-geometry), the face from -b/2 to +b/2. Tooth k's
// centre line in the section z lies at angle
//   theta_k(z) = 2 pi k / |z| + hand * z * tan(beta_b) / r_b
// (hand +1 right, -1 left, 0 spur: gear 1 takes the sign of pair.helix_angle, gear 2 of an
// external pair the opposite one), i.e. the section at z is the section at 0 turned by
// z tan(beta_b)/r_b as PHYSICS 1 says. Flank A is the counter-clockwise (+theta) side of each
// tooth, flank B the clockwise side (see tooth_outline.hpp).
//
// Cross-section: the tooth outline of tooth_outline.hpp (generated trochoid fillet from the root
// circle to the form circle, involute to the tip, tip arc, root arcs between teeth) for all
// teeth, the bore circle, and optionally a rim/web/hub split (circles at the rim's inner radius
// and the hub's outer radius) with circular lightening holes in the web annulus. The section is
// extruded across the face width with layers (a structured mesh across the width) and, for
// helical gears, a twist (gmsh geo::twist); with a web narrower than the face the extrusion runs
// in three stages split at the web's faces and the web volume exists only in the middle stage.
// The hub spans the whole face width. Elements: TET10 (gmsh order 2; prisms of the layers split
// into tetrahedra), gmsh node ordering: corners 0-3, then the mid-edge nodes of the edges
// (0,1), (1,2), (2,0), (3,0), (3,2), (3,1).
//
// Known approximations: fillet and involute are gmsh splines through dense samples of the core's
// profile (the deviation is far below 1 um for the default sampling); lightening holes follow the
// helical twist in helical gears (the whole section turns); internal ring gears are not yet
// supported (a clear error).
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "gearmesh/gearmesh.h"

namespace gm::mesh {

struct GearBodyOptions {
  double bore_radius = 0;        // m; 0 = 0.4 r_f (the analytical level's default)
  // Rim/web/hub. rim_inner_radius = 0: a solid disc from the bore to the teeth (no web).
  double rim_inner_radius = 0;   // m, inner radius of the rim (outer radius of the web)
  double hub_radius = 0;         // m, outer radius of the hub (inner radius of the web)
  double web_thickness = 0;      // m, axial; 0 or >= b = the web spans the whole face width
  double web_offset = 0;         // m, axial position of the web's mid-plane from mid-face
  // Lightening holes in the web (or in the disc if there is no web): count, radius, centre radius.
  int holes = 0;
  double hole_radius = 0;        // m
  double hole_circle_radius = 0; // m
  // Element counts.
  int elements_along_profile = 8;  // along the involute (form circle to tip) of each flank
  int elements_across_width = 6;   // layers across the face width
  int elements_in_fillet = 3;      // along each fillet (root circle to form circle)
  int elements_on_tip = 0;         // along the tip land; 0 = from the profile element size
  double body_size = 0;            // m, target element size in the body; 0 = 1.5 m_n
  int order = 2;                   // element order: 2 (TET10) only
  int samples_per_piece = 60;      // spline points per fillet and per involute
  int threads = 1;                 // gmsh threads (1: deterministic)
};

// One node on a flank surface.
struct FlankNode {
  int node = 0;       // index into GearBodyMesh::nodes
  double roll = 0;    // roll distance sqrt(R^2 - r_b^2) of the node's transverse radius R, m
  double face = 0;    // face coordinate z (from mid-face), m
};

struct GearBodyMesh {
  std::vector<Eigen::Vector3d> nodes;     // m, body frame (see above)
  std::vector<std::array<int, 10>> tets;  // TET10, gmsh ordering, 0-based node indices
  std::vector<int> bore_nodes;            // nodes on the bore surface
  // flanks[k][0] flank A, flanks[k][1] flank B of tooth k: the involute part (form circle to
  // tip), including its edges.
  std::vector<std::array<std::vector<FlankNode>, 2>> flanks;
  // Geometry used, for the FE stage and the tests.
  int teeth = 0;
  int hand = 0;                 // +1 right, -1 left, 0 spur
  double face_width = 0;        // b, m
  double base_radius = 0;       // r_b, m
  double root_radius = 0;       // r_f, m
  double form_radius = 0;       // r_Ff, m
  double tip_radius = 0;        // r_a, m
  double bore_radius = 0;       // m
  double eta_b = 0;             // half angle of the tooth at the base circle, rad
  double twist_rate = 0;        // tan(beta_b)/r_b, rad/m (magnitude)
  double mesh_seconds = 0;      // wall time of the gmsh part
};

// Build the mesh of gear `gear` (0 or 1) of validated parameters p with their geometry g.
// Initializes and finalizes gmsh within the call (not thread-safe against other gmsh users).
gm_status build_gear_body(const gm_model_params& p, const gm_pair_geometry& g, int gear,
                          const GearBodyOptions& options, GearBodyMesh& out, std::string& msg);

// Volume of a TET10 mesh (degree-3 exact quadrature of det J), m^3. For tests and checks.
double tet10_volume(const std::vector<Eigen::Vector3d>& nodes,
                    const std::vector<std::array<int, 10>>& tets);

}  // namespace gm::mesh
