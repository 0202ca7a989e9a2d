// User tables of stiffness level 1 and the TE excitation: parsers and lookups. Formats and
// meaning: user_tables.hpp. The text conventions are those of the deviation file
// (microgeometry.cpp): same tokens, comments, numbers and message shape.
#include "user_tables.hpp"

#include "text_file.hpp"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <utility>

namespace gm {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;               // file angles, deg -> rad
constexpr double kUm = 1e-6;                       // file TE, um -> m
constexpr double kStiffnessUnit = 1e9;             // file stiffness, N/(mm um) -> N/m^2
constexpr double kMaxRollAngleDeg = 360;           // roll angles in the file, deg
constexpr double kMaxStiffness = 1e5;              // N/(mm um), as model.user_stiffness's 1e14 N/m^2
constexpr double kMaxTeUm = 1000;                  // |TE excitation| in the file, um

using text::format_number;
using text::quote;
using text::to_double;

// What distinguishes the two table formats.
struct TableFormat {
  const char* magic;      // header word
  const char* what;       // "stiffness table", for messages
  const char* x_name;     // "roll angle"
  const char* x_unit;     // "deg"
  const char* y_name;     // "stiffness"
  const char* y_unit;     // "N/(mm um)"
  std::size_t min_rows;
  double x_lo, x_hi;      // allowed x range, file units
  bool x_hi_open;         // x < x_hi rather than x <= x_hi
  const char* x_hi_note;  // why the upper end is what it is
  double y_lo, y_hi;      // allowed y range, file units
  bool y_lo_open;         // y > y_lo rather than y >= y_lo
};

// Two-column table reader: header, then rows "<x> <y>", x strictly increasing. On error fills
// msg (file:line: what; allowed: ...) and returns false.
class TableParser {
 public:
  TableParser(const TableFormat& f, const char* name, std::string& msg)
      : f_(f), name_(name ? name : "(table file)"), msg_(msg) {}

  bool run(std::string_view text, std::vector<double>& xs, std::vector<double>& ys) {
    int last_line = 1;
    bool header = false;
    text::TokenLines lines(text);
    while (lines.next()) {
      const int line = lines.line();
      const std::string_view* tokens = lines.tokens().data();
      const std::size_t count = lines.tokens().size();
      last_line = line;
      if (!header) {
        if (!header_(line, tokens, count)) return false;
        header = true;
        continue;
      }
      if (!row_(line, tokens, count, xs, ys)) return false;
    }
    if (!header)
      return fail(1, "empty file (only blanks and comments)",
                  std::string("'") + f_.magic + " 1' as the first line");
    if (xs.size() < f_.min_rows)
      return fail(last_line,
                  std::string("the ") + f_.what + " has " + std::to_string(xs.size()) +
                      " rows at the end of the file",
                  "at least " + std::to_string(f_.min_rows) + " rows '<" + f_.x_name + " " +
                      f_.x_unit + "> <" + f_.y_name + " " + f_.y_unit + ">'");
    return true;
  }

 private:
  bool fail(int line, const std::string& what, const std::string& allowed) {
    msg_ = std::string(name_) + ":" + std::to_string(line) + ": " + what + "; allowed: " + allowed;
    return false;
  }

  bool header_(int line, const std::string_view* tokens, std::size_t count) {
    const std::string first = std::string("'") + f_.magic + " 1' as the first line";
    if (tokens[0] != f_.magic)
      return fail(line, std::string("expected the magic word '") + f_.magic + "', found " +
                            quote(tokens[0]),
                  first);
    if (count != 2 || tokens[1] != "1")
      return fail(line,
                  "unsupported format version " +
                      (count > 1 ? quote(tokens[1]) + (count > 2 ? " ..." : "") : std::string("(none)")),
                  std::string("version 1 ('") + f_.magic + " 1')");
    return true;
  }

  bool row_(int line, const std::string_view* tokens, std::size_t count, std::vector<double>& xs,
            std::vector<double>& ys) {
    const std::string row_form = std::string("'<") + f_.x_name + " " + f_.x_unit + "> <" +
                                 f_.y_name + " " + f_.y_unit + ">'";
    if (tokens[0] == f_.magic)
      return fail(line, std::string("second '") + f_.magic + "' line", "one header line, the first");
    if (count != 2)
      return fail(line, "a row with " + std::to_string(count) + " values",
                  "exactly two numbers per row, " + row_form);
    double x = 0, y = 0;
    std::string why;
    if (!to_double(tokens[0], x, why))
      return fail(line, std::string(f_.x_name) + " " + quote(tokens[0]) + " " + why,
                  std::string("a finite decimal number, ") + f_.x_unit + "; rows are " + row_form);
    if (!to_double(tokens[1], y, why))
      return fail(line, std::string(f_.y_name) + " " + quote(tokens[1]) + " " + why,
                  std::string("a finite decimal number, ") + f_.y_unit + "; rows are " + row_form);
    const std::string x_range = "[" + format_number(f_.x_lo) + ", " + format_number(f_.x_hi) +
                                (f_.x_hi_open ? ") " : "] ") + f_.x_unit + f_.x_hi_note;
    if (x < f_.x_lo || (f_.x_hi_open ? x >= f_.x_hi : x > f_.x_hi))
      return fail(line, std::string(f_.x_name) + " " + format_number(x) + " " + f_.x_unit +
                            " is out of range",
                  x_range);
    if (!xs.empty() && !(x > xs.back()))
      return fail(line, std::string(f_.x_name) + "s are not strictly increasing (" +
                            format_number(x) + " after " + format_number(xs.back()) + ")",
                  std::string("strictly increasing ") + f_.x_name + "s, " + f_.x_unit);
    if ((f_.y_lo_open ? y <= f_.y_lo : y < f_.y_lo) || y > f_.y_hi)
      return fail(line, std::string(f_.y_name) + " " + format_number(y) + " " + f_.y_unit +
                            " is out of range",
                  std::string(f_.y_lo_open ? "(" : "[") + format_number(f_.y_lo) + ", " +
                      format_number(f_.y_hi) + "] " + f_.y_unit);
    xs.push_back(x);
    ys.push_back(y);
    return true;
  }

