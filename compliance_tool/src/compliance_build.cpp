#include "compliance_build.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>
#include <sstream>
#include <vector>

#include <Eigen/Dense>

#include "fe_elasticity.hpp"

namespace gm::ctool {
namespace {

constexpr double kPi = 3.14159265358979323846;
using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// Cluster sorted values: gaps below tol join a cluster; returns the cluster means.
std::vector<double> cluster(std::vector<double> v, double tol) {
  std::sort(v.begin(), v.end());
  std::vector<double> out;
  std::size_t i = 0;
  while (i < v.size()) {
    std::size_t j = i + 1;
    double s = v[i];
    while (j < v.size() && v[j] - v[j - 1] < tol) s += v[j++];
    out.push_back(s / double(j - i));
    i = j;
  }
  return out;
}

int nearest(const std::vector<double>& grid, double x) {
  const auto it = std::lower_bound(grid.begin(), grid.end(), x);
  int i = int(it - grid.begin());
  if (i == int(grid.size())) return i - 1;
  if (i > 0 && x - grid[i - 1] < grid[i] - x) return i - 1;
  return i;
}

// TET10 shape functions (gmsh order) at reference coordinates xi.
std::array<double, 10> tet10_shape(const Eigen::Vector3d& xi) {
  const std::array<double, 4> L{1.0 - xi.sum(), xi(0), xi(1), xi(2)};
  std::array<double, 10> N{};
  for (int i = 0; i < 4; ++i) N[i] = L[i] * (2 * L[i] - 1);
  for (int e = 0; e < 6; ++e) N[4 + e] = 4 * L[fe::kTet10Edges[e][0]] * L[fe::kTet10Edges[e][1]];
  return N;
}
Eigen::Matrix<double, 10, 3> tet10_dshape(const Eigen::Vector3d& xi) {
  const std::array<double, 4> L{1.0 - xi.sum(), xi(0), xi(1), xi(2)};
  const std::array<Eigen::Vector3d, 4> dL{Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(1, 0, 0),
                                          Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(0, 0, 1)};
  Eigen::Matrix<double, 10, 3> d;
  for (int i = 0; i < 4; ++i) d.row(i) = (4.0 * L[i] - 1.0) * dL[i].transpose();
  for (int e = 0; e < 6; ++e) {
    const int a = fe::kTet10Edges[e][0], b = fe::kTet10Edges[e][1];
    d.row(4 + e) = 4.0 * (L[b] * dL[a] + L[a] * dL[b]).transpose();
  }
  return d;
}

// Observation functional: displacement along n at a point, as weights on nodal dofs.
struct Probe {
  std::array<int, 10> nodes{};
  std::array<double, 10> weight{};  // shape function values
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
};

// Locate x in the mesh (bounding boxes, then Newton on the quadratic map); false if outside.
class Locator {
 public:
  explicit Locator(const fe::Mesh& m) : m_(m) {
    lo_.resize(m.tets.size());
    hi_.resize(m.tets.size());
    for (std::size_t e = 0; e < m.tets.size(); ++e) {
      Eigen::Vector3d a = m.nodes[m.tets[e][0]], b = a;
      for (int n : m.tets[e]) a = a.cwiseMin(m.nodes[n]), b = b.cwiseMax(m.nodes[n]);
      lo_[e] = a;
      hi_[e] = b;
    }
  }
  bool locate(const Eigen::Vector3d& x, int& elem, Eigen::Vector3d& xi) const {
    const double tol = 1e-9;
    double best = -std::numeric_limits<double>::infinity();
    for (std::size_t e = 0; e < lo_.size(); ++e) {
      if ((x - lo_[e]).minCoeff() < -tol || (hi_[e] - x).minCoeff() < -tol) continue;
      Eigen::Vector3d s(0.25, 0.25, 0.25);
      for (int it = 0; it < 20; ++it) {
        const auto N = tet10_shape(s);
        const auto dN = tet10_dshape(s);
        Eigen::Vector3d r = -x;
        Eigen::Matrix3d J = Eigen::Matrix3d::Zero();
        for (int a = 0; a < 10; ++a) {
          r += N[a] * m_.nodes[m_.tets[e][a]];
          J += m_.nodes[m_.tets[e][a]] * dN.row(a);
        }
        const Eigen::Vector3d ds = J.fullPivLu().solve(r);
        s -= ds;
        if (ds.norm() < 1e-13) break;
        if (s.cwiseAbs().maxCoeff() > 10) break;
      }
      const double minbary = std::min(1.0 - s.sum(), s.minCoeff());
      if (minbary > best) {
        best = minbary;
        elem = int(e);
        xi = s;
      }
      if (minbary >= 0) return true;
    }
    return best > -1e-6;
  }

