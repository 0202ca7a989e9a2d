// fuzz_tables: the text parsers of the core's resource files on fuzzed text, and the lookups of
// what they accept. The first byte chooses the parser ('S' stiffness table, 'T' TE excitation
// table, anything else the flank deviation file: core/src/user_tables.cpp, microgeometry.cpp,
// text_file.cpp), the second the gear's teeth (5 + the byte, or 255 for 2000: gearN.teeth's ends) and, for a
// deviation file, the third its face width; the rest is the file's text. A table or file that
// parses is then looked up the way detection does (core/src/detection.cpp): at angles within
// the spin range, at roll distances and face positions around the flank, on every tooth.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "fuzz_bytes.h"
#include "microgeometry.hpp"
#include "user_tables.hpp"

namespace {

void require(bool ok, const char* what) {
  if (ok) return;
  std::fprintf(stderr, "fuzz_tables: %s\n", what);
  std::abort();
}

// A refusal names the file and line and says what is allowed (docs/reliability.md).
bool refusal_named(const std::string& msg) {
  return msg.rfind("fuzz.txt:", 0) == 0 && msg.find("allowed") != std::string::npos;
}

// A finite value within the spin range, as detection passes it (|phi| <= GM_MAX_SPIN_ANGLE).
double angle(fuzz_bytes& in) {
  const double x = fuzz_real(&in);
  return std::isfinite(x) && std::fabs(x) <= GM_MAX_SPIN_ANGLE ? x : 0.1;
}

void stiffness_table(std::string_view text, fuzz_bytes& in) {
  gm::StiffnessTable t;
  std::string msg;
  if (gm::parse_stiffness_table(text, "fuzz.txt", t, msg) != GM_OK) {
    require(refusal_named(msg) && t.empty(), "a refused stiffness table is named and left empty");
    return;
  }
  for (int k = 0; k < 8; ++k) {
    const double roll = angle(in);
    require(std::isfinite(gm::stiffness_at(t, roll)) && gm::stiffness_at(t, roll) > 0, "stiffness_at > 0");
    require(std::isfinite(gm::stiffness_slope_at(t, roll)), "stiffness_slope_at finite");
  }
}

void te_table(std::string_view text, int teeth, fuzz_bytes& in) {
  gm::TeTable t;
  std::string msg;
  if (gm::parse_te_table(text, "fuzz.txt", teeth, t, msg) != GM_OK) {
    require(refusal_named(msg) && t.empty(), "a refused TE table is named and left empty");
    return;
  }
  for (int k = 0; k < 8; ++k) {
    const gm::TeExcitation e = gm::te_excitation_at(t, angle(in));
    require(std::isfinite(e.te) && std::fabs(e.te) <= 1e-3 && std::isfinite(e.slope), "TE excitation in range");
  }
}

void deviations(std::string_view text, int teeth, double face_width, fuzz_bytes& in) {
  gm::DeviationTable t;
  std::string msg;
  if (gm::parse_deviations(text, "fuzz.txt", teeth, face_width, t, msg) != GM_OK) {
    require(refusal_named(msg), "a refused deviation file is named");
    return;
  }
  // set A's active profile, 21.46 .. 34.28 mm of roll distance (scenarios/deviations_example.txt)
  const gm::ActiveFlank active{21.46e-3, 34.28e-3, face_width};
  if (gm::validate_deviation_coverage("gear1", t, active, msg) != GM_OK) return;
  gm_gear_params gear{};
  gear.teeth = teeth;
  gear.face_width = face_width;
  const gm::GearMicrogeometry m = gm::make_microgeometry(gear, active, std::move(t));
  for (int k = 0; k < 8; ++k) {
    const int flank = int(fuzz_u8(&in) & 1), tooth = int(fuzz_u32(&in) % unsigned(teeth));
    const double rho = active.rho_start + (active.rho_tip - active.rho_start) * (1.4 * fuzz_u8(&in) / 255.0 - 0.2);
    const double y = face_width * (fuzz_u8(&in) / 255.0 - 0.5) * 1.2;
    double d_rho, d_y;
    require(std::isfinite(gm::flank_gap(m, flank, tooth, rho, y)), "flank_gap finite");
    require(std::isfinite(gm::flank_gap_slope(m, flank, tooth, rho, y, d_rho, d_y)) && std::isfinite(d_rho) &&
                std::isfinite(d_y), "flank_gap_slope finite");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 3) return 0;
  const int teeth = data[1] == 255 ? 2000 : 5 + data[1];  // 5 .. 259, and 2000
  const double face_width = 1e-3 * (1 + data[2]);      // 1 .. 256 mm
  const std::string_view text(reinterpret_cast<const char*>(data) + 3, size - 3);
  // the lookups' arguments come from the text's bytes too: a parsed file is mostly digits
  fuzz_bytes in{data + 3, size - 3, 0};
  if (data[0] == 'S') stiffness_table(text, in);
  else if (data[0] == 'T') te_table(text, teeth, in);
  else deviations(text, teeth, face_width, in);
  return 0;
}
