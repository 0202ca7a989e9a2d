#include "fe_elasticity.hpp"

#include <cholmod.h>
#include <Eigen/LU>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <stdexcept>
#include <string>

// The BLAS under CHOLMOD (Fortran interface), for solve_sparse's supernodal solves.
extern "C" {
void dgemm_(const char* transa, const char* transb, const int* m, const int* n, const int* k,
            const double* alpha, const double* a, const int* lda, const double* b, const int* ldb,
            const double* beta, double* c, const int* ldc);
void dtrsm_(const char* side, const char* uplo, const char* transa, const char* diag, const int* m,
            const int* n, const double* alpha, const double* a, const int* lda, double* b, const int* ldb);
}

namespace gm::fe {

namespace {

std::atomic<std::size_t> g_factorizations{0};

// 4-point degree-2 rule on the reference tetrahedron (volume 1/6): a = (5 + 3√5)/20,
// b = (5 - √5)/20 (Hammer, Marlowe & Stroud 1956).
struct QuadPoint {
  Eigen::Vector3d xi;
  double w;
};
const std::array<QuadPoint, 4>& tet_rule() {
  static const std::array<QuadPoint, 4> rule = [] {
    const double a = 0.5854101966249685, b = 0.1381966011250105, w = 1.0 / 24.0;
    return std::array<QuadPoint, 4>{{{Eigen::Vector3d(b, b, b), w},
                                     {Eigen::Vector3d(a, b, b), w},
                                     {Eigen::Vector3d(b, a, b), w},
                                     {Eigen::Vector3d(b, b, a), w}}};
  }();
  return rule;
}

// TET10 shape-function derivatives with respect to (ξ, η, ζ) at xi. Barycentrics
// L = (1-ξ-η-ζ, ξ, η, ζ); corners N_i = L_i (2 L_i - 1), edge (a, b): N = 4 L_a L_b.
Eigen::Matrix<double, 10, 3> tet10_dshape(const Eigen::Vector3d& xi) {
  const std::array<double, 4> L{1.0 - xi.sum(), xi(0), xi(1), xi(2)};
  static const std::array<Eigen::Vector3d, 4> dL{Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(1, 0, 0),
                                                 Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(0, 0, 1)};
  Eigen::Matrix<double, 10, 3> d;
  for (int i = 0; i < 4; ++i) d.row(i) = (4.0 * L[i] - 1.0) * dL[i].transpose();
  for (int e = 0; e < 6; ++e) {
    const int a = kTet10Edges[e][0], b = kTet10Edges[e][1];
    d.row(4 + e) = 4.0 * (L[b] * dL[a] + L[a] * dL[b]).transpose();
  }
  return d;
}

// Physical gradients (10 x 3) and det J at xi.
double tet10_gradients(const std::array<Eigen::Vector3d, 10>& x, const Eigen::Vector3d& xi,
                       Eigen::Matrix<double, 10, 3>& grad) {
  const Eigen::Matrix<double, 10, 3> dN = tet10_dshape(xi);
  Eigen::Matrix3d J = Eigen::Matrix3d::Zero();  // J(r, c) = ∂x_r / ∂ξ_c
  for (int n = 0; n < 10; ++n) J += x[n] * dN.row(n);
  const double det = J.determinant();
  if (!(det > 0.0)) throw std::runtime_error("fe: inverted or degenerate TET10 element (det J <= 0)");
  grad = dN * J.inverse();
  return det;
}

Eigen::Matrix<double, 6, 30> strain_matrix(const Eigen::Matrix<double, 10, 3>& g) {
  Eigen::Matrix<double, 6, 30> B = Eigen::Matrix<double, 6, 30>::Zero();
  for (int n = 0; n < 10; ++n) {
    const int c = 3 * n;
    B(0, c) = g(n, 0);
    B(1, c + 1) = g(n, 1);
    B(2, c + 2) = g(n, 2);
    B(3, c + 1) = g(n, 2), B(3, c + 2) = g(n, 1);
    B(4, c) = g(n, 2), B(4, c + 2) = g(n, 0);
    B(5, c) = g(n, 1), B(5, c + 1) = g(n, 0);
  }
  return B;
}

std::array<Eigen::Vector3d, 10> element_nodes(const Mesh& mesh, int e) {
  std::array<Eigen::Vector3d, 10> x;
  for (int n = 0; n < 10; ++n) x[n] = mesh.nodes[mesh.tets[e][n]];
  return x;
}

}  // namespace

Eigen::Matrix<double, 6, 6> elasticity_matrix(const Material& m) {
  if (!(m.E > 0.0) || !(m.nu > -1.0 && m.nu < 0.5)) throw std::runtime_error("fe: need E > 0 and -1 < nu < 0.5");
  const double lambda = m.E * m.nu / ((1.0 + m.nu) * (1.0 - 2.0 * m.nu));
  const double mu = m.E / (2.0 * (1.0 + m.nu));
  Eigen::Matrix<double, 6, 6> D = Eigen::Matrix<double, 6, 6>::Zero();
  D.topLeftCorner<3, 3>().setConstant(lambda);
  D.topLeftCorner<3, 3>().diagonal().array() += 2.0 * mu;
  D.bottomRightCorner<3, 3>().diagonal().setConstant(mu);
  return D;
}

ElementStiffness element_stiffness(const std::array<Eigen::Vector3d, 10>& x, const Material& m) {
  const Eigen::Matrix<double, 6, 6> D = elasticity_matrix(m);
  ElementStiffness K = ElementStiffness::Zero();
  Eigen::Matrix<double, 10, 3> g;
  for (const QuadPoint& q : tet_rule()) {
    const double det = tet10_gradients(x, q.xi, g);
    const Eigen::Matrix<double, 6, 30> B = strain_matrix(g);
    K.noalias() += (q.w * det) * B.transpose() * D * B;
  }
  return K;
}

Eigen::SparseMatrix<double> assemble_stiffness(const Mesh& mesh, const Material& m) {
  const int n = 3 * static_cast<int>(mesh.nodes.size());
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(mesh.tets.size() * 900);
  for (std::size_t e = 0; e < mesh.tets.size(); ++e) {
    const auto& t = mesh.tets[e];
    for (int id : t)
      if (id < 0 || 3 * id >= n) throw std::runtime_error("fe: element node index out of range");
    const ElementStiffness Ke = element_stiffness(element_nodes(mesh, static_cast<int>(e)), m);
    for (int a = 0; a < 10; ++a)
      for (int i = 0; i < 3; ++i)
        for (int b = 0; b < 10; ++b)
          for (int j = 0; j < 3; ++j) trip.emplace_back(3 * t[a] + i, 3 * t[b] + j, Ke(3 * a + i, 3 * b + j));
  }
  Eigen::SparseMatrix<double> K(n, n);
  K.setFromTriplets(trip.begin(), trip.end());
  return K;
}

Stress element_stress(const Mesh& mesh, int e, const Material& m, const Eigen::VectorXd& u,
                      const Eigen::Vector3d& xi) {
  Eigen::Matrix<double, 10, 3> g;
  tet10_gradients(element_nodes(mesh, e), xi, g);
  Eigen::Matrix<double, 30, 1> ue;
  for (int n = 0; n < 10; ++n) ue.segment<3>(3 * n) = u.segment<3>(3 * mesh.tets[e][n]);
  return elasticity_matrix(m) * (strain_matrix(g) * ue);
}

std::vector<int> nodes_where(const Mesh& mesh, const std::function<bool(const Eigen::Vector3d&)>& pred) {
  std::vector<int> out;
  for (std::size_t i = 0; i < mesh.nodes.size(); ++i)
    if (pred(mesh.nodes[i])) out.push_back(static_cast<int>(i));
  return out;
}

std::vector<int> dofs_of_nodes(const std::vector<int>& nodes) {
  std::vector<int> out;
  out.reserve(3 * nodes.size());
  for (int n : nodes)
    for (int c = 0; c < 3; ++c) out.push_back(3 * n + c);
  std::sort(out.begin(), out.end());
  return out;
}

Eigen::VectorXd traction_loads(const Mesh& mesh, const std::function<bool(const Eigen::Vector3d&)>& on_face,
                               const Eigen::Vector3d& t) {
  // TET10 faces as TRI6 (corners a, b, c; mid-nodes on ab, bc, ca), gmsh local numbering.
  static const int faces[4][6] = {{0, 1, 2, 4, 5, 6}, {0, 1, 3, 4, 9, 7}, {0, 2, 3, 6, 8, 7}, {1, 2, 3, 5, 8, 9}};
  // 3-point degree-2 rule on the reference triangle (area 1/2), points (1/6, 1/6) etc.
  static const double qp[3][2] = {{1.0 / 6, 1.0 / 6}, {2.0 / 3, 1.0 / 6}, {1.0 / 6, 2.0 / 3}};
  Eigen::VectorXd f = Eigen::VectorXd::Zero(3 * static_cast<Eigen::Index>(mesh.nodes.size()));
  std::vector<char> on(mesh.nodes.size());
  for (std::size_t i = 0; i < mesh.nodes.size(); ++i) on[i] = on_face(mesh.nodes[i]) ? 1 : 0;
  for (const auto& tet : mesh.tets) {
    for (const auto& face : faces) {
      std::array<int, 6> v;
      bool all = true;
      for (int i = 0; i < 6; ++i) all = all && on[v[i] = tet[face[i]]];
      if (!all) continue;
      for (const auto& q : qp) {
        const double s = q[0], r = q[1], l0 = 1.0 - s - r;
        // TRI6 shapes with barycentrics (l0, s, r).
        const double N[6] = {l0 * (2 * l0 - 1), s * (2 * s - 1), r * (2 * r - 1), 4 * l0 * s, 4 * s * r, 4 * r * l0};
        const double dNs[6] = {-(4 * l0 - 1), 4 * s - 1, 0, 4 * (l0 - s), 4 * r, -4 * r};
        const double dNr[6] = {-(4 * l0 - 1), 0, 4 * r - 1, -4 * s, 4 * s, 4 * (l0 - r)};
        Eigen::Vector3d ts = Eigen::Vector3d::Zero(), tr = Eigen::Vector3d::Zero();
        for (int i = 0; i < 6; ++i) ts += dNs[i] * mesh.nodes[v[i]], tr += dNr[i] * mesh.nodes[v[i]];
        const double dA = ts.cross(tr).norm() / 6.0;  // weight 1/6 per point
        for (int i = 0; i < 6; ++i) f.segment<3>(3 * v[i]) += N[i] * dA * t;
      }
    }
  }
  return f;
}

std::size_t cholmod_factorization_count() { return g_factorizations.load(); }

const char* cholmod_ordering_name(int ordering) {
  switch (ordering) {
    case CHOLMOD_NATURAL: return "natural";
    case CHOLMOD_GIVEN: return "given";
    case CHOLMOD_AMD: return "AMD";
    case CHOLMOD_METIS: return "METIS";
    case CHOLMOD_NESDIS: return "NESDIS";
    case CHOLMOD_COLAMD: return "COLAMD";
    case CHOLMOD_POSTORDERED: return "postordered";
    default: return "unknown";
  }
}

struct Solver::Factor {
  cholmod_common c;
  cholmod_factor* L = nullptr;
  // cholmod_solve2's solution and workspace, kept between solves (same sizes: no reallocation)
  cholmod_dense *X = nullptr, *Y = nullptr, *E = nullptr;
  Factor() { cholmod_start(&c); }
  ~Factor() {
    cholmod_free_dense(&X, &c);
    cholmod_free_dense(&Y, &c);
    cholmod_free_dense(&E, &c);
    cholmod_free_factor(&L, &c);
    cholmod_finish(&c);
  }
  // The free dofs' solution of F (free rows), in X.
  void solve(const Eigen::MatrixXd& F) {
    cholmod_dense B{};
    B.nrow = static_cast<std::size_t>(F.rows());
    B.ncol = static_cast<std::size_t>(F.cols());
    B.nzmax = B.nrow * B.ncol;
    B.d = B.nrow;
    B.x = const_cast<double*>(F.data());
    B.xtype = CHOLMOD_REAL;
    B.dtype = CHOLMOD_DOUBLE;
    if (!cholmod_solve2(CHOLMOD_A, L, &B, nullptr, &X, nullptr, &Y, &E, &c))
      throw std::runtime_error("fe: CHOLMOD solve failed (status " + std::to_string(c.status) + ")");
  }

