// The compliance database file (core/internal/gearmesh/internal/compliance_db.hpp): round trip, explicit byte order,
// corrupt and hostile files, and the check against the gear a model is created for.
#include <gtest/gtest.h>

#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "gearmesh/internal/compliance_db.hpp"
#include "gearmesh/internal/geometry.hpp"
#include "test_support.hpp"

namespace {

using gm::ComplianceDb;

std::string tmp_path(const std::string& name) {
  const char* dir = std::getenv("TMPDIR");
  return std::string(dir ? dir : "/tmp") + "/gm_cdb_" + std::to_string(::getpid()) + "_" + name + ".gcdb";
}

std::vector<unsigned char> slurp(const std::string& path) {
  std::ifstream is(path, std::ios::binary);
  return std::vector<unsigned char>(std::istreambuf_iterator<char>(is), {});
}

void spit(const std::string& path, const std::vector<unsigned char>& b) {
  std::ofstream os(path, std::ios::binary | std::ios::trunc);
  os.write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
}

void put_u32(std::vector<unsigned char>& b, std::size_t at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) b[at + i] = static_cast<unsigned char>(v >> (8 * i));
}

// Recompute the trailing CRC-32 after patching a file image.
void reseal(std::vector<unsigned char>& b) { put_u32(b, b.size() - 4, gm::crc32_update(0, b.data(), b.size() - 4)); }

// A database made for gear `gear` of p, with a small grid and random blocks.
ComplianceDb db_for(const gm_model_params& p, int gear, std::uint32_t n_roll, std::uint32_t n_face,
                    std::uint32_t n_c, unsigned seed = 1) {
  gm_pair_geometry geo{};
  std::string msg;
  EXPECT_EQ(gm::compute_pair_geometry(p, geo, msg), GM_OK) << msg;
  ComplianceDb db;
  record_gear(db, p, geo, gear);
  db.bore_radius = 0.02;
  db.mesh_size = 0.4e-3;
  db.mesh_order = 2;
  db.mesh_face_layers = 12;
  db.depth = 0.3e-3;
  db.note = "test database";
  db.n_coupled = n_c;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1e-8, 1e-8);
  for (std::uint32_t i = 0; i < n_roll; ++i) db.roll.push_back(0.005 + 0.001 * i);
  for (std::uint32_t i = 0; i < n_face; ++i) db.face.push_back(-0.01 + 0.002 * i);
  db.blocks.resize(db.block_count());
  for (auto& b : db.blocks) {
    b.resize(db.n_grid() * db.n_grid());
    for (double& x : b) x = u(rng);
  }
  return db;
}

