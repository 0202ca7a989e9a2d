// fuzz_fe_model: a compliance database through the FE level (stiffness level 5,
// core/src/fe_compliance.cpp, dense_solve.cpp): gm_model_create on set A with the database in the
// input as both gears' (set A's two gears are the same gear, tests/fuzz/fuzz_gcdb.h), then
// evaluations at a few poses and directional derivatives, through the C API. The first 32
// bytes are the pose (fuzz_bytes.h), the rest is the database, whose CRC-32 is recomputed so
// that every mutation of its header, grid and blocks reaches the model. The seeds are valid
// databases of set A's gear (tests/fuzz/make_core_seeds.cpp).
//
// Checks beyond the sanitizers: an evaluation or derivative that succeeds has finite outputs,
// and one that fails says why.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "fuzz_bytes.h"
#include "fuzz_files.h"
#include "fuzz_gcdb.h"
#include "gearmesh/gearmesh.h"
#include "gearmesh/internal/compliance_db.hpp"

namespace {

constexpr std::size_t kPoseBytes = 32;

void require(bool ok, const char* what, const char* msg) {
  if (ok) return;
  std::fprintf(stderr, "fuzz_fe_model: %s: %s\n", what, msg);
  std::abort();
}

bool finite(const gm_result& r) {
  const double* v[] = {&r.te, &r.te_angle, &r.normal_force, &r.stiffness, &r.friction_power,
                       &r.max_line_load, &r.elastic_energy, &r.damping_power};
  for (const double* x : v)
    if (!std::isfinite(*x)) return false;
  for (int i = 0; i < 2; ++i)
    for (int a = 0; a < 3; ++a)
      if (!std::isfinite(r.force[i][a]) || !std::isfinite(r.moment[i][a])) return false;
  return true;
}

// A pose near contact: gear 2 turned `approach` (m) along the line of action, gear 1 at phi1,
// small centre displacements and tilts, and a seed along the spins and one displacement.
void evaluate(const gm_model* m, gm_data* d, fuzz_bytes& pose) {
  const double rb2 = 0.5 * gm_model_geometry(m)->gear[1].d_b;
  for (int k = 0; k < 3; ++k) {
    gm_kinematics kin{}, seed{};
    kin.phi[0] = 0.002 * static_cast<int8_t>(fuzz_u8(&pose));              // +-0.25 rad
    kin.phi[1] = 1e-7 * static_cast<int8_t>(fuzz_u8(&pose)) / rb2;         // +-12.7 um
    kin.u[1][fuzz_pick(&pose, 3)] = 1e-7 * static_cast<int8_t>(fuzz_u8(&pose));
    kin.r[0][fuzz_u8(&pose) & 1] = 1e-5 * static_cast<int8_t>(fuzz_u8(&pose));
    kin.omega[0] = static_cast<int8_t>(fuzz_u8(&pose));
    kin.load_torque = 10.0 * static_cast<int8_t>(fuzz_u8(&pose));
    gm_result r{}, dr{};
    const gm_status st = gm_evaluate(m, d, &kin, &r);
    char what[400];
    std::snprintf(what, sizeof what,
                  "phi %.17g %.17g: te %g, normal force %g, stiffness %g, max line load %g, elastic energy %g, "
                  "friction power %g, damping power %g, fy %g %g, mz %g %g",
                  kin.phi[0], kin.phi[1], r.te, r.normal_force, r.stiffness, r.max_line_load, r.elastic_energy,
                  r.friction_power, r.damping_power, r.force[0][1], r.force[1][1], r.moment[0][2], r.moment[1][2]);
    if (st == GM_OK) require(finite(r), "finite outputs of gm_evaluate", what);
    else require(gm_data_message(d)[0] != '\0', "an error says why", "gm_evaluate");
    seed.phi[0] = 1, seed.phi[1] = -1, seed.u[0][1] = 1e-3;
    if (gm_directional_derivative(m, d, &kin, &seed, &dr) == GM_OK) {
      std::snprintf(what, sizeof what,
                    "phi %.17g %.17g: dte %g, dnormal force %g, dstiffness %g, dmax line load %g, delastic energy %g, "
                    "dfy %g %g, dmz %g %g (value: normal force %g, pairs %d)",
                    kin.phi[0], kin.phi[1], dr.te, dr.normal_force, dr.stiffness, dr.max_line_load, dr.elastic_energy,
                    dr.force[0][1], dr.force[1][1], dr.moment[0][2], dr.moment[1][2], r.normal_force,
                    r.pairs_in_contact);
      require(finite(dr), "finite derivatives of gm_directional_derivative", what);
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < kPoseBytes + 4) return 0;
  std::vector<unsigned char> file(data + kPoseBytes, data + size);
  const std::uint32_t crc = gm::crc32_update(0, file.data(), file.size() - 4);
  for (int i = 0; i < 4; ++i) file[file.size() - 4 + i] = static_cast<unsigned char>(crc >> (8 * i));
  static const std::string path = fuzz_temp_path("fe.gcdb");
  fuzz_write_file(path.c_str(), file.data(), file.size());

  fuzz_bytes pose{data, kPoseBytes, 0};
  gm_model_params p;
  fuzz_set_a_level5(&p, int(fuzz_u8(&pose) % 3));
  p.slices = 1 + int(fuzz_u8(&pose) % 6);
  p.quasi_static = fuzz_u8(&pose) & 1;
  p.compliance[0] = p.compliance[1] = path.c_str();
  gm_model* m = nullptr;
  char msg[512];
  if (gm_model_create(&p, &m, msg, sizeof msg) != GM_OK) {
    require(m == nullptr && msg[0] != '\0', "a refused model says why", msg);
    return 0;
  }
  gm_data* d = nullptr;
  require(gm_data_create(m, &d) == GM_OK, "gm_data_create", "");
  evaluate(m, d, pose);
  gm_data_free(d);
  gm_model_free(m);
  return 0;
}
