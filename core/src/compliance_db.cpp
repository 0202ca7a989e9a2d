// Compliance database file: see compliance_db.hpp for the format.
#include "gearmesh/internal/compliance_db.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <new>

#include <sys/stat.h>

#include "gearmesh/internal/geometry.hpp"
#include "params.hpp"

namespace gm {

namespace {

constexpr char kMagic[5] = {'G', 'M', 'C', 'D', 'B'};
constexpr std::uint64_t kFixedHeader = 145;  // bytes before the note's length
// Smallest possible file: fixed header, empty note, 5 u32 sizes, one roll, one face value, one
// 1 x 1 block, the checksum.
constexpr std::uint64_t kMinFile = kFixedHeader + 4 + 5 * 4 + 3 * 8 + 4;

const std::array<std::uint32_t, 256>& crc_table() {
  static const std::array<std::uint32_t, 256> table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1u) ? (0xEDB88320u ^ (c >> 1)) : (c >> 1);
      t[i] = c;
    }
    return t;
  }();
  return table;
}

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}
std::string num(double v) { return fmt("%.10g", v); }

// Byte-by-byte little-endian writer with a running CRC.
class Writer {
 public:
  explicit Writer(std::ofstream& os) : os_(os) {}
  void bytes(const unsigned char* b, std::size_t n) {
    crc_ = crc32_update(crc_, b, n);
    os_.write(reinterpret_cast<const char*>(b), std::streamsize(n));
  }
  void u32(std::uint32_t v) {
    unsigned char b[4];
    for (int i = 0; i < 4; ++i) b[i] = static_cast<unsigned char>((v >> (8 * i)) & 0xFFu);
    bytes(b, 4);
  }
  void f64(double v) {
    std::uint64_t u;
    static_assert(sizeof u == sizeof v, "binary64 expected");
    std::memcpy(&u, &v, sizeof u);  // the bit pattern of one double, not a struct layout
    unsigned char b[8];
    for (int i = 0; i < 8; ++i) b[i] = static_cast<unsigned char>((u >> (8 * i)) & 0xFFu);
    bytes(b, 8);
  }
  void f64s(const std::vector<double>& v) {
    for (double x : v) f64(x);
  }
  void str(const std::string& s) {
    u32(static_cast<std::uint32_t>(s.size()));
    bytes(reinterpret_cast<const unsigned char*>(s.data()), s.size());
  }
  void crc() { u32(crc_); }

 private:
  std::ofstream& os_;
  std::uint32_t crc_ = 0;
};

// Byte-by-byte little-endian reader; the caller has checked the length beforehand, a short read
// still only sets ok = false.
class Reader {
 public:
  explicit Reader(std::ifstream& is) : is_(is) {}
  bool ok = true;
  std::uint64_t pos = 0;
  void bytes(unsigned char* b, std::size_t n) {
    if (!ok) {
      std::memset(b, 0, n);
      return;
    }
    is_.read(reinterpret_cast<char*>(b), std::streamsize(n));
    if (std::size_t(is_.gcount()) != n) {
      ok = false;
      std::memset(b, 0, n);
    }
    pos += n;
  }
  std::uint32_t u32() {
    unsigned char b[4];
    bytes(b, 4);
    std::uint32_t v = 0;
    for (int i = 3; i >= 0; --i) v = (v << 8) | b[i];
    return v;
  }
  double f64() {
    unsigned char b[8];
    bytes(b, 8);
    std::uint64_t u = 0;
    for (int i = 7; i >= 0; --i) u = (u << 8) | b[i];
    double v;
    std::memcpy(&v, &u, sizeof v);
    return v;
  }
  void f64s(std::vector<double>& v) {
    for (double& x : v) x = f64();
  }

 private:
  std::ifstream& is_;
};

bool fail(std::string& msg, const std::string& what, const std::string& text) {
  msg = what + ": " + text;
  return false;
}