bool bit_equal(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

void expect_equal(const ComplianceDb& a, const ComplianceDb& b) {
  EXPECT_EQ(a.teeth, b.teeth);
  EXPECT_EQ(a.internal, b.internal);
  for (auto [x, y] : {std::pair{a.normal_module, b.normal_module}, {a.pressure_angle, b.pressure_angle},
                      {a.helix_angle, b.helix_angle}, {a.profile_shift, b.profile_shift},
                      {a.thickness_allowance, b.thickness_allowance}, {a.face_width, b.face_width},
                      {a.tip_diameter, b.tip_diameter}, {a.rack_addendum, b.rack_addendum},
                      {a.rack_dedendum, b.rack_dedendum}, {a.rack_tip_radius, b.rack_tip_radius},
                      {a.youngs_modulus, b.youngs_modulus}, {a.poisson_ratio, b.poisson_ratio},
                      {a.bore_radius, b.bore_radius}, {a.mesh_size, b.mesh_size}, {a.depth, b.depth}})
    EXPECT_TRUE(bit_equal(x, y)) << x << " vs " << y;
  EXPECT_EQ(a.mesh_order, b.mesh_order);
  EXPECT_EQ(a.mesh_face_layers, b.mesh_face_layers);
  EXPECT_EQ(a.note, b.note);
  EXPECT_EQ(a.cyclic, b.cyclic);
  EXPECT_EQ(a.mirror, b.mirror);
  EXPECT_EQ(a.n_coupled, b.n_coupled);
  ASSERT_EQ(a.roll.size(), b.roll.size());
  ASSERT_EQ(a.face.size(), b.face.size());
  ASSERT_EQ(a.blocks.size(), b.blocks.size());
  for (std::size_t i = 0; i < a.roll.size(); ++i) EXPECT_TRUE(bit_equal(a.roll[i], b.roll[i]));
  for (std::size_t i = 0; i < a.face.size(); ++i) EXPECT_TRUE(bit_equal(a.face[i], b.face[i]));
  for (std::size_t k = 0; k < a.blocks.size(); ++k) {
    ASSERT_EQ(a.blocks[k].size(), b.blocks[k].size());
    EXPECT_EQ(std::memcmp(a.blocks[k].data(), b.blocks[k].data(), a.blocks[k].size() * sizeof(double)), 0) << "block " << k;
  }
}

// The small database used by the corruption tests, written to disk, and its bytes.
struct SmallFile {
  std::string path;
  std::vector<unsigned char> bytes;
  explicit SmallFile(const std::string& name) : path(tmp_path(name)) {
    std::string msg;
    ComplianceDb db = db_for(gm_test::paper(), 0, 2, 2, 1);
    db.note = "n";
    EXPECT_EQ(gm::write_compliance_db(path.c_str(), db, msg), GM_OK) << msg;
    bytes = slurp(path);
  }
  ~SmallFile() { std::remove(path.c_str()); }
  // offset of `cyclic` (after the 1-byte note)
  static constexpr std::size_t kCyclic = 145 + 4 + 1;
};

TEST(ComplianceDb, Crc32StandardCheckValue) {
  const char* s = "123456789";
  EXPECT_EQ(gm::crc32_update(0, reinterpret_cast<const unsigned char*>(s), 9), 0xCBF43926u);
  // Continuation gives the same as one pass.
  const std::uint32_t a = gm::crc32_update(0, reinterpret_cast<const unsigned char*>(s), 4);
  EXPECT_EQ(gm::crc32_update(a, reinterpret_cast<const unsigned char*>(s) + 4, 5), 0xCBF43926u);
}

TEST(ComplianceDb, RoundTripBitForBit) {
  for (int variant = 0; variant < 3; ++variant) {
    gm_model_params p = gm_test::paper();
    p.pair.helix_angle = 0.2;
  p.pair.center_distance = 0.155;  // the helical pair needs a larger one
    ComplianceDb db = db_for(p, variant == 2 ? 1 : 0, 5, 4, 2, 42 + variant);
    if (variant == 1) {  // per-tooth, per-flank data
      db.cyclic = 0;
      db.mirror = 0;
      db.blocks = db_for(p, 0, 5, 4, 2).blocks;  // resized below
      db.blocks.resize(db.block_count(), std::vector<double>(db.n_grid() * db.n_grid(), -3.25e-9));
      db.blocks.back()[7] = 4.9e-324;  // a subnormal survives too
    }
    db.note = "UTF-8 \xc3\xa9 note\nwith a newline";
    const std::string path = tmp_path("roundtrip" + std::to_string(variant));
    std::string msg;
    ASSERT_EQ(gm::write_compliance_db(path.c_str(), db, msg), GM_OK) << msg;
    ComplianceDb back;
    ASSERT_EQ(gm::read_compliance_db(path.c_str(), back, msg), GM_OK) << msg;
    expect_equal(db, back);
    // Writing what was read gives the identical file.
    const std::string path2 = tmp_path("roundtrip_again");
    ASSERT_EQ(gm::write_compliance_db(path2.c_str(), back, msg), GM_OK) << msg;
    EXPECT_EQ(slurp(path), slurp(path2));
    std::remove(path.c_str());
    std::remove(path2.c_str());
  }
}

// A tiny database with exactly representable values, and its file written out by hand.
TEST(ComplianceDb, ExplicitLittleEndianBytes) {
  ComplianceDb db;
  db.teeth = 0x01020304 & 0x1FFF;  // 0x0304 = 772 teeth: distinct bytes show the order
  db.internal = 1;
  db.normal_module = 0.5;        // 3FE0000000000000
  db.pressure_angle = 0.25;      // 3FD0000000000000
  db.helix_angle = -0.5;         // BFE0000000000000
  db.profile_shift = 1.5;        // 3FF8000000000000
  db.thickness_allowance = -2;   // C000000000000000
  db.face_width = 2;             // 4000000000000000
  db.tip_diameter = 3;           // 4008000000000000
  db.rack_addendum = 1;          // 3FF0000000000000
  db.rack_dedendum = 1.25;       // 3FF4000000000000
  db.rack_tip_radius = 0.375;    // 3FD8000000000000
  db.youngs_modulus = 4;         // 4010000000000000
  db.poisson_ratio = 0.3;        // 3FD3333333333333
  db.bore_radius = 0.125;        // 3FC0000000000000
  db.mesh_size = 0;              // 0
  db.mesh_order = 2;
  db.mesh_face_layers = 0x0A0B0C;
  db.depth = 1.0 / 1024;         // 3F50000000000000
  db.note = "hi";
  db.cyclic = 1;
  db.mirror = 1;
  db.roll = {1.0};
  db.face = {-1.0};              // BFF0000000000000
  db.n_coupled = 1;
  db.blocks = {{-4.0}, {8.0}, {0.5}};  // C010..., 4020..., 3FE0...
  auto d = [](std::vector<unsigned char> hi_to_lo) {  // a double's bytes, most significant first
    return std::vector<unsigned char>(hi_to_lo.rbegin(), hi_to_lo.rend());
  };
  std::vector<std::vector<unsigned char>> parts = {
      {'G', 'M', 'C', 'D', 'B'},
      {0x01, 0x00, 0x00, 0x00},                      // version 1
      {0x04, 0x03, 0x00, 0x00},                      // teeth 0x0304
      {0x01, 0x00, 0x00, 0x00},                      // internal
      d({0x3F, 0xE0, 0, 0, 0, 0, 0, 0}),             // m_n 0.5
      d({0x3F, 0xD0, 0, 0, 0, 0, 0, 0}),             // alpha_n 0.25
      d({0xBF, 0xE0, 0, 0, 0, 0, 0, 0}),             // beta -0.5
      d({0x3F, 0xF8, 0, 0, 0, 0, 0, 0}),             // x 1.5
      d({0xC0, 0x00, 0, 0, 0, 0, 0, 0}),             // E_sn -2
      d({0x40, 0x00, 0, 0, 0, 0, 0, 0}),             // b 2
      d({0x40, 0x08, 0, 0, 0, 0, 0, 0}),             // d_a 3
      d({0x3F, 0xF0, 0, 0, 0, 0, 0, 0}),             // h_aP 1
      d({0x3F, 0xF4, 0, 0, 0, 0, 0, 0}),             // h_fP 1.25
      d({0x3F, 0xD8, 0, 0, 0, 0, 0, 0}),             // rho_fP 0.375
      d({0x40, 0x10, 0, 0, 0, 0, 0, 0}),             // E 4
      d({0x3F, 0xD3, 0x33, 0x33, 0x33, 0x33, 0x33, 0x33}),  // nu 0.3
      d({0x3F, 0xC0, 0, 0, 0, 0, 0, 0}),             // bore 0.125
      d({0, 0, 0, 0, 0, 0, 0, 0}),                   // mesh size 0
      {0x02, 0x00, 0x00, 0x00},                      // mesh order
      {0x0C, 0x0B, 0x0A, 0x00},                      // face layers 0x0A0B0C
      d({0x3F, 0x50, 0, 0, 0, 0, 0, 0}),             // depth 2^-10
      {0x02, 0x00, 0x00, 0x00, 'h', 'i'},            // note
      {0x01, 0, 0, 0}, {0x01, 0, 0, 0},              // cyclic, mirror
      {0x01, 0, 0, 0}, {0x01, 0, 0, 0}, {0x01, 0, 0, 0},  // n_roll, n_face, n_coupled
      d({0x3F, 0xF0, 0, 0, 0, 0, 0, 0}),             // roll 1
      d({0xBF, 0xF0, 0, 0, 0, 0, 0, 0}),             // face -1
      d({0xC0, 0x10, 0, 0, 0, 0, 0, 0}),             // C_-1 = -4
      d({0x40, 0x20, 0, 0, 0, 0, 0, 0}),             // C_0 = 8
      d({0x3F, 0xE0, 0, 0, 0, 0, 0, 0}),             // C_+1 = 0.5
  };
  std::vector<unsigned char> want;
  for (const auto& part : parts) want.insert(want.end(), part.begin(), part.end());
  ASSERT_EQ(want.size(), 145u + 4 + 2 + 20 + 8 * 5);
  const std::uint32_t crc = gm::crc32_update(0, want.data(), want.size());
  for (int i = 0; i < 4; ++i) want.push_back(static_cast<unsigned char>(crc >> (8 * i)));

  const std::string path = tmp_path("bytes");
  std::string msg;
  ASSERT_EQ(gm::write_compliance_db(path.c_str(), db, msg), GM_OK) << msg;
  const std::vector<unsigned char> got = slurp(path);
  ASSERT_EQ(got.size(), want.size());
  for (std::size_t i = 0; i < want.size(); ++i) EXPECT_EQ(int(got[i]), int(want[i])) << "byte " << i;
  // And the hand-written bytes read back to the same database.
  spit(path, want);
  ComplianceDb back;
  ASSERT_EQ(gm::read_compliance_db(path.c_str(), back, msg), GM_OK) << msg;
  expect_equal(db, back);
  std::remove(path.c_str());
}

TEST(ComplianceDb, EveryTruncationFailsCleanly) {
  SmallFile f("trunc");
  ASSERT_GT(f.bytes.size(), 500u);
  const std::string path = tmp_path("trunc_cut");
  for (std::size_t n = 0; n < f.bytes.size(); ++n) {
    spit(path, std::vector<unsigned char>(f.bytes.begin(), f.bytes.begin() + std::ptrdiff_t(n)));
    ComplianceDb out;
    std::string msg;
    ASSERT_EQ(gm::read_compliance_db(path.c_str(), out, msg), GM_ERR_PARAMETER) << "length " << n;
    EXPECT_NE(msg.find(path), std::string::npos) << msg;
    EXPECT_TRUE(out.blocks.empty() && out.roll.empty());
  }
  // Trailing garbage is refused as well.
  std::vector<unsigned char> longer = f.bytes;
  longer.push_back(0);
  spit(path, longer);
  ComplianceDb out;
  std::string msg;
  EXPECT_EQ(gm::read_compliance_db(path.c_str(), out, msg), GM_ERR_PARAMETER);
  std::remove(path.c_str());
}

TEST(ComplianceDb, EveryBitFlipDetected) {
  SmallFile f("flip");
  const std::string path = tmp_path("flip_bad");
  int crc_messages = 0, total = 0;
  for (std::size_t i = 0; i < f.bytes.size(); ++i) {
    for (int bit = 0; bit < 8; ++bit) {
      std::vector<unsigned char> b = f.bytes;
      b[i] ^= static_cast<unsigned char>(1u << bit);
      spit(path, b);
      ComplianceDb out;
      std::string msg;
      ASSERT_EQ(gm::read_compliance_db(path.c_str(), out, msg), GM_ERR_PARAMETER) << "byte " << i << " bit " << bit;
      EXPECT_NE(msg.find(path), std::string::npos) << msg;
      crc_messages += msg.find("checksum mismatch") != std::string::npos;
      ++total;
    }
    // A whole-byte change as well.
    std::vector<unsigned char> b = f.bytes;
    b[i] ^= 0xFF;
    spit(path, b);
    ComplianceDb out;
    std::string msg;
    ASSERT_EQ(gm::read_compliance_db(path.c_str(), out, msg), GM_ERR_PARAMETER) << "byte " << i;
  }
  // Everything past magic and version is caught by the checksum.
  EXPECT_EQ(crc_messages, total - 9 * 8);
  std::remove(path.c_str());
}

TEST(ComplianceDb, WrongMagicFutureVersionMissingFile) {
  SmallFile f("magic");
  const std::string path = tmp_path("magic_bad");
  std::string msg;
  ComplianceDb out;
  std::vector<unsigned char> b = f.bytes;
  b[0] = 'X';
  reseal(b);
  spit(path, b);
  EXPECT_EQ(gm::read_compliance_db(path.c_str(), out, msg), GM_ERR_PARAMETER);
  EXPECT_NE(msg.find("not a GearMesh compliance database"), std::string::npos) << msg;
  EXPECT_NE(msg.find(path), std::string::npos) << msg;

  b = f.bytes;
  put_u32(b, 5, 2);
  reseal(b);
  spit(path, b);
  EXPECT_EQ(gm::read_compliance_db(path.c_str(), out, msg), GM_ERR_PARAMETER);
  EXPECT_NE(msg.find("format version 2, this GearMesh reads version 1"), std::string::npos) << msg;

  std::remove(path.c_str());
  EXPECT_EQ(gm::read_compliance_db(path.c_str(), out, msg), GM_ERR_PARAMETER);
  EXPECT_NE(msg.find("cannot open"), std::string::npos) << msg;
  EXPECT_EQ(gm::read_compliance_db(nullptr, out, msg), GM_ERR_ARGUMENT);
}

// Declared sizes are checked against the limits and the file's length before any allocation: a
// small file (with a valid checksum) declaring matrices of more than 1 TB is refused at once.
TEST(ComplianceDb, OversizeDeclaredSizesRefusedWithoutAllocating) {
  SmallFile f("huge");
  const std::string path = tmp_path("huge_bad");
  const std::size_t c = SmallFile::kCyclic;  // cyclic, mirror, n_roll, n_face, n_coupled follow
  struct Case {
    std::uint32_t teeth, cyclic, mirror, n_roll, n_face, n_c;
    const char* expect;
  };
  const Case cases[] = {
      // 10000 teeth x 2 flanks x 41 blocks x (10^4)^2 x 8 B = 6.6e14 B > 1 TB: within the per-field
      // limits, refused by the length check.
      {10000, 0, 0, 100, 100, 20, "need 656000000001774 bytes"},
      // 2^32 - 1 grid points per axis: refused by the grid limit (would be 1.5e20 B).
      {57, 1, 1, 0xFFFFFFFFu, 0xFFFFFFFFu, 1, "allowed n_roll, n_face >= 1 and n_roll n_face <= 10000"},
      {57, 1, 1, 10000, 2, 1, "allowed n_roll, n_face >= 1 and n_roll n_face <= 10000"},
      {57, 1, 1, 2, 2, 21, "n_coupled = 21, allowed 0 .. 20"},
      {57, 1, 1, 2, 2, 29, "n_coupled = 29"},
      {57, 1, 1, 0, 2, 1, "n_roll = 0"},
      {57, 1, 1, 2, 3, 1, "need "},  // one more face value than the file holds
      {57, 2, 1, 2, 2, 1, "cyclic = 2, allowed 0 or 1"},
  };
  for (const Case& k : cases) {
    std::vector<unsigned char> b = f.bytes;
    put_u32(b, 9, k.teeth);
    put_u32(b, c, k.cyclic);
    put_u32(b, c + 4, k.mirror);
    put_u32(b, c + 8, k.n_roll);
    put_u32(b, c + 12, k.n_face);
    put_u32(b, c + 16, k.n_c);
    reseal(b);
    spit(path, b);
    ComplianceDb out;
    std::string msg;
    const auto t0 = std::chrono::steady_clock::now();
    EXPECT_EQ(gm::read_compliance_db(path.c_str(), out, msg), GM_ERR_PARAMETER);
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 1.0);
    EXPECT_NE(msg.find(k.expect), std::string::npos) << msg;
    EXPECT_NE(msg.find(path), std::string::npos) << msg;
    EXPECT_TRUE(out.blocks.empty());
  }
  // A huge note length likewise.
  std::vector<unsigned char> b = f.bytes;
  put_u32(b, 145, 0xFFFFFFF0u);
  reseal(b);
  spit(path, b);
  ComplianceDb out;
  std::string msg;
  EXPECT_EQ(gm::read_compliance_db(path.c_str(), out, msg), GM_ERR_PARAMETER);
  EXPECT_NE(msg.find("note of 4294967280 bytes declared, allowed <= 65536"), std::string::npos) << msg;
  std::remove(path.c_str());
}

