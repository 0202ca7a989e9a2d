// A synthetic compliance database shaped like a compliance_tool output (tests and benchmarks of
// level 5): the gear's own flank grid (n_roll roll distances over the active profile and a bit
// beyond, n_face face nodes from edge to edge), n_c coupled neighbours, and smooth, physically
// shaped, symmetric positive definite blocks
//
//   C_d[(a, m)][(b, n)] = kappa^|d| c_t s(rho_a) s(rho_b) exp(-|rho_a - rho_b| / l_roll)
//                         exp(-|z_m - z_n| / l_face) / (2 l_face)
//
// (m/N: the response to a unit point load): a uniform line load q over the face, which loads
// node n with q dz_n (dz_n its tributary strip width), then deflects a mid-face node by about
// c_t s^2 q (the face kernel integrates to one; half that at a face end), c_t the tooth
// compliance per unit face width at mid-profile, s^2 rising from 0.7 at the root to 1.5 at the
// tip (bending);
// kappa the share of a neighbour tooth (the AR(1) form keeps the block-Toeplitz matrix over teeth
// positive definite). Symmetric in (a, m) <-> (b, n) for d = 0 and C_d = C_{-d}^T (Maxwell-Betti).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include <unistd.h>

#include "gearmesh/internal/compliance_db.hpp"
#include "gearmesh/gearmesh.h"
#include "gearmesh/internal/geometry.hpp"

namespace gm_test {

struct SmoothDbShape {
  int n_roll = 17, n_face = 13, n_coupled = 2;
  double tooth_compliance = 1 / 3.5e10;  // c_t, m^2/N (per unit face width)
  double l_roll = 3e-3, l_face = 3e-3;   // m
  double kappa = 0.15;                   // neighbour tooth share
  double depth = 1e-3;                   // h, m
  std::uint32_t mesh_order = 2;          // 2: read with the elements' shape functions; 1: linearly
};

// Gear `gear` (0 or 1) of p; msg and a default database on failure.
inline gm::ComplianceDb smooth_db(const gm_model_params& p, int gear, const SmoothDbShape& s,
                                  std::string& msg) {
  gm::ComplianceDb db;
  gm_pair_geometry g{};
  if (gm::compute_pair_geometry(p, g, msg) != GM_OK) return db;
  gm::record_gear(db, p, g, gear);
  const gm_gear_geometry& gi = g.gear[gear];
  db.bore_radius = 0.2 * gi.d_f;
  db.mesh_size = 1e-3;
  db.depth = s.depth;
  db.mesh_order = s.mesh_order;
  db.note = "synthetic smooth database (tests/core/fe_synthetic.hpp)";
  db.n_coupled = std::uint32_t(s.n_coupled);
  // roll: the active profile (start of active profile to tip) and 10 % beyond each end (a ring's
  // roll grows from its tip outwards)
  const double sap = 0.5 * std::sqrt(std::max(0.0, gi.d_sap * gi.d_sap - gi.d_b * gi.d_b));
  const double lo = std::min(sap, gi.rho_a), hi = std::max(sap, gi.rho_a), pad = 0.1 * (hi - lo);
  for (int a = 0; a < s.n_roll; ++a)
    db.roll.push_back(lo - pad + (hi - lo + 2 * pad) * a / (s.n_roll - 1));
  const double b = p.gear[gear].face_width;
  for (int m = 0; m < s.n_face; ++m) db.face.push_back(-0.5 * b + b * m / (s.n_face - 1));
  const auto shape = [&](double rho) {
    const double u = std::clamp((rho - lo) / (hi - lo), -0.1, 1.1);
    return std::sqrt(0.7 + 0.8 * u * u);
  };
  const std::size_t ng = db.n_grid();
  std::vector<double> c0(ng * ng);
  for (int a = 0; a < s.n_roll; ++a)
    for (int m = 0; m < s.n_face; ++m)
      for (int bb = 0; bb < s.n_roll; ++bb)
        for (int n = 0; n < s.n_face; ++n)
          c0[(std::size_t(a) * s.n_face + m) * ng + std::size_t(bb) * s.n_face + n] =
              s.tooth_compliance * shape(db.roll[a]) * shape(db.roll[bb]) *
              std::exp(-std::fabs(db.roll[a] - db.roll[bb]) / s.l_roll) *
              std::exp(-std::fabs(db.face[m] - db.face[n]) / s.l_face) / (2 * s.l_face);
  for (int d = -s.n_coupled; d <= s.n_coupled; ++d) {
    std::vector<double> block(c0);
    const double k = std::pow(s.kappa, std::abs(d));
    for (double& v : block) v *= k;
    db.blocks.push_back(std::move(block));
  }
  return db;
}

// The files write_smooth_db wrote, removed when the process ends normally.
struct WrittenFiles {
  std::vector<std::string> paths;
  ~WrittenFiles() {
    std::error_code ec;
    for (const std::string& path : paths) std::filesystem::remove(path, ec);
  }
};
inline WrittenFiles& written_files() {
  static WrittenFiles files;
  return files;
}

// Gear `gear`'s smooth_db (default shape unless given), written to the temporary directory as
// `name` prefixed with the process id, so that tests running at once (ctest --parallel, two
// checkouts' suites) never share a file (benchmarks: level 5 without compliance_tool), and
// removed at the process's end. The path; "" and msg on failure.
inline std::string write_smooth_db(const gm_model_params& p, int gear, const std::string& name, std::string& msg,
                                   const SmoothDbShape& shape = SmoothDbShape{}) {
  gm_model_params q = p;
  q.compliance[0] = q.compliance[1] = nullptr;
  const gm::ComplianceDb db = smooth_db(q, gear, shape, msg);
  const std::string path =
      (std::filesystem::temp_directory_path() / (std::to_string(::getpid()) + "_" + name)).string();
  if (!msg.empty() || gm::write_compliance_db(path.c_str(), db, msg) != GM_OK) return "";
  written_files().paths.push_back(path);
  return path;
}

}  // namespace gm_test
