// Flank micro-geometry: design modifications, measured deviation grids and pitch deviations
// (docs/physics.md §2). Formulas and the deviation file format: microgeometry.hpp.
#include "microgeometry.hpp"

#include "dual.hpp"
#include "params.hpp"
#include "text_file.hpp"

#include <algorithm>
#include <cassert>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <utility>

namespace gm {
namespace {

constexpr double kUm = 1e-6;                    // file deviations, um -> m
constexpr double kMm = 1e-3;                    // file roll and face positions, mm -> m
constexpr double kMaxDeviationUm = 1e4;         // |deviation| in the file, um
constexpr double kMaxPositionMm = 1e5;          // |roll|, |face| in the file, mm
constexpr double kFaceToleranceMm = 1e-3;       // face points may exceed b/2 by this, mm

// ---------------------------------------------------------------------------------------------
// Deviation file parser.

using text::format_number;
using text::quote;
using text::to_double;

bool to_int(std::string_view t, int& v) {
  const char* end = t.data() + t.size();
  const auto r = std::from_chars(t.data(), end, v);
  return r.ec == std::errc() && r.ptr == end;
}

bool looks_numeric(std::string_view t) {
  const char c = t.empty() ? 'x' : t[0];
  return (c >= '0' && c <= '9') || c == '-' || c == '+' || c == '.';
}

// What the parser collects; parse_deviations moves it into the table.
struct Parsed {
  std::vector<double> roll_, face_;  // m
  std::vector<int> grid_offset_;     // [2 tooth + flank], -1 = none
  std::vector<double> values_;       // m, material added
};

class DeviationParser {
 public:
  DeviationParser(const char* name, int teeth, double face_width, std::string& msg)
      : name_(name ? name : "(deviation file)"), teeth_(teeth), half_b_mm_(0.5 * face_width / kMm),
        msg_(msg) {}

  bool run(std::string_view text, Parsed& t, std::vector<double>& fpt_um,
           std::vector<int>& pitch_line, std::vector<int>& grid_line) {
    fpt_um_ = &fpt_um;
    pitch_line_ = &pitch_line;
    grid_line_ = &grid_line;
    text::TokenLines lines(text);
    while (lines.next()) {
      tokens_ = lines.tokens();
      if (!handle_line(lines.line(), t)) return false;
    }
    if (!magic_)
      return fail(1, "empty file (only blanks and comments)",
                  "'gearmesh-deviations 1' as the first line");
    if (grid_open_)
      return fail(grid_open_line_, "grid " + std::to_string(grid_tooth_) + " " + "AB"[grid_flank_] +
                                       " has " + std::to_string(grid_read_) + " of " +
                                       std::to_string(grid_count_) + " values at the end of the file",
                  "n_roll * n_face values (roll-major) after 'grid <tooth> <A|B>'");
    return true;
  }

  bool fail(int line, const std::string& what, const std::string& allowed) {
    msg_ = std::string(name_) + ":" + std::to_string(line) + ": " + what + "; allowed: " + allowed;
    return false;
  }

