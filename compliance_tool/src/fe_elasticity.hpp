// Linear elastic finite elements for compliance_tool (docs/physics.md §5, FE level): quadratic
// tetrahedra, isotropic material, global sparse stiffness, Dirichlet constraints by
// elimination, one CHOLMOD factorization reused for many load cases, and the flank
// compliance C(k, j) = n_k · u_k under a unit load at node j along n_j.
//
// Units are whatever the caller uses consistently (the tool uses mm, N, MPa).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/SparseCore>

#include <array>
#include <cstddef>
#include <functional>
#include <memory>
#include <utility>
#include <vector>

namespace gm::fe {

// A mesh of quadratic tetrahedra (TET10) in gmsh's node ordering (gmsh element type 11):
//   0..3  corner nodes, positively oriented ((x1-x0) x (x2-x0) · (x3-x0) > 0);
//   4 on edge 0-1, 5 on edge 1-2, 6 on edge 2-0, 7 on edge 3-0, 8 on edge 3-2, 9 on edge 3-1.
// Degree of freedom 3*node + c is the displacement component c (x, y, z) of that node.
struct Mesh {
  std::vector<Eigen::Vector3d> nodes;     // node positions
  std::vector<std::array<int, 10>> tets;  // node indices per element, gmsh TET10 order
};

// The six edges of a TET10 as corner pairs; edge i carries node 4 + i.
inline constexpr std::array<std::array<int, 2>, 6> kTet10Edges{
    {{0, 1}, {1, 2}, {2, 0}, {3, 0}, {3, 2}, {3, 1}}};

// Isotropic linear elastic material.
struct Material {
  double E = 210000.0;  // Young's modulus
  double nu = 0.3;      // Poisson's ratio, in (-1, 0.5)
};

using Stress = Eigen::Matrix<double, 6, 1>;          // Voigt: xx, yy, zz, yz, xz, xy
using ElementStiffness = Eigen::Matrix<double, 30, 30>;

// 6x6 isotropic elasticity matrix for engineering shear strains (Hooke's law, Lamé form).
Eigen::Matrix<double, 6, 6> elasticity_matrix(const Material& m);

// Element stiffness ∫ Bᵀ D B dV with the 4-point degree-2 Gauss rule on the reference
// tetrahedron: exact for straight-sided TET10 (B linear, det J constant). Throws
// std::runtime_error on an inverted or degenerate element.
ElementStiffness element_stiffness(const std::array<Eigen::Vector3d, 10>& x, const Material& m);

// Global stiffness (3 * nodes.size() square, symmetric) assembled from triplets.
Eigen::SparseMatrix<double> assemble_stiffness(const Mesh& mesh, const Material& m);

// Stress in element e at reference coordinates xi (ξ, η, ζ; L0 = 1 - ξ - η - ζ) for the
// full nodal displacement vector u.
Stress element_stress(const Mesh& mesh, int e, const Material& m, const Eigen::VectorXd& u,
                      const Eigen::Vector3d& xi);

// Nodes whose position satisfies the predicate, ascending.
std::vector<int> nodes_where(const Mesh& mesh, const std::function<bool(const Eigen::Vector3d&)>& pred);

// All three degrees of freedom of each node, ascending.
std::vector<int> dofs_of_nodes(const std::vector<int>& nodes);

// Consistent nodal forces (full vector) of a uniform traction t (force per area) on every
// element face whose six nodes all satisfy the predicate (3-point rule on the TRI6 face,
// exact for flat faces).
Eigen::VectorXd traction_loads(const Mesh& mesh, const std::function<bool(const Eigen::Vector3d&)>& on_face,
                               const Eigen::Vector3d& t);

// CHOLMOD's name of an ordering method (Solver::Stats::ordering): "AMD", "METIS", ...
const char* cholmod_ordering_name(int ordering);

// Number of CHOLMOD factorizations done by any Solver in this process (for tests and progress).
std::size_t cholmod_factorization_count();

// K u = f with the degrees of freedom in fixed_dofs prescribed (eliminated): factorizes the
// free-free block once with CHOLMOD (supernodal LLᵀ on the system BLAS) at construction, then
// solves any number of load cases. The fill-reducing ordering is METIS's nested dissection of the
// node graph (a node's free dofs, dof / 3, kept together; CHOLMOD's cholmod_metis on the
// quotient graph, a ninth of the dof graph's edges, then cholmod_analyze_p with that order).
// Loads on fixed dofs are ignored (they go into reactions). Throws std::runtime_error if the free
// block is not positive definite (e.g. a rigid-body mode is left unconstrained). Not copyable;
// the solves are const but not thread-safe (they share CHOLMOD's workspace).
class Solver {
 public:
  Solver(const Eigen::SparseMatrix<double>& K, std::vector<int> fixed_dofs);
  // The same for the stiffness of mesh (assemble_stiffness's), assembled straight into the
  // free-free block's lower triangle (its pattern from the node graph, the element matrices added
  // in element order: the same sums as assemble_stiffness) and the free-fixed block; no full K.
  Solver(const Mesh& mesh, const Material& m, std::vector<int> fixed_dofs);
  ~Solver();
  Solver(const Solver&) = delete;
  Solver& operator=(const Solver&) = delete;

