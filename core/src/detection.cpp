// Contact detection: helical and spur, external and internal, both flanks, slices, tilts (two
// steps), micro-geometry, tip contact, contact velocities (docs/physics.md §3).
#include "detection.hpp"
#include "touch_point.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <Eigen/Geometry>

#include "gearmesh/internal/geometry.hpp"
#include "gearmesh/internal/hertz.hpp"

namespace gm {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kMaxSlices = 200;  // = the parameter range of model.slices

// The stages of detect_impl are inlined into it: called out of line, the frame they share
// escapes and every read of it becomes a reload (measured 1.5-3 % on the 1-slice evaluation).
#if defined(__GNUC__)
#define GM_STAGE inline __attribute__((always_inline))
#else
#define GM_STAGE inline
#endif

// Integer part n and fraction f of x / period with x = n period + f, 0 <= f < period.
template <class T>
void split_periods(const T& x, double period, double& n, T& f) {
  n = std::floor(val(x) / period);
  f = x - n * period;
  if (f < 0) f = 0;
  if (f >= period) f = std::nextafter(period, 0.0);
}

// Tooth index in [0, z) of the tooth m periods after the reference one (n and m are whole and
// finite: detect_impl refuses spins beyond GM_MAX_SPIN_ANGLE before they get here).
// Spins are at most GM_MAX_SPIN_ANGLE (1e7 rad), so |m - n| < 1e7 z / (2 pi) + 2: far inside a
// long long, and the remainder is integer arithmetic.
int tooth_index(double n, double m, int sigma, int z) {
  const double periods = sigma * (m - n);
  if (!(std::fabs(periods) < 9e15)) return 0;  // NaN or huge: never cast (unreachable)
  long long k = static_cast<long long>(periods) % z;
  if (k < 0) k += z;
  return static_cast<int>(k);
}

template <class T>
T wrap_angle(const T& x) { return x - 2 * kPi * std::nearbyint(val(x) / (2 * kPi)); }

template <class T>
using Vec2 = Eigen::Matrix<T, 2, 1>;
template <class T>
using Vec3 = Eigen::Matrix<T, 3, 1>;

template <class T>
Vec2<T> unit(const T& angle) {
  GM_AD_USING;
  return {cos(angle), sin(angle)};
}

// geometry.hpp's functions over the scalar type (the double ones are used as they are).
inline double op_pressure_angle(double rb1, double rb2, bool internal, double a) {
  return operating_pressure_angle(rb1, rb2, internal, a);
}
inline Dual op_pressure_angle(double rb1, double rb2, bool internal, const Dual& a) {
  const double c = (internal ? rb2 - rb1 : rb1 + rb2) / a.v;
  const double alpha = operating_pressure_angle(rb1, rb2, internal, a.v);
  // d alpha/da = c / (a sin alpha)
  return {alpha, c / (a.v * std::sin(alpha)) * a.d};
}
inline double involute_t(double alpha) { return involute(alpha); }
inline Dual involute_t(const Dual& alpha) {
  const double t = std::tan(alpha.v);
  return {involute(alpha.v), t * t * alpha.d};
}
inline double micro_gap(const GearMicrogeometry& m, int flank, int tooth, double rho, double y) {
  return flank_gap(m, flank, tooth, rho, y);
}
inline Dual micro_gap(const GearMicrogeometry& m, int flank, int tooth, const Dual& rho,
                      const Dual& y) {
  double d_rho = 0, d_y = 0;
  const double g = flank_gap_slope(m, flank, tooth, rho.v, y.v, d_rho, d_y);
  return {g, d_rho * rho.d + d_y * y.d};
}

// A gear's axis in H: its centre in the plane z is c + (z - c_z) slope (first order in tilt).
template <class T>
struct Axis {
  Vec3<T> c;
  Vec2<T> slope;
};

// The transverse frame of one slice plane (trivially constructible: an array of them is
// scratch on the stack, filled only for the slices of a tilted pair).
template <class T>
struct Section {
  T z;                      // plane, m
  Vec2<T> c[2];             // gear centres in the plane, m
  T gamma;                  // direction of the centre line, rad
  T alpha_w;                // operating pressure angle of this plane, rad
  T T1T2;                   // m
  T t_lo, t_hi;             // active contact positions from T1, m
  bool tip1_ends;           // t_hi is gear 1's tip (beyond it: gear 1's tip edge)
  bool tip2_starts;         // t_lo is gear 2's tip (before it: gear 2's tip edge)
  // per flank [0] A, [1] B: line of action direction (force on gear 2), tangency point T1,
  // and the unit vector from T1 towards gear 1's centre (towards gear 1's root along the profile)
  Vec2<T> n_line[2], T1[2], to_root1[2];
};

template <class T>
bool make_section(const MeshLayout& L, const Axis<T> ax[2], const T& z, Section<T>& S,
                  std::string& msg) {
  GM_AD_USING;
  S.z = z;
  for (int i = 0; i < 2; ++i) S.c[i] = ax[i].c.template head<2>() + (z - ax[i].c.z()) * ax[i].slope;
  const Vec2<T> d = S.c[1] - S.c[0];
  const T a = d.norm();
  S.gamma = atan2(d.y(), d.x());
  S.alpha_w = op_pressure_angle(L.base_radius[0], L.base_radius[1], L.sign < 0, a);
  if (!std::isfinite(val(S.alpha_w))) {
    char buf[220];
    std::snprintf(buf, sizeof buf,
                  "centre distance %.6g m at z = %.6g m (from the gear positions and tilts) is "
                  "below the base-circle limit %.6g m: the gears cannot mesh there",
                  val(a), val(z),
                  L.sign > 0 ? L.base_radius[0] + L.base_radius[1]
                             : L.base_radius[1] - L.base_radius[0]);
    msg = buf;
    return false;
  }
  S.T1T2 = a * sin(S.alpha_w);
  // Gear 1 between its form and tip circles, gear 2 likewise, with rho_2 = T1T2 - s t.
  const T hi1 = L.rho_tip[0];
  const T hi2 = L.sign > 0 ? T(S.T1T2 - L.rho_form[1]) : T(L.rho_form[1] - S.T1T2);
  const T lo1 = L.rho_form[0];
  const T lo2 = L.sign > 0 ? T(S.T1T2 - L.rho_tip[1]) : T(L.rho_tip[1] - S.T1T2);
  S.t_hi = fmin(hi1, hi2);
  S.t_lo = fmax(lo1, lo2);
  S.tip1_ends = hi1 <= hi2;
  S.tip2_starts = lo2 >= lo1;
  const T cg = cos(S.gamma), sg = sin(S.gamma);
  const T sa = sin(S.alpha_w), ca = cos(S.alpha_w);
  for (int f = 0; f < 2; ++f) {
    const int sigma = f == 0 ? 1 : -1;
    const T nx = L.sign * sa, ny = (L.sign * sigma) * ca;
    S.n_line[f] = Vec2<T>(cg * nx - sg * ny, sg * nx + cg * ny);
    const Vec2<T> e = unit<T>(S.gamma + L.zeta[0] - sigma * S.alpha_w);
    S.T1[f] = S.c[0] + L.base_radius[0] * e;
    S.to_root1[f] = -e;
  }
  return true;
}

// Penetration of point p into the flank sigma of the tooth (ring: space) of gear h whose
// centreline lies at angle theta_c, measured along that flank's involute normal: involutes of
// one base circle are parallel curves, so the distance is r_b times their angle difference.
// Also returns the normal line's tangency point and the roll distance of p on it.
template <class T>
bool involute_penetration(const MeshLayout& L, int h, int sigma, const T& theta_c,
                          const Vec2<T>& centre, const Vec2<T>& p, T& pen, Vec2<T>& tangency,
                          T& roll) {
  GM_AD_USING;
  const double rb = L.base_radius[h];
  const Vec2<T> d = p - centre;
  const T r = d.norm();
  if (r <= rb) return false;
  const T alpha_r = acos(rb / r);
  const T theta_p = atan2(d.y(), d.x());
  const T into_tooth = rb * (sigma * wrap_angle<T>(theta_c - theta_p) + L.eta[h] -
                             involute_t(alpha_r));
  const bool ring = h == 1 && L.sign < 0;  // for the ring the "tooth" is the space
  pen = ring ? -into_tooth : into_tooth;
  tangency = centre + rb * unit<T>(theta_p - sigma * alpha_r);
  roll = rb * tan(alpha_r);
  return true;
}

}  // namespace

