// Parameter defaults and range validation (the one place a bad parameter is named).
#include "params.hpp"

#include <cmath>
#include <cstdio>

namespace gm {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// Range checks that stop at the first failure and name the FMU variable.
class Checker {
 public:
  explicit Checker(std::string& msg) : msg_(msg) {}
  bool ok() const { return ok_; }

  // lo <= v <= hi (open ends when the flags say so).
  void real(const char* name, double v, double lo, double hi, const char* unit,
            bool lo_open = false, bool hi_open = false) {
    if (!ok_) return;
    const bool inside = std::isfinite(v) && (lo_open ? v > lo : v >= lo) &&
                        (hi_open ? v < hi : v <= hi);
    if (!inside) {
      char buf[256];
      std::snprintf(buf, sizeof buf, "%s = %.9g %s: allowed range %s%.9g, %.9g%s %s", name, v, unit,
                    lo_open ? "(" : "[", lo, hi, hi_open ? ")" : "]", unit);
      fail(buf);
    }
  }
  void integer(const char* name, int v, int lo, int hi) {
    if (!ok_) return;
    if (v < lo || v > hi) {
      char buf[200];
      std::snprintf(buf, sizeof buf, "%s = %d: allowed range [%d, %d]", name, v, lo, hi);
      fail(buf);
    }
  }
  void fail(const std::string& text) {
    if (ok_) msg_ = text;
    ok_ = false;
  }

 private:
  std::string& msg_;
  bool ok_ = true;
};

}  // namespace

gm_status validate_params(const gm_model_params& p, std::string& msg) {
  Checker c(msg);
  const gm_pair_params& pr = p.pair;
  c.real("pair.center_distance", pr.center_distance, 0, 20, "m", true);
  c.real("pair.normal_module", pr.normal_module, 1e-4, 0.1, "m");
  c.real("pair.pressure_angle", pr.pressure_angle, 10 * kDeg, 35 * kDeg, "rad");
  c.real("pair.helix_angle", pr.helix_angle, -45 * kDeg, 45 * kDeg, "rad", true, true);
  c.integer("pair.internal", pr.internal, 0, 1);
  c.real("pair.rack_addendum", pr.rack_addendum, 0.5, 2.0, "");
  c.real("pair.rack_dedendum", pr.rack_dedendum, pr.rack_addendum, 3.0, "", true);
  c.real("pair.rack_tip_radius", pr.rack_tip_radius, 0.0,
         (pr.rack_dedendum - pr.rack_addendum) / (1 - std::sin(pr.pressure_angle)) * 1.01,
         "(modules; up to the full round (h_fP* - h_aP*)/(1 - sin alpha_n) + 1 %)");
  for (int i = 0; i < 2; ++i) {
    const gm_gear_params& g = p.gear[i];
    const std::string n = "gear" + std::to_string(i + 1) + ".";
    c.integer((n + "teeth").c_str(), g.teeth, 5, 2000);
    c.real((n + "profile_shift").c_str(), g.profile_shift, -1.5, 3.0, "");
    c.real((n + "face_width").c_str(), g.face_width, 0, 2.0, "m", true);
    if (g.tip_diameter != 0)
      c.real((n + "tip_diameter").c_str(), g.tip_diameter, 0, 40.0, "m (0 = from the rack)", true);
    c.real((n + "thickness_allowance").c_str(), g.thickness_allowance, -0.5 * pr.normal_module,
           0.0, "m");
    c.real((n + "axial_offset").c_str(), g.axial_offset, -2.0, 2.0, "m");
    c.real((n + "youngs_modulus").c_str(), g.youngs_modulus, 1e8, 1e13, "Pa");
    c.real((n + "poisson_ratio").c_str(), g.poisson_ratio, 0.0, 0.5, "", false, true);
  }
  c.integer("model.stiffness", p.stiffness_level, GM_STIFFNESS_USER_CONSTANT, GM_STIFFNESS_FE);
  c.real("model.user_stiffness", p.user_stiffness, 0, 1e14, "N/m2", true);
  c.integer("model.slices", p.slices, 1, 200);
  c.integer("model.coupled_teeth", p.coupled_teeth, 0, 10);
  c.real("model.friction_coefficient", p.friction_coefficient, 0, 2.0, "");
  c.real("model.friction_velocity", p.friction_velocity, 0, 10.0, "m/s", true);
  c.real("model.damping", p.damping, 0, 1e9, "N.s/m2");
  c.real("solver.tolerance", p.solver_tolerance, 0, 1e-3, "m", true);
  c.integer("solver.max_iterations", p.solver_max_iterations, 1, 10000);
  c.real("model.rated_line_load", p.rated_line_load, 0, 1e8, "N/m");
  c.integer("model.quasi_static", p.quasi_static, 0, 1);
  return c.ok() ? GM_OK : GM_ERR_PARAMETER;
}

}  // namespace gm

extern "C" void gm_default_params(gm_model_params* p) {
  if (!p) return;
  *p = gm_model_params{};
  // The paper's gear set A (Table 1) with the assumptions of the scene: x1 = x2 = 0.35, tip
  // diameter from the rack, ISO 53 profile A, steel.
  p->pair.center_distance = 0.150;
  p->pair.normal_module = 0.0026;
  p->pair.pressure_angle = 20 * gm::kDeg;
  p->pair.helix_angle = 0;
  p->pair.internal = 0;
  p->pair.rack_addendum = 1.0;
  p->pair.rack_dedendum = 1.25;
  p->pair.rack_tip_radius = 0.38;
  for (gm_gear_params& g : p->gear) {
    g.teeth = 57;
    g.profile_shift = 0.35;
    g.face_width = 0.023;
    g.tip_diameter = 0;
    g.thickness_allowance = 0;
    g.axial_offset = 0;
    g.youngs_modulus = 210e9;
    g.poisson_ratio = 0.3;
  }
  p->stiffness_level = GM_STIFFNESS_USER_CONSTANT;
  p->user_stiffness = 1.5e10;  // 15 N/(mm um), near ISO 6336 c' of this pair
  p->slices = 1;
  p->coupled_teeth = 2;
  p->friction_coefficient = 0;
  p->friction_velocity = 1e-3;
  p->damping = 0;
  p->solver_tolerance = 1e-10;
  p->solver_max_iterations = 50;
}
