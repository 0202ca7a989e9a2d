#include "compliance_build.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <stdexcept>
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

// Locate x in the mesh (bucket grid of element bounding boxes, then Newton on the quadratic map).
// Returns the smallest barycentric coordinate of the best element found (>= 0: inside; slightly
// negative: just outside, e.g. a surface point off the quadratic facet), -inf if none is near.
class Locator {
 public:
  explicit Locator(const fe::Mesh& m) : m_(m) {
    const std::size_t ne = m.tets.size();
    lo_.resize(ne);
    hi_.resize(ne);
    Eigen::Vector3d glo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), ghi = -glo;
    double mean_size = 0;
    for (std::size_t e = 0; e < ne; ++e) {
      Eigen::Vector3d a = m.nodes[m.tets[e][0]], b = a;
      for (int n : m.tets[e]) a = a.cwiseMin(m.nodes[n]), b = b.cwiseMax(m.nodes[n]);
      // a curved (quadratic) element bulges out of its nodes' bounding box by up to its edges'
      // sagitta: the box is widened by 5 % of its size
      const Eigen::Vector3d pad = Eigen::Vector3d::Constant(0.05 * (b - a).maxCoeff());
      lo_[e] = a - pad;
      hi_[e] = b + pad;
      glo = glo.cwiseMin(a);
      ghi = ghi.cwiseMax(b);
      mean_size += (b - a).maxCoeff();
    }
    mean_size = ne ? mean_size / double(ne) : 1.0;
    origin_ = glo;
    cell_ = std::max(mean_size, 1e-12);
    for (int c = 0; c < 3; ++c) dims_[c] = std::clamp(int((ghi(c) - glo(c)) / cell_) + 1, 1, 4096);
    start_.assign(std::size_t(dims_[0]) * dims_[1] * dims_[2] + 1, 0);
    // Two passes (count, fill): element lists per cell in one array.
    for (int pass = 0; pass < 2; ++pass) {
      std::vector<int> fill = pass ? std::vector<int>(start_.begin(), start_.end() - 1) : std::vector<int>();
      if (pass) items_.resize(start_.back());
      for (std::size_t e = 0; e < ne; ++e) {
        const auto a = cell_of(lo_[e]), b = cell_of(hi_[e]);
        for (int i = a[0]; i <= b[0]; ++i)
          for (int j = a[1]; j <= b[1]; ++j)
            for (int k = a[2]; k <= b[2]; ++k) {
              const std::size_t c = (std::size_t(k) * dims_[1] + j) * dims_[0] + i;
              if (pass) items_[fill[c]++] = int(e);
              else ++start_[c + 1];
            }
      }
      if (!pass)
        for (std::size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
    }
  }
  double locate(const Eigen::Vector3d& x, int& elem, Eigen::Vector3d& xi) const {
    const double tol = 1e-9 * std::max(1.0, x.norm());
    double best = -std::numeric_limits<double>::infinity();
    const auto c0 = cell_of(x);
    const std::size_t c = (std::size_t(c0[2]) * dims_[1] + c0[1]) * dims_[0] + c0[0];
    for (int q = start_[c]; q < start_[c + 1]; ++q) {
      const int e = items_[q];
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
        elem = e;
        xi = s;
      }
      if (minbary >= 0) break;
    }
    return best;
  }

 private:
  std::array<int, 3> cell_of(const Eigen::Vector3d& x) const {
    std::array<int, 3> c{};
    for (int i = 0; i < 3; ++i) c[i] = std::clamp(int(std::floor((x(i) - origin_(i)) / cell_)), 0, dims_[i] - 1);
    return c;
  }
  const fe::Mesh& m_;
  std::vector<Eigen::Vector3d> lo_, hi_;
  Eigen::Vector3d origin_;
  double cell_ = 1;
  std::array<int, 3> dims_{1, 1, 1};
  std::vector<int> start_, items_;
};

// Reading (or load) at a point: the displacement (or force) along n, distributed on the nodes of
// the element containing the point with the TET10 shape functions (a point load anywhere is the
// transpose of this reading: consistent nodal forces N_a(x) n).
// U: displacements of some free dofs (fe::Solver::solve_sparse), row[f] the row of free dof f
// (-1: not there, read as zero), column c; fixed dofs are zero.
double reading(const Probe& pr, const fe::Solver& solver, const Eigen::MatrixXd& U,
               const std::vector<int>& row, int c) {
  double w = 0;
  for (int a = 0; a < 10; ++a) {
    if (pr.weight[a] == 0) continue;
    Eigen::Vector3d u;
    for (int i = 0; i < 3; ++i) {
      const int f = solver.free_index(3 * pr.nodes[a] + i);
      u(i) = f >= 0 && row[f] >= 0 ? U(row[f], c) : 0.0;
    }
    w += pr.weight[a] * pr.n.dot(u);
  }
  return w;
}

