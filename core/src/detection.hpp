// Contact detection for cylindrical involute gear pairs (paper section 2.1; docs/physics.md §0-3).
//
// Every tooth pair on both flanks is a candidate. In a transverse section the approach of a
// flank pair is exact for any centre distance because involutes stay conjugate: along the line
// of action of flank sigma (A = +1, B = -1) the flank of gear i sits at roll distance
//   rho_i = r_bi (sigma (theta_ci - gamma - zeta_i) + eta_i + alpha_w)
// from its tangency point T_i, with theta_ci the tooth (ring: space) centreline angle of that
// section (helical: turned by h_i y tan(beta_b)/r_bi across the face), gamma the direction of
// the centre line, zeta_i = 0 or pi the side of the mesh, eta_i the half base-circle angle of
// the tooth (ring: space) and alpha_w the operating pressure angle of the section's centre
// distance. The transverse approach is Delta_t = rho_1 + s rho_2 - s T1T2 (s = +1 external,
// -1 internal), positive when the flanks overlap, less the micro-geometry of both flanks; the
// normal approach is Delta_t cos(beta_b).
//
// Misalignment (the paper's two-step method): candidate pairs come from the section at the
// middle of the axial overlap (coarse step); each slice then evaluates them in its own plane,
// with each gear's centre placed there from its tilted axis (fine step). Tilts enter to first
// order; the neglected terms are of order r_a r^2 (docs/model.md, "Misalignment and its validity bound").
#pragma once

#include <string>

#include <Eigen/Core>

#include "gearmesh/gearmesh.h"
#include "dual.hpp"
#include "microgeometry.hpp"

