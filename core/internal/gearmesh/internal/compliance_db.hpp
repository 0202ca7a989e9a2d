// Compliance database of one gear body (docs/design.md "compliance_tool", docs/physics.md §5, FE
// level): written by compliance_tool, read by the core at gm_model_create.
//
// FILE FORMAT, version 1 (extension .gcdb). Binary, every number in explicit little-endian byte
// order, written and read byte by byte (independent of the host's byte order and struct layout):
//   u32  unsigned 32-bit integer, least significant byte first
//   f64  IEEE-754 binary64, its 64-bit pattern stored as a little-endian u64
//   str  u32 byte count n (<= 65536), then n bytes of UTF-8 text (no terminating NUL)
//
//   offset  field               type   meaning
//   0       magic               5 B    "GMCDB" (47 4D 43 44 42)
//   5       version             u32    1 (a reader refuses any other version)
//   9       teeth               u32    z, number of teeth (magnitude), 3..10000
//   13      internal            u32    1 if this gear is an internal ring, else 0
//   17      normal_module       f64    m_n, m
//   25      pressure_angle      f64    alpha_n, rad
//   33      helix_angle         f64    beta of THIS gear, rad, signed (+ right hand): gear 1 has
//                                      model.helix_angle, gear 2 its negative (external pair)
//                                      or model.helix_angle itself (internal pair)
//   41      profile_shift       f64    x, -
//   49      thickness_allowance f64    E_sn, m
//   57      face_width          f64    b, m
//   65      tip_diameter        f64    d_a as resolved by the core's geometry (ring: inner), m
//   73      rack_addendum       f64    h_aP*, in modules
//   81      rack_dedendum       f64    h_fP*, in modules
//   89      rack_tip_radius     f64    rho_fP*, in modules
//   97      youngs_modulus      f64    E, Pa
//   105     poisson_ratio       f64    nu, -
//   113     bore_radius         f64    radius of the clamped bore (the displacement reference), m
//   121     mesh_size           f64    target element edge length used on the flanks, m
//   129     mesh_order          u32    element order used, 1 or 2 (2 with an odd n_roll: the
//                                      roll grid is the elements' corner and mid nodes, corners
//                                      at even indices, and level 5 reads it with the quadratic
//                                      shape functions; else linearly)
//   133     mesh_face_layers    u32    element layers across the face width, >= 1
//   137     depth               f64    h, depth below the flank at which displacements are
//                                      taken (docs/physics.md §5), m, > 0
//   145     note                str    free text (tool version, mesh file, date, ...)
//   then (offsets now depend on the note's length):
//           cyclic              u32    1: cyclically symmetric body, one tooth set serves every
//                                      tooth; 0: one tooth set per tooth (z sets, tooth 0..z-1)
//           mirror              u32    1: flank B is the mirror image of flank A, one flank set
//                                      serves both; 0: flank A's set, then flank B's set
//           n_roll              u32    roll-distance grid size, 1..10000
//           n_face              u32    face-coordinate grid size, 1..10000
//           n_coupled           u32    n_c, coupled neighbour teeth each side, 0..20, and
//                                      2 n_c + 1 <= z
//           roll[n_roll]        f64    roll distances of the reference tooth's flank grid, m,
//                                      finite, strictly increasing
//           face[n_face]        f64    face coordinates from mid-face, m, finite, strictly
//                                      increasing
//           blocks              f64    for each tooth set t (0 .. (cyclic ? 1 : z) - 1), each
//                                      flank set f (0 .. (mirror ? 1 : 2) - 1), each tooth offset
//                                      d = -n_c .. +n_c: the dense matrix C_d of n_grid x n_grid
//                                      values (n_grid = n_roll n_face <= 10000), row-major,
//                                      entry [k][j] = normal displacement (m/N, finite) at depth
//                                      h on tooth t+d at grid point k under a unit normal load on
//                                      tooth t at grid point j. Grid point index
//                                      = i_roll * n_face + i_face.
//           crc32               u32    CRC-32 (IEEE 802.3 / zlib: reflected polynomial
//                                      0xEDB88320, initial value and final xor 0xFFFFFFFF) of
//                                      every byte before it
//   Nothing follows the checksum. Whole file <= 2 GiB.
//
// Reading checks, in this order, and never allocates by a declared size before the size is
// known to be within its limit and to match the file's actual length: file opens, its length
// <= 2 GiB and >= the smallest possible file, magic, version, checksum, then every field's
// range. Every error names the file, what is wrong and what is allowed.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "gearmesh/gearmesh.h"