// The nodes a probe weighs (nonzero shape function value), appended to out.
void probe_nodes(const Probe& pr, std::vector<int>& out) {
  for (int a = 0; a < 10; ++a)
    if (pr.weight[a] != 0) out.push_back(pr.nodes[a]);
}

std::string eta_text(double elapsed, double done, double total) {
  std::ostringstream s;
  s.precision(3);
  s << elapsed << " s";
  if (done > 0 && done < total) s << ", ETA " << elapsed * (total - done) / done << " s";
  return s.str();
}

}  // namespace

std::vector<int> select_loaded(int n_roll, int n_face, double fraction) {
  const int n = n_roll * n_face;
  const int want = std::clamp(int(std::ceil(fraction * n - 1e-9)), 1, n);
  std::vector<int> out;
  if (want >= n) {
    out.resize(n);
    std::iota(out.begin(), out.end(), 0);
    return out;
  }
  std::vector<char> is(n, 0);
  auto add = [&](int k) {
    if (!is[k] && int(out.size()) < want) is[k] = 1, out.push_back(k);
  };
  // The element vertices' lattice first (even roll and face indices), then greedily the point
  // farthest (in grid steps) from every loaded one; ties to the lowest index.
  for (int i = 0; i < n_roll; i += 2)
    for (int j = 0; j < n_face; j += 2) add(i * n_face + j);
  std::vector<double> dist(n, std::numeric_limits<double>::infinity());
  auto update = [&](int k) {
    const int ik = k / n_face, jk = k % n_face;
    for (int q = 0; q < n; ++q) dist[q] = std::min(dist[q], std::hypot(double(q / n_face - ik), double(q % n_face - jk)));
  };
  for (int k : out) update(k);
  while (int(out.size()) < want) {
    int best = -1;
    for (int q = 0; q < n; ++q)
      if (!is[q] && (best < 0 || dist[q] > dist[best])) best = q;
    add(best);
    update(best);
  }
  std::sort(out.begin(), out.end());
  return out;
}

namespace {

constexpr double kMm = 1e3;  // the FE model is in mm, N, MPa

// Load sets: (tooth class, flank) with their reading points.
struct LoadSet {
  int t = 0, f = 0;
  const std::vector<Probe>* surf = nullptr;
  std::vector<const std::vector<Probe>*> depth;  // d = -nc..nc
};

// build_compliance_db's working state, filled by the steps below in order.
struct Build {
  const gm_model_params& p;
  const int gear;
  const BuildOptions& o;
  ComplianceDb& out;
  BuildStats& stats;
  std::string& msg;
  gm_pair_geometry g{};
  int z = 0, nc = 0;
  bool user_mesh = false, cyclic = false;
  int sym = 1, distinct = 1;        // symmetry order; distinct teeth to load
  mesh::GearBodyOptions mesh_options{};
  mesh::GearBodyMesh body{};
  fe::Mesh fm{};                    // the body in mm
  std::vector<double> roll{}, face{};  // tooth 0 flank A's lattice values, m
  int n_roll = 0, n_face = 0, n_grid = 0;
  std::vector<int> grid_node{};     // grid point -> body node
  std::vector<Eigen::Vector3d> normal{};  // inward normal at each grid point
  bool helical = false, load_b = false;
  std::map<std::pair<int, int>, std::vector<Probe>> surf_cache{}, depth_cache{};
  std::string loc_err{};
  std::vector<LoadSet> sets{};
  std::vector<int> loaded{}, unloaded{};
  std::vector<std::vector<std::vector<double>>> result{};  // result[set][d] = C_d of that set

