// ISO 6336-1 method B tooth stiffness: single stiffness c' and mesh stiffness c_gamma
// (docs/physics.md §5, level GM_STIFFNESS_ISO6336). All results SI: stiffness per unit face
// width in N/m^2 (1 N/(mm um) = 1e9 N/m^2), q'_min in m^2/N.
//
// Formulas (ISO 6336-1:2006/2019, clause 9.3, method B):
//   q'_min = C1 + C2/z_n1 + C3/z_n2 + C4 x1 + C5 x1/z_n1 + C6 x2 + C7 x2/z_n2 + C8 x1^2 + C9 x2^2
//            (mm um/N), C1..C9 as in docs/physics.md §5; z_n = z/(cos^2 beta_b cos beta);
//   c'_th  = 1/q'_min;
//   c'     = c'_th C_M C_R C_B cos beta (E/E_st), C_M = 0.8, E = 2 E1 E2/(E1 + E2), E_st = 206 GPa;
//   C_B    = [1 + 0.5 (1.2 - h_fP/m_n)] [1 - 0.02 (20 deg - alpha_n)];
//   C_R    = 1 (solid discs), else 1 + ln(b_s/b)/(5 exp(s_R/(5 m_n))), b_s/b in [0.2, 1.2],
//            s_R/m_n >= 1 (values outside are clamped to these limits);
//   load correction: for F_t K_A/b < 100 N/mm, c' is multiplied by ((F_t K_A/b)/(100 N/mm))^0.25;
//   c_gamma_alpha = c' (0.75 eps_alpha + 0.25),  c_gamma_beta = 0.85 c_gamma_alpha.
//
// Where these were checked (with the search tools): the C1..C9 set, z_n, C_M, C_B, cos beta and
// 0.75 eps_alpha + 0.25 reproduce the published values of ISO/TR 6336-30:2017 example 1 (single
// helical carburized pair, m_n 8, z 17/103, x 0.145/0, beta 15.8 deg, basic rack h_fP = 1.4 m_n:
// z_n = 18.905/114.543, c'_th = 17.85584, c' = 12.37047, c_gamma_beta/c_gamma_alpha = 0.85),
// quoted in the test table of gfsReboucas/Drivetrain (MATISO_6336.m, example_01, "Annex A");
// tests/core/test_stiffness_iso.cpp checks them. C_B = 0.9 there confirms the C_B form. The load
// correction with the exponent 0.25 (ISO 6336-1:2019 Eq. 92), the C_R formula with its clamps,
// E = 2 E1 E2/(E1 + E2) (Eq. 90/91) and the regression's range x1 >= x2, -0.5 <= x1 + x2 <= 2
// are as quoted in independent public implementations (JRaposo-m/AxisForge-Shaft-Bearing-Gear-
// System-Analysis-Platform, axisforge/.../LoadCapacity_data/Kv_methodB.py, "eq. 92"; and a
// Python gearbox package's __c__); the standard's own text was not reachable. Note the exponent:
// the correction is the fourth root of the load ratio, not the ratio itself. That package also
// applies ISO's remark that c_gamma_alpha may be up to 10 % lower for spur gears with
// eps_alpha < 1.2; a "may", not applied here.
//
// Pinion and wheel: ISO's gear 1 is the pinion (fewer teeth) and gear 2 the wheel; this module
// orders the pair that way (the ring is always ISO's gear 2). Internal pairs: the ring is taken
// as z_n2 -> infinity (1/z_n2 = 0, the rack limit; ISO 6336-1's note for internal gears as
// recalled, not confirmed by the search tools), its x2 terms C6 x2 + C9 x2^2 kept with the ring's
// own profile shift (x > 0 thickens its tooth, docs/physics.md §1).
#pragma once

#include <string>

#include "gearmesh/gearmesh.h"