 private:
  bool handle_line(int line, Parsed& t) {
    const std::string_view key = tokens_[0];
    if (!magic_) {
      if (key != "gearmesh-deviations")
        return fail(line, "expected the magic word 'gearmesh-deviations', found " + quote(key),
                    "'gearmesh-deviations 1' as the first line");
      int version = 0;
      if (tokens_.size() != 2 || !to_int(tokens_[1], version) || version != 1)
        return fail(line,
                    "unsupported format version " +
                        (tokens_.size() > 1 ? quote(tokens_[1]) : std::string("(none)")),
                    "version 1 ('gearmesh-deviations 1')");
      magic_ = true;
      return true;
    }
    if (grid_open_) {
      if (key == "teeth" || key == "roll_mm" || key == "face_mm" || key == "grid" ||
          key == "pitch" || key == "gearmesh-deviations")
        return fail(line,
                    "grid " + std::to_string(grid_tooth_) + " " + "AB"[grid_flank_] + " of line " +
                        std::to_string(grid_open_line_) + " has only " + std::to_string(grid_read_) +
                        " of " + std::to_string(grid_count_) + " values before " + quote(key),
                    "n_roll * n_face = " + std::to_string(grid_count_) + " values (roll-major)");
      return grid_values_(line, 0, t);
    }
    if (key == "teeth") return teeth_line_(line);
    if (key == "roll_mm") return axis_(line, true, t);
    if (key == "face_mm") return axis_(line, false, t);
    if (key == "grid") return grid_(line, t);
    if (key == "pitch") return pitch_(line);
    if (key == "gearmesh-deviations")
      return fail(line, "second 'gearmesh-deviations' line", "one header line, the first");
    if (looks_numeric(key))
      return fail(line, "values outside a grid: " + quote(key),
                  "numbers only after 'roll_mm', 'face_mm', 'pitch <tooth> <A|B>', or after "
                  "'grid <tooth> <A|B>' until n_roll * n_face values are read");
    return fail(line, "unknown keyword " + quote(key),
                "'teeth', 'roll_mm', 'face_mm', 'grid', 'pitch' or a '#' comment");
  }

  bool teeth_line_(int line) {
    if (teeth_seen_) return fail(line, "duplicate 'teeth' line", "one 'teeth <z>' line");
    int z = 0;
    if (tokens_.size() != 2 || !to_int(tokens_[1], z))
      return fail(line, "malformed 'teeth' line", "'teeth <z>' with an integer z");
    if (z != teeth_)
      return fail(line, "the file is for a gear with " + std::to_string(z) + " teeth",
                  "'teeth " + std::to_string(teeth_) + "' (this gear has " +
                      std::to_string(teeth_) + " teeth)");
    teeth_seen_ = true;
    return true;
  }

  bool axis_(int line, bool roll, Parsed& t) {
    std::vector<double>& axis = roll ? roll_mm_ : face_mm_;
    const char* key = roll ? "roll_mm" : "face_mm";
    if (!axis.empty()) return fail(line, std::string("duplicate '") + key + "' line", std::string("one '") + key + "' line per file");
    if (tokens_.size() < 2)
      return fail(line, std::string("'") + key + "' without values", "at least one point, mm");
    std::vector<double> v;
    std::string why;
    for (std::size_t k = 1; k < tokens_.size(); ++k) {
      double x = 0;
      if (!to_double(tokens_[k], x, why))
        return fail(line, std::string(key) + " value " + std::to_string(k) + " " + quote(tokens_[k]) +
                              " " + why,
                    "finite decimal numbers, mm");
      if (std::fabs(x) > kMaxPositionMm)
        return fail(line, std::string(key) + " value " + format_number(x) + " mm is implausible",
                    "|value| <= " + format_number(kMaxPositionMm) + " mm");
      if (!v.empty() && !(x > v.back()))
        return fail(line, std::string(key) + " values are not strictly increasing at value " +
                              std::to_string(k) + " (" + format_number(x) + " after " +
                              format_number(v.back()) + ")",
                    "strictly increasing positions, mm");
      if (roll && x < 0)
        return fail(line, "roll_mm value " + format_number(x) + " is negative",
                    "roll distances from the base tangency point, >= 0 mm");
      if (!roll && std::fabs(x) > half_b_mm_ + kFaceToleranceMm)
        return fail(line, "face_mm value " + format_number(x) + " mm lies outside the face width",
                    "[-b/2, b/2] = [" + format_number(-half_b_mm_) + ", " +
                        format_number(half_b_mm_) + "] mm from mid-face");
      v.push_back(x);
    }
    axis = v;
    std::vector<double>& dst = roll ? t.roll_ : t.face_;
    dst.resize(v.size());
    for (std::size_t k = 0; k < v.size(); ++k) dst[k] = v[k] * kMm;
    return true;
  }

