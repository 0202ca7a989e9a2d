// Involute gear and pair geometry (ISO 21771; docs/physics.md §1).
//
// Sign convention inside this file only: ISO 21771's signed form for the internal ring, z2 < 0,
// so d2, d_b2, d_a2, d_f2, d_w2, the reference centre distance a_d and the operating centre
// distance a are negative for an internal pair and one set of formulas serves both kinds. The
// gm_pair_geometry outputs are magnitudes. In this convention x > 0 thickens the tooth at d for
// both kinds (the ring's tip then moves towards its axis: |d_a2| = |d2| - 2 m_n (h_aP* + x2)).
//
// Profile shift with allowance: the teeth are generated at x_E = x + E_sn/(2 m_n tan alpha_n)
// (DIN 3960 "Erzeugungs-Profilverschiebung"), so x_E sets the thickness, the root and form
// circles and the undercut limit; x alone sets the tip diameter from the basic rack.

#include "gearmesh/internal/geometry.hpp"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <limits>

#include "params.hpp"

namespace gm {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Backlash tolerance in modules: shift coefficients quoted to 4 decimals move j_bt by up to
// 2 m_n sin(alpha_n) 1e-4 ~ 0.7e-4 m_n (docs/physics.md §1's FZG C14 set sits 1.3e-5 m_n below zero).
constexpr double kBacklashTolerance = 1e-4;

std::string format(const char* fmt, ...) {
  char buf[512];
  va_list args;
  va_start(args, fmt);
  std::vsnprintf(buf, sizeof buf, fmt, args);
  va_end(args);
  return buf;
}

// Arc tooth thickness at signed diameter d_y (ISO 21771 tooth thickness; docs/physics.md §1):
// s_yt = d_y (s_t/d + inv alpha_t - inv alpha_yt).
// Positive for a real tooth of either kind (the ring's d_y/d > 0 and its tooth thickens outwards).
double thickness_at(double d_y, double d, double d_b, double s_t, double alpha_t) {
  const double alpha_yt = std::acos(std::min(1.0, d_b / d_y));
  return d_y * (s_t / d + involute(alpha_t) - involute(alpha_yt));
}

// Roll distance rho_y = 1/2 sqrt(d_y^2 - d_b^2) (docs/physics.md §1); 0 inside the base circle.
double roll_distance(double d_y, double d_b) {
  return 0.5 * std::sqrt(std::max(0.0, d_y * d_y - d_b * d_b));
}

// Per-gear working values in the signed convention.
struct Gear {
  double z, x, x_E, d, d_b, d_a, d_f, s_t;
};

}  // namespace

double involute(double alpha) { return std::tan(alpha) - alpha; }

double inverse_involute(double q) {
  if (!(q >= 0.0) || !std::isfinite(q)) return kNaN;
  if (q == 0.0) return 0.0;
  // Both starts lie right of the root (inv a > a^3/3, and tan a > q + pi/2 gives inv a > q) and
  // below pi/2, so Newton on the convex, increasing inv descends monotonically onto the root.
  double alpha = std::min(std::cbrt(3.0 * q), std::atan(q + 0.5 * kPi));
  for (int i = 0; i < 60; ++i) {
    const double t = std::tan(alpha);
    const double step = (t - alpha - q) / (t * t);  // inv'(a) = tan^2 a
    if (!(step > 0.0)) break;                       // at the rounding floor
    alpha -= step;
    if (step <= 1e-15 * alpha) break;
  }
  return alpha;
}

double operating_pressure_angle(double r_b1, double r_b2, bool internal, double a) {
  // cos alpha_wt = a_d cos alpha_t / a (ISO 21771 operating pressure angle), where
  // a_d cos alpha_t = r_b1 + r_b2 (external) or r_b2 - r_b1 (internal, magnitudes).
  const double c = (internal ? r_b2 - r_b1 : r_b1 + r_b2) / a;
  if (!(c > 0.0 && c <= 1.0)) return kNaN;
  return std::acos(c);
}