  // solve_sparse's view of the supernodal factor (filled by index() on first use): the supernode
  // of each column, each supernode's parent in the elimination tree (-1: a root), and the
  // position of each free dof in the factor's order (the inverse of L->Perm).
  std::vector<int> super_of, parent, iperm;
  std::pair<double, double> share{0.0, 0.0};  // of the last solve_sparse: forward, backward
  const int* super() const { return static_cast<const int*>(L->super); }
  const int* pi() const { return static_cast<const int*>(L->pi); }
  const int* px() const { return static_cast<const int*>(L->px); }
  const int* rows() const { return static_cast<const int*>(L->s); }
  const double* lx() const { return static_cast<const double*>(L->x); }
  int nsuper() const { return static_cast<int>(L->nsuper); }
  void index();
  std::vector<char> paths(const std::vector<int>& cols) const;
  double entries(const std::vector<char>& on) const;
  void forward(double* X, int nb, const std::vector<int>& pos, const std::vector<char>& on) const;
  void backward(double* X, int nb, const std::vector<int>& pos, const std::vector<char>& on) const;
};

void Solver::Factor::index() {
  if (!super_of.empty()) return;
  if (!L->is_super || !L->is_ll || L->xtype != CHOLMOD_REAL)
    throw std::runtime_error("fe: solve_sparse needs CHOLMOD's supernodal LL^T factor");
  const int n = static_cast<int>(L->n), ns = nsuper();
  const int* perm = static_cast<const int*>(L->Perm);
  super_of.assign(n, 0);
  parent.assign(ns, -1);
  iperm.assign(n, 0);
  for (int k = 0; k < n; ++k) iperm[perm[k]] = k;
  for (int s = 0; s < ns; ++s)
    for (int j = super()[s]; j < super()[s + 1]; ++j) super_of[j] = s;
  for (int s = 0; s < ns; ++s) {
    const int nscol = super()[s + 1] - super()[s];
    if (pi()[s + 1] - pi()[s] > nscol) parent[s] = super_of[rows()[pi()[s] + nscol]];
  }
}

// The supernodes of the columns cols (in the factor's order) and all their ancestors: where a
// forward solve with loads on cols is not zero, or what a backward solve for cols reads.
std::vector<char> Solver::Factor::paths(const std::vector<int>& cols) const {
  std::vector<char> on(parent.size(), 0);
  for (int j : cols) on[super_of[j]] = 1;
  for (std::size_t s = 0; s < on.size(); ++s)  // a parent comes after its children
    if (on[s] && parent[s] >= 0) on[parent[s]] = 1;
  return on;
}

// Entries of L in the supernodes marked on (as stored: each supernode's full trapezoid).
double Solver::Factor::entries(const std::vector<char>& on) const {
  double sum = 0;
  for (int s = 0; s < nsuper(); ++s)
    if (on[s]) sum += double(pi()[s + 1] - pi()[s]) * double(super()[s + 1] - super()[s]);
  return sum;
}

// X: the cases as rows (nb x columns, column-major: a column's nb values together), column j of
// the factor at X + nb pos[j] (a supernode's columns are consecutive). Forward: L y = b on the
// supernodes marked on, ascending: each one's diagonal block (TRSM), then its update of the rows
// below (GEMM into a workspace, subtracted at those rows).
void Solver::Factor::forward(double* X, int nb, const std::vector<int>& pos, const std::vector<char>& on) const {
  const double one = 1.0, zero = 0.0;
  std::vector<double> E;
  for (int s = 0; s < nsuper(); ++s) {
    if (!on[s]) continue;
    const int k1 = super()[s], nscol = super()[s + 1] - k1, nsrow = pi()[s + 1] - pi()[s];
    const int nr = nsrow - nscol;
    const double* Ls = lx() + px()[s];
    double* C = X + std::size_t(nb) * std::size_t(pos[k1]);
    dtrsm_("R", "L", "T", "N", &nb, &nscol, &one, Ls, &nsrow, C, &nb);  // y^T L_ss^T = b^T
    if (nr == 0) continue;
    E.resize(std::size_t(nb) * std::size_t(nr));
    dgemm_("N", "T", &nb, &nr, &nscol, &one, C, &nb, Ls + nscol, &nsrow, &zero, E.data(), &nb);
    const int* r = rows() + pi()[s] + nscol;
    for (int q = 0; q < nr; ++q) {
      double* dst = X + std::size_t(nb) * std::size_t(pos[r[q]]);
      const double* src = E.data() + std::size_t(nb) * q;
      for (int c = 0; c < nb; ++c) dst[c] -= src[c];
    }
  }
}

// Backward: L^T x = y on the supernodes marked on, descending: gather the rows below (already
// solved), subtract their contribution (GEMM), then the diagonal block (TRSM).
void Solver::Factor::backward(double* X, int nb, const std::vector<int>& pos, const std::vector<char>& on) const {
  const double one = 1.0, minus_one = -1.0;
  std::vector<double> E;
  for (int s = nsuper() - 1; s >= 0; --s) {
    if (!on[s]) continue;
    const int k1 = super()[s], nscol = super()[s + 1] - k1, nsrow = pi()[s + 1] - pi()[s];
    const int nr = nsrow - nscol;
    const double* Ls = lx() + px()[s];
    double* C = X + std::size_t(nb) * std::size_t(pos[k1]);
    if (nr > 0) {
      E.resize(std::size_t(nb) * std::size_t(nr));
      const int* r = rows() + pi()[s] + nscol;
      for (int q = 0; q < nr; ++q) {
        const double* src = X + std::size_t(nb) * std::size_t(pos[r[q]]);
        std::copy(src, src + nb, E.data() + std::size_t(nb) * q);
      }
      dgemm_("N", "N", &nb, &nscol, &nr, &minus_one, E.data(), &nb, Ls + nscol, &nsrow, &one, C, &nb);
    }
    dtrsm_("R", "L", "N", "N", &nb, &nscol, &one, Ls, &nsrow, C, &nb);  // x^T L_ss = y^T
  }
}

namespace {

// The lower triangle of a symmetric n x n matrix (CSC, sorted, int indices: column starts p,
// row indices i, values x, or none for a pattern) as a CHOLMOD view; nothing is copied.
cholmod_sparse cholmod_lower_view(std::size_t n, std::size_t nzmax, int* p, int* i, double* x) {
  cholmod_sparse s{};
  s.nrow = s.ncol = n;
  s.nzmax = nzmax;
  s.p = p;
  s.i = i;
  s.x = x;
  s.stype = -1;
  s.itype = CHOLMOD_INT;
  s.xtype = x ? CHOLMOD_REAL : CHOLMOD_PATTERN;
  s.dtype = CHOLMOD_DOUBLE;
  s.sorted = 1;
  s.packed = 1;
  return s;
}

// Fill-reducing order of the free dofs: METIS (through CHOLMOD) on the graph of their nodes
// (group of free dof i: its full dof / 3), each node's free dofs then together in ascending order.
// Kff: the free-free block's lower triangle (CSC), free: full dof of each free dof (ascending).
std::vector<int> node_graph_metis_order(const Eigen::Ref<Eigen::SparseMatrix<double>>& Kff, const std::vector<int>& free,
                                        cholmod_common& c) {
  const int nf = static_cast<int>(free.size());
  std::vector<int> group(nf), first;  // group of each free dof; first free dof of each group
  for (int i = 0; i < nf; ++i) {
    if (i == 0 || free[i] / 3 != free[i - 1] / 3) first.push_back(i);
    group[i] = static_cast<int>(first.size()) - 1;
  }
  const int ng = static_cast<int>(first.size());
  first.push_back(nf);
  // Lower triangle of the node graph (no diagonal), column by column with a marker.
  std::vector<int> p(ng + 1, 0), rows, mark(ng, -1);
  rows.reserve(static_cast<std::size_t>(Kff.nonZeros() / 6 + ng));
  for (int g = 0; g < ng; ++g) {
    const std::size_t start = rows.size();
    for (int j = first[g]; j < first[g + 1]; ++j)
      for (Eigen::Ref<Eigen::SparseMatrix<double>>::InnerIterator it(Kff, j); it; ++it) {
        const int h = group[it.row()];
        if (h > g && mark[h] != g) mark[h] = g, rows.push_back(h);
      }
    std::sort(rows.begin() + static_cast<std::ptrdiff_t>(start), rows.end());
    p[g + 1] = static_cast<int>(rows.size());
  }
  rows.resize(std::max<std::size_t>(1, rows.size()));
  cholmod_sparse G = cholmod_lower_view(static_cast<std::size_t>(ng), rows.size(), p.data(),
                                        rows.data(), nullptr);
  std::vector<int> gperm(ng);
  if (!cholmod_metis(&G, nullptr, 0, 1, gperm.data(), &c))
    throw std::runtime_error("fe: CHOLMOD's METIS ordering failed (status " + std::to_string(c.status) + ")");
  std::vector<int> perm;
  perm.reserve(nf);
  for (int g : gperm)
    for (int i = first[g]; i < first[g + 1]; ++i) perm.push_back(i);
  return perm;
}

}  // namespace

namespace {
using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }
}  // namespace

