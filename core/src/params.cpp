// Parameter defaults and validation (the one place a bad parameter is named): the static ranges
// of the parameter table (gearmesh/parameters.h, checked by check_rows), then the bounds that
// depend on other parameters, here.
#include "params.hpp"

#include <cmath>
#include <cstdio>

namespace gm {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

std::string number(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", x);
  return buf;
}

// The bounds that depend on other parameters, after the static ranges (check_rows): stop at the
// first failure and name the FMU variable.
class Checker {
 public:
  explicit Checker(std::string& msg) : msg_(msg) {}
  bool ok() const { return ok_; }

  // A bound that depends on other parameters: holds says whether v meets it.
  void bound(const std::string& name, double v, const char* unit, bool holds, const std::string& allowed) {
    if (ok_ && !holds) fail(name + " = " + number(v) + unit + ": allowed " + allowed);
  }

 private:
  void fail(const std::string& text) {
    msg_ = text;
    ok_ = false;
  }
  std::string& msg_;
  bool ok_ = true;
};

void check_pair(Checker& c, const gm_pair_params& pr) {
  c.bound(GM_PARAM_NAME(pair.rack_dedendum), pr.rack_dedendum, "", pr.rack_dedendum > pr.rack_addendum,
          std::string("> ") + GM_PARAM_NAME(pair.rack_addendum) + " = " + number(pr.rack_addendum));
  const double full_round = (pr.rack_dedendum - pr.rack_addendum) / (1 - std::sin(pr.pressure_angle));
  c.bound(GM_PARAM_NAME(pair.rack_tip_radius), pr.rack_tip_radius, "", pr.rack_tip_radius <= full_round * 1.01,
          "<= " + number(full_round * 1.01) + " (the full round (h_fP* - h_aP*)/(1 - sin alpha_n) + 1 %)");
}

void check_gear(Checker& c, const gm_gear_params& g, double normal_module, int i) {
  c.bound(GM_GEAR_PARAM_NAME(i, thickness_allowance), g.thickness_allowance, " m",
          g.thickness_allowance >= -0.5 * normal_module,
          ">= " + number(-0.5 * normal_module) + " m (-0.5 " + GM_PARAM_NAME(pair.normal_module) + ")");
}

}  // namespace

gm_status validate_params(const gm_model_params& p, std::string& msg) {
  if (!check_rows(GM_PARAM_IN_MODEL, &p, msg)) return GM_ERR_PARAMETER;
  Checker c(msg);
  check_pair(c, p.pair);
  for (int i = 0; i < 2; ++i) check_gear(c, p.gear[i], p.pair.normal_module, i);
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
  // level 4 with 10 slices and its tooth coupling: the level a user should start with (within
  // 1.2 % of the independent FE reference's mean TE on this pair, docs/validation.md)
  p->stiffness_level = GM_STIFFNESS_ANALYTICAL;
  p->user_stiffness = 1.5e10;  // 15 N/(mm um), near ISO 6336 c' of this pair (level 0)
  p->slices = 10;
  p->coupled_teeth = 2;
  p->friction_coefficient = 0;
  p->friction_velocity = 1e-3;
  p->damping = 0;
  p->solver_tolerance = 1e-10;
  p->solver_max_iterations = 50;
  p->solver_face_shapes = 3;
}