  // "<tooth> <A|B>" at tokens_[1], tokens_[2].
  bool tooth_flank_(int line, const char* what, int& tooth, int& flank) {
    if (!teeth_seen_)
      return fail(line, std::string("'") + what + "' line before the 'teeth' line",
                  "'teeth <z>' after the header, before any grid or pitch line");
    if (tokens_.size() < 3)
      return fail(line, std::string("malformed '") + what + "' line",
                  std::string("'") + what + " <tooth> <A|B> ...'");
    if (!to_int(tokens_[1], tooth))
      return fail(line, "tooth " + quote(tokens_[1]) + " is not an integer",
                  "a tooth index 0.." + std::to_string(teeth_ - 1));
    if (tooth < 0 || tooth >= teeth_)
      return fail(line, "tooth " + std::to_string(tooth) + " out of range",
                  "0.." + std::to_string(teeth_ - 1) + " (teeth " + std::to_string(teeth_) + ")");
    if (tokens_[2] == "A") {
      flank = 0;
    } else if (tokens_[2] == "B") {
      flank = 1;
    } else {
      return fail(line, "bad flank " + quote(tokens_[2]), "'A' or 'B'");
    }
    return true;
  }

  bool grid_(int line, Parsed& t) {
    int tooth = 0, flank = 0;
    if (!tooth_flank_(line, "grid", tooth, flank)) return false;
    if (roll_mm_.empty() || face_mm_.empty())
      return fail(line, "grid line before the axes", "'roll_mm ...' and 'face_mm ...' before any grid");
    const std::size_t slot = 2 * static_cast<std::size_t>(tooth) + flank;
    if (t.grid_offset_.empty()) {
      t.grid_offset_.assign(2 * static_cast<std::size_t>(teeth_), -1);
      grid_line_->assign(2 * static_cast<std::size_t>(teeth_), 0);
    }
    if (t.grid_offset_[slot] >= 0)
      return fail(line,
                  "duplicate grid for tooth " + std::to_string(tooth) + " " + "AB"[flank] +
                      " (first on line " + std::to_string((*grid_line_)[slot]) + ")",
                  "one grid per tooth and flank");
    t.grid_offset_[slot] = static_cast<int>(t.values_.size());
    (*grid_line_)[slot] = line;
    grid_open_ = true;
    grid_open_line_ = line;
    grid_tooth_ = tooth;
    grid_flank_ = flank;
    grid_read_ = 0;
    grid_count_ = roll_mm_.size() * face_mm_.size();
    return grid_values_(line, 3, t);
  }

  bool grid_values_(int line, std::size_t first, Parsed& t) {
    std::string why;
    for (std::size_t k = first; k < tokens_.size(); ++k) {
      if (grid_read_ == grid_count_)
        return fail(line,
                    "grid " + std::to_string(grid_tooth_) + " " + "AB"[grid_flank_] + " of line " +
                        std::to_string(grid_open_line_) + " has more than " +
                        std::to_string(grid_count_) + " values",
                    "n_roll * n_face = " + std::to_string(roll_mm_.size()) + " * " +
                        std::to_string(face_mm_.size()) + " values (roll-major)");
      double v = 0;
      if (!to_double(tokens_[k], v, why))
        return fail(line, "grid value " + quote(tokens_[k]) + " " + why, "finite numbers, um");
      if (std::fabs(v) > kMaxDeviationUm)
        return fail(line, "grid value " + format_number(v) + " um is implausible",
                    "|deviation| <= " + format_number(kMaxDeviationUm) + " um");
      t.values_.push_back(v * kUm);
      ++grid_read_;
    }
    if (grid_read_ == grid_count_) grid_open_ = false;
    return true;
  }