void Solver::number_dofs() {
  std::sort(fixed_.begin(), fixed_.end());
  fixed_.erase(std::unique(fixed_.begin(), fixed_.end()), fixed_.end());
  index_.assign(n_, n_);  // free index, or -1 - fixed index
  for (std::size_t k = 0; k < fixed_.size(); ++k) {
    if (fixed_[k] < 0 || fixed_[k] >= n_) throw std::runtime_error("fe: fixed dof out of range");
    index_[fixed_[k]] = -1 - static_cast<int>(k);
  }
  for (int i = 0; i < n_; ++i)
    if (index_[i] == n_) {
      index_[i] = static_cast<int>(free_.size());
      free_.push_back(i);
    }
  if (free_.empty()) throw std::runtime_error("fe: every degree of freedom is fixed");
}

Solver::Solver(const Eigen::SparseMatrix<double>& K, std::vector<int> fixed_dofs)
    : n_(static_cast<int>(K.rows())), fixed_(std::move(fixed_dofs)), factor_(std::make_unique<Factor>()) {
  const auto t0 = Clock::now();
  if (K.rows() != K.cols()) throw std::runtime_error("fe: stiffness matrix is not square");
  number_dofs();
  std::vector<Eigen::Triplet<double>> ff, fc;
  ff.reserve(K.nonZeros() / 2 + free_.size());
  for (int c = 0; c < K.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(K, c); it; ++it) {
      const int r = static_cast<int>(it.row()), ir = index_[r], ic = index_[c];
      if (ir < 0) continue;
      if (ic >= 0) {
        if (ir >= ic) ff.emplace_back(ir, ic, it.value());  // CHOLMOD reads the lower triangle only
      } else {
        fc.emplace_back(ir, -1 - ic, it.value());
      }
    }
  Eigen::SparseMatrix<double> Kff(free_dofs(), free_dofs());
  Kff.setFromTriplets(ff.begin(), ff.end());
  std::vector<Eigen::Triplet<double>>().swap(ff);
  K_fc_.resize(free_dofs(), static_cast<Eigen::Index>(fixed_.size()));
  K_fc_.setFromTriplets(fc.begin(), fc.end());
  stats_.setup_seconds = seconds_since(t0);
  factorize(Kff);
}

