// Writes the hand-made seeds of fuzz_compliance_db, fuzz_fe_model and fuzz_tables into
// <corpus>/<target>/ (tests/fuzz/corpus/; the rest of the committed corpus is what libFuzzer's
// -merge kept from longer runs, docs/reliability.md "Fuzzing and sanitizers"):
//   make_core_seeds tests/fuzz/corpus
// Databases: set A's gear as coarse synthetic databases (tests/fuzz/fuzz_gcdb.h), cyclic and
// mirrored, and one of each other layout (per-tooth sets, separate flank sets).
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "fuzz_gcdb.h"
#include "gearmesh/internal/compliance_db.hpp"

namespace {

using Bytes = std::vector<unsigned char>;

Bytes read(const std::string& path) {
  std::ifstream is(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(is), std::istreambuf_iterator<char>()};
}

void write(const std::string& path, const Bytes& prefix, const Bytes& body) {
  std::ofstream os(path, std::ios::binary | std::ios::trunc);
  os.write(reinterpret_cast<const char*>(prefix.data()), std::streamsize(prefix.size()));
  os.write(reinterpret_cast<const char*>(body.data()), std::streamsize(body.size()));
  if (!os) {
    std::perror(path.c_str());
    std::exit(1);
  }
}

Bytes text(const char* s) { return Bytes(s, s + std::string(s).size()); }

// A synthetic database of set A's gear, rewritten with the given layout flags.
Bytes database(int n_roll, int n_face, int n_coupled, bool per_tooth, bool two_flanks) {
  const std::string path = "make_core_seeds.tmp.gcdb";
  fuzz_write_set_a_gcdb(path.c_str(), n_roll, n_face, n_coupled);
  gm::ComplianceDb db;
  std::string msg;
  if (gm::read_compliance_db(path.c_str(), db, msg) != GM_OK) std::exit((std::puts(msg.c_str()), 1));
  const std::vector<std::vector<double>> one = db.blocks;
  db.cyclic = per_tooth ? 0 : 1;
  db.mirror = two_flanks ? 0 : 1;
  db.blocks.clear();
  for (std::size_t s = 0; s < db.tooth_sets() * db.flank_sets(); ++s)
    db.blocks.insert(db.blocks.end(), one.begin(), one.end());
  if (gm::write_compliance_db(path.c_str(), db, msg) != GM_OK) std::exit((std::puts(msg.c_str()), 1));
  Bytes bytes = read(path);
  std::remove(path.c_str());
  return bytes;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_core_seeds CORPUS_DIR (tests/fuzz/corpus)\n");
    return 2;
  }
  const std::string dir = argv[1];
  const Bytes restamp{1}, keep{0};
  const Bytes cyclic = database(4, 2, 2, false, false), small = database(2, 2, 0, false, false);
  write(dir + "/fuzz_compliance_db/set_a_4x2_c2", keep, cyclic);
  write(dir + "/fuzz_compliance_db/set_a_2x2_c0_restamped", restamp, small);
  write(dir + "/fuzz_compliance_db/set_a_2x2_c0_per_tooth", keep, database(2, 2, 0, true, false));
  write(dir + "/fuzz_compliance_db/set_a_2x2_c1_two_flanks", keep, database(2, 2, 1, false, true));

  // fuzz_fe_model: 32 pose bytes (fuzz_fe_model.cpp), then the database
  Bytes pose(32, 0);
  pose[0] = 2, pose[1] = 2;          // coupled teeth 2, slices 3
  pose[3] = 0, pose[4] = 40;         // phi1 = 0, gear 2 turned 4 um
  write(dir + "/fuzz_fe_model/set_a_4x2_c2", pose, cyclic);
  pose[2] = 1, pose[10] = 5;         // quasi-static, load torque 50 N m
  write(dir + "/fuzz_fe_model/set_a_2x2_c0_quasi_static", pose, small);

  // fuzz_tables: parser byte, teeth byte (52 -> 57 teeth), face width byte (22 -> 23 mm)
  write(dir + "/fuzz_tables/stiffness", text("S\x34\x16"),
        text("gearmesh-stiffness-table 1\n# roll angle deg, N/(mm um)\n15 14\n20 15\n25 15.5\n30 14\n"));
  write(dir + "/fuzz_tables/te", text("T\x34\x16"), text("gearmesh-te-table 1\n0 0\n3 1.5\n6 -0.5\n"));
  write(dir + "/fuzz_tables/deviations", text("D\x34\x16"),
        text("\xEF\xBB\xBFgearmesh-deviations 1\nteeth 57\nroll_mm 21.5 27.5 34.3\nface_mm -11.5 11.5\n"
             "grid 0 A -1 -1.5\n 1 0.5\n 0.5 0\ngrid 3 B 0 0 1 1 2 2\npitch 5 A 3\npitch 6 A -3\n"));
  return 0;
}