  bool pitch_(int line) {
    int tooth = 0, flank = 0;
    if (!tooth_flank_(line, "pitch", tooth, flank)) return false;
    if (tokens_.size() != 4)
      return fail(line, "'pitch' line with " + std::to_string(tokens_.size() - 3) + " values",
                  "'pitch <tooth> <A|B> <f_pt um>' with exactly one value");
    double v = 0;
    std::string why;
    if (!to_double(tokens_[3], v, why))
      return fail(line, "pitch value " + quote(tokens_[3]) + " " + why, "a finite number, um");
    if (std::fabs(v) > kMaxDeviationUm)
      return fail(line, "pitch value " + format_number(v) + " um is implausible",
                  "|f_pt| <= " + format_number(kMaxDeviationUm) + " um");
    const std::size_t slot = 2 * static_cast<std::size_t>(tooth) + flank;
    if (fpt_um_->empty()) {
      fpt_um_->assign(2 * static_cast<std::size_t>(teeth_), 0.0);
      pitch_line_->assign(2 * static_cast<std::size_t>(teeth_), 0);
    }
    if ((*pitch_line_)[slot] != 0)
      return fail(line,
                  "duplicate pitch for tooth " + std::to_string(tooth) + " " + "AB"[flank] +
                      " (first on line " + std::to_string((*pitch_line_)[slot]) + ")",
                  "one pitch line per tooth and flank");
    (*fpt_um_)[slot] = v;
    (*pitch_line_)[slot] = line;
    return true;
  }

  const char* name_;
  int teeth_;
  double half_b_mm_;
  std::string& msg_;
  std::vector<std::string_view> tokens_;
  bool magic_ = false;
  bool teeth_seen_ = false;
  std::vector<double> roll_mm_, face_mm_;
  bool grid_open_ = false;
  int grid_open_line_ = 0, grid_tooth_ = 0, grid_flank_ = 0;
  std::size_t grid_read_ = 0, grid_count_ = 0;
  std::vector<double>* fpt_um_ = nullptr;
  std::vector<int>* pitch_line_ = nullptr;
  std::vector<int>* grid_line_ = nullptr;
};

// Position of x on a strictly increasing axis: a[i] + t (a[i1] - a[i]), edge values held.
inline void locate(const std::vector<double>& a, double x, std::size_t& i, std::size_t& i1,
                   double& t) {
  const std::size_t n = a.size();
  if (n == 1 || !(x > a[0])) {
    i = i1 = 0;
    t = 0;
  } else if (!(x < a[n - 1])) {
    i = i1 = n - 1;
    t = 0;
  } else {
    i1 = static_cast<std::size_t>(std::upper_bound(a.begin(), a.end(), x) - a.begin());
    i = i1 - 1;
    t = (x - a[i]) / (a[i1] - a[i]);
  }
}

// ---------------------------------------------------------------------------------------------
// Modification checks: stop at the first failure and name the FMU parameter.

class ModChecker {
 public:
  ModChecker(const char* prefix, std::string& msg) : prefix_(prefix ? prefix : "gear"), msg_(msg) {}
  bool ok() const { return ok_; }

  // A relief length while its relief is on: in (0, hi], hi from the flank's size (note says which).
  void length(const char* name, double v, double hi, const char* note) {
    if (!ok_ || (v > 0 && v <= hi)) return;
    char buf[400];
    std::snprintf(buf, sizeof buf, "%s.%s = %.9g m: allowed range (0, %.9g] m%s", prefix_, name, v, hi, note);
    fail(buf);
  }