  int dofs() const { return n_; }
  int free_dofs() const { return static_cast<int>(free_.size()); }
  // Index of full dof d among the free dofs, -1 if it is fixed.
  int free_index(int d) const { return index_[d] >= 0 ? index_[d] : -1; }

  // What the factorization cost and what CHOLMOD chose (its Common statistics).
  struct Stats {
    double setup_seconds = 0;    // the free-free block (and free-fixed): split from K, or assembled
    double analyze_seconds = 0;  // fill-reducing ordering and symbolic analysis
    double factor_seconds = 0;   // numerical (supernodal) factorization
    double lnz = 0, flops = 0;   // entries of L, flops of the factorization
    double stored = 0;           // values L holds (its supernodes' trapezoids, with the zeros
                                 // of relaxed amalgamation): 8 bytes each
    int ordering = -1;           // CHOLMOD_METIS (on the node graph), ...
  };
  const Stats& stats() const { return stats_; }

  // Full displacement vector for full load vector f; u_fixed (full size, or empty for zero)
  // supplies the prescribed values on the fixed dofs.
  Eigen::VectorXd solve(const Eigen::VectorXd& f, const Eigen::VectorXd& u_fixed = {}) const;

  // Many load cases at once (one column each, full size), fixed dofs held at zero.
  Eigen::MatrixXd solve(const Eigen::MatrixXd& F) const;

  // Many load cases given on the free dofs (free_dofs() rows, fixed dofs held at zero): the
  // displacements of the free dofs, in CHOLMOD's own storage, valid until the next solve (no
  // copy of the full field: the caller reads the dofs it needs through free_index()).
  Eigen::Map<const Eigen::MatrixXd> solve_free(const Eigen::MatrixXd& F_free) const;

  // Many load cases with sparse loads, only some responses wanted: the displacements of the free
  // dofs `wanted` (row i: free dof wanted[i]) under the loads F_free (free_dofs() x cases, fixed
  // dofs held at zero). The supernodal triangular solves run only where they matter: forward
  // through the supernodes on the paths from the loaded columns to the root of the elimination
  // tree (the rest of L^-1 F is zero), backward through those on the paths from the wanted
  // columns (nothing else feeds them); the same operations as a full solve on those supernodes.
  Eigen::MatrixXd solve_sparse(const Eigen::SparseMatrix<double>& F_free, const std::vector<int>& wanted) const;
  // Share of L's entries the last solve_sparse went through, forward and backward (each 0..1).
  std::pair<double, double> last_sparse_share() const;

 private:
  struct Factor;
  void number_dofs();  // free_, fixed_ (sorted, unique), index_
  void factorize(Eigen::Ref<Eigen::SparseMatrix<double>> Kff);  // lower triangle, CSC
  int n_ = 0;
  std::vector<int> free_;   // full dof of each free dof
  std::vector<int> fixed_;  // full dof of each fixed dof
  std::vector<int> index_;  // full dof -> free index, or -1 - fixed index
  Eigen::SparseMatrix<double> K_fc_;  // free rows, fixed columns
  std::unique_ptr<Factor> factor_;
  Stats stats_;
};

// A node and a direction (normalized on use): a flank grid point and its surface normal.
struct NodeDirection {
  int node = 0;
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();
};

// Compliance matrix C(k, j) = n_k · u(node_k) under a unit load at node_j along n_j
// (all load cases solved with the one factorization). Symmetric by Maxwell–Betti.
Eigen::MatrixXd compliance_matrix(const Solver& solver, const std::vector<NodeDirection>& points);

// Structured box [lo, hi] of nx × ny × nz hexahedra, each split into 6 TET10 (Kuhn split along
// the lo-hi diagonal, conforming between neighbours); mid-edge nodes are shared. Nodes lie on
// the (2nx+1) × (2ny+1) × (2nz+1) lattice, node index i + (2nx+1) (j + (2ny+1) k).
Mesh box_mesh(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int nx, int ny, int nz);

}  // namespace gm::fe