// Scalar fields (everything up to and including n_coupled).
bool validate_scalars(const ComplianceDb& db, const std::string& what, std::string& msg) {
  auto pos_finite = [](double v) { return std::isfinite(v) && v > 0; };
  const double half_pi = 1.5707963267948966;
  if (db.teeth < 3 || db.teeth > kComplianceDbMaxTeeth)
    return fail(msg, what, "teeth = " + std::to_string(db.teeth) + ", allowed 3 .. " + std::to_string(kComplianceDbMaxTeeth));
  if (db.internal > 1) return fail(msg, what, "internal = " + std::to_string(db.internal) + ", allowed 0 or 1");
  if (!pos_finite(db.normal_module)) return fail(msg, what, "normal_module = " + num(db.normal_module) + " m, allowed finite > 0");
  if (!(db.pressure_angle > 0 && db.pressure_angle < half_pi))
    return fail(msg, what, "pressure_angle = " + num(db.pressure_angle) + " rad, allowed (0, pi/2)");
  if (!(std::abs(db.helix_angle) < half_pi))
    return fail(msg, what, "helix_angle = " + num(db.helix_angle) + " rad, allowed (-pi/2, pi/2)");
  if (!std::isfinite(db.profile_shift)) return fail(msg, what, "profile_shift = " + num(db.profile_shift) + ", allowed finite");
  if (!std::isfinite(db.thickness_allowance))
    return fail(msg, what, "thickness_allowance = " + num(db.thickness_allowance) + " m, allowed finite");
  if (!pos_finite(db.face_width)) return fail(msg, what, "face_width = " + num(db.face_width) + " m, allowed finite > 0");
  if (!pos_finite(db.tip_diameter)) return fail(msg, what, "tip_diameter = " + num(db.tip_diameter) + " m, allowed finite > 0");
  if (!(std::isfinite(db.rack_addendum) && db.rack_addendum >= 0))
    return fail(msg, what, "rack_addendum = " + num(db.rack_addendum) + ", allowed finite >= 0");
  if (!(std::isfinite(db.rack_dedendum) && db.rack_dedendum >= 0))
    return fail(msg, what, "rack_dedendum = " + num(db.rack_dedendum) + ", allowed finite >= 0");
  if (!(std::isfinite(db.rack_tip_radius) && db.rack_tip_radius >= 0))
    return fail(msg, what, "rack_tip_radius = " + num(db.rack_tip_radius) + ", allowed finite >= 0");
  if (!pos_finite(db.youngs_modulus)) return fail(msg, what, "youngs_modulus = " + num(db.youngs_modulus) + " Pa, allowed finite > 0");
  if (!(db.poisson_ratio > -1 && db.poisson_ratio < 0.5))
    return fail(msg, what, "poisson_ratio = " + num(db.poisson_ratio) + ", allowed (-1, 0.5)");
  if (!(std::isfinite(db.bore_radius) && db.bore_radius >= 0))
    return fail(msg, what, "bore_radius = " + num(db.bore_radius) + " m, allowed finite >= 0");
  if (!(std::isfinite(db.mesh_size) && db.mesh_size >= 0))
    return fail(msg, what, "mesh_size = " + num(db.mesh_size) + " m, allowed finite >= 0");
  if (db.mesh_order < 1 || db.mesh_order > 2) return fail(msg, what, "mesh_order = " + std::to_string(db.mesh_order) + ", allowed 1 or 2");
  if (db.mesh_face_layers < 1) return fail(msg, what, "mesh_face_layers = 0, allowed >= 1");
  if (!pos_finite(db.depth)) return fail(msg, what, "depth = " + num(db.depth) + " m, allowed finite > 0");
  if (db.note.size() > kComplianceDbMaxNote)
    return fail(msg, what, "note of " + std::to_string(db.note.size()) + " bytes, allowed <= " + std::to_string(kComplianceDbMaxNote));
  if (db.cyclic > 1) return fail(msg, what, "cyclic = " + std::to_string(db.cyclic) + ", allowed 0 or 1");
  if (db.mirror > 1) return fail(msg, what, "mirror = " + std::to_string(db.mirror) + ", allowed 0 or 1");
  if (db.n_coupled > kComplianceDbMaxCoupled || 2 * std::uint64_t(db.n_coupled) + 1 > db.teeth)
    return fail(msg, what, "n_coupled = " + std::to_string(db.n_coupled) + ", allowed 0 .. " +
                               std::to_string(kComplianceDbMaxCoupled) + " with 2 n_coupled + 1 <= teeth (" +
                               std::to_string(db.teeth) + ")");
  return true;
}

