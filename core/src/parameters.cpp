// The parameter table (gearmesh/parameters.h) as data: the rows, their static ranges, the lookup
// by name, the setter, and the range checks of the core (one loop over the rows), which
// gm_model_create (params.cpp) and the dynamics (dynamics.cpp) run.
#include "gearmesh/parameters.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>

#include "params.hpp"

namespace {

constexpr gm_param_where where_of(const char* w) {
  return w[0] == 'M' ? GM_PARAM_IN_MODEL : w[0] == 'D' ? GM_PARAM_IN_DYNAMICS
                                                       : GM_PARAM_IN_HOST;
}

// The offset of a field in the struct of its row (HOST rows: none).
#define GM_OFFSET_MODEL(field) offsetof(gm_model_params, field)
#define GM_OFFSET_DYNAMICS(field) offsetof(gm_dynamics_params, field)
#define GM_OFFSET_HOST(field) 0

#define ROW(_, name, kind, type, where, field, unit, dunit, lo, hi, bounds, levels, modes, group, flags, desc)         \
  gm_param_info{name,                                                                                              \
                sizeof(#kind) == sizeof("calculated"),                                                             \
                GM_PARAM_##type,                                                                                   \
                where_of(#where),                                                                                  \
                GM_OFFSET_##where(field),                                                                          \
                unit,                                                                                              \
                dunit,                                                                                             \
                (bounds) == GM_NO_RANGE ? -HUGE_VAL : double(lo),                                                  \
                (bounds) == GM_NO_RANGE ? HUGE_VAL : double(hi),                                                   \
                ((bounds) & GM_LO_OPEN) != 0 && (bounds) != GM_NO_RANGE,                                           \
                ((bounds) & GM_HI_OPEN) != 0 && (bounds) != GM_NO_RANGE,                                           \
                (bounds) != GM_NO_RANGE,                                                                           \
                levels,                                                                                            \
                modes,                                                                                             \
                group,                                                                                             \
                flags,                                                                                             \
                desc},
const gm_param_info kRows[] = {GM_PARAMETERS(ROW, _)};
#undef ROW

constexpr size_t kRowCount = sizeof kRows / sizeof kRows[0];

// Each HOST row's field as written in the table, for host_parameter_name.
struct HostField {
  const char* field;
  const char* name;
};
#define HOST_FIELD_MODEL(field, name)
#define HOST_FIELD_DYNAMICS(field, name)
#define HOST_FIELD_HOST(field, name) HostField{#field, name},
#define HOST_FIELD(_, name, kind, type, where, field, unit, dunit, lo, hi, bounds, levels, modes, group, flags, desc) \
  HOST_FIELD_##where(field, name)
const HostField kHostFields[] = {GM_PARAMETERS(HOST_FIELD, _)};
#undef HOST_FIELD

// The static ranges: the rows that have one, then the outputs that declare their values.
#define RANGE(_, name, kind, type, where, field, unit, dunit, lo, hi, bounds, levels, modes, group, flags, desc)       \
  +((bounds) != GM_NO_RANGE)
constexpr size_t kParamRanges = 0 GM_PARAMETERS(RANGE, _);
#undef RANGE
#define OUTPUT_RANGE(_, member, type, shape, source, name, unit, dunit, lo, hi, bounds, depends, desc) \
  +((bounds) != GM_NO_RANGE)
constexpr size_t kOutputRanges = 0 GM_OUTPUTS(OUTPUT_RANGE, _);
#undef OUTPUT_RANGE
#define OUTPUT_RANGE(_, member, type, shape, source, name, unit, dunit, lo, hi, bounds, depends, desc) \
  if ((bounds) != GM_NO_RANGE)                                                                     \
    rows[k++] = {name, lo, hi, ((bounds) & GM_LO_OPEN) != 0, ((bounds) & GM_HI_OPEN) != 0, unit};
constexpr size_t kRangeCount = kParamRanges + kOutputRanges;

struct Ranges {
  gm_param_range rows[kRangeCount];
  Ranges() : rows() {
    size_t k = 0;
    for (const gm_param_info& r : kRows)
      if (r.has_range) rows[k++] = {r.name, r.lo, r.hi, r.lo_open, r.hi_open, r.unit};
    GM_OUTPUTS(OUTPUT_RANGE, _)  // the outputs that declare the values they take
  }
};
const Ranges kRanges;

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

// The value of a Real, Integer or Boolean field as a double.
double number_at(const gm_param_info& r, const void* field) {
  if (r.type == GM_PARAM_Real) return *static_cast<const double*>(field);
  return *static_cast<const int*>(field);
}

}  // namespace

namespace gm {

bool check_range(const char* name, double v, std::string& msg) {
  const gm_param_range* r = gm_param_range_find(name);
  if (!r) {
    msg = std::string(name) + ": no static range (gearmesh/parameters.h)";
    return false;
  }
  if (inside(*r, v)) return true;
  msg = message(*r, v);
  return false;
}

const char* parameter_name(gm_param_where where, size_t offset) {
  for (const gm_param_info& r : kRows)
    if (r.where == where && r.offset == offset) return r.name;
  return "(a field without a row in gearmesh/parameters.h)";
}

const char* host_parameter_name(const char* field) {
  for (const HostField& h : kHostFields)
    if (std::strcmp(h.field, field) == 0) return h.name;
  return "(a host field without a row in gearmesh/parameters.h)";
}

bool check_rows(gm_param_where where, const void* values, std::string& msg) {
  for (const gm_param_info& r : kRows) {
    if (r.where != where || r.calculated || r.type == GM_PARAM_String) continue;
    // a flank modification: both flanks of gm_gear_params, flank B at one gm_flank_modification on
    const int copies = (r.flags & GM_PARAM_FLANK) ? 2 : 1;
    for (int c = 0; c < copies; ++c) {
      const void* field = static_cast<const char*>(values) + r.offset + c * sizeof(gm_flank_modification);
      const double v = number_at(r, field);
      if (r.type == GM_PARAM_Boolean) {
        if (v == 0 || v == 1) continue;
        msg = std::string(r.name) + " = " + std::to_string(int(v)) + ": allowed 0 (false) or 1 (true)";
        return false;
      }
      if (!r.has_range) continue;
      const gm_param_range range{r.name, r.lo, r.hi, r.lo_open, r.hi_open, r.unit};
      if (inside(range, v)) continue;
      msg = message(range, v);
      return false;
    }
  }
  return true;
}

}  // namespace gm

extern "C" const gm_param_info* gm_parameters(size_t* count) {
  if (count) *count = kRowCount;
  return kRows;
}

extern "C" const gm_param_info* gm_parameter_find(const char* name) {
  if (!name) return nullptr;
  for (const gm_param_info& r : kRows)
    if (std::strcmp(r.name, name) == 0) return &r;
  return nullptr;
}

extern "C" void* gm_parameter_field(const gm_param_info* r, gm_model_params* p, gm_dynamics_params* dp) {
  if (!r) return nullptr;
  if (r->where == GM_PARAM_IN_MODEL && p) return reinterpret_cast<char*>(p) + r->offset;
  if (r->where == GM_PARAM_IN_DYNAMICS && dp) return reinterpret_cast<char*>(dp) + r->offset;
  return nullptr;
}

extern "C" gm_status gm_parameter_set(gm_model_params* p, gm_dynamics_params* dp, const char* name, double value,
                                      char* msg, size_t msg_size) {
  const gm_param_info* r = gm_parameter_find(name);
  void* field = gm_parameter_field(r, p, dp);
  const char* why = !r                           ? "no such parameter (gearmesh/parameters.h)"
                    : r->type == GM_PARAM_String ? "a String (a file name), not a number"
                    : !field                     ? "not a field of the given parameter structs"
                    : r->type != GM_PARAM_Real && !(std::isfinite(value) && value == std::floor(value) &&
                                                    std::fabs(value) <= 2147483647.0)
                        ? "not a whole number"
                        : nullptr;
  if (why) {
    if (msg && msg_size) std::snprintf(msg, msg_size, "%s = %.9g: %s", name ? name : "(null)", value, why);
    return GM_ERR_ARGUMENT;
  }
  if (r->type == GM_PARAM_Real) *static_cast<double*>(field) = value;
  else *static_cast<int*>(field) = int(value);
  return GM_OK;
}

extern "C" const gm_param_range* gm_param_ranges(size_t* count) {
  if (count) *count = kRangeCount;
  return kRanges.rows;
}

extern "C" const gm_param_range* gm_param_range_find(const char* name) {
  if (!name) return nullptr;
  for (const gm_param_range& r : kRanges.rows)
    if (std::strcmp(r.name, name) == 0) return &r;
  return nullptr;
}

extern "C" gm_status gm_param_range_check(const gm_param_range* r, double value, char* msg, size_t msg_size) {
  if (!r) return GM_ERR_ARGUMENT;
  if (inside(*r, value)) return GM_OK;
  if (msg && msg_size) std::snprintf(msg, msg_size, "%s", message(*r, value).c_str());
  return GM_ERR_PARAMETER;
}
