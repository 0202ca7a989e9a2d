// FE foundation of compliance_tool (docs/physics.md §5, FE level): TET10 linear elasticity, sparse
// assembly, constraint elimination, one CHOLMOD factorization, flank compliances.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "fe_elasticity.hpp"

namespace {

using gm::fe::Material;
using gm::fe::Mesh;
using Eigen::Vector3d;

constexpr double kTol = 1e-9;  // coordinate tolerance for picking boundary nodes

// Rigid-body modes (3 translations, 3 rotations) are in the null space of the free stiffness.
TEST(FeElasticity, RigidBodyModesCarryNoForce) {
  const Mesh mesh = gm::fe::box_mesh(Vector3d(0, 0, 0), Vector3d(2, 1, 1.5), 2, 2, 2);
  const auto K = gm::fe::assemble_stiffness(mesh, Material{});
  const int n = static_cast<int>(mesh.nodes.size());
  for (int mode = 0; mode < 6; ++mode) {
    Eigen::VectorXd u(3 * n);
    for (int i = 0; i < n; ++i) {
      const Vector3d e = Vector3d::Unit(mode % 3);
      u.segment<3>(3 * i) = mode < 3 ? e : Vector3d(e.cross(mesh.nodes[i]));
    }
    EXPECT_LT((K * u).norm(), 1e-9 * K.norm() * u.norm()) << "mode " << mode;
  }
}

TEST(FeElasticity, StiffnessIsSymmetricAndEveryNodeIsUsed) {
  const Mesh mesh = gm::fe::box_mesh(Vector3d(0, 0, 0), Vector3d(2, 1, 1.5), 3, 2, 2);
  EXPECT_EQ(mesh.tets.size(), 6u * 3 * 2 * 2);
  EXPECT_EQ(mesh.nodes.size(), 7u * 5 * 5);
  const auto K = gm::fe::assemble_stiffness(mesh, Material{});
  const Eigen::SparseMatrix<double> A = K - Eigen::SparseMatrix<double>(K.transpose());
  EXPECT_LT(A.norm(), 1e-14 * K.norm());
  // Every node is used: a lattice node no element touches would leave a zero row.
  for (int i = 0; i < K.rows(); ++i) EXPECT_GT(K.coeff(i, i), 0.0) << "dof " << i;
}

// Patch test: a linear displacement field imposed on the boundary of a distorted mesh is
// reproduced exactly inside, with the uniform stress D ε(G) in every element.
TEST(FeElasticity, PatchTestReproducesLinearFieldAndUniformStress) {
  const Vector3d lo(0, 0, 0), hi(1, 1, 1);
  Mesh mesh = gm::fe::box_mesh(lo, hi, 3, 3, 3);
  // Move interior vertex-lattice nodes at random, then put mid-edge nodes back at edge midpoints.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-0.08, 0.08);
  const auto interior = [&](const Vector3d& x) {
    return (x - lo).minCoeff() > kTol && (hi - x).minCoeff() > kTol;
  };
  for (auto& x : mesh.nodes)
    if (interior(x)) x += Vector3d(jitter(rng), jitter(rng), jitter(rng));
  for (const auto& t : mesh.tets)
    for (int e = 0; e < 6; ++e)
      mesh.nodes[t[4 + e]] = 0.5 * (mesh.nodes[t[gm::fe::kTet10Edges[e][0]]] + mesh.nodes[t[gm::fe::kTet10Edges[e][1]]]);

  const Material mat{210000.0, 0.3};
  Eigen::Matrix3d G;
  G << 1.0e-3, 2.0e-4, -3.0e-4, -1.0e-4, 5.0e-4, 4.0e-4, 2.5e-4, -6.0e-4, -2.0e-4;
  const Vector3d a(1e-3, -2e-3, 3e-3);
  const int n = static_cast<int>(mesh.nodes.size());
  Eigen::VectorXd exact(3 * n);
  for (int i = 0; i < n; ++i) exact.segment<3>(3 * i) = a + G * mesh.nodes[i];

  const auto boundary = gm::fe::nodes_where(mesh, [&](const Vector3d& x) { return !interior(x); });
  const gm::fe::Solver solver(gm::fe::assemble_stiffness(mesh, mat), gm::fe::dofs_of_nodes(boundary));
  ASSERT_GT(solver.free_dofs(), 0);
  const Eigen::VectorXd u = solver.solve(Eigen::VectorXd::Zero(3 * n), exact);
  const double err = (u - exact).cwiseAbs().maxCoeff() / exact.cwiseAbs().maxCoeff();
  std::printf("patch test: max relative displacement error %.3e\n", err);
  EXPECT_LT(err, 1e-10);

  const Eigen::Matrix3d eps = 0.5 * (G + G.transpose());
  Eigen::Matrix<double, 6, 1> ev;
  ev << eps(0, 0), eps(1, 1), eps(2, 2), 2 * eps(1, 2), 2 * eps(0, 2), 2 * eps(0, 1);
  const gm::fe::Stress sigma = gm::fe::elasticity_matrix(mat) * ev;
  double serr = 0.0;
  for (int e = 0; e < static_cast<int>(mesh.tets.size()); ++e)
    for (const Vector3d& xi : {Vector3d(0.25, 0.25, 0.25), Vector3d(0, 0, 0), Vector3d(0.1, 0.7, 0.1)})
      serr = std::max(serr, (gm::fe::element_stress(mesh, e, mat, u, xi) - sigma).cwiseAbs().maxCoeff());
  std::printf("patch test: max relative stress error %.3e\n", serr / sigma.cwiseAbs().maxCoeff());
  EXPECT_LT(serr, 1e-10 * sigma.cwiseAbs().maxCoeff());
}

// Cantilever x in [0, L], square section h x h, clamped at x = 0, shear load F on the end face
// (uniform traction). Timoshenko tip deflection F L³/(3 E I) + F L/(k G A), Cowper's
// k = 10 (1 + ν)/(12 + 11 ν) for a rectangle, compared at the centroid of the tip face.
double cantilever_tip_error(int nx, int nyz, double* seconds) {
  const double L = 10.0, h = 1.0, F = 100.0;
  const Material mat{210000.0, 0.3};
  const auto t0 = std::chrono::steady_clock::now();
  const Mesh mesh = gm::fe::box_mesh(Vector3d(0, -h / 2, -h / 2), Vector3d(L, h / 2, h / 2), nx, nyz, nyz);
  const auto clamped = gm::fe::nodes_where(mesh, [](const Vector3d& x) { return x(0) < kTol; });
  const gm::fe::Solver solver(gm::fe::assemble_stiffness(mesh, mat), gm::fe::dofs_of_nodes(clamped));
  const Eigen::VectorXd f =
      gm::fe::traction_loads(mesh, [&](const Vector3d& x) { return x(0) > L - kTol; }, Vector3d(0, 0, F / (h * h)));
  EXPECT_NEAR(f.sum(), F, 1e-9 * F);
  const Eigen::VectorXd u = solver.solve(f);
  *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const auto tip = gm::fe::nodes_where(mesh, [&](const Vector3d& x) { return (x - Vector3d(L, 0, 0)).norm() < kTol; });
  EXPECT_EQ(tip.size(), 1u);
  const double I = h * h * h * h / 12.0, A = h * h, G = mat.E / (2 * (1 + mat.nu));
  const double k = 10 * (1 + mat.nu) / (12 + 11 * mat.nu);
  const double w = F * L * L * L / (3 * mat.E * I) + F * L / (k * G * A);
  return (u(3 * tip[0] + 2) - w) / w;
}

TEST(FeElasticity, CantileverMatchesTimoshenkoAndConverges) {
  const int meshes[][2] = {{10, 1}, {20, 2}, {40, 4}};
  double prev = 1e9;
  for (const auto& m : meshes) {
    double s = 0.0;
    const double err = cantilever_tip_error(m[0], m[1], &s);
    std::printf("cantilever %dx%dx%d hexes: tip error vs Timoshenko %+.4f %% (%.3f s)\n", m[0], m[1], m[1],
                100 * err, s);
    EXPECT_LT(std::abs(err), prev) << "no convergence at " << m[0];
    prev = std::abs(err);
  }
  EXPECT_LT(prev, 0.02);
}

// Maxwell–Betti: the compliance matrix between surface nodes (mixed directions) is symmetric.
TEST(FeElasticity, ComplianceIsReciprocal) {
  const Mesh mesh = gm::fe::box_mesh(Vector3d(0, 0, 0), Vector3d(4, 1, 1), 8, 2, 2);
  const gm::fe::Solver solver(gm::fe::assemble_stiffness(mesh, Material{}),
                              gm::fe::dofs_of_nodes(gm::fe::nodes_where(mesh, [](const Vector3d& x) { return x(0) < kTol; })));
  std::vector<gm::fe::NodeDirection> pts;
  std::mt19937 rng(3);
  std::normal_distribution<double> g;
  for (int i : gm::fe::nodes_where(mesh, [](const Vector3d& x) { return x(0) > kTol && (x(2) > 1 - kTol || x(1) < kTol); }))
    if (i % 3 == 0) pts.push_back({i, Vector3d(g(rng), g(rng), g(rng))});
  ASSERT_GT(pts.size(), 20u);
  const Eigen::MatrixXd C = gm::fe::compliance_matrix(solver, pts);
  const double asym = (C - C.transpose()).cwiseAbs().maxCoeff() / C.cwiseAbs().maxCoeff();
  std::printf("reciprocity: %zu points, max |C - Cᵀ| / max |C| = %.3e\n", pts.size(), asym);
  EXPECT_LT(asym, 1e-10);
  // Compliance along the load is positive (positive definite C).
  for (Eigen::Index i = 0; i < C.rows(); ++i) EXPECT_GT(C(i, i), 0.0);
}

// One factorization serves every load case; each column matches a single-vector solve.
TEST(FeElasticity, OneFactorizationForManyLoadCases) {
  const Mesh mesh = gm::fe::box_mesh(Vector3d(0, 0, 0), Vector3d(3, 1, 1), 6, 2, 2);
  const auto before = gm::fe::cholmod_factorization_count();
  const gm::fe::Solver solver(gm::fe::assemble_stiffness(mesh, Material{}),
                              gm::fe::dofs_of_nodes(gm::fe::nodes_where(mesh, [](const Vector3d& x) { return x(0) < kTol; })));
  EXPECT_EQ(gm::fe::cholmod_factorization_count(), before + 1);
  std::vector<gm::fe::NodeDirection> pts;
  for (int i : gm::fe::nodes_where(mesh, [](const Vector3d& x) { return x(2) > 1 - kTol; }))
    pts.push_back({i, Vector3d(0, 0.3, -1)});
  const Eigen::MatrixXd C = gm::fe::compliance_matrix(solver, pts);
  for (std::size_t j = 0; j < pts.size(); j += 7) {
    Eigen::VectorXd f = Eigen::VectorXd::Zero(solver.dofs());
    const Vector3d nj = pts[j].direction.normalized();
    f.segment<3>(3 * pts[j].node) = nj;
    const Eigen::VectorXd u = solver.solve(f);
    EXPECT_NEAR(nj.dot(u.segment<3>(3 * pts[j].node)), C(j, j), 1e-12 * std::abs(C(j, j)));
  }
  EXPECT_EQ(gm::fe::cholmod_factorization_count(), before + 1);
}

// solve_sparse (supernodal solves restricted to the loads' and the wanted dofs' elimination-tree
// paths) against a dense Cholesky of the free-free block (Eigen, no CHOLMOD): a bar clamped at
// x = 0, point loads near the free end, responses at a few scattered dofs.
TEST(FeElasticity, SparseSolveMatchesADenseReference) {
  const Mesh mesh = gm::fe::box_mesh(Vector3d(0, 0, 0), Vector3d(4, 1, 1), 8, 2, 2);
  const Eigen::SparseMatrix<double> K = gm::fe::assemble_stiffness(mesh, Material{});
  const std::vector<int> fixed =
      gm::fe::dofs_of_nodes(gm::fe::nodes_where(mesh, [](const Vector3d& x) { return x(0) < kTol; }));
  const gm::fe::Solver solver(K, fixed);
  // Loads: a few cases at nodes of the end x > 3.5 (some cases on two nodes), random directions.
  const std::vector<int> end = gm::fe::nodes_where(mesh, [](const Vector3d& x) { return x(0) > 3.5 - kTol; });
  std::mt19937 rng(7);
  std::normal_distribution<double> g;
  const int cases = 6;
  std::vector<Eigen::Triplet<double>> t;
  for (int c = 0; c < cases; ++c)
    for (int r = 0; r < 1 + c % 2; ++r) {
      const int node = end[(5 * c + 11 * r) % end.size()];
      for (int i = 0; i < 3; ++i) t.emplace_back(solver.free_index(3 * node + i), c, g(rng));
    }
  Eigen::SparseMatrix<double> F(solver.free_dofs(), cases);
  F.setFromTriplets(t.begin(), t.end());
  std::vector<int> wanted;
  for (int f = 0; f < solver.free_dofs(); f += 37) wanted.push_back(f);
  const Eigen::MatrixXd U = solver.solve_sparse(F, wanted);
  // Reference: the free-free block, dense, Eigen's LLT.
  std::vector<int> free;
  for (int d = 0; d < solver.dofs(); ++d)
    if (solver.free_index(d) >= 0) free.push_back(d);
  const Eigen::MatrixXd Kd = Eigen::MatrixXd(K);
  Eigen::MatrixXd Kff(free.size(), free.size());
  for (std::size_t i = 0; i < free.size(); ++i)
    for (std::size_t j = 0; j < free.size(); ++j) Kff(i, j) = Kd(free[i], free[j]);
  const Eigen::MatrixXd Uref = Kff.llt().solve(Eigen::MatrixXd(F));
  double worst = 0;
  for (std::size_t i = 0; i < wanted.size(); ++i)
    for (int c = 0; c < cases; ++c) worst = std::max(worst, std::fabs(U(i, c) - Uref(wanted[i], c)));
  const double scale = Uref.cwiseAbs().maxCoeff();
  const auto share = solver.last_sparse_share();
  std::printf("sparse solve: %zu wanted dofs, %d cases, max |U - U_ref| / max |U_ref| = %.2e; through "
              "%.0f %% of L forward, %.0f %% backward\n",
              wanted.size(), cases, worst / scale, 100 * share.first, 100 * share.second);
  EXPECT_LT(worst / scale, 1e-10);
  EXPECT_LT(share.first, 1.0);  // the loads at the free end reach only part of the factor
}

TEST(FeElasticity, UnconstrainedBodyIsAClearError) {
  const Mesh mesh = gm::fe::box_mesh(Vector3d(0, 0, 0), Vector3d(1, 1, 1), 1, 1, 1);
  EXPECT_THROW(gm::fe::Solver(gm::fe::assemble_stiffness(mesh, Material{}), {0, 1, 2}), std::runtime_error);
}

}  // namespace