Solver::Solver(const Mesh& mesh, const Material& m, std::vector<int> fixed_dofs)
    : n_(3 * static_cast<int>(mesh.nodes.size())), fixed_(std::move(fixed_dofs)), factor_(std::make_unique<Factor>()) {
  const auto t0 = Clock::now();
  number_dofs();
  const int nn = static_cast<int>(mesh.nodes.size()), nf = free_dofs();
  for (const auto& t : mesh.tets)
    for (int id : t)
      if (id < 0 || id >= nn) throw std::runtime_error("fe: element node index out of range");
  // Node graph (each node with itself), sorted, from the elements of each node.
  std::vector<int> ep(nn + 1, 0), elems;
  for (const auto& t : mesh.tets)
    for (int id : t) ++ep[id + 1];
  for (int v = 0; v < nn; ++v) ep[v + 1] += ep[v];
  elems.resize(ep[nn]);
  {
    std::vector<int> fill(ep.begin(), ep.end() - 1);
    for (std::size_t e = 0; e < mesh.tets.size(); ++e)
      for (int id : mesh.tets[e]) elems[fill[id]++] = static_cast<int>(e);
  }
  std::vector<int> np(nn + 1, 0), nbr, mark(nn, -1);
  nbr.reserve(static_cast<std::size_t>(nn) * 30);
  for (int v = 0; v < nn; ++v) {
    const std::size_t start = nbr.size();
    for (int q = ep[v]; q < ep[v + 1]; ++q)
      for (int w : mesh.tets[elems[q]])
        if (w >= v && mark[w] != v) mark[w] = v, nbr.push_back(w);  // the lower triangle: w >= v
    std::sort(nbr.begin() + static_cast<std::ptrdiff_t>(start), nbr.end());
    np[v + 1] = static_cast<int>(nbr.size());
  }
  std::vector<int>().swap(elems);
  // Pattern of the free-free block's lower triangle, column by column (free dof order = full
  // dof order, so the rows come out sorted).
  std::vector<int> cp(nf + 1, 0), ri;
  ri.reserve(static_cast<std::size_t>(np[nn]) * 9 / 2 + nf);
  for (int j = 0; j < nf; ++j) {
    const int d = free_[j], v = d / 3;
    for (int q = np[v]; q < np[v + 1]; ++q)
      for (int c = 0; c < 3; ++c) {
        const int i = index_[3 * nbr[q] + c];
        if (i >= j) ri.push_back(i);
      }
    cp[j + 1] = static_cast<int>(ri.size());
  }
  std::vector<int>().swap(nbr);
  std::vector<double> val(ri.size(), 0.0);
  std::vector<Eigen::Triplet<double>> fc;
  // Element by element (the order of the former triplet assembly: the same sums).
  std::array<int, 30> idx;
  for (std::size_t e = 0; e < mesh.tets.size(); ++e) {
    const auto& t = mesh.tets[e];
    const ElementStiffness Ke = element_stiffness(element_nodes(mesh, static_cast<int>(e)), m);
    for (int a = 0; a < 10; ++a)
      for (int i = 0; i < 3; ++i) idx[3 * a + i] = index_[3 * t[a] + i];
    for (int b = 0; b < 30; ++b) {
      const int c = idx[b];
      for (int a = 0; a < 30; ++a) {
        const int r = idx[a];
        if (r < 0) continue;
        if (c < 0) {
          fc.emplace_back(r, -1 - c, Ke(a, b));
        } else if (r >= c) {
          const int* lo = ri.data() + cp[c];
          const int* hi = ri.data() + cp[c + 1];
          val[std::lower_bound(lo, hi, r) - ri.data()] += Ke(a, b);
        }
      }
    }
  }
  K_fc_.resize(nf, static_cast<Eigen::Index>(fixed_.size()));
  K_fc_.setFromTriplets(fc.begin(), fc.end());
  std::vector<Eigen::Triplet<double>>().swap(fc);
  Eigen::Map<Eigen::SparseMatrix<double>> Kff(nf, nf, static_cast<Eigen::Index>(ri.size()), cp.data(), ri.data(), val.data());
  stats_.setup_seconds = seconds_since(t0);
  factorize(Kff);
}