MeshLayout make_mesh_layout(const gm_model_params& p, const gm_pair_geometry& g,
                            GearMicrogeometry micro1, GearMicrogeometry micro2) {
  MeshLayout L;
  L.sign = p.pair.internal ? -1 : 1;
  L.base_pitch = g.p_bt;
  L.center_distance = p.pair.center_distance;
  L.slices = p.slices;
  L.tan_beta_b = std::tan(g.beta_b);
  L.cos_beta_b = std::cos(g.beta_b);
  L.sin_beta_b = std::sin(g.beta_b);
  const int hand1 = p.pair.helix_angle > 0 ? 1 : (p.pair.helix_angle < 0 ? -1 : 0);
  L.hand[0] = hand1;
  L.hand[1] = L.sign > 0 ? -hand1 : hand1;  // external: opposite hands; internal: same hand
  const double inv_w = involute(g.alpha_wt);
  for (int i = 0; i < 2; ++i) {
    const gm_gear_geometry& gi = g.gear[i];
    L.teeth[i] = p.gear[i].teeth;
    L.base_radius[i] = 0.5 * gi.d_b;
    L.tip_radius[i] = 0.5 * gi.d_a;
    L.inv_tip[i] = involute(std::acos(gi.d_b / gi.d_a));
    const double alpha_a = std::acos(gi.d_b / gi.d_a);
    // The tooth narrows towards its tip, a ring's too (its tooth widens outwards, to its root),
    // so the tip corner's interior angle is pi/2 + alpha_a on both gears.
    L.corner_near_field[i] = corner_near_field(0.5 * kPi + alpha_a);
    L.eta[i] = gi.eta_b;
    L.rho_tip[i] = gi.rho_a;
    L.rho_form[i] = gi.rho_Ff;
    L.face_width[i] = p.gear[i].face_width;
    L.axial_offset[i] = p.gear[i].axial_offset;
    // External: the mesh lies at +x of gear 1 and at -x of gear 2. Internal: the pinion sits
    // inside the ring at the ring's -x side, so both see the mesh at -x.
    L.zeta[i] = (i == 0 && L.sign > 0) ? 0.0 : kPi;
    // Reference configuration (docs/physics.md §0): at phi = 0 the flank A involutes of tooth 0 and of
    // tooth (space) 0 meet at the pitch point, rho_i = r_bi tan alpha_wt, in the plane of the
    // gear centres.
    L.theta0[i] = L.zeta[i] + inv_w - L.eta[i];
  }
  L.micro[0] = std::move(micro1);
  L.micro[1] = std::move(micro2);
  return L;
}