 private:
  void fail(const char* text) {
    msg_ = text;
    ok_ = false;
  }
  const char* prefix_;
  std::string& msg_;
  bool ok_ = true;
};

}  // namespace

// ---------------------------------------------------------------------------------------------
// DeviationTable

bool DeviationTable::has_grid(int tooth, int flank) const {
  if (grid_offset_.empty() || tooth < 0 || tooth >= teeth_ || flank < 0 || flank > 1) return false;
  return grid_offset_[2 * static_cast<std::size_t>(tooth) + flank] >= 0;
}

double DeviationTable::measured(int tooth, int flank, double rho, double y) const {
  if (!has_grid(tooth, flank)) return 0;
  const double* v = values_.data() + grid_offset_[2 * static_cast<std::size_t>(tooth) + flank];
  std::size_t i, i1, j, j1;
  double s, t;
  locate(roll_, rho, i, i1, s);
  locate(face_, y, j, j1, t);
  const std::size_t m = face_.size();
  const double a = v[i * m + j] + t * (v[i * m + j1] - v[i * m + j]);
  const double b = v[i1 * m + j] + t * (v[i1 * m + j1] - v[i1 * m + j]);
  return a + s * (b - a);
}

double DeviationTable::measured_slope(int tooth, int flank, double rho, double y, double& d_rho,
                                      double& d_y) const {
  d_rho = d_y = 0;
  if (!has_grid(tooth, flank)) return 0;
  const double* v = values_.data() + grid_offset_[2 * static_cast<std::size_t>(tooth) + flank];
  std::size_t i, i1, j, j1;
  double s, t;
  locate(roll_, rho, i, i1, s);
  locate(face_, y, j, j1, t);
  const std::size_t m = face_.size();
  const double a = v[i * m + j] + t * (v[i * m + j1] - v[i * m + j]);
  const double b = v[i1 * m + j] + t * (v[i1 * m + j1] - v[i1 * m + j]);
  // held at the edges (i == i1, j == j1): no slope there
  if (i1 != i) d_rho = (b - a) / (roll_[i1] - roll_[i]);
  if (j1 != j)
    d_y = ((1 - s) * (v[i * m + j1] - v[i * m + j]) + s * (v[i1 * m + j1] - v[i1 * m + j])) /
          (face_[j1] - face_[j]);
  return a + s * (b - a);
}

double DeviationTable::cumulative_pitch(int tooth, int flank) const {
  if (pitch_.empty() || tooth < 0 || tooth >= teeth_ || flank < 0 || flank > 1) return 0;
  return pitch_[2 * static_cast<std::size_t>(tooth) + flank];
}

double DeviationTable::gap(int tooth, int flank, double rho, double y) const {
  return -(measured(tooth, flank, rho, y) + cumulative_pitch(tooth, flank));
}

gm_status parse_deviations(std::string_view text, const char* name, int teeth, double face_width,
                           DeviationTable& out, std::string& msg) {
  if (teeth <= 0 || !(face_width > 0) || !std::isfinite(face_width)) {
    msg = std::string(name ? name : "(deviation file)") +
          ": parse_deviations needs teeth > 0 and a finite face width > 0";
    return GM_ERR_ARGUMENT;
  }
  DeviationParser parser(name, teeth, face_width, msg);
  Parsed p;
  std::vector<double> fpt_um;
  std::vector<int> pitch_line, grid_line;
  if (!parser.run(text, p, fpt_um, pitch_line, grid_line)) return GM_ERR_PARAMETER;
  DeviationTable t;
  t.teeth_ = teeth;
  if (!p.grid_offset_.empty()) {  // axes without grids carry no information
    t.roll_ = std::move(p.roll_);
    t.face_ = std::move(p.face_);
    t.grid_offset_ = std::move(p.grid_offset_);
    t.values_ = std::move(p.values_);
  }
  if (!fpt_um.empty()) {
    t.pitch_.assign(fpt_um.size(), 0.0);
    for (int f = 0; f < 2; ++f) {
      double sum = 0, max_abs = 0;
      int last_line = 0;
      for (int k = 0; k < teeth; ++k) {
        const std::size_t slot = 2 * static_cast<std::size_t>(k) + f;
        sum += fpt_um[slot];
        max_abs = std::max(max_abs, std::fabs(fpt_um[slot]));
        last_line = std::max(last_line, pitch_line[slot]);
        t.pitch_[slot] = sum * kUm;  // F_p(k) = sum_{j=0..k} f_pt(j)
      }
      const double allowed = 1e-3 + 1e-3 * max_abs;
      if (std::fabs(sum) > allowed) {
        parser.fail(last_line,
                    std::string("the single pitch deviations of flank ") + "AB"[f] +
                        " do not close around the gear: their sum over the " +
                        std::to_string(teeth) + " teeth is " + format_number(sum) + " um",
                    "|sum| <= " + format_number(allowed) +
                        " um (0.001 um + 0.001 max |f_pt|); unlisted teeth count as 0");
        return GM_ERR_PARAMETER;
      }
    }
  }
  out = std::move(t);
  return GM_OK;
}

gm_status load_deviations(const char* path, int teeth, double face_width, DeviationTable& out,
                          std::string& msg) {
  if (!path || !*path) {
    msg = "load_deviations: no path given";
    return GM_ERR_ARGUMENT;
  }
  std::string text;
  if (!text::read_file(path, "deviation file", "gearmesh-deviations", text, msg))
    return GM_ERR_PARAMETER;
  return parse_deviations(text, path, teeth, face_width, out, msg);
}

// ---------------------------------------------------------------------------------------------
// Design modifications

GearMicrogeometry make_microgeometry(const gm_gear_params& g, const ActiveFlank& active,
                                     DeviationTable deviations) {
  GearMicrogeometry m;
  m.flank[0] = g.flank[0];
  m.flank[1] = g.flank[1];
  m.active = active;
  m.deviations = std::move(deviations);
  m.profile_dir = active.rho_tip >= active.rho_start ? 1.0 : -1.0;
  const double L = std::fabs(active.rho_tip - active.rho_start);
  m.profile_length = L;
  m.inv_profile_length = L > 0 ? 1.0 / L : 0.0;
  for (int f = 0; f < 2; ++f) {
    const gm_flank_modification& d = m.flank[f];
    m.profile_any[f] = d.profile_crowning != 0 || (d.tip_relief != 0 && d.tip_relief_length > 0) ||
                       (d.root_relief != 0 && d.root_relief_length > 0) || d.profile_slope != 0;
    m.lead_any[f] = active.face_width > 0 &&
                    (d.lead_crowning != 0 || d.helix_slope != 0 ||
                     (d.end_relief != 0 && d.end_relief_length > 0));
  }
  m.any = m.profile_any[0] || m.profile_any[1] || m.lead_any[0] || m.lead_any[1] ||
          !m.deviations.empty();
  return m;
}

namespace {

// The design modifications of one flank at (rho, y), for T = double or Dual (derivatives along
// rho and y); the measured deviations are added by the callers.
template <class T>
T modification_gap(const GearMicrogeometry& m, int flank, const T& rho, const T& y) {
  const gm_flank_modification& d = m.flank[flank];
  T gap = 0;
  if (m.profile_any[flank]) {
    const double L = m.profile_length;
    const T s = (rho - m.active.rho_start) * m.profile_dir;  // from the SAP towards the tip
    const T u = s * m.inv_profile_length;                    // 0 at the SAP, 1 at the tip
    if (d.profile_crowning != 0) {
      const T q = 2 * u - 1;
      gap += d.profile_crowning * q * q;
    }
    if (d.tip_relief != 0 && d.tip_relief_length > 0) {
      const T depth = s - (L - d.tip_relief_length);
      if (depth > 0) {
        const T r = depth / d.tip_relief_length;
        gap += d.tip_relief * (d.tip_relief_parabolic ? r * r : r);
      }
    }
    if (d.root_relief != 0 && d.root_relief_length > 0) {
      const T depth = d.root_relief_length - s;
      if (depth > 0) {
        const T r = depth / d.root_relief_length;
        gap += d.root_relief * (d.root_relief_parabolic ? r * r : r);
      }
    }
    if (d.profile_slope != 0) gap += d.profile_slope * (u - 0.5);
  }
  if (m.lead_any[flank]) {
    const double b = m.active.face_width;
    const T v = y / b;  // -1/2 .. 1/2
    if (d.lead_crowning != 0) gap += d.lead_crowning * 4 * v * v;
    if (d.helix_slope != 0) gap += d.helix_slope * v;
    if (d.end_relief != 0 && d.end_relief_length > 0) {
      const T depth = (y < 0 ? -y : y) - (0.5 * b - d.end_relief_length);
      if (depth > 0) gap += d.end_relief * depth / d.end_relief_length;
    }
  }
  return gap;
}

int reduced_tooth(int tooth, int z) { return tooth < 0 || tooth >= z ? ((tooth % z) + z) % z : tooth; }

}  // namespace

double flank_gap(const GearMicrogeometry& m, int flank, int tooth, double rho, double y) {
  assert(flank == 0 || flank == 1);
  if (!m.any) return 0;
  double gap = modification_gap(m, flank, rho, y);
  if (!m.deviations.empty())
    gap += m.deviations.gap(reduced_tooth(tooth, m.deviations.teeth()), flank, rho, y);
  return gap;
}

namespace {

// flank_gap over dual numbers: the same terms, with derivatives along (rho, y).
Dual flank_gap_dual(const GearMicrogeometry& m, int flank, int tooth, Dual rho, Dual y) {
  assert(flank == 0 || flank == 1);
  if (!m.any) return 0;
  Dual gap = modification_gap(m, flank, rho, y);
  if (!m.deviations.empty()) {
    tooth = reduced_tooth(tooth, m.deviations.teeth());
    double d_rho = 0, d_y = 0;
    const double measured = m.deviations.measured_slope(tooth, flank, rho.v, y.v, d_rho, d_y);
    gap += Dual(-(measured + m.deviations.cumulative_pitch(tooth, flank)),
                -(d_rho * rho.d + d_y * y.d));
  }
  return gap;
}

}  // namespace

double flank_gap_slope(const GearMicrogeometry& m, int flank, int tooth, double rho, double y,
                       double& d_rho, double& d_y) {
  const Dual by_rho = flank_gap_dual(m, flank, tooth, Dual(rho, 1), Dual(y, 0));
  d_rho = by_rho.d;
  d_y = flank_gap_dual(m, flank, tooth, Dual(rho, 0), Dual(y, 1)).d;
  return by_rho.v;
}

gm_status validate_modification(const char* prefix, const gm_flank_modification& mod,
                                const ActiveFlank& active, std::string& msg) {
  ModChecker c(prefix, msg);
  // Lengths may reach their limits up to rounding of the decimal inputs.
  const double L = std::fabs(active.rho_tip - active.rho_start);
  const double half_b = 0.5 * active.face_width;
  const double slack = 1e-9;
  // A relief length reaches its limit only while its relief is on.
  if (mod.tip_relief != 0)
    c.length("tip_relief_length", mod.tip_relief_length, L * (1 + slack), " (the active profile length)");
  if (mod.root_relief != 0) {
    const double tip = mod.tip_relief != 0 ? mod.tip_relief_length : 0;
    c.length("root_relief_length", mod.root_relief_length, L - tip + slack * L,
             tip > 0 ? " (the active profile length less the tip relief length)"
                     : " (the active profile length)");
  }
  if (mod.end_relief != 0)
    c.length("end_relief_length", mod.end_relief_length, half_b * (1 + slack), " (half the face width)");
  return c.ok() ? GM_OK : GM_ERR_PARAMETER;
}

gm_status validate_deviation_coverage(const char* prefix, const DeviationTable& table,
                                      const ActiveFlank& active, std::string& msg) {
  const std::vector<double>& r = table.roll_axis();
  if (r.empty()) return GM_OK;
  const double lo = std::min(active.rho_start, active.rho_tip);
  const double hi = std::max(active.rho_start, active.rho_tip);
  if (r.back() >= lo && r.front() <= hi) return GM_OK;
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "%s.deviations: the measured roll distances %.6g..%.6g mm do not overlap the "
                "active profile %.6g..%.6g mm; allowed: roll_mm values that overlap it, roll "
                "distances from the base tangency point, rho = sqrt(d^2 - d_b^2)/2 (not "
                "diameters or roll angles)",
                prefix ? prefix : "gear", r.front() / kMm, r.back() / kMm, lo / kMm, hi / kMm);
  msg = buf;
  return GM_ERR_PARAMETER;
}

}  // namespace gm