void Solver::factorize(Eigen::Ref<Eigen::SparseMatrix<double>> Kff) {
  auto t0 = Clock::now();
  cholmod_common& c = factor_->c;
  c.supernodal = CHOLMOD_SUPERNODAL;
  c.final_asis = 1;  // keep the supernodal LL^T
  c.nmethods = 1;
  c.method[0].ordering = CHOLMOD_GIVEN;
  c.postorder = 1;
  cholmod_sparse A = cholmod_lower_view(static_cast<std::size_t>(Kff.rows()),
                                        static_cast<std::size_t>(Kff.nonZeros()),
                                        Kff.outerIndexPtr(), Kff.innerIndexPtr(), Kff.valuePtr());
  std::vector<int> perm = node_graph_metis_order(Kff, free_, c);
  factor_->L = cholmod_analyze_p(&A, perm.data(), nullptr, 0, &c);
  stats_.analyze_seconds = seconds_since(t0);
  if (!factor_->L)
    throw std::runtime_error("fe: CHOLMOD analysis failed (status " + std::to_string(c.status) + ")");
  t0 = Clock::now();
  const int ok = cholmod_factorize(&A, factor_->L, &c);
  stats_.factor_seconds = seconds_since(t0);
  stats_.lnz = c.lnz;
  stats_.flops = c.fl;
  stats_.stored = static_cast<double>(factor_->L->xsize);
  stats_.ordering = CHOLMOD_METIS;
  ++g_factorizations;
  if (!ok || c.status != CHOLMOD_OK || factor_->L->minor < factor_->L->n)
    throw std::runtime_error("fe: CHOLMOD factorization failed (stiffness not positive definite: "
                             "is every rigid-body mode constrained?)");
}