namespace gm {

constexpr std::uint32_t kComplianceDbVersion = 1;
constexpr std::uint32_t kComplianceDbMaxGrid = 10000;      // n_roll n_face
constexpr std::uint32_t kComplianceDbMaxCoupled = 20;      // n_c
constexpr std::uint32_t kComplianceDbMaxTeeth = 10000;
constexpr std::uint32_t kComplianceDbMaxNote = 65536;      // bytes
constexpr std::uint64_t kComplianceDbMaxFile = 2ull << 30; // 2 GiB

// One gear's compliance database in memory (the fields of the file, same names and units).
struct ComplianceDb {
  // the gear it was made for
  std::uint32_t teeth = 0;
  std::uint32_t internal = 0;
  double normal_module = 0, pressure_angle = 0, helix_angle = 0;
  double profile_shift = 0, thickness_allowance = 0, face_width = 0, tip_diameter = 0;
  double rack_addendum = 0, rack_dedendum = 0, rack_tip_radius = 0;
  double youngs_modulus = 0, poisson_ratio = 0;
  // how it was made
  double bore_radius = 0, mesh_size = 0;
  std::uint32_t mesh_order = 2, mesh_face_layers = 1;
  double depth = 0;
  std::string note;
  // the flank grid and the compliance blocks
  std::uint32_t cyclic = 1, mirror = 1;
  std::vector<double> roll, face;  // n_roll, n_face
  std::uint32_t n_coupled = 0;
  // blocks[((t * flank_sets() + f) * (2 n_c + 1) + (d + n_c))] is C_d, n_grid * n_grid row-major.
  std::vector<std::vector<double>> blocks;

  std::size_t n_grid() const { return roll.size() * face.size(); }
  std::size_t tooth_sets() const { return cyclic ? 1 : teeth; }
  std::size_t flank_sets() const { return mirror ? 1 : 2; }
  std::size_t block_count() const { return tooth_sets() * flank_sets() * (2 * std::size_t(n_coupled) + 1); }
  std::size_t block_index(std::size_t t, std::size_t f, int d) const {
    return (t * flank_sets() + f) * (2 * std::size_t(n_coupled) + 1) + std::size_t(d + int(n_coupled));
  }
};

// CRC-32 (IEEE 802.3, as zlib's crc32) of n bytes, continuing from crc (0 to start).
std::uint32_t crc32_update(std::uint32_t crc, const unsigned char* bytes, std::size_t n);

// Check db's fields against the format's ranges (the same checks as reading); msg names the
// field, its value and what is allowed, prefixed with `what` (e.g. the file name).
gm_status validate_compliance_db(const ComplianceDb& db, const std::string& what, std::string& msg);

// Write db to path (validated first). GM_ERR_PARAMETER if db is invalid, GM_ERR_ARGUMENT if the
// file cannot be written; msg says why.
gm_status write_compliance_db(const char* path, const ComplianceDb& db, std::string& msg);

// Read path into out. GM_ERR_PARAMETER on a missing, corrupt, truncated, wrong-version or
// out-of-range file (out is then left empty), GM_ERR_MEMORY if the allocation fails; msg names
// the file, what is wrong and what is allowed.
gm_status read_compliance_db(const char* path, ComplianceDb& out, std::string& msg);

// Check that db was made for gear `gear` (0 = gear 1, 1 = gear 2) of p: every recorded gear
// quantity, in this order (z, internal, m_n, alpha_n, beta of this gear, x, E_sn, b, h_aP*,
// h_fP*, rho_fP*, E, nu, then d_a as resolved by compute_pair_geometry, whose errors are passed
// on) within a relative 1e-9 (plus 1e-15 m / 1e-12 rad / 1e-12 absolute), and n_c of the
// database >= p.coupled_teeth. Bore radius, mesh options, depth and note are not checked (they
// describe how the database was made, not which gear it fits). On mismatch GM_ERR_PARAMETER and msg names the first mismatching
// quantity with both values, e.g. "gear1.compliance: made for z = 40, this gear has z = 57".
gm_status check_db_matches(const ComplianceDb& db, const gm_model_params& p, int gear, std::string& msg);

// Largest compliance value gm_model_create accepts, m/N. A gear body's point compliance at the
// flank is about 1e-10 .. 1e-7 m/N (compliance_tool's databases of the committed scenes:
// 8.6e-11 .. 3.4e-8 m/N); the format reads any finite value, but values near the largest double
// give forces near the smallest, whose local Hertz law and derivatives came out NaN
// (tests/fuzz/fuzz_fe_model).
constexpr double kComplianceDbMaxValue = 1e-3;

// Smallest depth h and grid spacing gm_model_create accepts, m (compliance_tool's default depth is
// 0.5 mm, its grid spacing about a millimetre).
constexpr double kComplianceDbMinLength = 1e-9;

// Check that every block entry of db is within +-kComplianceDbMaxValue, that the depth h lies in
// [kComplianceDbMinLength, the gear's tip radius tip_diameter/2] (a depth of 7.5e168 m made the
// derivatives of the local Hertz law NaN at 144 N, a subnormal one its energy NaN at 7.5 kN:
// tests/fuzz/fuzz_fe_model), and that the roll and face grids lie within +-tip_diameter with
// steps of at least kComplianceDbMinLength (their interpolation divides by the steps). On
// failure GM_ERR_PARAMETER and
// msg names the gear's parameter (gear1.compliance), the field (block and entry, or depth), its
// value and the allowed range.
gm_status check_db_values(const ComplianceDb& db, int gear, std::string& msg);

// Record in db the gear it is made for (what check_db_matches compares): gear `gear` (0 or 1)
// of p, with its tip diameter from the pair geometry g. gear 2 of an external pair records -beta.
void record_gear(ComplianceDb& db, const gm_model_params& p, const gm_pair_geometry& g, int gear);

}  // namespace gm
