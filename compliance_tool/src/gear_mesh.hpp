// Gear-body mesher of compliance_tool (docs/design.md "compliance_tool"; docs/physics.md §1 and 5): one gear of
// a scene -> gmsh model of the whole gear -> 3-D quadratic tetrahedral mesh plus the node sets the
// FE stage needs (the clamped surface; per tooth and flank the flank surface nodes with their roll
// distance and face coordinate). Or, with GearBodyOptions::mesh_file, the same from a user's mesh.
//
// Geometry (body frame of the gear): z along the gear axis, z = 0 at mid-face (the face
// coordinate of docs/physics.md §1 and the core's micro-geometry), the face from -b/2 to +b/2. Tooth k's
// centre line (internal ring: the centre line of SPACE k) in the section z lies at angle
//   theta_k(z) = 2 pi k / |z| + hand * z * tan(beta_b) / r_b
// (hand +1 right, -1 left, 0 spur: gear 1 takes the sign of pair.helix_angle, gear 2 of an
// external pair the opposite one, the ring of an internal pair the same one), i.e. the section at
// z is the section at 0 turned by z tan(beta_b)/r_b as docs/physics.md §1 says. Flank A is the
// counter-clockwise (+theta) side of each tooth, flank B the clockwise side (see
// tooth_outline.hpp). Internal ring: "tooth k" is space k, as in the core's detection
// (detection.hpp: the ring's "tooth" is the space, flank sigma = +1 at theta_c + eta_b - inv
// alpha): flank A of ring tooth-index k is the +theta side of space k, i.e. the clockwise flank of
// the ring tooth between spaces k and k+1; flank B the -theta side of space k. Roll distance on
// either kind: sqrt(R^2 - r_b^2) of the node's transverse radius R (for the ring it grows from
// the tip, the inner circle, towards the root).
//
// Cross-section, external gear: the tooth outline of tooth_outline.hpp (generated trochoid
// fillet from the root circle to the form circle, involute to the tip, tip arc, root arcs between
// teeth) for all teeth, the bore circle, and optionally a rim/web/hub split (circles at the rim's
// inner radius and the hub's outer radius) with circular lightening holes in the web annulus.
// Internal ring: the toothed inner outline (involute of the ring's space from the core's
// geometry, circular-arc root fillet, see tooth_outline.hpp; root arcs at the bottom of each
// space, tip arcs on the ring teeth) and the outer rim circle (outer_radius), clamped.
// The section is extruded across the face width with layers (a structured mesh across the width)
// and, for helical gears, a twist (gmsh geo::twist); with a web narrower than the face the
// extrusion runs in three stages split at the web's faces and the web volume exists only in the
// middle stage. The hub spans the whole face width. Elements: TET10 (gmsh order 2; prisms of the
// layers split into tetrahedra), gmsh node ordering: corners 0-3, then the mid-edge nodes of the
// edges (0,1), (1,2), (2,0), (3,0), (3,2), (3,1).
//
// Size field (on the 2-D section, before the extrusion). The fine region F is the sector of the
// fine teeth (|theta| <= (fine_teeth + 1/2) 2 pi / z around tooth 0) from fine_depth below the
// root circle outward (ring: from fine_depth beyond the root circle inward); there the size is
// the profile element size h_t (involute length / elements_along_profile). The far teeth have
// h_c = involute length / far_elements_along_profile down to fine_depth below their roots. Away
// from these the size grows linearly at size_growth (size per unit distance) up to body_size h_b:
//   h(x) = min(h_b, h_t + g dist(x, F), h_c + g max(0, (r_f - fine_depth) - R))   (external)
//   (ring: R - (r_f + fine_depth) in the last term; if body_size is below h_t the body is made
//   finer instead of coarser, h = max(h_b, ...)).
// Where there are lightening holes, the annulus that holds them (hole circle radius +- hole
// radius) has at most hole_band_size h_h (default: a tenth of the hole diameter), growing at
// size_growth away from it: h(x) = min(h(x), h_h + g dist(x, annulus)). The body's 4 m_n alone
// puts one or two elements across a ligament between holes; the default's convergence on the
// lightweight scene: docs/validation.md, "Set B in 3-D, the internal ring, the lightweight body".
// The outline itself is fixed by the element counts (transfinite curves). The layering across
// the width is the same everywhere (layer thickness b / elements_across_width). The defaults (4
// layers, body_size 4 m_n) were chosen by their cost at an unchanged answer: on set A, against
// 6 layers and 2 m_n, the line-load compliance moves by 0.1 % and the neighbour coupling by
// 0.02 %, the factor shrinks from 1.95e8 to 7.9e7 entries (docs/performance.md, "FE database").
//
// User-supplied mesh (GearBodyOptions::mesh_file): a gmsh .msh file holding TET10 elements
// (type 11) only, in the body frame above, in metres. The clamped nodes are the nodes within
// tol of the smallest transverse radius (external gear: the bore; bore_radius, if given, must
// match it) or the largest (ring: its outer rim; outer_radius, if given, must match). Flank
// nodes: the nodes on the mesh's boundary faces (faces of one tetrahedron only) that lie within
// tol of the involute helicoid of tooth k's flank f (the formula above) with R between the form
// and tip circles (within tol). tol = mesh_tolerance (default 1e-3 m_n). Refused with a message
// naming the file: a missing or unreadable file, volume elements other than TET10, a face width
// other than b, a boundary node strictly between the form and tip circles (0.02 m_n inside them,
// away from the end faces) that lies on no involute of this gear (a mesh of another gear), a
// tooth flank without nodes.
//
// Known approximations: fillet and involute are gmsh splines through dense samples of the
// profile (the deviation is far below 1 um for the default sampling of the fine teeth, 0.03 um
// on set A's involute; below 1 um on the far teeth's 16 samples, 0.4 um there); lightening holes follow
// the helical twist in helical gears (the whole section turns); the ring's fillet is a circular
// arc, not the trochoid of its pinion cutter.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "gearmesh/gearmesh.h"