int slice_capacity(const MeshLayout& L) {
  // Tooth pairs per flank: the active span in base pitches, widened by the helical spread over
  // the face and by the margins of the enumeration (tip contact beyond both path ends).
  const double span1 = L.rho_tip[0] - L.rho_form[0];
  const double span2 = std::fabs(L.rho_tip[1] - L.rho_form[1]);
  const double spread = L.tan_beta_b * std::min(L.face_width[0], L.face_width[1]);
  const int pairs =
      static_cast<int>(std::ceil((std::min(span1, span2) + spread) / L.base_pitch)) + 5;
  return 2 * pairs * L.slices;
}

namespace {

// The spins detection takes: the period split below casts tooth counts to int, so only finite
// spins in range get there.
template <class K>
bool spins_in_range(const K& kin, std::string& msg) {
  for (int i = 0; i < 2; ++i) {
    if (!(std::fabs(val(kin.phi[i])) <= GM_MAX_SPIN_ANGLE)) {
      char buf[160];
      std::snprintf(buf, sizeof buf, "gear%d.phi = %g rad: outside the allowed range [-%g, %g] rad",
                    i + 1, val(kin.phi[i]), GM_MAX_SPIN_ANGLE, GM_MAX_SPIN_ANGLE);
      msg = buf;
      return false;
    }
  }
  return true;
}

// The slices of one evaluation: the axes, the axial overlap split into equal slices, the
// section in the middle of the overlap (coarse step: it finds the candidate pairs) and, when
// tilted, each slice's own section (fine step; aligned slices share `mid`). Trivially
// constructible like Section: scratch on the stack.
template <class T>
struct SliceFrame {
  Axis<T> ax[2];
  bool aligned;           // no tilt (dual numbers: nor a tilting direction)
  T zlo, zhi, width, z_mid;
  Section<T> mid;
  Section<T> sections[kMaxSlices];
  double tilt_margin;     // how far the slices' sections move the path (a decision bound: values)
};

// 1 with F made, 0 when the face widths do not overlap, -1 with msg set.
template <class T, class K>
GM_STAGE int make_frame(const MeshLayout& L, const K& kin, SliceFrame<T>& F, std::string& msg) {
  GM_AD_USING;
  Axis<T>* ax = F.ax;
  for (int i = 0; i < 2; ++i) {
    ax[i].c = Vec3<T>(kin.u[i][0] + (i == 1 ? L.center_distance : 0.0), kin.u[i][1],
                      kin.u[i][2]);
    // axis direction exp([r_x, r_y, 0]^) e_z = (r_y, -r_x, 1) to first order
    ax[i].slope = Vec2<T>(kin.r[i][1], -kin.r[i][0]);
  }
  F.aligned = identical(T(kin.r[0][0]), T(0.0)) && identical(T(kin.r[0][1]), T(0.0)) &&
              identical(T(kin.r[1][0]), T(0.0)) && identical(T(kin.r[1][1]), T(0.0));
  // Equal face ends (equal widths, aligned) are a kink: fmax/fmin give the derivative on the
  // side the seed points to.
  const T z1lo = ax[0].c.z() + L.axial_offset[0] - 0.5 * L.face_width[0];
  const T z2lo = ax[1].c.z() + L.axial_offset[1] - 0.5 * L.face_width[1];
  F.zlo = fmax(z1lo, z2lo);
  F.zhi = fmin(T(z1lo + L.face_width[0]), T(z2lo + L.face_width[1]));
  if (F.zhi <= F.zlo) return 0;
  F.width = (F.zhi - F.zlo) / L.slices;
  F.z_mid = 0.5 * (F.zlo + F.zhi);
  if (!make_section<T>(L, ax, F.z_mid, F.mid, msg)) return -1;
  F.tilt_margin = 0;
  if (!F.aligned) {
    for (int k = 0; k < L.slices; ++k) {
      Section<T>& S = F.sections[k];
      if (!make_section<T>(L, ax, T(F.zlo + (k + 0.5) * F.width), S, msg)) return -1;
      F.tilt_margin = std::max(
          F.tilt_margin, (L.base_radius[0] + L.base_radius[1]) *
                               (std::fabs(val(S.gamma) - val(F.mid.gamma)) +
                                std::fabs(val(S.alpha_w) - val(F.mid.alpha_w))) +
                           std::fabs(val(S.T1T2) - val(F.mid.T1T2)));
    }
  }
  return 1;
}

// The contact of one slice of a tooth pair (aligned spur slices differ only in z: computed once
// per pair). dz1, dz2: the tilted helical gears' body heights off the slice plane.
template <class T>
struct SliceContact {
  Vec2<T> n_t, point;
  T roll1 = 0, roll2 = 0, rigid = 0, dz1 = 0, dz2 = 0, path = 0, gain = 0;
  T corner_slope = 0;  // tan of the angle between the corner's own flank and the mate's (a tip corner)
  int kind = kFlankContact;
  bool contact = false;
};

// Tip (corner) contact outside the path: the tip edge of one gear against the mate's flank,
// with the mate's involute normal (paper 2.1; docs/physics.md §3). A tip edge penetrates at most
// as far as the flanks overlap on the line of action (conjugate action makes its penetration
// fall off the line): no overlap, no candidate. t: the flank contact position from T1.
template <class T>
void tip_contact(const MeshLayout& L, const Section<T>& S, int sigma, const T& rho1, const T& rho2,
                 const T& t, SliceContact<T>& G) {
  GM_AD_USING;
  const int s = L.sign;
  const double rb2 = L.base_radius[1];
  const int g = t > S.t_hi ? 0 : 1, h = 1 - g;
  const T theta_rel1 = sigma * (rho1 / L.base_radius[0] - L.eta[0] - S.alpha_w);
  const T theta_rel2 = sigma * (rho2 / rb2 - L.eta[1] - S.alpha_w);
  const T theta_c[2] = {S.gamma + L.zeta[0] + theta_rel1, S.gamma + L.zeta[1] + theta_rel2};
  const T theta_corner = theta_c[g] + sigma * (L.eta[g] - L.inv_tip[g]);
  const Vec2<T> corner = S.c[g] + L.tip_radius[g] * unit<T>(theta_corner);
  T pen, roll_h;
  Vec2<T> tangency;
  G.contact = involute_penetration<T>(L, h, sigma, theta_c[h], S.c[h], corner, pen, tangency,
                                      roll_h) &&
              pen > 0;  // an open tip edge carries nothing: not a candidate
  if (!G.contact) return;
  G.rigid = pen;
  G.kind = g == 0 ? kTipOfGear1 : kTipOfGear2;
  G.roll1 = g == 0 ? T(L.rho_tip[0]) : roll_h;
  G.roll2 = g == 0 ? roll_h : T(L.rho_tip[1]);
  // outward normal of the mate's material; the force on gear 2 follows from it
  const bool ring_h = h == 1 && s < 0;
  const Vec2<T> out_h = (ring_h ? -1.0 : 1.0) * (corner - tangency).normalized();
  G.n_t = g == 0 ? Vec2<T>(-out_h) : out_h;
  G.point = corner;
  // The corner's own flank leaves the mate's at delta (docs/physics.md §4): its involute normal
  // is the radius turned by +-(pi/2 - alpha_a) (tangent to the base circle; which sign is the
  // flank's, the nearer of the two to the mate's normal), and tan(delta) = |n x m| / |n . m|.
  {
    const double turn = 0.5 * kPi - std::acos(L.base_radius[g] / L.tip_radius[g]);
    T best = T(1e300);
    for (const double side : {1.0, -1.0}) {
      const Vec2<T> n_own = unit<T>(theta_corner + side * turn);
      const T cross = fabs(n_own.x() * out_h.y() - n_own.y() * out_h.x());
      const T dot = fabs(n_own.dot(out_h));
      const T slope = cross / dot;
      if (slope < best) best = slope;
    }
    // rounded over its first kCornerSlopeOnset so that it starts with zero slope where a contact
    // moves onto the corner (tan(delta) grows in proportion to the turn past the path's end): the
    // local law's slope in the pose stays continuous there, as the integrator and the step's
    // derivative need (laws.hpp, the near field's blend)
    G.corner_slope = best < kCornerSlopeOnset ? best * best / (2.0 * kCornerSlopeOnset)
                                              : best - 0.5 * kCornerSlopeOnset;
  }
  G.path = g == 0 ? 1.0 : 0.0;
  // d(pen)/d(TE): gear 2 turns by dTE/(s r_b2). Against gear 2's flank the involute moves by
  // r_b2 per radian; gear 2's own edge moves along its tip circle.
  G.gain = g == 0 ? T(sigma)
                  : T(-out_h.dot(Vec2<T>(-(corner - S.c[1]).y(), (corner - S.c[1]).x())) /
                      (s * rb2));
}

// The contact of the slice at height z in section S, of the pair whose roll distances in the
// middle section are rho1_mid, rho2_mid, on flank sigma (fl its index).
template <class T>
GM_STAGE void slice_contact(const MeshLayout& L, const SliceFrame<T>& F, const Section<T>& S, int sigma,
                   int fl, const T& rho1_mid, const T& rho2_mid, const T& z, SliceContact<T>& G) {
  const int s = L.sign;
  const double rb1 = L.base_radius[0], rb2 = L.base_radius[1];
  const double tb = L.tan_beta_b;
  const Section<T>& mid = F.mid;
  const T dz = z - F.z_mid;
  // Roll distances in this slice's section: helical turn and the section's own frame.
  T rho1 = rho1_mid + (sigma * L.hand[0] * tb) * dz;
  T rho2 = rho2_mid + (sigma * L.hand[1] * tb) * dz;
  const Vec2<T>& n_line = S.n_line[fl];
  const Vec2<T>& T1 = S.T1[fl];
  if (!F.aligned) {
    rho1 += rb1 * (-sigma * (S.gamma - mid.gamma) + (S.alpha_w - mid.alpha_w));
    rho2 += rb2 * (-sigma * (S.gamma - mid.gamma) + (S.alpha_w - mid.alpha_w));
    if (tb != 0) {
      // A tilted helical gear meets the slice plane at body height z + r x (X - c):
      // the contact point X sits a pitch radius off the axis, so this is first order.
      const T t0 = rho1 - 0.5 * (rho1 + s * rho2 - s * S.T1T2);
      const Vec2<T> X = T1 + t0 * n_line;
      G.dz1 = F.ax[0].slope.dot(X - F.ax[0].c.template head<2>());
      G.dz2 = F.ax[1].slope.dot(X - F.ax[1].c.template head<2>());
      rho1 += (sigma * L.hand[0] * tb) * G.dz1;
      rho2 += (sigma * L.hand[1] * tb) * G.dz2;
    }
  }
  G.rigid = rho1 + s * rho2 - s * S.T1T2;
  const T t = rho1 - 0.5 * G.rigid;  // contact midway between the two flanks
  G.contact = true;
  G.kind = kFlankContact;
  G.corner_slope = 0;
  if (t >= S.t_lo && t <= S.t_hi) {
    G.roll1 = t;
    G.roll2 = S.T1T2 - s * t;
    G.n_t = n_line;
    G.point = T1 + t * n_line;
    G.path = (t - S.t_lo) / (S.t_hi - S.t_lo);
    G.gain = T(sigma);  // d(Delta_t)/d(TE): rho_2 moves with phi_2 (docs/physics.md §3)
  } else if (G.rigid > 0 && ((t > S.t_hi && S.tip1_ends) || (t < S.t_lo && S.tip2_starts))) {
    tip_contact(L, S, sigma, rho1, rho2, t, G);
  } else {
    G.contact = false;
  }
}

// The input velocities: each gear's angular velocity and centre velocity.
template <class T>
struct Motion {
  Vec3<T> omega[2], vc[2];
};

// One candidate slice from its contact: its approach along the normal, point, normal, contact
// velocities and profile tangent.
template <class T>
GM_STAGE void fill_slice(const MeshLayout& L, const SliceFrame<T>& F, const Section<T>& S,
                const Motion<T>& mo, const SliceContact<T>& G, int sigma, int fl, const T& z,
                const T& approach_t, ContactSliceT<T>& c) {
  c.flank = sigma;
  c.kind = G.kind;
  c.approach = approach_t * L.cos_beta_b;
  c.width = F.width;
  c.roll[0] = G.roll1;
  c.roll[1] = G.roll2;
  c.point = Vec3<T>(G.point.x(), G.point.y(), z);
  // The flank normal lies in the plane of action, inclined by beta_b to the transverse
  // plane; its axial part follows the helix hand of gear 1.
  c.normal = Vec3<T>(L.cos_beta_b * G.n_t.x(), L.cos_beta_b * G.n_t.y(),
                     T(-sigma * L.hand[0] * L.sin_beta_b));
  // Contact velocities from the input velocities (rigid bodies, small tilts).
  const Vec3<T> v1 = mo.vc[0] + mo.omega[0].cross(c.point - F.ax[0].c);
  const Vec3<T> v2 = mo.vc[1] + mo.omega[1].cross(c.point - F.ax[1].c);
  c.approach_rate = (v1 - v2).dot(c.normal);
  // profile tangent: perpendicular to the transverse normal, towards gear 1's root
  Vec2<T> tan2(-G.n_t.y(), G.n_t.x());
  if (tan2.dot(S.to_root1[fl]) < 0) tan2 = -tan2;
  c.tangent = Vec3<T>(tan2.x(), tan2.y(), T(0));
  c.sliding_velocity = (v1 - v2).dot(c.tangent);
  c.te_gain = G.gain * L.cos_beta_b;
  c.path_position = G.path;
  c.corner_slope = G.corner_slope;
}

// The next slice of an aligned spur pair: the pair's first slice moved along the face to z,
// with its own normal approach. Only the contact velocities change, by
// (omega_1 - omega_2) x (0, 0, dz).
template <class T>
GM_STAGE void shift_slice(const ContactSliceT<T>& first, const Motion<T>& mo, const T& z,
                          const T& approach_n, ContactSliceT<T>& c) {
  c = first;
  const T dz = z - first.point.z();
  const Vec3<T> dv((mo.omega[0].y() - mo.omega[1].y()) * dz,
                   (mo.omega[1].x() - mo.omega[0].x()) * dz, T(0));
  c.point.z() = z;
  c.approach = approach_n;
  c.approach_rate = first.approach_rate + dv.dot(first.normal);
  c.sliding_velocity = first.sliding_velocity + dv.dot(first.tangent);
}

// The approach beyond the detection range (a quarter base pitch): msg set.
template <class T>
void approach_too_large(const MeshLayout& L, int sigma, const T& approach_t, std::string& msg) {
  char buf[240];
  std::snprintf(buf, sizeof buf,
                "flank %c approach %.6g m exceeds the detection range (a quarter base "
                "pitch, %.6g m): the gear poses (phi, u, r inputs) are not physical",
                sigma > 0 ? 'A' : 'B', val(approach_t), 0.25 * L.base_pitch);
  msg = buf;
}

template <class T, class K>
int detect_impl(const MeshLayout& L, const K& kin, ContactSliceT<T>* out, int capacity,
                std::string& msg, double emit_above, bool merge_repeats) {
  GM_AD_USING;
  if (!spins_in_range(kin, msg)) return -1;
  SliceFrame<T> F;
  const int framed = make_frame(L, kin, F, msg);
  if (framed <= 0) return framed;
  const Section<T>& mid = F.mid;
  const int s = L.sign;
  const double pb = L.base_pitch;
  const double rb1 = L.base_radius[0], rb2 = L.base_radius[1];
  const double tau1 = 2 * kPi / L.teeth[0], tau2 = 2 * kPi / L.teeth[1];
  const double tb = L.tan_beta_b;
  const double margin = pb + 0.5 * tb * val(F.zhi - F.zlo) + F.tilt_margin;
  const bool uniform = F.aligned && tb == 0;  // every slice has the same section and roll distances
  const bool micro = L.micro[0].any || L.micro[1].any;  // approaches that vary over the face
  Motion<T> mo;
  mo.omega[0] = Vec3<T>(kin.w[0][0], kin.w[0][1], kin.omega[0]);
  mo.omega[1] = Vec3<T>(kin.w[1][0], kin.w[1][1], kin.omega[1]);
  mo.vc[0] = Vec3<T>(kin.v[0][0], kin.v[0][1], kin.v[0][2]);
  mo.vc[1] = Vec3<T>(kin.v[1][0], kin.v[1][1], kin.v[1][2]);
  // every slice of a pair repeats its first (the contact velocities alike too: no tilt rate
  // between the gears, by value): one slice of the summed width at the mean face position
  const bool one_per_pair = merge_repeats && uniform && !micro && L.slices > 1 &&
                            val(mo.omega[0].x()) == val(mo.omega[1].x()) &&
                            val(mo.omega[0].y()) == val(mo.omega[1].y());

  int count = 0, pair = 0;
  for (int sigma = 1; sigma >= -1; sigma -= 2) {
    const int fl = sigma > 0 ? 0 : 1;  // flank index for the micro-geometry
    const bool touch = touch_applies(L, fl);
    // Reduce the unbounded angles to a period so that roll distances keep full precision. The
    // helical sections turn by h_i y_i tan(beta_b)/r_bi, y_i along gear i's axis from its centre.
    double n1, n2;
    T f1, f2;
    split_periods(sigma * (L.theta0[0] + kin.phi[0] +
                           L.hand[0] * (F.z_mid - F.ax[0].c.z()) * tb / rb1 - mid.gamma - L.zeta[0]),
                  tau1, n1, f1);
    split_periods(sigma * (L.theta0[1] + kin.phi[1] +
                           L.hand[1] * (F.z_mid - F.ax[1].c.z()) * tb / rb2 - mid.gamma - L.zeta[1]),
                  tau2, n2, f2);
    const T base1 = rb1 * (f1 + L.eta[0] + mid.alpha_w);  // rho_1 = base1 + m1 p_bt
    const T base2 = rb2 * (f2 + L.eta[1] + mid.alpha_w);  // rho_2 = base2 + m2 p_bt
    const double m_first = std::ceil((val(mid.t_lo) - margin - val(base1)) / pb);
    const double m_last = std::floor((val(mid.t_hi) + margin - val(base1)) / pb);
    for (double m1 = m_first; m1 <= m_last; m1 += 1) {
      const T rho1_mid = base1 + m1 * pb;
      const double m2 = std::nearbyint(val(mid.T1T2 - s * rho1_mid - base2) / pb);
      const T rho2_mid = base2 + m2 * pb;
      int tooth1 = -1, tooth2 = -1;  // found at the pair's first contact
      int first = -1;                // the pair's first slice
      bool emitted = false;
      SliceContact<T> G;
      T touch_growth = 0;
      bool touch_known = false;
      for (int k = 0; k < L.slices; ++k) {
        const Section<T>& S = F.aligned ? mid : F.sections[k];
        const T z = F.zlo + (k + 0.5) * F.width;
        if (!uniform || k == 0) slice_contact(L, F, S, sigma, fl, rho1_mid, rho2_mid, z, G);
        if (!G.contact) {
          if (uniform) break;
          continue;
        }
        T approach_t = G.rigid;
        // face coordinates from each gear's mid-face
        const T y1 = z - F.ax[0].c.z() + G.dz1 - L.axial_offset[0];
        const T y2 = z - F.ax[1].c.z() + G.dz2 - L.axial_offset[1];
        if (tooth1 < 0) {
          tooth1 = tooth_index(n1, m1, sigma, L.teeth[0]);
          tooth2 = tooth_index(n2, m2, sigma, L.teeth[1]);
        }
        // micro-geometry gaps are along the flank normal (docs/physics.md §2): Delta_n = Delta_t cos(beta_b) - gap
        if (L.micro[0].any) approach_t -= micro_gap(L.micro[0], fl, tooth1, G.roll1, y1) / L.cos_beta_b;
        if (L.micro[1].any) approach_t -= micro_gap(L.micro[1], fl, tooth2, G.roll2, y2) / L.cos_beta_b;
        // where modified flanks touch: the same for every slice of an aligned spur pair
        if (touch && G.kind == kFlankContact) {
          if (!uniform || k == 0 || !touch_known) touch_growth = touch_gain(L, fl, G.roll1, G.roll2);
          touch_known = true;
          approach_t += touch_growth;
        }
        if (approach_t > 0.25 * pb) {
          approach_too_large(L, sigma, approach_t, msg);
          return -1;
        }
        if (val(approach_t) * L.cos_beta_b <= emit_above) {  // cannot carry load
          if (uniform && !micro) break;  // nor can the pair's other slices, all alike
          continue;
        }
        if (count >= capacity) {
          msg = "more candidate slices than the model's capacity: the tilts are far outside "
                "the small-tilt range of the detection";
          return -1;
        }
        ContactSliceT<T>& c = out[count++];
        if (uniform && emitted) {
          shift_slice(out[first], mo, z, T(approach_t * L.cos_beta_b), c);
          c.slice = k;
          continue;
        }
        fill_slice(L, F, S, mo, G, sigma, fl, z, approach_t, c);
        c.tooth[0] = tooth1;
        c.tooth[1] = tooth2;
        c.pair = pair;
        c.slice = k;
        c.run = 1;
        first = count - 1;
        emitted = true;
        if (one_per_pair) {
          const ContactSliceT<T> one = c;
          shift_slice(one, mo, T(F.zlo + (0.5 * L.slices) * F.width), c.approach, c);
          c.width = one.width * double(L.slices);
          c.run = L.slices;
          break;
        }
      }
      pair += emitted;
    }
  }
  return count;
}

}  // namespace

int detect_contacts(const MeshLayout& L, const gm_kinematics& kin, ContactSlice* out, int capacity,
                    std::string& msg, double emit_above, bool merge_repeats) {
  return detect_impl<double>(L, kin, out, capacity, msg, emit_above, merge_repeats);
}

int detect_contacts(const MeshLayout& L, const KinematicsT<Dual>& kin, ContactSliceT<Dual>* out,
                    int capacity, std::string& msg, double emit_above, bool merge_repeats) {
  return detect_impl<Dual>(L, kin, out, capacity, msg, emit_above, merge_repeats);
}

}  // namespace gm
