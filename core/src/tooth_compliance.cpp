// Analytical tooth compliance: Weber's beam terms and Sainsot's foundation term (model, sources
// and limits in tooth_compliance.hpp).
#include "gearmesh/internal/tooth_compliance.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "params.hpp"

namespace gm {

namespace {

constexpr double kPi = 3.14159265358979323846;

// 8-point Gauss-Legendre on [-1, 1]: nodes +-x_k, weights w_k.
constexpr double kGaussX[4] = {0.1834346424956498, 0.5255324099163290, 0.7966664774136267,
                               0.9602898564975363};
constexpr double kGaussW[4] = {0.3626837833783620, 0.3137066458778873, 0.2223810344533745,
                               0.1012285362903763};

// Sainsot et al. 2004, Table: X* = A/theta_f^2 + B h_f^2 + C h_f/theta_f + D/theta_f + E h_f + F,
// rows L*, M*, P*, Q*; with the range of each X* over the fitted designs.
struct SainsotRow {
  double A, B, C, D, E, F, lo, hi;
};
constexpr SainsotRow kSainsot[4] = {
    {-5.574e-5, -1.9986e-3, -2.3015e-4, 4.7702e-3, 0.0271, 6.8045, 6.82, 6.94},
    {60.111e-5, 28.100e-3, -83.431e-4, -9.9256e-3, 0.1624, 0.9086, 1.08, 3.29},
    {-50.952e-5, 185.50e-3, 0.0538e-4, 53.300e-3, 0.2895, 0.9236, 2.56, 13.47},
    {-6.2042e-5, 9.0889e-3, -4.0964e-4, 7.8297e-3, -0.1472, 0.6904, 0.141, 0.62},
};

std::string format(const char* fmt, double a, double b = 0) {
  char buf[400];
  std::snprintf(buf, sizeof buf, fmt, a, b);
  return buf;
}


}  // namespace

BeamMaterial plane_strain_material(double youngs_modulus, double poisson_ratio) {
  BeamMaterial m;
  m.E_prime = youngs_modulus / (1.0 - poisson_ratio * poisson_ratio);
  m.G = youngs_modulus / (2.0 * (1.0 + poisson_ratio));
  return m;
}

BeamCompliance beam_compliance(const std::function<BeamStation(double)>& profile, double t0,
                               double t1, const BeamLoad& load, const BeamMaterial& material,
                               int panels) {
  // Weber (energy method): bending 12 cos^2 phi int (y_F - y)^2/(E' (2w)^3) dy,
  // shear 1.2 cos^2 phi int 1/(G 2w) dy, compression sin^2 phi int 1/(E' 2w) dy.
  double bend = 0, inv_thickness = 0;
  const int n = std::max(1, panels);
  const double h = (t1 - t0) / n;
  for (int k = 0; k < n; ++k) {
    const double mid = t0 + (k + 0.5) * h;
    for (int j = 0; j < 4; ++j) {
      for (int sgn = -1; sgn <= 1; sgn += 2) {
        const BeamStation st = profile(mid + sgn * 0.5 * h * kGaussX[j]);
        const double dy = st.dy_dt * 0.5 * h * kGaussW[j];
        const double t = 2.0 * st.half_thickness;
        const double arm = load.centre_line_point - st.y;
        bend += arm * arm / (t * t * t) * dy;
        inv_thickness += dy / t;
      }
    }
  }
  const double c = std::cos(load.angle), s = std::sin(load.angle);
  BeamCompliance out;
  out.bending = 12.0 * c * c / material.E_prime * bend;
  out.shear = kWeberShearFactor * c * c / material.G * inv_thickness;
  out.compression = s * s / material.E_prime * inv_thickness;
  return out;
}

BeamCompliance beam_compliance(const std::function<double(double)>& half_thickness, double y0,
                               const BeamLoad& load, const BeamMaterial& material, int panels) {
  return beam_compliance([&](double y) { return BeamStation{y, half_thickness(y), 1.0}; }, y0,
                         load.station, load, material, panels);
}

SainsotCoefficients sainsot_coefficients(const FoundationGeometry& f) {
  const double th = f.root_half_angle, hf = f.root_radius / f.bore_radius;
  double x[4];
  bool inside = true;
  for (int i = 0; i < 4; ++i) {
    const SainsotRow& r = kSainsot[i];
    x[i] = r.A / (th * th) + r.B * hf * hf + r.C * hf / th + r.D / th + r.E * hf + r.F;
    inside = inside && x[i] >= r.lo && x[i] <= r.hi;
  }
  return {x[0], x[1], x[2], x[3], inside};
}

double sainsot_foundation_compliance(const FoundationGeometry& f, const SainsotCoefficients& k,
                                     double u_f, double load_angle, double youngs_modulus) {
  // Sainsot et al. 2004: (cos^2 phi/E) [L* (u_f/S_f)^2 + M* u_f/S_f + P* (1 + Q* tan^2 phi)]
  const double S_f = 2.0 * f.root_radius * f.root_half_angle;
  const double u = u_f / S_f, c = std::cos(load_angle), t = std::tan(load_angle);
  return c * c / youngs_modulus * (k.L * u * u + k.M * u + k.P * (1.0 + k.Q * t * t));
}

BeamStation tooth_fillet_station(const ToothSection& s, double psi) {
  // Rack generation in the gear's frame (y along the tooth centre line): the gear turned by phi
  // sees the rack moved by -r phi along the rolling line; the tip round's centre C sits at depth
  // t_c below the rolling line and offset e from the tooth centre line, and the generated point
  // lies on the line from the pitch point P through C, one round radius beyond C. With psi the
  // angle of P->C from the radial direction: phi = (e + t_c tan psi)/r and, before turning back
  // by phi, S = (-t_c tan psi - rho_t sin psi, r - t_c - rho_t cos psi). psi = 0 is the root
  // circle (theta_f = e/r), psi = pi/2 - alpha_t the end of the straight rack flank (form circle).
  const double r = s.pitch_radius, tc = s.round_depth, rt = s.round_radius, e = s.round_offset;
  const double tp = std::tan(psi), sp = std::sin(psi), cp = std::cos(psi);
  const double ph = (e + tc * tp) / r, sph = std::sin(ph), cph = std::cos(ph);
  const double Sx = -tc * tp - rt * sp, Sy = r - tc - rt * cp;
  const double Gx = Sx * cph + Sy * sph, Gy = -Sx * sph + Sy * cph;
  const double sec2 = 1.0 + tp * tp;
  const double dSx = -tc * sec2 - rt * cp, dSy = rt * sp, dph = tc * sec2 / r;
  return {Gy, Gx, -dSx * sph + dSy * cph - dph * Gx};
}

BeamStation tooth_involute_station(const ToothSection& s, double alpha) {
  // R = r_b/cos alpha, half angle eta = eta_b - inv alpha (docs/physics.md §1's s_yt/(2 R)).
  const double R = s.base_radius / std::cos(alpha), ta = std::tan(alpha);
  const double eta = s.eta_b - (ta - alpha);
  const double ce = std::cos(eta), se = std::sin(eta);
  return {R * ce, R * se, R * ta * (ce + ta * se)};  // dR/da = R tan a, d eta/da = -tan^2 a
}

BeamLoad tooth_load(const ToothSection& s, double rho) {
  const double rb = s.base_radius;
  const double alpha = std::atan2(rho, rb), R = std::hypot(rb, rho);
  const double eta = s.eta_b - (rho / rb - alpha);  // inv alpha = tan alpha - alpha
  const double xc = R * std::sin(eta), yc = R * std::cos(eta);
  BeamLoad load;
  load.station = yc;
  load.angle = alpha - eta;  // phi = alpha_y - eta_y
  load.centre_line_point = yc - xc * std::tan(load.angle);
  return load;
}

ToothComplianceParts tooth_compliance_exact(const ToothSection& s, double rho) {
  const BeamLoad load = tooth_load(s, rho);
  const double alpha_c = std::atan2(rho, s.base_radius);
  auto fillet = [&s](double psi) { return tooth_fillet_station(s, psi); };
  auto invol = [&s](double a) { return tooth_involute_station(s, a); };
  const BeamCompliance a = beam_compliance(fillet, 0.0, s.fillet_end, load, s.material, s.panels);
  const BeamCompliance b =
      beam_compliance(invol, s.form_pressure_angle, alpha_c, load, s.material, s.panels);
  ToothComplianceParts parts;
  parts.beam.bending = a.bending + b.bending;
  parts.beam.shear = a.shear + b.shear;
  parts.beam.compression = a.compression + b.compression;
  parts.foundation = sainsot_foundation_compliance(s.foundation, s.sainsot,
                                                   load.centre_line_point - s.root_radius,
                                                   load.angle, s.youngs_modulus);
  return parts;
}

gm_status build_tooth_section(const gm_model_params& p, const gm_pair_geometry& g, int gear,
                              const ToothSectionOptions& options, ToothSection& out,
                              std::string& msg) {
  out = ToothSection{};
  msg.clear();
  auto fail = [&msg](std::string text) {
    msg = std::move(text);
    return GM_ERR_PARAMETER;
  };
  if (gear != 0 && gear != 1) return fail("analytical tooth compliance: gear index must be 0 or 1");
  const std::string name = gear == 0 ? "gear1" : "gear2";
  if (gear == 1 && p.pair.internal)
    return fail(std::string(GM_PARAM_NAME(pair.internal)) +
                " = true: the internal ring has no analytical tooth compliance (Sainsot's gear-body formula is for an "
                "external gear around a bore); allowed levels for a ring: 0-3 and 5");
  const gm_gear_geometry& gg = g.gear[gear];
  if (gg.undercut)
    return fail(name + ".profile_shift: analytical tooth compliance needs a tooth without "
                       "undercut (the rack's trochoid cuts into the involute); allowed for an "
                       "undercut tooth: levels 0-3, or a larger " + name + ".profile_shift");

  const double m_n = p.pair.normal_module, alpha_n = p.pair.pressure_angle;
  const double alpha_t = g.alpha_t;
  ToothSection& s = out;
  s.gear = gear;
  s.youngs_modulus = p.gear[gear].youngs_modulus;
  s.material = plane_strain_material(s.youngs_modulus, p.gear[gear].poisson_ratio);
  s.base_radius = 0.5 * gg.d_b;
  s.pitch_radius = 0.5 * gg.d;
  s.root_radius = 0.5 * gg.d_f;
  s.form_radius = 0.5 * gg.d_Ff;
  s.tip_radius = 0.5 * gg.d_a;
  s.eta_b = gg.eta_b;
  s.form_pressure_angle = std::atan2(gg.rho_Ff, s.base_radius);
  // Transverse tip round: same end of the straight flank as geometry.cpp's h_FfP (see header).
  const double rho_fP = p.pair.rack_tip_radius * m_n;
  s.round_radius = rho_fP * (1.0 - std::sin(alpha_n)) / (1.0 - std::sin(alpha_t));
  s.round_depth = p.pair.rack_dedendum * m_n - gg.x_E * m_n - s.round_radius;
  if (!(s.round_depth > 0.0))
    return fail(name + format(".profile_shift = %g: analytical tooth compliance needs the rack "
                              "tip round's centre below the rolling line (x_E < h_fP* - rho_t* = "
                              "%g)",
                              p.gear[gear].profile_shift,
                              p.pair.rack_dedendum - s.round_radius / m_n));
  // Offset of the round's centre from the tooth centre line along the rolling line: half the
  // tooth thickness there, plus the flank's run-out over depth t_c, plus the round's offset from
  // the flank line.
  s.round_offset = 0.5 * gg.s_t + s.round_depth * std::tan(alpha_t) +
                   s.round_radius / std::cos(alpha_t);
  s.fillet_end = 0.5 * kPi - alpha_t;
  s.panels = std::max(1, options.panels);

  // The fillet's end must meet the involute at the form circle.
  const BeamStation f_end = tooth_fillet_station(s, s.fillet_end);
  const BeamStation i_start = tooth_involute_station(s, s.form_pressure_angle);
  if (std::hypot(f_end.y - i_start.y, f_end.half_thickness - i_start.half_thickness) >
      1e-9 * s.pitch_radius)
    return fail(name + ": internal error, the generated fillet does not meet the involute at the "
                       "form circle");
  // y must grow along the fillet (the beam axis) with a positive thickness.
  for (int k = 0; k <= 256; ++k) {
    const BeamStation st = tooth_fillet_station(s, s.fillet_end * k / 256.0);
    if (!(st.dy_dt > 0.0) || !(st.half_thickness > 0.0))
      return fail(name + ": the generated fillet folds back along the tooth centre line; "
                         "analytical tooth compliance not available for this tooth form");
  }

  const double theta_f = s.round_offset / s.pitch_radius;
  s.foundation.root_radius = s.root_radius;
  s.foundation.root_half_angle = theta_f;
  s.foundation.bore_radius = options.bore_radius > 0 ? options.bore_radius : 0.4 * s.root_radius;
  if (!(s.foundation.bore_radius < s.root_radius))
    return fail(format("analytical tooth compliance: bore radius %g m must be below the root "
                       "radius %g m",
                       s.foundation.bore_radius, s.root_radius));
  s.sainsot = sainsot_coefficients(s.foundation);
  s.foundation_extrapolated = !s.sainsot.in_fitted_range;

  // Table over rho, from the form circle to the tip.
  s.rho_min = gg.rho_Ff;
  s.rho_max = gg.rho_a;
  const int n = std::max(4, options.table_points);
  const double step = (s.rho_max - s.rho_min) / (n - 1);
  const double h = 1e-3 * step;  // slope by differences of the exact model
  auto c = [&s](double rho) { return tooth_compliance_exact(s, rho).total(); };
  s.table_compliance.resize(n);
  s.table_slope.resize(n);
  for (int k = 0; k < n; ++k) {
    const double rho = s.rho_min + k * step;
    s.table_compliance[k] = c(rho);
    if (k == 0)
      s.table_slope[k] = (-3.0 * s.table_compliance[k] + 4.0 * c(rho + h) - c(rho + 2.0 * h)) /
                         (2.0 * h);
    else if (k == n - 1)
      s.table_slope[k] = (3.0 * s.table_compliance[k] - 4.0 * c(rho - h) + c(rho - 2.0 * h)) /
                         (2.0 * h);
    else
      s.table_slope[k] = (c(rho + h) - c(rho - h)) / (2.0 * h);
    if (!(s.table_compliance[k] > 0.0) || !std::isfinite(s.table_slope[k]))
      return fail(name + ": analytical tooth compliance is not finite and positive");
  }
  return GM_OK;
}

double tooth_compliance(const ToothSection& s, double rho) {
  // Cubic Hermite on the uniform rho grid.
  const int n = static_cast<int>(s.table_compliance.size());
  const double step = (s.rho_max - s.rho_min) / (n - 1);
  double t = (std::clamp(rho, s.rho_min, s.rho_max) - s.rho_min) / step;
  if (!(t >= 0)) t = 0;  // NaN rho: no float-to-int cast of it
  const int k = std::min(n - 2, std::max(0, static_cast<int>(t)));
  const double u = t - k, u2 = u * u, u3 = u2 * u;
  return (2 * u3 - 3 * u2 + 1) * s.table_compliance[k] +
         (u3 - 2 * u2 + u) * step * s.table_slope[k] +
         (-2 * u3 + 3 * u2) * s.table_compliance[k + 1] +
         (u3 - u2) * step * s.table_slope[k + 1];
}

double tooth_compliance_slope(const ToothSection& s, double rho) {
  if (!(rho > s.rho_min && rho < s.rho_max)) return 0;  // clamped: constant
  const int n = static_cast<int>(s.table_compliance.size());
  const double step = (s.rho_max - s.rho_min) / (n - 1);
  const double t = (rho - s.rho_min) / step;
  const int k = std::min(n - 2, std::max(0, static_cast<int>(t)));
  const double u = t - k, u2 = u * u;
  return ((6 * u2 - 6 * u) * s.table_compliance[k] + (3 * u2 - 4 * u + 1) * step * s.table_slope[k] +
          (-6 * u2 + 6 * u) * s.table_compliance[k + 1] + (3 * u2 - 2 * u) * step * s.table_slope[k + 1]) /
         step;
}

double tooth_contact_depth(const ToothSection& s, double rho) {
  return tooth_contact_depth_t<double>(s, rho);
}

}  // namespace gm