bool validate_grid_sizes(std::uint64_t n_roll, std::uint64_t n_face, const std::string& what, std::string& msg) {
  if (n_roll < 1 || n_face < 1 || n_roll > kComplianceDbMaxGrid || n_face > kComplianceDbMaxGrid ||
      n_roll * n_face > kComplianceDbMaxGrid)
    return fail(msg, what, "flank grid n_roll = " + std::to_string(n_roll) + " x n_face = " + std::to_string(n_face) +
                               ", allowed n_roll, n_face >= 1 and n_roll n_face <= " + std::to_string(kComplianceDbMaxGrid));
  return true;
}

bool validate_axis(const std::vector<double>& v, const char* name, const std::string& what, std::string& msg) {
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (!std::isfinite(v[i]))
      return fail(msg, what, std::string(name) + "[" + std::to_string(i) + "] = " + num(v[i]) + " m, allowed finite");
    if (i > 0 && !(v[i] > v[i - 1]))
      return fail(msg, what, std::string(name) + "[" + std::to_string(i) + "] = " + fmt("%.17g", v[i]) + " m after " +
                                 fmt("%.17g", v[i - 1]) + " m, allowed strictly increasing");
  }
  return true;
}

bool validate_block(const std::vector<double>& b, std::size_t index, std::size_t n_grid, const std::string& what,
                    std::string& msg) {
  if (b.size() != n_grid * n_grid)
    return fail(msg, what, "block " + std::to_string(index) + " has " + std::to_string(b.size()) + " values, allowed n_grid^2 = " +
                               std::to_string(n_grid * n_grid));
  for (std::size_t i = 0; i < b.size(); ++i)
    if (!std::isfinite(b[i]))
      return fail(msg, what, "block " + std::to_string(index) + " entry " + std::to_string(i) + " = " + num(b[i]) +
                                 " m/N, allowed finite");
  return true;
}

// Total file length implied by the sizes (all bounded before, so no overflow in 64 bits).
std::uint64_t implied_size(const ComplianceDb& db, std::uint64_t n_roll, std::uint64_t n_face) {
  const std::uint64_t n_grid = n_roll * n_face;
  const std::uint64_t blocks =
      std::uint64_t(db.cyclic ? 1 : db.teeth) * (db.mirror ? 1 : 2) * (2 * std::uint64_t(db.n_coupled) + 1);
  return kFixedHeader + 4 + db.note.size() + 5 * 4 + 8 * (n_roll + n_face) + 8 * n_grid * n_grid * blocks + 4;
}

}  // namespace