  void say(const std::string& s) const {
    if (o.progress) o.progress(s);
  }
  int nd() const { return 2 * nc + 1; }
};

// The arguments and the gear's geometry.
gm_status check_inputs(Build& B) {
  const gm_model_params& p = B.p;
  const BuildOptions& o = B.o;
  if (B.gear != 0 && B.gear != 1) {
    B.msg = "compliance_tool: gear must be 1 or 2";
    return GM_ERR_ARGUMENT;
  }
  char cmsg[1024] = {0};
  if (gm_compute_geometry(&p, &B.g, cmsg, sizeof cmsg) != GM_OK) {
    B.msg = cmsg;
    return GM_ERR_PARAMETER;
  }
  B.z = p.gear[B.gear].teeth;
  B.nc = o.coupled < 0 ? p.coupled_teeth : o.coupled;
  if (B.nc < 0 || B.nc > int(kComplianceDbMaxCoupled) || 2 * B.nc + 1 > B.z) {
    B.msg = "compliance_tool: coupled = " + std::to_string(B.nc) +
            ": allowed 0..20 with 2 n_c + 1 <= z = " + std::to_string(B.z);
    return GM_ERR_PARAMETER;
  }
  if (!(o.load_fraction > 0 && o.load_fraction <= 1)) {
    B.msg = "compliance_tool: load fraction " + std::to_string(o.load_fraction) + ": allowed 0 < F <= 1";
    return GM_ERR_PARAMETER;
  }
  if (!(o.depth > 0) || !std::isfinite(o.depth)) {
    B.msg = "compliance_tool: depth must be > 0 m";
    return GM_ERR_PARAMETER;
  }
  return GM_OK;
}

// Symmetry (decided before meshing: it sets which teeth the mesh must resolve). A body is
// cyclic per tooth unless lightening holes break it (symmetry order gcd(z, holes)), a user mesh
// (never assumed cyclic) or --every-tooth.
// The mesher resolves tooth 0 and fine_teeth teeth each side at the full element counts
// (gear_mesh.hpp). A cyclic body loads tooth 0 and reads teeth up to +-n_c: fine_teeth >= n_c + 1
// (the read teeth and one beyond, so that no read tooth borders a coarse one). A body of
// symmetry order g loads the z/g distinct teeth 0 .. z/g - 1 (flank B through the mirror, from
// teeth 0 .. -(z/g - 1)) and reads +-n_c around each: fine_teeth >= z/g + n_c. Every tooth
// (--every-tooth, a user mesh): every tooth fine.
void plan_symmetry(Build& B) {
  const BuildOptions& o = B.o;
  const int z = B.z;
  B.user_mesh = !o.mesh.mesh_file.empty();
  B.sym = B.user_mesh ? 1 : (o.mesh.holes > 0 ? std::gcd(z, o.mesh.holes) : z);
  B.stats.symmetry = B.sym;
  B.cyclic = B.sym == z && !o.every_tooth;
  B.distinct = B.cyclic ? 1 : (o.every_tooth ? z : z / B.sym);
  B.mesh_options = o.mesh;
  if (o.every_tooth) B.mesh_options.fine_teeth = -1;
  else if (B.mesh_options.fine_teeth >= 0)
    B.mesh_options.fine_teeth = std::max(B.mesh_options.fine_teeth, B.distinct + B.nc);
}

// 1. Mesh, and the FE model in mm, N, MPa.
gm_status mesh_body(Build& B) {
  BuildStats& stats = B.stats;
  B.say("meshing gear " + std::to_string(B.gear + 1) + " (z = " + std::to_string(B.z) + ") with gmsh ...");
  gm_status st = mesh::build_gear_body(B.p, B.g, B.gear, B.mesh_options, B.body, B.msg);
  if (st != GM_OK) return st;
  const mesh::GearBodyMesh& body = B.body;
  stats.mesh_seconds = body.mesh_seconds;
  if (!B.o.write_mesh.empty()) {
    st = mesh::write_gear_body_msh(body, B.o.write_mesh, B.msg);
    if (st != GM_OK) return st;
    B.say("wrote the body mesh to " + B.o.write_mesh);
  }
  stats.nodes = int(body.nodes.size());
  stats.elements = int(body.tets.size());
  stats.dofs = 3 * stats.nodes;
  {
    std::ostringstream s;
    s << "  " << stats.nodes << " nodes, " << stats.elements << " TET10, " << body.clamped_nodes.size()
      << " clamped nodes, " << body.mesh_seconds << " s";
    B.say(s.str());
  }
  if (body.flanks.empty() || body.flanks[0][0].empty() || body.clamped_nodes.empty()) {
    B.msg = "compliance_tool: the mesh has no flank or clamped nodes";
    return GM_ERR_PARAMETER;
  }
  B.fm.nodes.reserve(body.nodes.size());
  for (const auto& x : body.nodes) B.fm.nodes.push_back(x * kMm);
  B.fm.tets = body.tets;
  return GM_OK;
}

// 2. Flank grid of tooth 0, flank A.
// Roll values from the nodes of the first face level, the end face z = -b/2: the section
// itself, so its profile nodes (vertices and mid-edge nodes) lie exactly on the involute.
// Face values from the nodes on the form-circle edge (smallest roll): along a twisted
// (helical) layer that edge is a helix whose mid-layer nodes sit on the chord, a little
// inside the helix (radial sag R dtheta^2 / 8, about 2 um for 2.5 mm layers at beta 15 deg),
// which moves their roll distance by R/rho times that near the form circle: they are taken
// within a quarter of the roll spacing. Nodes of the mid levels that are midpoints of the
// layers' diagonals likewise sit slightly off the lattice values; every node is assigned to
// the nearest value and the largest offset is checked below.
gm_status flank_grid(Build& B) {
  const auto& flank = B.body.flanks[0][0];
  const double face_min = std::min_element(flank.begin(), flank.end(), [](const auto& a, const auto& b) {
                            return a.face < b.face;
                          })->face;
  std::vector<double> rolls0;
  for (const auto& f : flank)
    if (std::fabs(f.face - face_min) < 1e-6) rolls0.push_back(f.roll);
  B.roll = cluster(rolls0, 1e-6);
  const std::vector<double>& roll = B.roll;
  double roll_step = std::numeric_limits<double>::infinity();
  for (std::size_t i = 1; i < roll.size(); ++i) roll_step = std::min(roll_step, roll[i] - roll[i - 1]);
  std::vector<double> faces0;
  for (const auto& f : flank)
    if (f.roll - roll.front() < 0.25 * roll_step) faces0.push_back(f.face);
  B.face = cluster(faces0, 1e-6);
  const std::vector<double>& face = B.face;
  const int n_roll = B.n_roll = int(roll.size()), n_face = B.n_face = int(face.size());
  const int n_grid = B.n_grid = n_roll * n_face;
  BuildStats& stats = B.stats;
  stats.grid = n_grid;
  if (int(flank.size()) != n_grid || n_grid > int(kComplianceDbMaxGrid)) {
    B.msg = "compliance_tool: tooth 0's flank A has " + std::to_string(flank.size()) +
            " nodes, not a lattice of " + std::to_string(n_roll) + " roll x " + std::to_string(n_face) +
            " face values (or more than 10000)";
    return GM_ERR_PARAMETER;
  }
  B.grid_node.assign(n_grid, -1);
  for (const auto& f : flank) {
    const int k = nearest(roll, f.roll) * n_face + nearest(face, f.face);
    if (B.grid_node[k] >= 0) {
      B.msg = "compliance_tool: two flank nodes fall on the same grid point";
      return GM_ERR_PARAMETER;
    }
    B.grid_node[k] = f.node;
    const int ir = nearest(roll, f.roll);
    const double spacing = roll[std::min(ir + 1, n_roll - 1)] - roll[std::max(ir - 1, 0)];
    stats.max_roll_offset = std::max(stats.max_roll_offset, std::fabs(f.roll - roll[ir]) / (0.5 * spacing));
    const int iz = nearest(face, f.face);
    const double zspacing = face[std::min(iz + 1, n_face - 1)] - face[std::max(iz - 1, 0)];
    stats.max_roll_offset = std::max(stats.max_roll_offset, std::fabs(f.face - face[iz]) / (0.5 * zspacing));
  }
  if (stats.max_roll_offset > 0.25) {
    B.msg = "compliance_tool: tooth 0's flank A nodes are not a roll x face lattice (a node is " +
            std::to_string(stats.max_roll_offset) + " grid spacings off its roll value)";
    return GM_ERR_PARAMETER;
  }
  return GM_OK;
}

// Inward normals at the grid points (see the header).
void flank_normals(Build& B) {
  const mesh::GearBodyMesh& body = B.body;
  const double rb = body.base_radius;
  const double tan_bb = body.twist_rate * rb;  // tan(beta_b)
  B.normal.resize(B.n_grid);
  for (int k = 0; k < B.n_grid; ++k) {
    const Eigen::Vector3d P = body.nodes[B.grid_node[k]];
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
    B.normal[k] = body.ring ? n : -n;
  }
}

// 3. Symmetry and the tooth sets to load: distinct teeth 0 .. distinct-1 (tooth t ~ t mod
// distinct); every tooth when forced. Flank B from flank A by the body's mirror symmetry (spur:
// the mirror through tooth 0's centre plane, y -> -y; helical: the half turn about tooth 0's
// radial centre line at mid-face, (x, y, z) -> (x, -y, -z), which also flips the face
// coordinate): a generated body has it unless a helical body's web is off mid-face. A user mesh
// is not assumed to have it. Without it flank B is loaded explicitly (a cyclic body then has two
// flank sets, mirror = 0).
void choose_flank_sets(Build& B) {
  B.helical = B.body.hand != 0;
  const bool mirror_sym = !B.user_mesh && (!B.helical || std::fabs(B.o.mesh.web_offset) < 1e-12);
  B.load_b = !mirror_sym;
  B.stats.tooth_sets = B.cyclic ? 1 : B.distinct;
  if (!B.cyclic) {
    std::ostringstream s;
    s << "body symmetry order " << B.sym << " of z = " << B.z << (B.o.every_tooth ? " (every tooth forced)" : "")
      << ": loading " << B.distinct << " distinct teeth"
      << (B.load_b ? ", both flanks" : ", flank A (flank B by the mirror)");
    B.say(s.str());
  }
}

// Flank B of tooth 0 from flank A: the half turn H = diag(1, -1, -1) about tooth 0's radial
// centre line at mid-face maps flank A at face height -z onto flank B at height z (spur and
// helical alike: H keeps the hand). Flank B's grid point (i, j) is therefore H applied to flank
// A's point at roll row i moved along its helicoid from its height z_j to -z_j (the screw
// x -> Rot_z(hand c s) x + s e_z with s = -2 z_j, c = tan(beta_b) / r_b; a translation for a
// spur gear): exact on the involute helicoid, and at flank B's own heights z_j even when the
// face grid is not symmetric (a web off mid-face). Its normal turns the same way.
Eigen::Vector3d to_flank_b(const Build& B, int k, const Eigen::Vector3d& x, bool point) {
  const Eigen::Matrix3d half_turn = Eigen::Vector3d(1, -1, -1).asDiagonal().toDenseMatrix();
  const double s = -2 * B.body.nodes[B.grid_node[k]].z();
  const Eigen::Matrix3d screw =
      Eigen::AngleAxisd(B.body.hand * B.body.twist_rate * s, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return half_turn * (screw * x + (point ? s : 0.0) * Eigen::Vector3d::UnitZ());
}

// Face index of flank B's database set read through the mirror (the non-cyclic copies below):
// reversed for a helical gear (H flips the face), kept for a spur gear. Used only when the body
// has the mirror symmetry, whose face grid is then symmetric.
int src_index(const Build& B, int f, int k) {
  if (f == 0 || !B.helical) return k;
  return (k / B.n_face) * B.n_face + (B.n_face - 1 - k % B.n_face);
}

// The probes of tooth t, flank f: loads on the flank (surface) or readings at depth h; cached
// per (tooth, flank). Null with B.loc_err set when a point lies outside the mesh.
const std::vector<Probe>* probes(Build& B, Locator& loc, int t, int f, bool depth) {
  const int z = B.z;
  t = ((t % z) + z) % z;
  auto& cache = depth ? B.depth_cache : B.surf_cache;
  const auto key = std::make_pair(t, f);
  auto it = cache.find(key);
  if (it != cache.end()) return &it->second;
  std::vector<Probe> v(B.n_grid);
  const Eigen::Matrix3d rot = Eigen::AngleAxisd(2 * kPi * t / z, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  for (int k = 0; k < B.n_grid; ++k) {
    Probe& pr = v[k];
    if (!depth && t == 0 && f == 0) {  // the reference flank's own nodes
      pr.n = B.normal[k];
      pr.nodes.fill(B.grid_node[k]);
      pr.weight.fill(0);
      pr.weight[0] = 1;
      continue;
    }
    const Eigen::Vector3d P = B.body.nodes[B.grid_node[k]];
    Eigen::Vector3d x = depth ? Eigen::Vector3d(P + B.o.depth * B.normal[k]) : P, n = B.normal[k];
    if (f == 1) x = to_flank_b(B, k, x, true), n = to_flank_b(B, k, n, false);
    x = rot * x;
    pr.n = rot * n;
    // Helical: the normal has an axial component, so at a face end the depth point would leave
    // the body; it is kept on the end face (z clamped to +-b/2).
    if (depth) x.z() = std::clamp(x.z(), -0.5 * B.body.face_width, 0.5 * B.body.face_width);
    const Eigen::Vector3d X = x * kMm;
    int e = -1;
    Eigen::Vector3d xi;
    const double best = loc.locate(X, e, xi);
    if (!(best > (depth ? -1e-6 : -1e-3))) {
      std::ostringstream s;
      s << "compliance_tool: the " << (depth ? "point at depth h = " + std::to_string(B.o.depth) + " m below"
                                             : std::string("flank point at"))
        << " grid point " << k << " of tooth " << t << " flank " << (f ? "B" : "A")
        << " lies outside the mesh" << (depth ? " (h too large?)" : " (the body is not the same on every tooth?)");
      B.loc_err = s.str();
      return nullptr;
    }
    pr.nodes = B.fm.tets[e];
    pr.weight = tet10_shape(xi);
  }
  return &cache.emplace(key, std::move(v)).first->second;
}

// 4. Points: the load sets with their loads on the flank and readings at depth h.
gm_status locate_points(Build& B) {
  const auto t_loc = Clock::now();
  B.say("locating points (bucket grid) ...");
  Locator loc(B.fm);
  for (int t = 0; t < B.distinct; ++t)
    for (int f = 0; f < (B.load_b ? 2 : 1); ++f) {
      LoadSet ls;
      ls.t = t;
      ls.f = f;
      ls.surf = probes(B, loc, t, f, false);
      for (int d = -B.nc; d <= B.nc && ls.surf; ++d) {
        ls.depth.push_back(probes(B, loc, t + d, f, true));
        if (!ls.depth.back()) ls.surf = nullptr;
      }
      if (!ls.surf) {
        B.msg = B.loc_err;
        return GM_ERR_PARAMETER;
      }
      B.sets.push_back(std::move(ls));
    }
  B.stats.locate_seconds = seconds_since(t_loc);
  return GM_OK;
}

// Loaded grid points (all, or a well-spread subset: see select_loaded).
void choose_loaded(Build& B) {
  B.loaded = select_loaded(B.n_roll, B.n_face, B.o.load_fraction);
  {
    std::vector<char> is(B.n_grid, 0);
    for (int k : B.loaded) is[k] = 1;
    for (int k = 0; k < B.n_grid; ++k)
      if (!is[k]) B.unloaded.push_back(k);
  }
  const int nL = int(B.loaded.size());
  B.stats.loaded = nL;
  if (!B.unloaded.empty()) {
    std::ostringstream s;
    s << "loading " << nL << " of " << B.n_grid << " grid points (fraction " << B.o.load_fraction
      << "), the other " << B.unloaded.size() << " from the reduction space";
    B.say(s.str());
  }
}

// Unloaded columns from the reduction space Psi = the loaded cases' displacement fields (the
// paper's Psi): u_j ~ Psi a_j with (Psi^T K Psi) a_j = Psi^T f_j, the Galerkin (energy-best)
// approximation in that space. Psi^T K Psi = Psi^T F_L = S_LL (the surface readings at the
// loaded points), Psi^T f_j = S_jL; the readings at depth follow as C[:, L] a_j. Nothing but the
// loaded solves is needed. S[k][c]: the surface reading at grid point k under loaded case c.
void reduce_unloaded(const Build& B, const Eigen::MatrixXd& S, std::vector<std::vector<double>>& blocks) {
  const std::vector<int>& loaded = B.loaded;
  const std::vector<int>& unloaded = B.unloaded;
  const int nL = int(loaded.size()), n_grid = B.n_grid, n_face = B.n_face, nd = B.nd();
  Eigen::MatrixXd SLL(nL, nL), SjL(nL, unloaded.size());
  for (int i = 0; i < nL; ++i) {
    for (int l = 0; l < nL; ++l) SLL(i, l) = S(loaded[i], l);
    for (std::size_t u = 0; u < unloaded.size(); ++u) SjL(i, u) = S(unloaded[u], i);
  }
  const Eigen::MatrixXd Ssym = 0.5 * (SLL + SLL.transpose());
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(Ssym);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive())
    throw std::runtime_error("the loaded points' compliance matrix is not positive definite");
  const Eigen::MatrixXd Acoef = ldlt.solve(SjL);  // nL x n_unloaded
  for (int d = 0; d < nd; ++d)
    for (int k = 0; k < n_grid; ++k) {
      double* row = &blocks[d][std::size_t(k) * n_grid];
      for (std::size_t u = 0; u < unloaded.size(); ++u) {
        double v = 0;
        for (int i = 0; i < nL; ++i) v += row[loaded[i]] * Acoef(i, u);
        row[unloaded[u]] = v;
      }
    }
  // The reduction space carries the global shapes but not the local field under the
  // unloaded point itself (its own diagonal is where it errs most). Where both roll
  // neighbours j -+ 1 row are loaded, the column is instead the mean of theirs shifted by
  // one row (C[k][j] = (C[k+1][j+1] + C[k-1][j-1]) / 2 in roll rows: the local field moves
  // with the load, second order along the profile), for the receivers k off the grid's
  // first and last roll rows; the reduction space stays for the rest.
  std::vector<char> is_loaded(n_grid, 0);
  for (int k : loaded) is_loaded[k] = 1;
  for (int j : unloaded) {
    const int ir = j / n_face;
    if (ir == 0 || ir == B.n_roll - 1 || !is_loaded[j - n_face] || !is_loaded[j + n_face]) continue;
    for (int d = 0; d < nd; ++d)
      for (int k = n_face; k < n_grid - n_face; ++k)
        blocks[d][std::size_t(k) * n_grid + j] =
            0.5 * (blocks[d][std::size_t(k + n_face) * n_grid + (j + n_face)] +
                   blocks[d][std::size_t(k - n_face) * n_grid + (j - n_face)]);
  }
}

// 6. One load set's solves: its loaded columns in batches, then the unloaded ones. done: the
// solves so far (progress), of total; t0: when the solves started.
// The free dofs a load set's readings need (its depth probes, and its surface probes if some
// grid points are not loaded), ascending; row: free dof -> its index there, or -1.
std::vector<int> read_dofs(const Build& B, const LoadSet& ls, const fe::Solver& solver, std::vector<int>& row) {
  std::vector<int> nodes, dofs;
  for (const auto* probes : ls.depth)
    for (const Probe& pr : *probes) probe_nodes(pr, nodes);
  if (!B.unloaded.empty())
    for (const Probe& pr : *ls.surf) probe_nodes(pr, nodes);
  row.assign(std::size_t(solver.free_dofs()), -1);
  for (int v : nodes)
    for (int i = 0; i < 3; ++i) {
      const int f = solver.free_index(3 * v + i);
      if (f >= 0) row[f] = 0;
    }
  for (int f = 0; f < solver.free_dofs(); ++f)
    if (row[f] == 0) row[f] = int(dofs.size()), dofs.push_back(f);
  return dofs;
}

// Loads of the cases loaded[c0 .. c0 + nb) of a load set on the free dofs (a clamped node takes
// none): unit forces along n, on the nodes of the element at the point (see reading()).
Eigen::SparseMatrix<double> load_block(const Build& B, const LoadSet& ls, const fe::Solver& solver, int c0, int nb) {
  std::vector<Eigen::Triplet<double>> t;
  for (int c = 0; c < nb; ++c) {
    const Probe& lp = (*ls.surf)[B.loaded[c0 + c]];
    for (int a = 0; a < 10; ++a)
      if (lp.weight[a] != 0)
        for (int i = 0; i < 3; ++i) {
          const int f = solver.free_index(3 * lp.nodes[a] + i);
          if (f >= 0) t.emplace_back(f, c, lp.weight[a] * lp.n(i));
        }
  }
  Eigen::SparseMatrix<double> F(solver.free_dofs(), nb);
  F.setFromTriplets(t.begin(), t.end());  // duplicates summed
  return F;
}

void solve_set(Build& B, const fe::Solver& solver, std::size_t si, int total, int& done,
               Clock::time_point t0) {
  const LoadSet& ls = B.sets[si];
  const std::vector<int>& loaded = B.loaded;
  const int nL = int(loaded.size()), n_grid = B.n_grid, nd = B.nd();
  const int batches = (nL + std::max(1, B.o.batch) - 1) / std::max(1, B.o.batch);
  const int batch = (nL + batches - 1) / std::max(1, batches);  // even batches
  auto& blocks = B.result[si];
  blocks.assign(nd, std::vector<double>(std::size_t(n_grid) * n_grid, 0.0));
  std::vector<int> row;
  const std::vector<int> wanted = read_dofs(B, ls, solver, row);
  if (B.o.full_solves) std::iota(row.begin(), row.end(), 0);  // U holds every free dof
  Eigen::MatrixXd S(n_grid, nL);
  for (int c0 = 0; c0 < nL; c0 += batch) {
    const int nb = std::min(batch, nL - c0);
    const Eigen::SparseMatrix<double> F = load_block(B, ls, solver, c0, nb);
    const Eigen::MatrixXd U = B.o.full_solves ? Eigen::MatrixXd(solver.solve_free(Eigen::MatrixXd(F)))
                                              : solver.solve_sparse(F, wanted);
    for (int c = 0; c < nb; ++c) {
      const int j = loaded[c0 + c];
      for (int d = 0; d < nd; ++d)
        for (int k = 0; k < n_grid; ++k)
          blocks[d][std::size_t(k) * n_grid + j] = reading((*ls.depth[d])[k], solver, U, row, c) / kMm;  // m/N
      if (!B.unloaded.empty())
        for (int k = 0; k < n_grid; ++k) S(k, c0 + c) = reading((*ls.surf)[k], solver, U, row, c);
    }
    done += nb;
    std::ostringstream s;
    s << "  solves " << done << "/" << total;
    if (B.sets.size() > 1) s << " (tooth " << ls.t << (ls.f ? " flank B" : "") << ")";
    const auto share = solver.last_sparse_share();
    s << ", " << eta_text(seconds_since(t0), done, total) << " (through " << std::lround(100 * share.first)
      << " % of L forward, " << std::lround(100 * share.second) << " % backward)";
    B.say(s.str());
  }
  if (!B.unloaded.empty()) reduce_unloaded(B, S, blocks);
}

// 5.-6. Assemble, clamp the bore, factorize; the solves of every load set.
gm_status solve_all(Build& B) {
  BuildStats& stats = B.stats;
  const gm_gear_params& gp = B.p.gear[B.gear];
  fe::Material mat;
  mat.E = gp.youngs_modulus * 1e-6;  // MPa
  mat.nu = gp.poisson_ratio;
  B.result.resize(B.sets.size());
  try {
    B.say("assembling and factorizing (CHOLMOD, " + std::to_string(stats.dofs) + " dofs) ...");
    // assembled straight into the free-free block (no full K), then factorized
    std::vector<int> held = fe::dofs_of_nodes(B.body.clamped_nodes);
    if (B.o.plane_strain) {  // u_z = 0 everywhere: a plane-strain slab
      for (int n = 0; n < int(B.fm.nodes.size()); ++n) held.push_back(3 * n + 2);
      std::sort(held.begin(), held.end());
      held.erase(std::unique(held.begin(), held.end()), held.end());
    }
    const fe::Solver solver(B.fm, mat, std::move(held));
    const fe::Solver::Stats& fs = solver.stats();
    stats.assembly_seconds = fs.setup_seconds;
    stats.factor_seconds = fs.analyze_seconds + fs.factor_seconds;
    {
      std::ostringstream s;
      s << "  assembly " << stats.assembly_seconds << " s, factorization " << stats.factor_seconds
        << " s (ordering " << fe::cholmod_ordering_name(fs.ordering) << " and analysis "
        << fs.analyze_seconds << " s, numerical " << fs.factor_seconds << " s; lnz " << fs.lnz
        << ", stored " << fs.stored << ", "
        << fs.flops << " flops)";
      B.say(s.str());
    }
    const auto t0 = Clock::now();
    const int total = int(B.sets.size()) * int(B.loaded.size());
    int done = 0;
    for (std::size_t si = 0; si < B.sets.size(); ++si) solve_set(B, solver, si, total, done, t0);
    stats.solve_seconds = seconds_since(t0);
    stats.solves = total;
  } catch (const std::exception& e) {
    B.msg = std::string("compliance_tool: FE solve failed: ") + e.what();
    B.out = ComplianceDb{};
    return GM_ERR_SOLVER;
  }
  return GM_OK;
}

// The database's blocks: cyclic, one tooth set (flank A, then flank B if it was loaded); else z
// tooth sets (copies for the symmetric repeats), flank A then flank B (by the mirror: B of tooth
// t, offset d = A of tooth -t, offset -d, with the face index flipped for helical gears).
void arrange_blocks(Build& B) {
  ComplianceDb& out = B.out;
  auto& result = B.result;
  const int z = B.z, nc = B.nc, nd = B.nd(), n_grid = B.n_grid, classes = B.distinct;
  if (B.cyclic) {
    out.blocks = std::move(result[0]);
    if (B.load_b)
      for (auto& b : result[1]) out.blocks.push_back(std::move(b));
    return;
  }
  out.blocks.resize(std::size_t(z) * 2 * nd);
  auto set_of = [&](int t, int f) -> const std::vector<std::vector<double>>& {
    const int c = ((t % classes) + classes) % classes;
    return result[B.load_b ? 2 * c + f : c];
  };
  for (int t = 0; t < z; ++t)
    for (int f = 0; f < 2; ++f)
      for (int d = -nc; d <= nc; ++d) {
        auto& dst = out.blocks[(std::size_t(t) * 2 + f) * nd + (d + nc)];
        if (f == 0 || B.load_b) {
          dst = set_of(t, f)[d + nc];
          continue;
        }
        const auto& src = set_of(-t, 0)[-d + nc];
        dst.resize(src.size());
        for (int k = 0; k < n_grid; ++k)
          for (int j = 0; j < n_grid; ++j)
            dst[std::size_t(k) * n_grid + j] = src[std::size_t(src_index(B, 1, k)) * n_grid + src_index(B, 1, j)];
      }
}

// 7. Header, then the database's own checks.
gm_status write_header(Build& B) {
  ComplianceDb& out = B.out;
  const BuildOptions& o = B.o;
  const gm_gear_params& gp = B.p.gear[B.gear];
  record_gear(out, B.p, B.g, B.gear);
  out.bore_radius = B.body.clamped_radius;
  const int nprof = std::max(1, o.mesh.elements_along_profile);
  out.mesh_size = (B.roll.back() - B.roll.front()) / nprof;  // roll length per element along the profile
  out.mesh_order = 2;
  out.mesh_face_layers = std::uint32_t(std::max(1, o.mesh.elements_across_width));
  out.depth = o.depth;
  {
    std::ostringstream s;
    s << "compliance_tool 1: gear " << B.gear + 1 << ", gmsh TET10 " << B.stats.nodes << " nodes "
      << B.stats.elements << " elements, profile x width elements " << o.mesh.elements_along_profile
      << " x " << o.mesh.elements_across_width << (B.body.ring ? ", outer rim" : ", bore")
      << " clamped r = " << B.body.clamped_radius
      << " m, E " << gp.youngs_modulus << " Pa nu " << gp.poisson_ratio;
    if (o.plane_strain) s << "; PLANE STRAIN (every node's axial displacement held: for comparison with plane models)";
    if (!o.note.empty()) s << "; " << o.note;
    out.note = s.str();
  }
  out.cyclic = B.cyclic ? 1 : 0;
  out.mirror = B.cyclic && !B.load_b ? 1 : 0;
  out.roll = B.roll;
  out.face = B.face;
  out.n_coupled = std::uint32_t(B.nc);
  const gm_status st = validate_compliance_db(out, "compliance_tool", B.msg);
  if (st != GM_OK) out = ComplianceDb{};
  return st;
}

}  // namespace

gm_status build_compliance_db(const gm_model_params& p, int gear, const BuildOptions& o,
                              ComplianceDb& out, BuildStats& stats, std::string& msg) {
  out = ComplianceDb{};
  stats = BuildStats{};
  Build B{p, gear, o, out, stats, msg};
  gm_status st = check_inputs(B);
  if (st != GM_OK) return st;
  plan_symmetry(B);
  if ((st = mesh_body(B)) != GM_OK) return st;
  if ((st = flank_grid(B)) != GM_OK) return st;
  flank_normals(B);
  choose_flank_sets(B);
  if ((st = locate_points(B)) != GM_OK) return st;
  choose_loaded(B);
  if ((st = solve_all(B)) != GM_OK) return st;
  arrange_blocks(B);
  return write_header(B);
}

}  // namespace gm::ctool
