// The static ranges of the FMU's parameters (gearmesh/param_ranges.h): the one table. The core's
// checks (params.cpp, microgeometry.cpp, dynamics.cpp), the FMU binary (fmu_src/model_gearmesh.c)
// and modelDescription.xml's min/max (modelDescription/generate_model_description.c) read it.
#include "gearmesh/param_ranges.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>

#include "params.hpp"

namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;
constexpr double kNone = HUGE_VAL;
constexpr double kMaxModule = 0.1;   // pair.normal_module, m
constexpr double kMaxAmount = 1e-3;  // micro-geometry amounts and slopes, m
enum { kClosed = 0, kLoOpen = 1, kHiOpen = 2, kOpen = 3 };

constexpr gm_param_range row(const char* name, double lo, double hi, int open, const char* unit) {
  return {name, lo, hi, open & kLoOpen, (open & kHiOpen) / kHiOpen, unit};
}

// One row per gear.
#define GEAR(field, lo, hi, open, unit) \
  row("gear1." field, lo, hi, open, unit), row("gear2." field, lo, hi, open, unit)

// Bounds that also depend on other parameters are checked after these (params.cpp,
// microgeometry.cpp, dynamics.cpp); here is their envelope.
constexpr gm_param_range kRanges[] = {
    row("pair.center_distance", 0, 20, kLoOpen, "m"),
    row("pair.normal_module", 1e-4, kMaxModule, kClosed, "m"),
    row("pair.pressure_angle", 10 * kDeg, 35 * kDeg, kClosed, "rad"),
    row("pair.helix_angle", -45 * kDeg, 45 * kDeg, kOpen, "rad"),
    row("pair.rack_addendum", 0.5, 2.0, kClosed, ""),
    row("pair.rack_dedendum", 0.5, 3.0, kLoOpen, ""),   // and > pair.rack_addendum
    row("pair.rack_tip_radius", 0.0, 1.0, kClosed, ""),  // and <= the full round + 1 %
    GEAR("teeth", 5, 2000, kClosed, ""),
    GEAR("profile_shift", -1.5, 3.0, kClosed, ""),
    GEAR("face_width", 0, 2.0, kLoOpen, "m"),
    GEAR("tip_diameter", 0, 40.0, kClosed, "m"),  // 0 = from the rack
    GEAR("thickness_allowance", -0.5 * kMaxModule, 0.0, kClosed, "m"),  // and >= -0.5 m_n
    GEAR("axial_offset", -2.0, 2.0, kClosed, "m"),
    GEAR("youngs_modulus", 1e8, 1e13, kClosed, "Pa"),
    GEAR("poisson_ratio", 0.0, 0.5, kHiOpen, ""),
    // micro-geometry; a relief length is also <= the active profile or b/2 while its relief is on
    GEAR("profile_crowning", 0, kMaxAmount, kClosed, "m"),
    GEAR("tip_relief", 0, kMaxAmount, kClosed, "m"),
    GEAR("tip_relief_length", 0, kNone, kClosed, "m"),
    GEAR("root_relief", 0, kMaxAmount, kClosed, "m"),
    GEAR("root_relief_length", 0, kNone, kClosed, "m"),
    GEAR("profile_slope", -kMaxAmount, kMaxAmount, kClosed, "m"),
    GEAR("lead_crowning", 0, kMaxAmount, kClosed, "m"),
    GEAR("helix_slope", -kMaxAmount, kMaxAmount, kClosed, "m"),
    GEAR("end_relief", 0, kMaxAmount, kClosed, "m"),
    GEAR("end_relief_length", 0, kNone, kClosed, "m"),
    row("model.stiffness", GM_STIFFNESS_USER_CONSTANT, GM_STIFFNESS_FE, kClosed, ""),
    row("model.user_stiffness", 0, 1e14, kLoOpen, "N/m2"),
    row("model.slices", 1, 200, kClosed, ""),
    row("model.coupled_teeth", 0, 10, kClosed, ""),
    row("model.friction_coefficient", 0, 2.0, kClosed, ""),
    row("model.friction_velocity", 0, 10.0, kLoOpen, "m/s"),
    row("model.damping", 0, 1e9, kClosed, "N.s/m2"),
    row("solver.tolerance", 0, 1e-3, kLoOpen, "m"),
    row("solver.max_iterations", 1, 10000, kClosed, ""),
    row("model.rated_line_load", 0, 1e8, kClosed, "N/m"),
    // large-step dynamics (dynamics.cpp)
    row("model.dynamics", 0, 1, kClosed, ""),
    GEAR("inertia", 1e-9, 1e6, kClosed, "kg.m2"),
    GEAR("shaft_stiffness", 0, 1e12, kClosed, "N.m/rad"),
    GEAR("shaft_damping", 0, 1e9, kClosed, "N.m.s/rad"),
    row("dynamics.tolerance", 1e-14, 1e-4, kClosed, "m"),
    row("dynamics.max_step", 1e-9, 1.0, kClosed, "s"),
    row("dynamics.min_step", 1e-15, 1.0, kClosed, "s"),  // and <= dynamics.max_step
    row("dynamics.mesh_damping_ratio", 0, 10.0, kClosed, ""),
    row("dynamics.order_cycles", 1, GM_ORDER_CYCLES_MAX, kClosed, ""),
    // an output: the values it takes (0 none, 1 flank A, 2 flank B, 3 both)
    row("mesh.flank", 0, 3, kClosed, ""),
};
#undef GEAR

constexpr size_t kCount = sizeof kRanges / sizeof kRanges[0];

bool inside(const gm_param_range& r, double v) {
  return std::isfinite(v) && (r.lo_open ? v > r.lo : v >= r.lo) && (r.hi_open ? v < r.hi : v <= r.hi);
}

std::string message(const gm_param_range& r, double v) {
  const std::string unit = *r.unit ? std::string(" ") + r.unit : "";
  char buf[256];
  std::snprintf(buf, sizeof buf, "%s = %.9g%s: allowed range %c%.9g, %.9g%c%s", r.name, v, unit.c_str(),
                r.lo_open || std::isinf(r.lo) ? '(' : '[', r.lo, r.hi, r.hi_open || std::isinf(r.hi) ? ')' : ']',
                unit.c_str());
  return buf;
}

}  // namespace

namespace gm {

bool check_range(const char* name, double v, std::string& msg) {
  const gm_param_range* r = gm_param_range_find(name);
  if (!r) {
    msg = std::string(name) + ": no static range (core/src/param_ranges.cpp)";
    return false;
  }
  if (inside(*r, v)) return true;
  msg = message(*r, v);
  return false;
}

}  // namespace gm

extern "C" const gm_param_range* gm_param_ranges(size_t* count) {
  if (count) *count = kCount;
  return kRanges;
}

extern "C" const gm_param_range* gm_param_range_find(const char* name) {
  if (!name) return nullptr;
  for (const gm_param_range& r : kRanges)
    if (std::strcmp(r.name, name) == 0) return &r;
  return nullptr;
}

extern "C" gm_status gm_param_range_check(const gm_param_range* r, double value, char* msg, size_t msg_size) {
  if (!r) return GM_ERR_ARGUMENT;
  if (inside(*r, value)) return GM_OK;
  if (msg && msg_size) std::snprintf(msg, msg_size, "%s", message(*r, value).c_str());
  return GM_ERR_PARAMETER;
}