std::uint32_t crc32_update(std::uint32_t crc, const unsigned char* bytes, std::size_t n) {
  const auto& t = crc_table();
  std::uint32_t c = crc ^ 0xFFFFFFFFu;
  for (std::size_t i = 0; i < n; ++i) c = t[(c ^ bytes[i]) & 0xFFu] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

gm_status validate_compliance_db(const ComplianceDb& db, const std::string& what, std::string& msg) {
  if (!validate_scalars(db, what, msg)) return GM_ERR_PARAMETER;
  if (!validate_grid_sizes(db.roll.size(), db.face.size(), what, msg)) return GM_ERR_PARAMETER;
  if (!validate_axis(db.roll, "roll", what, msg) || !validate_axis(db.face, "face", what, msg)) return GM_ERR_PARAMETER;
  if (db.blocks.size() != db.block_count()) {
    msg = what + ": " + std::to_string(db.blocks.size()) + " blocks, allowed tooth sets (" + std::to_string(db.tooth_sets()) +
          ") x flank sets (" + std::to_string(db.flank_sets()) + ") x (2 n_coupled + 1) = " + std::to_string(db.block_count());
    return GM_ERR_PARAMETER;
  }
  for (std::size_t i = 0; i < db.blocks.size(); ++i)
    if (!validate_block(db.blocks[i], i, db.n_grid(), what, msg)) return GM_ERR_PARAMETER;
  if (implied_size(db, db.roll.size(), db.face.size()) > kComplianceDbMaxFile) {
    msg = what + ": the file would have " + std::to_string(implied_size(db, db.roll.size(), db.face.size())) +
          " bytes, allowed <= 2 GiB (" + std::to_string(kComplianceDbMaxFile) + ")";
    return GM_ERR_PARAMETER;
  }
  return GM_OK;
}

gm_status write_compliance_db(const char* path, const ComplianceDb& db, std::string& msg) {
  if (!path) {
    msg = "compliance database: no file name given";
    return GM_ERR_ARGUMENT;
  }
  const std::string what = std::string("compliance database '") + path + "'";
  if (gm_status s = validate_compliance_db(db, what, msg); s != GM_OK) return s;
  std::ofstream os(path, std::ios::binary | std::ios::trunc);
  if (!os) {
    msg = what + ": cannot open the file for writing";
    return GM_ERR_ARGUMENT;
  }
  Writer w(os);
  w.bytes(reinterpret_cast<const unsigned char*>(kMagic), sizeof kMagic);
  w.u32(kComplianceDbVersion);
  w.u32(db.teeth);
  w.u32(db.internal);
  for (double v : {db.normal_module, db.pressure_angle, db.helix_angle, db.profile_shift, db.thickness_allowance,
                   db.face_width, db.tip_diameter, db.rack_addendum, db.rack_dedendum, db.rack_tip_radius,
                   db.youngs_modulus, db.poisson_ratio, db.bore_radius, db.mesh_size})
    w.f64(v);
  w.u32(db.mesh_order);
  w.u32(db.mesh_face_layers);
  w.f64(db.depth);
  w.str(db.note);
  w.u32(db.cyclic);
  w.u32(db.mirror);
  w.u32(static_cast<std::uint32_t>(db.roll.size()));
  w.u32(static_cast<std::uint32_t>(db.face.size()));
  w.u32(db.n_coupled);
  w.f64s(db.roll);
  w.f64s(db.face);
  for (const auto& b : db.blocks) w.f64s(b);
  w.crc();
  os.close();
  if (!os) {
    msg = what + ": writing failed (disk full or not writable?)";
    return GM_ERR_ARGUMENT;
  }
  return GM_OK;
}

namespace {

// The steps of read_compliance_db: each names the file (what) and returns GM_OK or sets msg.

// A regular file of at most 2 GiB, opened; size receives its length.
gm_status open_db_file(const char* path, const std::string& what, std::ifstream& is, std::uint64_t& size,
                       std::string& msg) {
  // a FIFO would block the open until a writer comes (forever), a directory or device is no file
  struct stat st;
  if (::stat(path, &st) == 0 && !S_ISREG(st.st_mode)) {
    msg = what + ": not a regular file (a directory, FIFO, socket or device); allowed: a .gcdb file";
    return GM_ERR_PARAMETER;
  }
  is.open(path, std::ios::binary);
  if (!is) {
    msg = what + ": cannot open the file (missing or not readable)";
    return GM_ERR_PARAMETER;
  }
  is.seekg(0, std::ios::end);
  const std::streamoff end = is.tellg();
  is.seekg(0, std::ios::beg);
  if (end < 0 || !is) {
    msg = what + ": cannot determine the file's length";
    return GM_ERR_PARAMETER;
  }
  size = std::uint64_t(end);
  if (size > kComplianceDbMaxFile) {
    msg = what + ": " + std::to_string(size) + " bytes, allowed <= 2 GiB (" + std::to_string(kComplianceDbMaxFile) + ")";
    return GM_ERR_PARAMETER;
  }
  return GM_OK;
}

// Magic and version first: a file of another kind or a newer format is named as such.
gm_status check_magic_and_version(Reader& r, std::uint64_t size, const std::string& what, std::string& msg) {
  unsigned char magic[5];
  r.bytes(magic, 5);
  if (!r.ok || std::memcmp(magic, kMagic, 5) != 0) {
    msg = what + ": not a GearMesh compliance database (the file must start with \"GMCDB\")";
    return GM_ERR_PARAMETER;
  }
  const std::uint32_t version = r.u32();
  if (!r.ok) {
    msg = what + ": truncated after " + std::to_string(size) + " bytes, inside the header (a database has at least " +
          std::to_string(kMinFile) + " bytes)";
    return GM_ERR_PARAMETER;
  }
  if (version != kComplianceDbVersion) {
    msg = what + ": format version " + std::to_string(version) + ", this GearMesh reads version " +
          std::to_string(kComplianceDbVersion) + " only (regenerate it with this GearMesh's compliance_tool)";
    return GM_ERR_PARAMETER;
  }
  if (size < kMinFile) {
    msg = what + ": truncated, " + std::to_string(size) + " bytes, a database has at least " + std::to_string(kMinFile) +
          " bytes";
    return GM_ERR_PARAMETER;
  }
  return GM_OK;
}

// The CRC-32 over the whole file before any field is trusted; leaves the stream after the
// version.
gm_status check_checksum(std::ifstream& is, std::uint64_t size, const std::string& what, std::string& msg) {
  is.seekg(0, std::ios::beg);
  std::vector<unsigned char> chunk(std::size_t(std::min<std::uint64_t>(size, 1 << 20)));  // the whole file, at most 1 MiB
  std::uint32_t crc = 0;
  std::uint64_t left = size - 4;
  while (left > 0) {
    const std::size_t n = std::size_t(std::min<std::uint64_t>(left, chunk.size()));
    is.read(reinterpret_cast<char*>(chunk.data()), std::streamsize(n));
    if (std::size_t(is.gcount()) != n) {
      msg = what + ": read error while checking the checksum";
      return GM_ERR_PARAMETER;
    }
    crc = crc32_update(crc, chunk.data(), n);
    left -= n;
  }
  unsigned char b[4];
  is.read(reinterpret_cast<char*>(b), 4);
  if (is.gcount() != 4) {
    msg = what + ": read error while checking the checksum";
    return GM_ERR_PARAMETER;
  }
  const std::uint32_t stored = std::uint32_t(b[0]) | std::uint32_t(b[1]) << 8 | std::uint32_t(b[2]) << 16 |
                               std::uint32_t(b[3]) << 24;
  if (stored != crc) {
    char buf[160];
    std::snprintf(buf, sizeof buf, ": checksum mismatch (stored CRC-32 %08X, contents give %08X): the file is "
                  "corrupt or truncated; regenerate it with compliance_tool", unsigned(stored), unsigned(crc));
    msg = what + buf;
    return GM_ERR_PARAMETER;
  }
  is.clear();
  is.seekg(9, std::ios::beg);
  return GM_OK;
}

// The header after the version: the gear, mesh and grid sizes, checked, and the file's length
// against the length they imply.
gm_status read_header(Reader& r, std::uint64_t size, const std::string& what, ComplianceDb& db,
                      std::uint32_t& n_roll, std::uint32_t& n_face, std::string& msg) {
  r.pos = 9;
  db.teeth = r.u32();
  db.internal = r.u32();
  double* f[] = {&db.normal_module, &db.pressure_angle, &db.helix_angle, &db.profile_shift, &db.thickness_allowance,
                 &db.face_width, &db.tip_diameter, &db.rack_addendum, &db.rack_dedendum, &db.rack_tip_radius,
                 &db.youngs_modulus, &db.poisson_ratio, &db.bore_radius, &db.mesh_size};
  for (double* v : f) *v = r.f64();
  db.mesh_order = r.u32();
  db.mesh_face_layers = r.u32();
  db.depth = r.f64();
  const std::uint32_t note_len = r.u32();
  if (note_len > kComplianceDbMaxNote || r.pos + note_len > size) {
    msg = what + ": note of " + std::to_string(note_len) + " bytes declared, allowed <= " + std::to_string(kComplianceDbMaxNote) +
          " and within the file (" + std::to_string(size) + " bytes)";
    return GM_ERR_PARAMETER;
  }
  db.note.resize(note_len);
  if (note_len) {
    std::vector<unsigned char> t(note_len);
    r.bytes(t.data(), note_len);
    db.note.assign(t.begin(), t.end());
  }
  db.cyclic = r.u32();
  db.mirror = r.u32();
  n_roll = r.u32();
  n_face = r.u32();
  db.n_coupled = r.u32();
  if (!r.ok) {
    msg = what + ": truncated inside the header (" + std::to_string(size) + " bytes)";
    return GM_ERR_PARAMETER;
  }
  if (!validate_scalars(db, what, msg) || !validate_grid_sizes(n_roll, n_face, what, msg)) return GM_ERR_PARAMETER;
  const std::uint64_t want = implied_size(db, n_roll, n_face);
  if (want != size) {
    msg = what + ": the declared sizes (n_roll " + std::to_string(n_roll) + ", n_face " + std::to_string(n_face) +
          ", n_coupled " + std::to_string(db.n_coupled) + ", cyclic " + std::to_string(db.cyclic) + ", mirror " +
          std::to_string(db.mirror) + ", teeth " + std::to_string(db.teeth) + ") need " + std::to_string(want) +
          " bytes, the file has " + std::to_string(size) + " (allowed: exactly the declared size, <= 2 GiB)";
    return GM_ERR_PARAMETER;
  }
  return GM_OK;
}

// The grid axes and the compliance blocks, each checked as it is read.
gm_status read_arrays(Reader& r, std::uint64_t size, std::uint32_t n_roll, std::uint32_t n_face,
                      const std::string& what, ComplianceDb& db, std::string& msg) {
  try {
    db.roll.resize(n_roll);
    db.face.resize(n_face);
    r.f64s(db.roll);
    r.f64s(db.face);
    if (!validate_axis(db.roll, "roll", what, msg) || !validate_axis(db.face, "face", what, msg)) return GM_ERR_PARAMETER;
    const std::size_t n_grid = db.n_grid();
    db.blocks.resize(db.block_count());
    for (std::size_t i = 0; i < db.blocks.size(); ++i) {
      db.blocks[i].resize(n_grid * n_grid);
      r.f64s(db.blocks[i]);
      if (!validate_block(db.blocks[i], i, n_grid, what, msg)) return GM_ERR_PARAMETER;
    }
  } catch (const std::bad_alloc&) {
    msg = what + ": out of memory while reading " + std::to_string(size) + " bytes";
    return GM_ERR_MEMORY;
  }
  if (!r.ok || r.pos + 4 != size) {
    msg = what + ": read error or inconsistent length while reading the compliance blocks";
    return GM_ERR_PARAMETER;
  }
  return GM_OK;
}

}  // namespace

gm_status read_compliance_db(const char* path, ComplianceDb& out, std::string& msg) {
  out = ComplianceDb{};
  if (!path) {
    msg = "compliance database: no file name given";
    return GM_ERR_ARGUMENT;
  }
  const std::string what = std::string("compliance database '") + path + "'";
  std::ifstream is;
  std::uint64_t size = 0;
  if (gm_status s = open_db_file(path, what, is, size, msg); s != GM_OK) return s;
  Reader r(is);
  if (gm_status s = check_magic_and_version(r, size, what, msg); s != GM_OK) return s;
  if (gm_status s = check_checksum(is, size, what, msg); s != GM_OK) return s;
  ComplianceDb db;
  std::uint32_t n_roll = 0, n_face = 0;
  if (gm_status s = read_header(r, size, what, db, n_roll, n_face, msg); s != GM_OK) return s;
  if (gm_status s = read_arrays(r, size, n_roll, n_face, what, db, msg); s != GM_OK) return s;
  out = std::move(db);
  return GM_OK;
}

gm_status check_db_matches(const ComplianceDb& db, const gm_model_params& p, int gear, std::string& msg) {
  if (gear != 0 && gear != 1) {
    msg = "check_db_matches: gear index " + std::to_string(gear) + ", allowed 0 or 1";
    return GM_ERR_ARGUMENT;
  }
  const std::string name = "gear" + std::to_string(gear + 1) + ".compliance";
  const gm_gear_params& g = p.gear[gear];
  const bool ring = gear == 1 && p.pair.internal;
  const double beta = (gear == 0 || p.pair.internal) ? p.pair.helix_angle : -p.pair.helix_angle;

  auto mismatch_int = [&](const char* q, long long made, long long has) {
    msg = name + ": made for " + q + " = " + std::to_string(made) + ", this gear has " + q + " = " + std::to_string(has);
    return GM_ERR_PARAMETER;
  };
  if (db.teeth != std::uint32_t(g.teeth)) return mismatch_int("z", db.teeth, g.teeth);
  if (db.internal != (ring ? 1u : 0u)) return mismatch_int("internal", db.internal, ring ? 1 : 0);

  struct Q {
    const char* name;
    const char* unit;
    double made, has, abs_tol;
  };
  const Q qs[] = {
      {"m_n", " m", db.normal_module, p.pair.normal_module, 1e-15},
      {"alpha_n", " rad", db.pressure_angle, p.pair.pressure_angle, 1e-12},
      {"beta", " rad", db.helix_angle, beta, 1e-12},
      {"x", "", db.profile_shift, g.profile_shift, 1e-12},
      {"E_sn", " m", db.thickness_allowance, g.thickness_allowance, 1e-15},
      {"b", " m", db.face_width, g.face_width, 1e-15},
      {"h_aP*", "", db.rack_addendum, p.pair.rack_addendum, 1e-12},
      {"h_fP*", "", db.rack_dedendum, p.pair.rack_dedendum, 1e-12},
      {"rho_fP*", "", db.rack_tip_radius, p.pair.rack_tip_radius, 1e-12},
      {"E", " Pa", db.youngs_modulus, g.youngs_modulus, 1e-12},
      {"nu", "", db.poisson_ratio, g.poisson_ratio, 1e-12},
  };
  auto differs = [&](const Q& q) {
    const double tol = 1e-9 * std::max(std::abs(q.made), std::abs(q.has)) + q.abs_tol;
    if (std::abs(q.made - q.has) <= tol) return false;
    std::string a = num(q.made), b = num(q.has);
    if (a == b) a = fmt("%.17g", q.made), b = fmt("%.17g", q.has);
    msg = name + ": made for " + q.name + " = " + a + q.unit + ", this gear has " + q.name + " = " + b + q.unit;
    return true;
  };
  for (const Q& q : qs)
    if (differs(q)) return GM_ERR_PARAMETER;
  // The tip diameter as the core resolves it (0 = from the basic rack), so needs the geometry.
  gm_pair_geometry geo{};
  std::string gmsg;
  if (gm_status s = compute_pair_geometry(p, geo, gmsg); s != GM_OK) {
    msg = name + ": cannot check the database, the gear geometry is invalid: " + gmsg;
    return s;
  }
  if (differs(Q{"d_a", " m", db.tip_diameter, geo.gear[gear].d_a, 1e-15})) return GM_ERR_PARAMETER;
  if (p.coupled_teeth > int(db.n_coupled)) {
    msg = name + ": the model couples " + std::to_string(p.coupled_teeth) +
          " neighbour teeth each side (" + GM_PARAM_NAME(coupled_teeth) + "), the database only " +
          std::to_string(db.n_coupled) +
          " (allowed: coupled_teeth <= " + std::to_string(db.n_coupled) + ", or regenerate the database)";
    return GM_ERR_PARAMETER;
  }
  return GM_OK;
}

gm_status check_db_values(const ComplianceDb& db, int gear, std::string& msg) {
  const std::string name = "gear" + std::to_string(gear + 1) + ".compliance: ";
  const double r_a = 0.5 * db.tip_diameter;
  if (!(db.depth >= kComplianceDbMinLength && db.depth <= r_a)) {
    msg = name + "depth = " + num(db.depth) + " m; allowed [" + num(kComplianceDbMinLength) + ", " + num(r_a) +
          "] m (inside the gear: at most its tip radius)";
    return GM_ERR_PARAMETER;
  }
  for (const auto* axis : {&db.roll, &db.face})
    for (std::size_t i = 0; i < axis->size(); ++i) {
      const double v = (*axis)[i], step = i ? v - (*axis)[i - 1] : kComplianceDbMinLength;
      if (!(std::abs(v) <= db.tip_diameter && step >= kComplianceDbMinLength)) {
        msg = name + (axis == &db.roll ? "roll[" : "face[") + std::to_string(i) + "] = " + fmt("%.17g", v) +
              " m; allowed within +-" + num(db.tip_diameter) + " m (the tip diameter), at least " +
              num(kComplianceDbMinLength) + " m after the previous value";
        return GM_ERR_PARAMETER;
      }
    }
  for (std::size_t b = 0; b < db.blocks.size(); ++b)
    for (std::size_t i = 0; i < db.blocks[b].size(); ++i)
      if (!(std::abs(db.blocks[b][i]) <= kComplianceDbMaxValue)) {
        msg = "gear" + std::to_string(gear + 1) + ".compliance: block " + std::to_string(b) + " entry " +
              std::to_string(i) + " = " + num(db.blocks[b][i]) + " m/N; allowed |value| <= " +
              num(kComplianceDbMaxValue) + " m/N (a gear body's compliance is about 1e-10 .. 1e-7 m/N)";
        return GM_ERR_PARAMETER;
      }
  return GM_OK;
}

void record_gear(ComplianceDb& db, const gm_model_params& p, const gm_pair_geometry& g, int gear) {
  const gm_gear_params& gp = p.gear[gear];
  db.teeth = std::uint32_t(gp.teeth);
  db.internal = (gear == 1 && p.pair.internal) ? 1u : 0u;
  db.normal_module = p.pair.normal_module;
  db.pressure_angle = p.pair.pressure_angle;
  db.helix_angle = (gear == 0 || p.pair.internal) ? p.pair.helix_angle : -p.pair.helix_angle;
  db.profile_shift = gp.profile_shift;
  db.thickness_allowance = gp.thickness_allowance;
  db.face_width = gp.face_width;
  db.tip_diameter = g.gear[gear].d_a;
  db.rack_addendum = p.pair.rack_addendum;
  db.rack_dedendum = p.pair.rack_dedendum;
  db.rack_tip_radius = p.pair.rack_tip_radius;
  db.youngs_modulus = gp.youngs_modulus;
  db.poisson_ratio = gp.poisson_ratio;
}

}  // namespace gm