namespace gm {

constexpr double kIsoSteelModulus = 206e9;      // E_st, Pa
constexpr double kIsoReferenceLineLoad = 1e5;   // 100 N/mm in N/m

// Gear blank of the pair for C_R (ISO 6336-1 gives mean values for mating gears of similar
// blank design, so one description serves the pair). Default: solid discs, C_R = 1.
struct IsoGearBlank {
  bool solid = true;
  double web_ratio = 1.0;  // b_s/b: web thickness over face width (clamped to [0.2, 1.2])
  double rim_ratio = 1.0;  // s_R/m_n: rim thickness over normal module (clamped to >= 1)
};

// Everything method B needs, ISO's numbering (1 = pinion, 2 = wheel).
struct IsoStiffnessInput {
  double z_n[2] = {0, 0};          // virtual numbers of teeth; z_n[1] = +inf for a ring
  double x[2] = {0, 0};            // profile shift coefficients, -
  double helix_angle = 0;          // |beta|, rad
  double pressure_angle = 0;       // alpha_n of the basic rack, rad
  double rack_dedendum = 1.25;     // h_fP/m_n, -
  double youngs_modulus[2] = {kIsoSteelModulus, kIsoSteelModulus};  // Pa
  double eps_alpha = 0;            // transverse contact ratio, -
  IsoGearBlank blank;
};

struct IsoStiffness {
  double q_min = 0;          // q'_min, m^2/N (1 mm um/N = 1e-9 m^2/N)
  double c_th = 0;           // c'_th = 1/q'_min, N/m^2
  double C_M = 0, C_R = 0, C_B = 0;
  double material = 0;       // E/E_st, -
  double c_single = 0;       // c' without load correction (F_t K_A/b >= 100 N/mm), N/m^2
  double c_gamma_alpha = 0;  // c' (0.75 eps_alpha + 0.25), N/m^2
  double c_gamma_beta = 0;   // 0.85 c_gamma_alpha, N/m^2
  bool in_regression_range = true;  // x1 >= x2 and -0.5 <= x1 + x2 <= 2
};

// z_n = z/(cos^2 beta_b cos beta) (ISO 6336-1 virtual number of teeth).
double iso_virtual_teeth(double z, double helix_angle, double base_helix_angle);

// C_R of the blank.
double iso_blank_factor(const IsoGearBlank& blank);

// C_B = [1 + 0.5 (1.2 - h_fP/m_n)] [1 - 0.02 (20 deg - alpha_n)], alpha_n in rad.
double iso_basic_rack_factor(double rack_dedendum, double pressure_angle);

// Method B from explicit inputs (no validation beyond what the formulas need).
IsoStiffness iso_stiffness(const IsoStiffnessInput& in);

// Method B for a model: inputs from the parameters (x, not x_E; the rack's h_fP and alpha_n;
// both moduli) and the pair geometry (beta_b, eps_alpha). GM_ERR_PARAMETER with msg if q'_min is
// not positive (far outside the regression's range).
gm_status iso_stiffness(const gm_model_params& p, const gm_pair_geometry& g,
                        const IsoGearBlank& blank, IsoStiffness& out, std::string& msg);

// ISO's load correction of c' (and so of c_gamma): ((F_t K_A/b)/(100 N/mm))^0.25 below
// 100 N/mm, 1 at and above; line_load = F_t K_A/b in N/m. line_load <= 0 means "not given": 1.
double iso_load_factor(double line_load);

// c' and c_gamma_alpha at line load F_t K_A/b (N/m): the full-load values times
// iso_load_factor(line_load).
double iso_single_stiffness_at(const IsoStiffness& s, double line_load);
double iso_mesh_stiffness_at(const IsoStiffness& s, double line_load);

// The pair's c' and c_gamma_alpha at model.rated_line_load into g.c_single and g.c_gamma_alpha (the
// calculated parameters of every level; level 2 builds its law from the same values); 0 where
// q'_min is not positive (levels 2 and 3 refuse such a pair at their build).
void iso_published(const gm_model_params& p, gm_pair_geometry& g);

}  // namespace gm