namespace gm {

// What detection needs of the model, derived once at model creation.
struct MeshLayout {
  int sign = 1;                    // s: +1 external pair, -1 internal (gear 2 is the ring)
  int teeth[2] = {0, 0};           // z_i (magnitudes)
  int hand[2] = {0, 0};            // h_i: +1 right, -1 left, 0 spur
  double base_radius[2] = {0, 0};  // r_bi, m
  double tip_radius[2] = {0, 0};   // r_ai, m (ring: inner)
  double inv_tip[2] = {0, 0};      // inv(alpha_a) of the tip circle
  double eta[2] = {0, 0};          // half base-circle angle of tooth (ring: space), rad
  double theta0[2] = {0, 0};       // body angle of tooth (ring: space) 0 at phi = 0, rad
  double zeta[2] = {0, 0};         // side of the mesh seen from gear i: 0 or pi, rad
  double rho_tip[2] = {0, 0};      // roll distance of the tip circle, m
  // kappa of each gear's tip corner in a corner contact (hertz.hpp, corner_near_field): the wedge
  // between its tip circle and its flank, pi/2 + alpha_a (a ring's tooth too narrows towards
  // its tip), alpha_a the transverse pressure angle at the tip circle
  double corner_near_field[2] = {1, 1};
  double rho_form[2] = {0, 0};     // roll distance of the form circle, m
  double tan_beta_b = 0;           // tan of the base helix angle (magnitude)
  double cos_beta_b = 1, sin_beta_b = 0;
  double base_pitch = 0;           // p_bt, m
  double center_distance = 0;      // nominal a, m
  double face_width[2] = {0, 0};   // b_i, m
  double axial_offset[2] = {0, 0}; // mid-face position from the gear centre, m
  int slices = 1;                  // slices across the axial overlap
  GearMicrogeometry micro[2];      // flank modifications and deviations of each gear
};

// Where a candidate slice touches.
enum ContactKind {
  kFlankContact = 0,  // flank against flank on the line of action
  kTipOfGear1 = 1,    // gear 1's tip edge against gear 2's flank, outside the path of contact
  kTipOfGear2 = 2     // gear 2's tip edge against gear 1's flank
};

// One candidate slice of one tooth pair on one flank.
template <class T>
struct ContactSliceT {
  int flank = 1;                   // +1 flank A, -1 flank B
  int kind = kFlankContact;        // ContactKind
  int tooth[2] = {0, 0};           // tooth index on gear 1, tooth (ring: space) index on gear 2
  int pair = 0;                    // index of the tooth pair within this evaluation
  int slice = 0;                   // its first slice across the axial overlap, 0 .. slices - 1,
  int run = 1;                     // and how many consecutive ones it stands for (merged: > 1)
  T approach = 0;             // normal approach Delta_n, m: > 0 overlap, < 0 gap
  T width = 0;                // axial slice width L, m
  T roll[2] = {T(0), T(0)};         // roll distances of the contact point on both flanks, m
  T approach_rate = 0;        // d(Delta_n)/dt from the input velocities, m/s
  T sliding_velocity = 0;     // velocity of gear 1 relative to gear 2 along `tangent`, m/s
  T te_gain = 0;              // d(Delta_n)/d(TE) at fixed phi_1: +-cos(beta_b) on the flanks
  T path_position = 0;        // 0 at the start of the path of contact, 1 at its end
  T corner_slope = 0;         // tip corner: tan of the angle between its own flank and the mate's
                              // (the local law's contact width, docs/physics.md §4); 0 on a flank
  Eigen::Matrix<T, 3, 1> tangent{T(0), T(0), T(0)};// unit profile tangent in the transverse plane, towards gear 1's root
  Eigen::Matrix<T, 3, 1> point{T(0), T(0), T(0)};// contact point in H, m
  Eigen::Matrix<T, 3, 1> normal{T(0), T(0), T(0)}; // unit direction of the normal force on gear 2, in H
};

using ContactSlice = ContactSliceT<double>;

// gm_kinematics over a scalar type (the Jacobian evaluates with dual numbers).
template <class T>
struct KinematicsT {
  T u[2][3];
  T r[2][2];
  T phi[2];
  T v[2][3];
  T w[2][2];
  T omega[2];
  T load_torque;
};

// A tip corner's slope (ContactSliceT::corner_slope) is tan(delta) less kCornerSlopeOnset/2 beyond
// tan(delta) = kCornerSlopeOnset (about 0.3 degrees) and tan^2(delta)/(2 kCornerSlopeOnset) below:
// it sets in with zero slope where a contact moves onto the corner.
constexpr double kCornerSlopeOnset = 0.005;

// detect_contacts' default: every candidate (no approach is below -kEmitAll).
constexpr double kEmitAll = 1e300;

// Derive the detection layout from validated parameters, their geometry and the gears'
// micro-geometry (moved in).
MeshLayout make_mesh_layout(const gm_model_params& p, const gm_pair_geometry& g,
                            GearMicrogeometry micro1, GearMicrogeometry micro2);

// Most candidate slices detect_contacts can return for this layout.
int slice_capacity(const MeshLayout& L);

// Candidate slices at the given pose. Writes at most `capacity` slices into out and returns
// their number, or -1 with msg set when the pose is outside the detection range. Slices whose
// normal approach is at most `emit_above` (m) are left out: a plain solve needs only the slices
// that can carry load (emit_above = the gap the TE excitation adds), the quasi-static one all.
// merge_repeats: a tooth pair whose slices would all repeat the first (aligned spur, no
// micro-geometry, no tilt rate between the gears) is returned as ONE slice of their summed width
// at their mean face position, as merge_repeated_slices (slice_merge.hpp) would make of them
// (levels 0-4, whose laws are linear in the width).
int detect_contacts(const MeshLayout& L, const gm_kinematics& kin, ContactSlice* out, int capacity,
                    std::string& msg, double emit_above = -kEmitAll, bool merge_repeats = false);

// The same with derivatives along one input direction (gm_directional_derivative): the same
// candidates, in the same order, as the double evaluation at the values of kin.
int detect_contacts(const MeshLayout& L, const KinematicsT<Dual>& kin, ContactSliceT<Dual>* out,
                    int capacity, std::string& msg, double emit_above = -kEmitAll,
                    bool merge_repeats = false);

}  // namespace gm
