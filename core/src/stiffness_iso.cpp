// ISO 6336-1 method B single and mesh stiffness (sources and checks in stiffness_iso.hpp).
#include "stiffness_iso.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "params.hpp"

namespace gm {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;
constexpr double kInf = std::numeric_limits<double>::infinity();

// q'_min regression coefficients C1..C9, mm um/N (ISO 6336-1 method B; docs/physics.md §5).
constexpr double kC[9] = {0.04723,  0.15551, 0.25791,  -0.00635, -0.11654,
                          -0.00193, -0.24188, 0.00529, 0.00182};
constexpr double kMmUmPerN = 1e-9;  // 1 mm um/N in m^2/N
constexpr double kCorrectionFactor = 0.8;  // C_M (ISO 6336-1: measured vs theoretical, solid discs)

}  // namespace

double iso_virtual_teeth(double z, double helix_angle, double base_helix_angle) {
  const double cb = std::cos(base_helix_angle);
  return z / (cb * cb * std::cos(helix_angle));  // z_n = z/(cos^2 beta_b cos beta)
}

double iso_blank_factor(const IsoGearBlank& blank) {
  if (blank.solid) return 1.0;
  const double web = std::clamp(blank.web_ratio, 0.2, 1.2);
  const double rim = std::max(blank.rim_ratio, 1.0);
  // C_R = 1 + ln(b_s/b)/(5 e^(s_R/(5 m_n)))
  return 1.0 + std::log(web) / (5.0 * std::exp(rim / 5.0));
}

double iso_basic_rack_factor(double rack_dedendum, double pressure_angle) {
  // C_B = [1 + 0.5 (1.2 - h_fP/m_n)] [1 - 0.02 (20 deg - alpha_n)], alpha_n in degrees
  return (1.0 + 0.5 * (1.2 - rack_dedendum)) * (1.0 - 0.02 * (20.0 - pressure_angle / kDeg));
}

IsoStiffness iso_stiffness(const IsoStiffnessInput& in) {
  IsoStiffness s;
  const double x1 = in.x[0], x2 = in.x[1];
  const double r1 = 1.0 / in.z_n[0], r2 = 1.0 / in.z_n[1];  // 1/inf = 0 for a ring
  const double q = kC[0] + kC[1] * r1 + kC[2] * r2 + kC[3] * x1 + kC[4] * x1 * r1 + kC[5] * x2 +
                   kC[6] * x2 * r2 + kC[7] * x1 * x1 + kC[8] * x2 * x2;  // mm um/N
  s.q_min = q * kMmUmPerN;
  s.c_th = 1.0 / s.q_min;
  s.C_M = kCorrectionFactor;
  s.C_R = iso_blank_factor(in.blank);
  s.C_B = iso_basic_rack_factor(in.rack_dedendum, in.pressure_angle);
  const double E1 = in.youngs_modulus[0], E2 = in.youngs_modulus[1];
  s.material = 2.0 * E1 * E2 / (E1 + E2) / kIsoSteelModulus;  // E/E_st, E = 2 E1 E2/(E1 + E2)
  s.c_single = s.c_th * s.C_M * s.C_R * s.C_B * std::cos(in.helix_angle) * s.material;
  s.c_gamma_alpha = s.c_single * (0.75 * in.eps_alpha + 0.25);
  s.c_gamma_beta = 0.85 * s.c_gamma_alpha;
  s.in_regression_range = x1 >= x2 && x1 + x2 >= -0.5 && x1 + x2 <= 2.0;
  return s;
}

gm_status iso_stiffness(const gm_model_params& p, const gm_pair_geometry& g,
                        const IsoGearBlank& blank, IsoStiffness& out, std::string& msg) {
  msg.clear();
  const bool internal = p.pair.internal != 0;
  const double beta = std::abs(p.pair.helix_angle);
  // ISO's pinion: the external gear of an internal pair, else the gear with fewer teeth.
  const int pinion = internal ? 0 : (p.gear[1].teeth < p.gear[0].teeth ? 1 : 0);
  const int wheel = 1 - pinion;
  IsoStiffnessInput in;
  in.z_n[0] = iso_virtual_teeth(p.gear[pinion].teeth, beta, g.beta_b);
  in.z_n[1] = internal ? kInf : iso_virtual_teeth(p.gear[wheel].teeth, beta, g.beta_b);
  in.x[0] = p.gear[pinion].profile_shift;
  in.x[1] = p.gear[wheel].profile_shift;
  in.helix_angle = beta;
  in.pressure_angle = p.pair.pressure_angle;
  in.rack_dedendum = p.pair.rack_dedendum;
  in.youngs_modulus[0] = p.gear[pinion].youngs_modulus;
  in.youngs_modulus[1] = p.gear[wheel].youngs_modulus;
  in.eps_alpha = g.eps_alpha;
  in.blank = blank;
  out = iso_stiffness(in);
  if (!(out.q_min > 0.0) || !std::isfinite(out.c_single)) {
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "%s = ISO 6336: q'_min = %.4g mm um/N is not positive for profile "
                  "shifts %g/%g (the method B regression holds for x1 >= x2, -0.5 <= x1 + x2 <= 2)",
                  GM_PARAM_NAME(stiffness_level), out.q_min / kMmUmPerN, in.x[0], in.x[1]);
    msg = buf;
    return GM_ERR_PARAMETER;
  }
  return GM_OK;
}

double iso_load_factor(double line_load) {
  if (!(line_load > 0.0) || line_load >= kIsoReferenceLineLoad) return 1.0;
  return std::pow(line_load / kIsoReferenceLineLoad, 0.25);  // ISO 6336-1:2019 Eq. 92
}

double iso_single_stiffness_at(const IsoStiffness& s, double line_load) {
  return s.c_single * iso_load_factor(line_load);
}

double iso_mesh_stiffness_at(const IsoStiffness& s, double line_load) {
  return s.c_gamma_alpha * iso_load_factor(line_load);
}

void iso_published(const gm_model_params& p, gm_pair_geometry& g) {
  IsoStiffness iso{};
  std::string ignored;
  const bool ok = iso_stiffness(p, g, IsoGearBlank{}, iso, ignored) == GM_OK;
  g.c_single = ok ? iso_single_stiffness_at(iso, p.rated_line_load) : 0.0;
  g.c_gamma_alpha = ok ? iso_mesh_stiffness_at(iso, p.rated_line_load) : 0.0;
}

}  // namespace gm