namespace gm::mesh {

struct GearBodyOptions {
  double bore_radius = 0;        // m; 0 = 0.4 r_f (the analytical level's default); external only
  // Internal ring: radius of the outer rim (the clamped outer cylinder); 0 = r_f + 3 m_n (a rim
  // three modules thick behind the root circle).
  double outer_radius = 0;       // m, internal ring only, > root radius
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
  // Teeth each side of tooth 0 meshed with the counts above (the loaded tooth of the compliance
  // database and its coupled neighbours need them: fine_teeth >= n_c + 1); < 0 = every tooth.
  // The other ("far") teeth carry load only through the body and get the far_* counts.
  int fine_teeth = 3;
  int far_elements_along_profile = 1;
  int far_elements_in_fillet = 1;
  double body_size = 0;            // m, target element size in the body; 0 = 4 m_n
  // m, element size in the annulus of the lightening holes (see "Size field"); 0 = a tenth of
  // the hole diameter where there are holes, else none; never coarser than body_size.
  double hole_band_size = 0;
  double fine_depth = 0;           // m, band below the root circle at the profile size; 0 = 1 m_n
  double size_growth = 0.5;        // size increase per unit distance beyond that band, > 0
  int order = 2;                   // element order: 2 (TET10) only
  int samples_per_piece = 60;      // spline points per fillet and per involute
  // The same for the far teeth (coarse, one element along the involute by default). gmsh's
  // built-in kernel extrudes the section in a time quadratic in its spline points (it sorts the
  // list of points it has moved after each one it adds): 57 teeth at 60 took 2-3 s of set A's
  // mesh, with the far teeth at 16 about a fifth of that.
  int far_samples_per_piece = 16;
  int threads = 1;                 // gmsh threads (1: deterministic)
  // User-supplied mesh (see above): when set, nothing is meshed; the element counts and sizes
  // are not used.
  std::string mesh_file;
  double mesh_tolerance = 0;       // m, geometric tolerance for the node sets; 0 = 1e-3 m_n
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
  std::vector<int> clamped_nodes;         // the clamped surface: bore, or the ring's outer rim
  // flanks[k][0] flank A, flanks[k][1] flank B of tooth k: the involute part (form circle to
  // tip), including its edges.
  std::vector<std::array<std::vector<FlankNode>, 2>> flanks;
  // Geometry used, for the FE stage and the tests.
  int teeth = 0;
  bool ring = false;            // internal ring gear (tooth k = space k, see above)
  int hand = 0;                 // +1 right, -1 left, 0 spur
  double face_width = 0;        // b, m
  double base_radius = 0;       // r_b, m
  double root_radius = 0;       // r_f, m
  double form_radius = 0;       // r_Ff, m
  double tip_radius = 0;        // r_a, m
  double clamped_radius = 0;    // m, radius of the clamped cylinder (bore, or the ring's rim)
  double eta_b = 0;             // half angle of the tooth (ring: space) at the base circle, rad
  double twist_rate = 0;        // tan(beta_b)/r_b, rad/m (magnitude)
  double profile_size = 0;      // h_t, the element size along the involute, m
  double mesh_seconds = 0;      // wall time of the gmsh part
};

// The lightening holes' rule, in one place for the command line (main.cpp) and the body plan:
// `holes` holes of size `hole` on a circle of size `circle` lie inside the annulus (inner,
// outer) and do not overlap (all diameters, or all radii, in any one unit).
enum class HolesFit { kFits,
                      kOutsideAnnulus,
                      kOverlap };
HolesFit holes_fit(int holes, double hole, double circle, double inner, double outer);
// The largest hole that `holes` holes on a circle of size `circle` can have without overlapping.
double holes_overlap_limit(int holes, double circle);

// Build the mesh of gear `gear` (0 or 1) of validated parameters p with their geometry g.
// Initializes and finalizes gmsh within the call (not thread-safe against other gmsh users).
gm_status build_gear_body(const gm_model_params& p, const gm_pair_geometry& g, int gear,
                          const GearBodyOptions& options, GearBodyMesh& out, std::string& msg);

// Volume of a TET10 mesh (degree-3 exact quadrature of det J), m^3. For tests and checks.
double tet10_volume(const std::vector<Eigen::Vector3d>& nodes,
                    const std::vector<std::array<int, 10>>& tets);

// Write a mesh's nodes and TET10 elements as a gmsh .msh file (format 4.1; node tags 1..N in
// the order of mesh.nodes), e.g. to inspect it or to feed it back as mesh_file.
gm_status write_gear_body_msh(const GearBodyMesh& mesh, const std::string& path, std::string& msg);

}  // namespace gm::mesh