TEST(ComplianceDb, NonFiniteOrUnorderedValuesRefused) {
  SmallFile f("nan");
  const std::string path = tmp_path("nan_bad");
  const std::size_t roll0 = SmallFile::kCyclic + 20, block0 = roll0 + 4 * 8;
  auto patch_f64 = [&](std::size_t at, std::uint64_t bits, const char* expect) {
    std::vector<unsigned char> b = f.bytes;
    for (int i = 0; i < 8; ++i) b[at + i] = static_cast<unsigned char>(bits >> (8 * i));
    reseal(b);
    spit(path, b);
    ComplianceDb out;
    std::string msg;
    EXPECT_EQ(gm::read_compliance_db(path.c_str(), out, msg), GM_ERR_PARAMETER);
    EXPECT_NE(msg.find(expect), std::string::npos) << msg;
  };
  patch_f64(17, 0x7FF8000000000000ull, "normal_module = nan");
  patch_f64(block0 + 8 * 5, 0x7FF0000000000000ull, "block 0 entry 5 = inf");
  patch_f64(roll0 + 8, 0x0ull, "allowed strictly increasing");  // roll[1] = 0 < roll[0]
  std::remove(path.c_str());
  // The writer refuses an inconsistent database.
  ComplianceDb db = db_for(gm_test::paper(), 0, 2, 2, 1);
  db.blocks.pop_back();
  std::string msg;
  EXPECT_EQ(gm::write_compliance_db(path.c_str(), db, msg), GM_ERR_PARAMETER);
  EXPECT_NE(msg.find("blocks, allowed"), std::string::npos) << msg;
}