Solver::~Solver() = default;

Eigen::Map<const Eigen::MatrixXd> Solver::solve_free(const Eigen::MatrixXd& F_free) const {
  if (F_free.rows() != free_dofs()) throw std::runtime_error("fe: free load matrix of the wrong size");
  factor_->solve(F_free);
  const cholmod_dense* X = factor_->X;
  return Eigen::Map<const Eigen::MatrixXd>(static_cast<const double*>(X->x), static_cast<Eigen::Index>(X->nrow),
                                           static_cast<Eigen::Index>(X->ncol));
}

Eigen::MatrixXd Solver::solve_sparse(const Eigen::SparseMatrix<double>& F_free, const std::vector<int>& wanted) const {
  if (F_free.rows() != free_dofs()) throw std::runtime_error("fe: free load matrix of the wrong size");
  Factor& f = *factor_;
  f.index();
  const int nb = static_cast<int>(F_free.cols());
  std::vector<int> loaded_cols, wanted_cols;
  for (int c = 0; c < F_free.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(F_free, c); it; ++it) loaded_cols.push_back(f.iperm[it.row()]);
  for (int w : wanted) {
    if (w < 0 || w >= free_dofs()) throw std::runtime_error("fe: wanted dof out of range");
    wanted_cols.push_back(f.iperm[w]);
  }
  const std::vector<char> fwd = f.paths(loaded_cols), bwd = f.paths(wanted_cols);
  // Storage for the columns of the supernodes either solve touches, in the factor's order.
  std::vector<int> pos(static_cast<std::size_t>(free_dofs()), -1);
  int count = 0;
  for (int s = 0; s < f.nsuper(); ++s)
    if (fwd[s] || bwd[s])
      for (int j = f.super()[s]; j < f.super()[s + 1]; ++j) pos[j] = count++;
  std::vector<double> X(std::size_t(nb) * std::size_t(count), 0.0);
  for (int c = 0; c < F_free.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(F_free, c); it; ++it)
      X[std::size_t(nb) * std::size_t(pos[f.iperm[it.row()]]) + std::size_t(c)] += it.value();
  f.forward(X.data(), nb, pos, fwd);
  f.backward(X.data(), nb, pos, bwd);
  const double total = f.entries(std::vector<char>(static_cast<std::size_t>(f.nsuper()), 1));
  f.share = {f.entries(fwd) / total, f.entries(bwd) / total};
  Eigen::MatrixXd U(static_cast<Eigen::Index>(wanted.size()), nb);
  for (std::size_t i = 0; i < wanted.size(); ++i)
    for (int c = 0; c < nb; ++c)
      U(static_cast<Eigen::Index>(i), c) = X[std::size_t(nb) * std::size_t(pos[wanted_cols[i]]) + std::size_t(c)];
  return U;
}

