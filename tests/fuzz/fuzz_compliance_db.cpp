// fuzz_compliance_db: bytes through the compliance database reader (read_compliance_db,
// core/src/compliance_db.cpp), from a file as gm_model_create reads gear<i>.compliance. The
// first byte chooses whether the CRC-32 at the end is recomputed (odd), so that mutations reach
// the field checks behind the checksum, or left as the input has it; the rest is the file.
// A database that reads must pass validate_compliance_db, is compared with set A's gear
// (check_db_matches), and written back: the bytes written must be those read (one encoding
// per database).
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "fuzz_files.h"
#include "fuzz_gcdb.h"
#include "gearmesh/internal/compliance_db.hpp"

namespace {

void require(bool ok, const char* what, const std::string& msg) {
  if (ok) return;
  std::fprintf(stderr, "fuzz_compliance_db: %s: %s\n", what, msg.c_str());
  std::abort();
}

std::vector<unsigned char> read_back(const char* path) {
  std::ifstream is(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(is), std::istreambuf_iterator<char>()};
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  std::vector<unsigned char> file(data + 1, data + size);
  if ((data[0] & 1) && file.size() >= 4) {
    const std::uint32_t crc = gm::crc32_update(0, file.data(), file.size() - 4);
    for (int i = 0; i < 4; ++i) file[file.size() - 4 + i] = static_cast<unsigned char>(crc >> (8 * i));
  }
  static const std::string path = fuzz_temp_path("fuzz.gcdb");
  static const std::string copy = fuzz_temp_path("copy.gcdb");
  fuzz_write_file(path.c_str(), file.data(), file.size());

  gm::ComplianceDb db;
  std::string msg;
  const gm_status st = gm::read_compliance_db(path.c_str(), db, msg);
  if (st != GM_OK) {
    require(st == GM_ERR_PARAMETER && msg.rfind("compliance database '" + path + "': ", 0) == 0,
            "a refused database is GM_ERR_PARAMETER naming the file", msg);
    require(db.blocks.empty() && db.roll.empty(), "a refused database leaves the output empty", msg);
    return 0;
  }
  require(gm::validate_compliance_db(db, "read", msg) == GM_OK, "what reads validates", msg);
  gm_model_params p;
  fuzz_set_a_level5(&p, 0);
  for (int gear = 0; gear < 2; ++gear) {
    msg.clear();
    const gm_status match = gm::check_db_matches(db, p, gear, msg);
    require(match == GM_OK || (match == GM_ERR_PARAMETER && msg.rfind("gear", 0) == 0),
            "a mismatch names the parameter", msg);
  }
  require(gm::write_compliance_db(copy.c_str(), db, msg) == GM_OK, "what reads writes", msg);
  require(read_back(copy.c_str()) == file, "written back byte for byte", path);
  return 0;
}