namespace {

// compute_pair_geometry's working state, filled step by step (each step below in the order the
// checks are made; a step returns GM_ERR_PARAMETER with msg set, or GM_OK).
struct PairWork {
  const gm_model_params& p;
  gm_pair_geometry& g;
  std::string& msg;
  bool internal = false;
  double m_n = 0, alpha_n = 0, beta = 0, tan_an = 0;
  double a = 0;    // centre distance, magnitude, as given
  double a_s = 0;  // signed (ISO 21771: negative for internal pairs)
  double m_t = 0, alpha_t = 0, inv_t = 0;
  Gear w[2] = {};
  double r_b1 = 0, r_b2 = 0, rho_a1 = 0, rho_a2 = 0;
  double z_sum = 0, a_d = 0;
  bool tight_exists = false;
  double alpha_wt = 0;
  double A = 0, E = 0;  // line of action: start and end of the path of contact from T1

  gm_status fail(std::string text) {
    msg = std::move(text);
    return GM_ERR_PARAMETER;
  }
};

// Transverse basics (ISO 21771 helical gear relations, docs/physics.md §1).
gm_status transverse_basics(PairWork& c) {
  const gm_model_params& p = c.p;
  gm_pair_geometry& g = c.g;
  c.internal = p.pair.internal != 0;
  c.m_n = p.pair.normal_module;
  c.alpha_n = p.pair.pressure_angle;
  c.beta = std::abs(p.pair.helix_angle);
  c.tan_an = std::tan(c.alpha_n);
  c.a = p.pair.center_distance;
  c.a_s = c.internal ? -c.a : c.a;
  c.m_t = c.m_n / std::cos(c.beta);
  c.alpha_t = std::atan(c.tan_an / std::cos(c.beta));
  c.inv_t = involute(c.alpha_t);
  g.m_t = c.m_t;
  g.alpha_t = c.alpha_t;
  g.beta_b = std::asin(std::sin(c.beta) * std::cos(c.alpha_n));  // sin beta_b = sin beta cos alpha_n
  g.p_bt = kPi * c.m_t * std::cos(c.alpha_t);                    // p_bt = pi m_t cos alpha_t
  g.p_bn = g.p_bt * std::cos(g.beta_b);                          // p_bn = p_bt cos beta_b
  if (c.internal && p.gear[1].teeth - p.gear[0].teeth < 5)
    return c.fail(format("%s = %d: an internal ring needs at least %s + 5 = %d teeth to mesh with the pinion",
                         GM_GEAR_PARAM_NAME(1, teeth), p.gear[1].teeth, GM_GEAR_PARAM_NAME(0, teeth),
                         p.gear[0].teeth + 5));
  return GM_OK;
}

// Each gear's blank in the signed convention.
void gear_blanks(PairWork& c) {
  const double m_n = c.m_n, m_t = c.m_t, tan_an = c.tan_an;
  for (int i = 0; i < 2; ++i) {
    const gm_gear_params& gp = c.p.gear[i];
    const double sgn = (i == 1 && c.internal) ? -1.0 : 1.0;
    Gear& q = c.w[i];
    q.z = sgn * gp.teeth;
    q.x = gp.profile_shift;
    q.x_E = q.x + gp.thickness_allowance / (2.0 * m_n * tan_an);  // docs/physics.md §1, DIN 3960 x_E
    q.d = q.z * m_t;                                               // d = z m_t
    q.d_b = q.d * std::cos(c.alpha_t);                             // d_b = d cos alpha_t
    // Tip and root diameters (ISO 21771 tooth depth; docs/physics.md §1), the root cut at x_E.
    q.d_a = gp.tip_diameter > 0.0 ? sgn * gp.tip_diameter
                                  : q.d + 2.0 * m_n * (c.p.pair.rack_addendum + q.x);
    q.d_f = q.d - 2.0 * m_n * (c.p.pair.rack_dedendum - q.x_E);
    q.s_t = m_t * (0.5 * kPi + 2.0 * q.x_E * tan_an);  // transverse thickness at d (docs/physics.md §1)
  }
}

// Tip feasibility of each gear, and the ring's tip circle outside the pinion's.
gm_status check_tips(PairWork& c) {
  const Gear* w = c.w;
  for (int i = 0; i < 2; ++i) {
    const Gear& q = w[i];
    const char* src =
        c.p.gear[i].tip_diameter > 0.0 ? "" : " (from the basic rack, d + 2 m_n (h_aP* + x))";
    const bool ring = q.z < 0.0;
    if (std::abs(q.d_a) <= std::abs(q.d_b))
      return c.fail(format("%s = %.6g m%s: the tip circle lies inside the base circle; allowed > %.6g m (the base "
                           "diameter)",
                           GM_GEAR_PARAM_NAME(i, tip_diameter), std::abs(q.d_a), src, std::abs(q.d_b)));
    if (q.d_a <= q.d_f)  // signed: also |d_a2| < |d_f2| for the ring
      return c.fail(format("%s = %.6g m%s: no tooth height above the root diameter %.6g m; allowed %s %.6g m",
                           GM_GEAR_PARAM_NAME(i, tip_diameter), std::abs(q.d_a), src, std::abs(q.d_f), ring ? "<" : ">",
                           std::abs(q.d_f)));
    if (!(thickness_at(q.d_a, q.d, q.d_b, q.s_t, c.alpha_t) > 0.0)) {
      // Pointed circle: inv alpha = s_t/d + inv alpha_t (s_yt = 0 above).
      const double alpha_p = inverse_involute(std::max(0.0, q.s_t / q.d + c.inv_t));
      const double d_p = std::abs(q.d_b) / std::cos(alpha_p);
      return c.fail(format("%s = %.6g m%s: the tooth comes to a point before its tip; allowed %s %.6g m (profile "
                           "shift %g)",
                           GM_GEAR_PARAM_NAME(i, tip_diameter), std::abs(q.d_a), src, ring ? ">" : "<", d_p, q.x));
    }
  }
  if (c.internal && std::abs(w[1].d_a) <= w[0].d_a)
    return c.fail(format("%s = %.6g m: the ring's inner tip circle must be larger than the pinion's tip circle; "
                         "allowed > %.6g m",
                         GM_GEAR_PARAM_NAME(1, tip_diameter), std::abs(w[1].d_a), w[0].d_a));
  return GM_OK;
}

// Base radii, tip roll distances, the reference and the tight-mesh centre distance.
void centre_distances(PairWork& c) {
  gm_pair_geometry& g = c.g;
  const Gear* w = c.w;
  c.r_b1 = 0.5 * std::abs(w[0].d_b);
  c.r_b2 = 0.5 * std::abs(w[1].d_b);
  c.rho_a1 = roll_distance(w[0].d_a, w[0].d_b);
  c.rho_a2 = roll_distance(w[1].d_a, w[1].d_b);
  for (int i = 0; i < 2; ++i) g.gear[i].rho_a = i == 0 ? c.rho_a1 : c.rho_a2;
  // Reference centre distance, signed (ISO 21771): a_d = m_t (z1 + z2)/2.
  c.z_sum = w[0].z + w[1].z;
  c.a_d = 0.5 * c.m_t * c.z_sum;
  g.a_d = std::abs(c.a_d);
  // Tight-mesh centre distance (ISO 21771 zero-backlash mesh, with x_E):
  // inv alpha_w = inv alpha_t + 2 tan alpha_n (x_E1 + x_E2)/(z1 + z2),
  // a_tight = a_d cos alpha_t / cos alpha_w. If that involute is <= 0 the backlash never closes
  // (external) / never opens (internal) before the base circles' limit alpha_w = 0, whose
  // distance a_d cos alpha_t stands in for a_tight.
  const double inv_tight = c.inv_t + 2.0 * c.tan_an * (w[0].x_E + w[1].x_E) / c.z_sum;
  c.tight_exists = inv_tight > 0.0;
  const double alpha_tight = c.tight_exists ? inverse_involute(inv_tight) : 0.0;
  g.a_tight = std::abs(c.a_d) * std::cos(c.alpha_t) / std::cos(alpha_tight);
}

// Allowed centre distances for these gears: non-negative backlash and g_alpha > 0. External:
// [a_tight, a_max) with T1T2(a_max) = rho_a1 + rho_a2; internal: (a_min, a_tight] with
// T1T2(a_min) = rho_a2 - rho_a1, since T1T2 = sqrt(a^2 - (r_b2 -+ r_b1)^2) (docs/physics.md §1).
std::string range_text(const PairWork& c) {
  double lo, hi;
  const char *open_lo, *close_hi;
  if (!c.internal) {
    lo = c.g.a_tight;
    hi = std::hypot(c.r_b1 + c.r_b2, c.rho_a1 + c.rho_a2);
    open_lo = c.tight_exists ? "[" : "(";
    close_hi = ")";
  } else {
    lo = std::hypot(c.r_b2 - c.r_b1, std::max(0.0, c.rho_a2 - c.rho_a1));
    hi = c.g.a_tight;
    open_lo = "(";
    close_hi = "]";
    if (!c.tight_exists) hi = 0.0;  // teeth too thick at every centre distance
  }
  if (!(lo < hi))
    return "no centre distance works for these gears (change the profile shifts or tip "
           "diameters)";
  return format("allowed range %s%.6g, %.6g%s m for these gears", open_lo, lo, hi, close_hi);
}

// Operating pressure angle, zero-backlash shift sum and the backlash at the operating pitch
// circles.
gm_status operating_mesh(PairWork& c) {
  gm_pair_geometry& g = c.g;
  const double a = c.a;
  // Operating pressure angle (ISO 21771; docs/physics.md §1): cos alpha_wt = a_d cos alpha_t / a.
  c.alpha_wt = operating_pressure_angle(c.r_b1, c.r_b2, c.internal, a);
  const double alpha_wt = c.alpha_wt;
  if (!(alpha_wt > 0.0))
    return c.fail(format("%s = %.6g m: no operating pressure angle exists (a must exceed %.6g m); %s",
                         GM_PARAM_NAME(pair.center_distance), a, c.internal ? c.r_b2 - c.r_b1 : c.r_b1 + c.r_b2,
                         range_text(c).c_str()));
  g.alpha_wt = alpha_wt;
  const double inv_wt = involute(alpha_wt);
  // Zero-backlash shift sum (ISO 21771, signed z; it applies to x_E1 + x_E2):
  // (z1 + z2)(inv alpha_wt - inv alpha_t)/(2 tan alpha_n).
  g.x_sum_zero_backlash = c.z_sum * (inv_wt - c.inv_t) / (2.0 * c.tan_an);
  // Backlash at the operating pitch circles d_w = d_b / cos alpha_wt (docs/physics.md §1).
  double s_w[2];
  for (int i = 0; i < 2; ++i) {
    const double d_w = c.w[i].d_b / std::cos(alpha_wt);
    g.gear[i].d_w = std::abs(d_w);
    s_w[i] = thickness_at(d_w, c.w[i].d, c.w[i].d_b, c.w[i].s_t, c.alpha_t);
  }
  g.j_wt = kPi * g.gear[0].d_w / c.w[0].z - s_w[0] - s_w[1];  // j_wt = pi d_w1/z1 - s_wt1 - s_wt2
  g.j_bt = g.j_wt * std::cos(alpha_wt);                       // j_bt = j_wt cos alpha_wt
  if (g.j_bt < -kBacklashTolerance * c.m_n)
    return c.fail(format("%s = %.6g m: the teeth overlap (backlash j_bt = %.3g m < 0; tight-mesh distance %.6g m); %s",
                         GM_PARAM_NAME(pair.center_distance), a, g.j_bt, g.a_tight, range_text(c).c_str()));
  return GM_OK;
}

// Line of action from T1 (docs/physics.md §1): external A = T1T2 - rho_a2; internal (the ring's
// tip is its inner circle, T2 lies behind T1) A = rho_a2 - T1T2; E = rho_a1 in both.
gm_status line_of_action(PairWork& c) {
  gm_pair_geometry& g = c.g;
  g.T1T2 = c.a * std::sin(c.alpha_wt);
  c.A = c.internal ? c.rho_a2 - g.T1T2 : g.T1T2 - c.rho_a2;
  c.E = c.rho_a1;
  g.path_start = c.A;
  g.path_end = c.E;
  g.g_alpha = c.E - c.A;
  if (!(g.g_alpha > 0.0))
    return c.fail(format("%s = %.6g m: the tip circles do not overlap on the line of action (path of contact %.3g m "
                         "<= 0); %s",
                         GM_PARAM_NAME(pair.center_distance), c.a, g.g_alpha, range_text(c).c_str()));
  g.eps_alpha = g.g_alpha / g.p_bt;  // eps_alpha = g_alpha / p_bt
  return GM_OK;
}

// Tip clearance: the tip circle must stay off the mate's root circle: a - r_ai - r_fj >= 0
// (signed; gives |r_f2| - r_a1 - |a| and |r_a2| - |a| - r_f1 for the ring).
gm_status check_tip_clearance(PairWork& c) {
  const Gear* w = c.w;
  for (int i = 0; i < 2; ++i) {
    const double cl = c.a_s - 0.5 * w[i].d_a - 0.5 * w[1 - i].d_f;
    if (cl < 0.0) {
      const bool ring = w[i].z < 0.0;
      return c.fail(format("%s = %.6g m: the tip reaches into the root circle of gear %d (tip clearance %.3g m); "
                           "allowed %s %.6g m at %s = %.6g m",
                           GM_GEAR_PARAM_NAME(i, tip_diameter), std::abs(w[i].d_a), 2 - i, cl, ring ? ">=" : "<=",
                           std::abs(2.0 * (c.a_s - 0.5 * w[1 - i].d_f)), GM_PARAM_NAME(pair.center_distance), c.a));
    }
  }
  return GM_OK;
}

// Form circles from the basic rack. h_FfP = m_n (h_fP* - rho_fP* (1 - sin alpha_n))
// (docs/physics.md §1). Rack generation (derived here; ISO 21771 root form diameter for
// rack-type tools): the last generated involute point is where the LOA through the pitch point
// (C at r sin alpha_t from T) meets the end of the straight rack flank, (h_FfP - x_E m_n) inside
// the rolling line, i.e. (h_FfP - x_E m_n)/sin alpha_t short of C:
// rho_Ff = r sin alpha_t - (h_FfP - x_E m_n)/sin alpha_t, r_Ff = sqrt(r_b^2 + rho_Ff^2).
// rho_Ff <= 0 is exactly the undercut condition of docs/physics.md §1 (with x_E).
void form_circles(PairWork& c) {
  const gm_model_params& p = c.p;
  const double m_n = c.m_n;
  const double h_FfP =
      m_n * (p.pair.rack_dedendum - p.pair.rack_tip_radius * (1.0 - std::sin(c.alpha_n)));
  const double sin_at = std::sin(c.alpha_t);
  for (int i = 0; i < 2; ++i) {
    const Gear& q = c.w[i];
    gm_gear_geometry& o = c.g.gear[i];
    const double rho = 0.5 * q.d * sin_at - (h_FfP - q.x_E * m_n) / sin_at;
    if (q.z > 0.0) {
      o.rho_Ff = std::max(0.0, rho);
      // Undercut iff x_E < h_FfP/m_n - z sin^2 alpha_t/(2 cos beta) (docs/physics.md §1), i.e. rho <= 0.
      o.undercut = rho <= 0.0 ? 1 : 0;
    } else {
      // Ring: the mirrored rack (signed r gives |r| sin alpha_t + (h_FfP - x_E m_n)/sin alpha_t,
      // form circle outside the pitch circle). Real rings are cut with pinion cutters, so this
      // is the rack approximation.
      o.rho_Ff = std::abs(rho);
      o.undercut = 0;
    }
    o.d_Ff = 2.0 * std::hypot(0.5 * q.d_b, o.rho_Ff);
  }
}

// Active profile (docs/physics.md §1): gear 1 from A; gear 2 from T1T2 - E (external) or
// T1T2 + E (ring, its outer end). A contact point behind the base circle is clamped to it for
// d_sap and flagged as interference.
void active_profile(PairWork& c) {
  const double rho_sap[2] = {c.A, c.internal ? c.g.T1T2 + c.E : c.g.T1T2 - c.E};
  for (int i = 0; i < 2; ++i) {
    gm_gear_geometry& o = c.g.gear[i];
    o.d_sap = 2.0 * std::hypot(0.5 * std::abs(c.w[i].d_b), std::max(0.0, rho_sap[i]));
    const bool ring = c.w[i].z < 0.0;
    o.interference = ring ? (rho_sap[i] > o.rho_Ff) : (rho_sap[i] < 0.0 || rho_sap[i] < o.rho_Ff);
  }
}

// Per-gear outputs (magnitudes).
void gear_outputs(PairWork& c) {
  for (int i = 0; i < 2; ++i) {
    const Gear& q = c.w[i];
    gm_gear_geometry& o = c.g.gear[i];
    o.d = std::abs(q.d);
    o.d_b = std::abs(q.d_b);
    o.d_a = std::abs(q.d_a);
    o.d_f = std::abs(q.d_f);
    o.x_E = q.x_E;
    o.s_t = q.s_t;
    // Half angle at the base circle (s_yt above at d_y = d_b): tooth s_t/d + inv alpha_t;
    // ring: its space, pi/|z2| + s_t2/d2 + inv alpha_t with d2 < 0.
    o.eta_b = q.z > 0.0 ? q.s_t / q.d + c.inv_t : kPi / std::abs(q.z) + q.s_t / q.d + c.inv_t;
  }
}

// Overlap ratio (ISO 21771; docs/physics.md §1): eps_beta = b sin|beta|/(pi m_n), with b the
// axial overlap of the two face widths after their axial offsets (min(b1, b2) when both are
// centred), the same width the slices cover (docs/physics.md §3).
gm_status overlap_ratio(PairWork& c) {
  const gm_model_params& p = c.p;
  const double lo1 = p.gear[0].axial_offset - 0.5 * p.gear[0].face_width;
  const double lo2 = p.gear[1].axial_offset - 0.5 * p.gear[1].face_width;
  const double b =
      std::min(lo1 + p.gear[0].face_width, lo2 + p.gear[1].face_width) - std::max(lo1, lo2);
  const double half_sum = 0.5 * (p.gear[0].face_width + p.gear[1].face_width);
  if (!(b > 0.0))
    return c.fail(format("%s = %.6g m: the face widths do not overlap; allowed range (%.6g, %.6g) m",
                         GM_GEAR_PARAM_NAME(1, axial_offset), p.gear[1].axial_offset, p.gear[0].axial_offset - half_sum,
                         p.gear[0].axial_offset + half_sum));
  c.g.face_overlap = b;
  c.g.eps_beta = b * std::sin(c.beta) / (kPi * c.m_n);
  return GM_OK;
}

// Nothing above may leave a NaN unnoticed.
gm_status check_finite(PairWork& c) {
  const gm_pair_geometry& g = c.g;
  const double check[] = {g.alpha_wt, g.x_sum_zero_backlash, g.j_bt, g.a_tight, g.T1T2, g.g_alpha,
                          g.eps_alpha, g.eps_beta, g.gear[0].d_Ff, g.gear[1].d_Ff,
                          g.gear[0].d_sap, g.gear[1].d_sap, g.gear[0].eta_b, g.gear[1].eta_b};
  for (double v : check)
    if (!std::isfinite(v))
      return c.fail("pair: the gear geometry is not finite for these parameters (check module, "
                    "pressure angle, helix angle and teeth)");
  return GM_OK;
}

}  // namespace

gm_status compute_pair_geometry(const gm_model_params& p, gm_pair_geometry& g, std::string& msg) {
  g = gm_pair_geometry{};
  msg.clear();
  PairWork c{p, g, msg};
  gm_status st = transverse_basics(c);
  if (st != GM_OK) return st;
  gear_blanks(c);
  if ((st = check_tips(c)) != GM_OK) return st;
  centre_distances(c);
  if ((st = operating_mesh(c)) != GM_OK) return st;
  if ((st = line_of_action(c)) != GM_OK) return st;
  if ((st = check_tip_clearance(c)) != GM_OK) return st;
  form_circles(c);
  active_profile(c);
  gear_outputs(c);
  if ((st = overlap_ratio(c)) != GM_OK) return st;
  return check_finite(c);
}

}  // namespace gm