 private:
  const fe::Mesh& m_;
  std::vector<Eigen::Vector3d> lo_, hi_;
};

}  // namespace

gm_status build_compliance_db(const gm_model_params& p, int gear, const BuildOptions& o,
                              ComplianceDb& out, BuildStats& stats, std::string& msg) {
  out = ComplianceDb{};
  stats = BuildStats{};
  auto say = [&](const std::string& s) {
    if (o.progress) o.progress(s);
  };
  if (gear != 0 && gear != 1) {
    msg = "compliance_tool: gear must be 1 or 2";
    return GM_ERR_ARGUMENT;
  }
  gm_pair_geometry g;
  char cmsg[1024] = {0};
  if (gm_compute_geometry(&p, &g, cmsg, sizeof cmsg) != GM_OK) {
    msg = cmsg;
    return GM_ERR_PARAMETER;
  }
  const gm_gear_params& gp = p.gear[gear];
  const int z = gp.teeth;
  const int nc = o.coupled < 0 ? p.coupled_teeth : o.coupled;
  if (nc < 0 || nc > int(kComplianceDbMaxCoupled) || 2 * nc + 1 > z) {
    msg = "compliance_tool: coupled = " + std::to_string(nc) + ": allowed 0..20 with 2 n_c + 1 <= z = " +
          std::to_string(z);
    return GM_ERR_PARAMETER;
  }
  if (!(o.depth > 0) || !std::isfinite(o.depth)) {
    msg = "compliance_tool: depth must be > 0 m";
    return GM_ERR_PARAMETER;
  }

  // 1. Mesh.
  say("meshing gear " + std::to_string(gear + 1) + " (z = " + std::to_string(z) + ") with gmsh ...");
  mesh::GearBodyMesh body;
  gm_status st = mesh::build_gear_body(p, g, gear, o.mesh, body, msg);
  if (st != GM_OK) return st;
  stats.mesh_seconds = body.mesh_seconds;
  stats.nodes = int(body.nodes.size());
  stats.elements = int(body.tets.size());
  stats.dofs = 3 * stats.nodes;
  {
    std::ostringstream s;
    s << "  " << stats.nodes << " nodes, " << stats.elements << " TET10, " << body.clamped_nodes.size()
      << " clamped nodes, " << body.mesh_seconds << " s";
    say(s.str());
  }
  if (body.flanks.empty() || body.flanks[0][0].empty() || body.clamped_nodes.empty()) {
    msg = "compliance_tool: the mesh has no flank or clamped nodes";
    return GM_ERR_PARAMETER;
  }

  // FE model in mm, N, MPa.
  constexpr double mm = 1e3;
  fe::Mesh fm;
  fm.nodes.reserve(body.nodes.size());
  for (const auto& x : body.nodes) fm.nodes.push_back(x * mm);
  fm.tets = body.tets;

  // 2. Flank grid of tooth 0, flank A.
  const auto& flank = body.flanks[0][0];
  std::vector<double> rolls;
  for (const auto& f : flank) rolls.push_back(f.roll);
  // Roll values from the nodes of the first face level (the profile's vertices and mid-edge
  // nodes); nodes of the mid levels that are midpoints of the layers' diagonals may sit slightly
  // off these (the quadratic node on a curved surface), they are assigned to the nearest value
  // and the largest offset is checked below.
  // Face values likewise from the nodes on the form-circle edge (smallest roll), whose mid-layer
  // nodes are true mid-edge nodes (a twisted layer's diagonal midpoints are off the mid-plane).
  const double roll_min = *std::min_element(rolls.begin(), rolls.end());
  std::vector<double> faces0;
  for (const auto& f : flank)
    if (f.roll - roll_min < 1e-6) faces0.push_back(f.face);
  const std::vector<double> face = cluster(faces0, 1e-6);
  std::vector<double> rolls0;
  for (const auto& f : flank)
    if (std::fabs(f.face - face.front()) < 1e-6) rolls0.push_back(f.roll);
  const std::vector<double> roll = cluster(rolls0, 1e-6);
  const int n_roll = int(roll.size()), n_face = int(face.size()), n_grid = n_roll * n_face;
  stats.grid = n_grid;
  if (int(flank.size()) != n_grid || n_grid > int(kComplianceDbMaxGrid)) {
    msg = "compliance_tool: tooth 0's flank A has " + std::to_string(flank.size()) +
          " nodes, not a lattice of " + std::to_string(n_roll) + " roll x " + std::to_string(n_face) +
          " face values (or more than 10000)";
    return GM_ERR_PARAMETER;
  }
  std::vector<int> grid_node(n_grid, -1);
  for (const auto& f : flank) {
    const int k = nearest(roll, f.roll) * n_face + nearest(face, f.face);
    if (grid_node[k] >= 0) {
      msg = "compliance_tool: two flank nodes fall on the same grid point";
      return GM_ERR_PARAMETER;
    }
    grid_node[k] = f.node;
    const int ir = nearest(roll, f.roll);
    const double spacing = roll[std::min(ir + 1, n_roll - 1)] - roll[std::max(ir - 1, 0)];
    stats.max_roll_offset = std::max(stats.max_roll_offset, std::fabs(f.roll - roll[ir]) / (0.5 * spacing));
    const int iz = nearest(face, f.face);
    const double zspacing = face[std::min(iz + 1, n_face - 1)] - face[std::max(iz - 1, 0)];
    stats.max_roll_offset = std::max(stats.max_roll_offset, std::fabs(f.face - face[iz]) / (0.5 * zspacing));
  }
  if (stats.max_roll_offset > 0.25) {
    msg = "compliance_tool: tooth 0's flank A nodes are not a roll x face lattice (a node is " +
          std::to_string(stats.max_roll_offset) + " grid spacings off its roll value)";
    return GM_ERR_PARAMETER;
  }

  // Inward normals (see the header).
  const double rb = body.base_radius;
  const double tan_bb = body.twist_rate * rb;  // tan(beta_b)
  std::vector<Eigen::Vector3d> normal(n_grid);
  for (int k = 0; k < n_grid; ++k) {
    const Eigen::Vector3d P = body.nodes[grid_node[k]];
    const double R = std::hypot(P.x(), P.y()), psi = std::atan2(P.y(), P.x());
    const double alpha = std::acos(std::min(1.0, rb / R));
    const Eigen::Vector3d T(rb * std::cos(psi - alpha), rb * std::sin(psi - alpha), P.z());
    Eigen::Vector3d nt = P - T;
    if (nt.norm() < 1e-12) nt = Eigen::Vector3d(-std::sin(psi), std::cos(psi), 0);  // on the base circle
    nt.normalize();
    const Eigen::Vector3d e_theta(-std::sin(psi), std::cos(psi), 0);
    const Eigen::Vector3d tau = Eigen::Vector3d::UnitZ().cross(nt);
    const Eigen::Vector3d helix = body.hand * tan_bb / rb * R * e_theta + Eigen::Vector3d::UnitZ();
    Eigen::Vector3d n = tau.cross(helix).normalized();
    if (n.dot(nt) < 0) n = -n;
    // Inward, into the tooth material: n points out of the external tooth, and out of the ring's
    // space, i.e. into the ring's tooth (gear_mesh.hpp: a ring's "tooth" k is space k).
    normal[k] = body.ring ? n : -n;
  }

  // 3. Probes at depth h on teeth -n_c .. n_c.
  const auto t_loc = Clock::now();
  say("locating " + std::to_string((2 * nc + 1) * n_grid) + " depth points ...");
  Locator loc(fm);
  std::vector<Probe> probes((2 * nc + 1) * n_grid);
  for (int d = -nc; d <= nc; ++d) {
    const Eigen::Matrix3d rot = Eigen::AngleAxisd(2 * kPi * d / z, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    for (int k = 0; k < n_grid; ++k) {
      // Helical: the normal has an axial component, so at a face end the depth point would leave
      // the body; it is kept on the end face (z clamped to +-b/2).
      Eigen::Vector3d Qb = body.nodes[grid_node[k]] + o.depth * normal[k];
      Qb.z() = std::clamp(Qb.z(), -0.5 * body.face_width, 0.5 * body.face_width);
      const Eigen::Vector3d Q = rot * Qb * mm;
      int e = -1;
      Eigen::Vector3d xi;
      if (!loc.locate(Q, e, xi)) {
        std::ostringstream s;
        s << "compliance_tool: the point at depth h = " << o.depth << " m below grid point " << k
          << " of tooth offset " << d << " lies outside the mesh (h too large?)";
        msg = s.str();
        return GM_ERR_PARAMETER;
      }
      Probe& pr = probes[(d + nc) * n_grid + k];
      pr.nodes = fm.tets[e];
      pr.weight = tet10_shape(xi);
      pr.n = rot * normal[k];
    }
  }
  stats.locate_seconds = seconds_since(t_loc);

  // 4. Assemble, clamp the bore, factorize.
  fe::Material mat;
  mat.E = gp.youngs_modulus * 1e-6;  // MPa
  mat.nu = gp.poisson_ratio;
  try {
    say("assembling " + std::to_string(stats.dofs) + " dofs ...");
    auto t0 = Clock::now();
    const Eigen::SparseMatrix<double> K = fe::assemble_stiffness(fm, mat);
    stats.assembly_seconds = seconds_since(t0);
    say("factorizing (CHOLMOD) ...");
    t0 = Clock::now();
    fe::Solver solver(K, fe::dofs_of_nodes(body.clamped_nodes));
    stats.factor_seconds = seconds_since(t0);
    {
      std::ostringstream s;
      s << "  assembly " << stats.assembly_seconds << " s, factorization " << stats.factor_seconds << " s";
      say(s.str());
    }

    // 5. Solves.
    t0 = Clock::now();
    std::vector<std::vector<double>> blocks(2 * nc + 1, std::vector<double>(std::size_t(n_grid) * n_grid));
    const int batch = std::max(1, o.batch);
    for (int j0 = 0; j0 < n_grid; j0 += batch) {
      const int nb = std::min(batch, n_grid - j0);
      Eigen::MatrixXd F = Eigen::MatrixXd::Zero(stats.dofs, nb);
      for (int c = 0; c < nb; ++c)
        F.block<3, 1>(3 * grid_node[j0 + c], c) = normal[j0 + c];
      const Eigen::MatrixXd U = solver.solve(F);
      for (int c = 0; c < nb; ++c)
        for (std::size_t q = 0; q < probes.size(); ++q) {
          const Probe& pr = probes[q];
          double w = 0;
          for (int a = 0; a < 10; ++a) w += pr.weight[a] * pr.n.dot(U.block<3, 1>(3 * pr.nodes[a], c));
          const int d = int(q) / n_grid, k = int(q) % n_grid;
          blocks[d][std::size_t(k) * n_grid + (j0 + c)] = w / mm;  // mm/N -> m/N
        }
      say("  solves " + std::to_string(j0 + nb) + "/" + std::to_string(n_grid));
    }
    stats.solve_seconds = seconds_since(t0);
    out.blocks = std::move(blocks);
  } catch (const std::exception& e) {
    msg = std::string("compliance_tool: FE solve failed: ") + e.what();
    out = ComplianceDb{};
    return GM_ERR_SOLVER;
  }

  // 6. Header.
  record_gear(out, p, g, gear);
  out.bore_radius = body.clamped_radius;
  const int nprof = std::max(1, o.mesh.elements_along_profile);
  out.mesh_size = (roll.back() - roll.front()) / nprof;  // roll length per element along the profile
  out.mesh_order = 2;
  out.mesh_face_layers = std::uint32_t(std::max(1, o.mesh.elements_across_width));
  out.depth = o.depth;
  {
    std::ostringstream s;
    s << "compliance_tool 1: gear " << gear + 1 << ", gmsh TET10 " << stats.nodes << " nodes "
      << stats.elements << " elements, profile x width elements " << o.mesh.elements_along_profile
      << " x " << o.mesh.elements_across_width << (body.ring ? ", outer rim" : ", bore")
      << " clamped r = " << body.clamped_radius
      << " m, E " << gp.youngs_modulus << " Pa nu " << gp.poisson_ratio;
    if (!o.note.empty()) s << "; " << o.note;
    out.note = s.str();
  }
  out.cyclic = 1;
  out.mirror = 1;
  out.roll = roll;
  out.face = face;
  out.n_coupled = std::uint32_t(nc);
  st = validate_compliance_db(out, "compliance_tool", msg);
  if (st != GM_OK) out = ComplianceDb{};
  return st;
}

}  // namespace gm::ctool