std::pair<double, double> Solver::last_sparse_share() const { return factor_->share; }

Eigen::VectorXd Solver::solve(const Eigen::VectorXd& f, const Eigen::VectorXd& u_fixed) const {
  if (f.size() != n_ || (u_fixed.size() != 0 && u_fixed.size() != n_))
    throw std::runtime_error("fe: load or prescribed-displacement vector of the wrong size");
  Eigen::VectorXd rhs(free_dofs());
  for (int i = 0; i < free_dofs(); ++i) rhs(i) = f(free_[i]);
  Eigen::VectorXd u = Eigen::VectorXd::Zero(n_);
  if (u_fixed.size() != 0) {
    Eigen::VectorXd uc(static_cast<Eigen::Index>(fixed_.size()));
    for (std::size_t k = 0; k < fixed_.size(); ++k) u(fixed_[k]) = uc(k) = u_fixed(fixed_[k]);
    rhs -= K_fc_ * uc;
  }
  const auto uf = solve_free(rhs);
  for (int i = 0; i < free_dofs(); ++i) u(free_[i]) = uf(i, 0);
  return u;
}

Eigen::MatrixXd Solver::solve(const Eigen::MatrixXd& F) const {
  if (F.rows() != n_) throw std::runtime_error("fe: load matrix of the wrong size");
  Eigen::MatrixXd rhs(free_dofs(), F.cols());
  for (int i = 0; i < free_dofs(); ++i) rhs.row(i) = F.row(free_[i]);
  const auto uf = solve_free(rhs);
  Eigen::MatrixXd U = Eigen::MatrixXd::Zero(n_, F.cols());
  for (int i = 0; i < free_dofs(); ++i) U.row(free_[i]) = uf.row(i);
  return U;
}