  const TableFormat& f_;
  const char* name_;
  std::string& msg_;
};

const TableFormat kStiffnessFormat{
    "gearmesh-stiffness-table", "stiffness table", "roll angle", "deg", "stiffness", "N/(mm um)",
    2, 0.0, kMaxRollAngleDeg, false, " (roll distance on gear 1's flank / r_b1)",
    0.0, kMaxStiffness, true};

}  // namespace

gm_status parse_stiffness_table(std::string_view text, const char* name, StiffnessTable& out,
                                std::string& msg) {
  std::vector<double> x, y;
  if (!TableParser(kStiffnessFormat, name, msg).run(text, x, y)) return GM_ERR_PARAMETER;
  for (double& v : x) v *= kDeg;
  for (double& v : y) v *= kStiffnessUnit;
  out.roll_angle = std::move(x);
  out.stiffness = std::move(y);
  return GM_OK;
}

gm_status load_stiffness_table(const char* path, StiffnessTable& out, std::string& msg) {
  if (!path || !*path) {
    msg = "load_stiffness_table: no path given";
    return GM_ERR_ARGUMENT;
  }
  std::string text;
  if (!text::read_file(path, "stiffness table", kStiffnessFormat.magic, text, msg)) return GM_ERR_PARAMETER;
  return parse_stiffness_table(text, path, out, msg);
}

gm_status parse_te_table(std::string_view text, const char* name, int teeth1, TeTable& out,
                         std::string& msg) {
  if (teeth1 <= 0) {
    msg = std::string(name ? name : "(table file)") + ": parse_te_table needs teeth1 > 0";
    return GM_ERR_ARGUMENT;
  }
  const double pitch_deg = 360.0 / teeth1;
  const std::string note = " (one pitch of gear 1, 360/" + std::to_string(teeth1) +
                           " deg; the period itself is the first row again)";
  const TableFormat format{"gearmesh-te-table", "TE table", "angle", "deg", "TE", "um", 1,
                           0.0, pitch_deg, true, note.c_str(), -kMaxTeUm, kMaxTeUm, false};
  std::vector<double> x, y;
  if (!TableParser(format, name, msg).run(text, x, y)) return GM_ERR_PARAMETER;
  for (double& v : x) v *= kDeg;
  for (double& v : y) v *= kUm;
  out.period = 2 * kPi / teeth1;
  out.angle = std::move(x);
  out.te = std::move(y);
  return GM_OK;
}

gm_status load_te_table(const char* path, int teeth1, TeTable& out, std::string& msg) {
  if (!path || !*path) {
    msg = "load_te_table: no path given";
    return GM_ERR_ARGUMENT;
  }
  std::string text;
  if (!text::read_file(path, "TE table", "gearmesh-te-table", text, msg)) return GM_ERR_PARAMETER;
  return parse_te_table(text, path, teeth1, out, msg);
}

double stiffness_at(const StiffnessTable& t, double roll_angle) {
  const std::vector<double>& a = t.roll_angle;
  const std::size_t n = a.size();
  if (!(roll_angle > a[0])) return t.stiffness[0];
  if (!(roll_angle < a[n - 1])) return t.stiffness[n - 1];
  const std::size_t j = static_cast<std::size_t>(std::upper_bound(a.begin(), a.end(), roll_angle) - a.begin());
  const double u = (roll_angle - a[j - 1]) / (a[j] - a[j - 1]);
  return t.stiffness[j - 1] + u * (t.stiffness[j] - t.stiffness[j - 1]);
}

double stiffness_slope_at(const StiffnessTable& t, double roll_angle) {
  const std::vector<double>& a = t.roll_angle;
  const std::size_t n = a.size();
  if (!(roll_angle > a[0]) || !(roll_angle < a[n - 1])) return 0;
  const std::size_t j = static_cast<std::size_t>(std::upper_bound(a.begin(), a.end(), roll_angle) - a.begin());
  return (t.stiffness[j] - t.stiffness[j - 1]) / (a[j] - a[j - 1]);
}

TeExcitation te_excitation_at(const TeTable& t, double phi1) {
  const std::vector<double>& a = t.angle;
  const std::size_t n = a.size();
  if (n == 1) return {t.te[0], 0.0};
  const double P = t.period;
  double x = phi1 - P * std::floor(phi1 / P);
  if (!(x < P)) x -= P;  // rounding at the period's end
  if (!(x >= 0)) x = 0;
  const std::size_t j = static_cast<std::size_t>(std::upper_bound(a.begin(), a.end(), x) - a.begin());
  // segment from row j - 1 to row j, wrapping from the last row to the first one period later
  const double x0 = j == 0 ? a[n - 1] - P : a[j - 1];
  const double y0 = j == 0 ? t.te[n - 1] : t.te[j - 1];
  const double x1 = j == n ? a[0] + P : a[j];
  const double y1 = j == n ? t.te[0] : t.te[j];
  const double slope = (y1 - y0) / (x1 - x0);
  return {y0 + slope * (x - x0), slope};
}

}  // namespace gm