TEST(ComplianceDb, MatchCheckNamesEveryQuantity) {
  gm_model_params p = gm_test::paper();
  p.pair.helix_angle = 0.2;
  p.pair.center_distance = 0.155;  // the helical pair needs a larger one
  const ComplianceDb db1 = db_for(p, 0, 2, 2, 2), db2 = db_for(p, 1, 2, 2, 2);
  std::string msg;
  EXPECT_EQ(gm::check_db_matches(db1, p, 0, msg), GM_OK) << msg;
  EXPECT_EQ(gm::check_db_matches(db2, p, 1, msg), GM_OK) << msg;
  // gear 2 has the opposite hand: gear 1's database does not fit it
  EXPECT_EQ(gm::check_db_matches(db1, p, 1, msg), GM_ERR_PARAMETER);
  EXPECT_EQ(msg, "gear2.compliance: made for beta = 0.2 rad, this gear has beta = -0.2 rad");
  // the resolved tip diameter: giving it explicitly is the same gear
  gm_model_params q = p;
  q.gear[0].tip_diameter = db1.tip_diameter;
  EXPECT_EQ(gm::check_db_matches(db1, q, 0, msg), GM_OK) << msg;

  ComplianceDb z40 = db1;
  z40.teeth = 40;
  EXPECT_EQ(gm::check_db_matches(z40, p, 0, msg), GM_ERR_PARAMETER);
  EXPECT_EQ(msg, "gear1.compliance: made for z = 40, this gear has z = 57");

  struct Case {
    const char* q;
    void (*change)(gm_model_params&);
  };
  const Case cases[] = {
      {"m_n", [](gm_model_params& p) { p.pair.normal_module *= 1.001; }},
      {"alpha_n", [](gm_model_params& p) { p.pair.pressure_angle += 1e-4; }},
      {"beta", [](gm_model_params& p) { p.pair.helix_angle = 0.21; }},
      {"x", [](gm_model_params& p) { p.gear[0].profile_shift += 0.01; }},
      {"E_sn", [](gm_model_params& p) { p.gear[0].thickness_allowance -= 1e-6; }},
      {"b", [](gm_model_params& p) { p.gear[0].face_width += 1e-4; }},
      {"d_a", [](gm_model_params& p) { p.gear[0].tip_diameter = 0.16; }},
      {"h_aP*", [](gm_model_params& p) { p.pair.rack_addendum = 1.1; }},
      {"h_fP*", [](gm_model_params& p) { p.pair.rack_dedendum = 1.3; }},
      {"rho_fP*", [](gm_model_params& p) { p.pair.rack_tip_radius = 0.3; }},
      {"E", [](gm_model_params& p) { p.gear[0].youngs_modulus = 206e9; }},
      {"nu", [](gm_model_params& p) { p.gear[0].poisson_ratio = 0.29; }},
  };
  for (const Case& k : cases) {
    gm_model_params r = p;
    k.change(r);
    EXPECT_EQ(gm::check_db_matches(db1, r, 0, msg), GM_ERR_PARAMETER) << k.q;
    const std::string q = k.q;
    EXPECT_EQ(msg.rfind("gear1.compliance: made for " + q + " = ", 0), 0u) << msg;
    EXPECT_NE(msg.find(", this gear has " + q + " = "), std::string::npos) << msg;
  }
  // A difference in the 12th digit is still shown as two different numbers.
  gm_model_params r = p;
  r.gear[0].face_width *= 1 + 3e-9;
  EXPECT_EQ(gm::check_db_matches(db1, r, 0, msg), GM_ERR_PARAMETER);
  EXPECT_NE(msg.find("b = 0.023 m"), std::string::npos) << msg;
  // Round-off below the tolerance is the same gear.
  r = p;
  r.gear[0].face_width *= 1 + 1e-13;
  EXPECT_EQ(gm::check_db_matches(db1, r, 0, msg), GM_OK) << msg;
  // The model may couple no more neighbours than the database holds.
  r = p;
  r.coupled_teeth = 3;
  EXPECT_EQ(gm::check_db_matches(db1, r, 0, msg), GM_ERR_PARAMETER);
  EXPECT_NE(msg.find("coupled_teeth <= 2"), std::string::npos) << msg;
  // The ring of an internal pair: the internal flag is recorded.
  gm_model_params ring = gm_test::ring();
  const ComplianceDb dr = db_for(ring, 1, 2, 2, 2);
  EXPECT_EQ(gm::check_db_matches(dr, ring, 1, msg), GM_OK) << msg;
  ComplianceDb ext = dr;
  ext.internal = 0;
  EXPECT_EQ(gm::check_db_matches(ext, ring, 1, msg), GM_ERR_PARAMETER);
  EXPECT_EQ(msg, "gear2.compliance: made for internal = 0, this gear has internal = 1");
  EXPECT_EQ(gm::check_db_matches(dr, ring, 2, msg), GM_ERR_ARGUMENT);
}

}  // namespace