Eigen::MatrixXd compliance_matrix(const Solver& solver, const std::vector<NodeDirection>& points) {
  const Eigen::Index m = static_cast<Eigen::Index>(points.size());
  std::vector<Eigen::Vector3d> n(points.size());
  Eigen::MatrixXd F = Eigen::MatrixXd::Zero(solver.dofs(), m);
  for (Eigen::Index j = 0; j < m; ++j) {
    const NodeDirection& p = points[j];
    if (p.node < 0 || 3 * p.node + 2 >= solver.dofs()) throw std::runtime_error("fe: compliance node out of range");
    const double len = p.direction.norm();
    if (!(len > 0.0)) throw std::runtime_error("fe: compliance direction is zero");
    n[j] = p.direction / len;
    F.block<3, 1>(3 * p.node, j) = n[j];
  }
  const Eigen::MatrixXd U = solver.solve(F);
  Eigen::MatrixXd C(m, m);
  for (Eigen::Index j = 0; j < m; ++j)
    for (Eigen::Index k = 0; k < m; ++k) C(k, j) = n[k].dot(U.block<3, 1>(3 * points[k].node, j));
  return C;
}

Mesh box_mesh(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int nx, int ny, int nz) {
  if (nx < 1 || ny < 1 || nz < 1) throw std::runtime_error("fe: box mesh needs at least one cell per axis");
  const int px = 2 * nx + 1, py = 2 * ny + 1, pz = 2 * nz + 1;
  Mesh mesh;
  mesh.nodes.reserve(static_cast<std::size_t>(px) * py * pz);
  for (int k = 0; k < pz; ++k)
    for (int j = 0; j < py; ++j)
      for (int i = 0; i < px; ++i) {
        const Eigen::Vector3d s(double(i) / (px - 1), double(j) / (py - 1), double(k) / (pz - 1));
        mesh.nodes.push_back(lo + (hi - lo).cwiseProduct(s));
      }
  const auto id = [&](const Eigen::Vector3i& p) { return p(0) + px * (p(1) + py * p(2)); };
  static const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  mesh.tets.reserve(6 * static_cast<std::size_t>(nx) * ny * nz);
  for (int c = 0; c < nz; ++c)
    for (int b = 0; b < ny; ++b)
      for (int a = 0; a < nx; ++a)
        for (const auto& p : perms) {
          // Kuhn simplex: walk from the low corner to the high one, one axis at a time.
          std::array<Eigen::Vector3i, 4> v;
          v[0] = Eigen::Vector3i(2 * a, 2 * b, 2 * c);
          v[1] = v[0], v[1](p[0]) += 2;
          v[2] = v[1], v[2](p[1]) += 2;
          v[3] = v[0] + Eigen::Vector3i(2, 2, 2);
          Eigen::Matrix3d M;
          for (int r = 0; r < 3; ++r) M.col(r) = (v[r + 1] - v[0]).cast<double>().cwiseProduct(hi - lo);
          if (M.determinant() < 0) std::swap(v[1], v[2]);
          std::array<int, 10> t;
          for (int r = 0; r < 4; ++r) t[r] = id(v[r]);
          for (int e = 0; e < 6; ++e) t[4 + e] = id((v[kTet10Edges[e][0]] + v[kTet10Edges[e][1]]) / 2);
          mesh.tets.push_back(t);
        }
  return mesh;
}

}  // namespace gm::fe
