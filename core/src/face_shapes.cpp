// The reduced face basis's shapes, made once per model (face_shapes.hpp).
#include "face_shapes.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/SVD>

#include "face_basis.hpp"
#include "fe_compliance.hpp"
#include "gearmesh/internal/hertz.hpp"
#include "laws.hpp"
#include "model.hpp"

namespace gm {
namespace {

// Where the reference pair's responses are sampled: gear 1's roll distance at kPositions points
// evenly over the path of contact (its ends included), each at the line loads kLoads (N/m).
constexpr int kPositions = 7;
constexpr double kLoads[] = {1e4, 4e4, 1e5, 2.5e5};
// Columns from the uniform approach's responses (kUniformShapes, face_basis.hpp): the first is the
// mean face load, the second and third hold the zigzag of a real database's face load (its depth
// moves with the roll position and the Hertz slope); with two, set B's mesh order 3 at 350 N m
// moves by 0.5 % against the full solve, with three by 0.04 % (docs/model.md, "FE level").
constexpr int kUniform = kUniformShapes;

// Legendre polynomial P_j(x), x in [-1, 1]: (j + 1) P_{j+1} = (2j + 1) x P_j - j P_{j-1}.
double legendre(int j, double x) {
  double p0 = 1, p1 = x;
  if (j == 0) return p0;
  for (int i = 1; i < j; ++i) {
    const double p2 = ((2 * i + 1) * x * p1 - i * p0) / (i + 1);
    p0 = p1;
    p1 = p2;
  }
  return p1;
}

}  // namespace

std::vector<double> reference_face_shapes(const gm_model& m) {
  const MeshLayout& L = m.layout;
  const int K = std::min(m.params.solver_face_shapes, FaceBasis::kMaxShapes), S = L.slices;
  if (!m.level.database || K <= 0 || L.tan_beta_b != 0 || S < 1) return {};
  // the slices of tooth pair (0, 0) on flank A as detection places them across the axial overlap
  // of the faces, no axial displacement
  const double zlo = std::fmax(L.axial_offset[0] - 0.5 * L.face_width[0], L.axial_offset[1] - 0.5 * L.face_width[1]);
  const double zhi = std::fmin(L.axial_offset[0] + 0.5 * L.face_width[0], L.axial_offset[1] + 0.5 * L.face_width[1]);
  const double width = (zhi - zlo) / S;
  std::vector<ContactSlice> slices(static_cast<std::size_t>(S));
  for (int s = 0; s < S; ++s) {
    ContactSlice& c = slices[static_cast<std::size_t>(s)];
    c.flank = 1;
    c.slice = s;
    c.point.z() = zlo + (s + 0.5) * width;
    c.width = width;
  }
  // the smooth approaches: uniform (its responses give up to kUniform columns), and from
  // K = kUniform + 1 on the Legendre polynomials of degree 1 .. K - kUniform (a tilt, its bending)
  const int degrees = 1 + std::max(0, K - kUniform);
  Eigen::MatrixXd P(S, degrees);
  for (int s = 0; s < S; ++s)
    for (int j = 0; j < degrees; ++j) P(s, j) = legendre(j, S > 1 ? (s - 0.5 * (S - 1)) / (0.5 * (S - 1)) : 0.0);
  // the responses (C_ref + f'(w) I)^-1 P at every sample, each scaled to unit length
  const int loads = int(sizeof kLoads / sizeof kLoads[0]);
  Eigen::MatrixXd R(S, kPositions * loads * degrees);
  Eigen::MatrixXd C(S, S), A(S, S);
  Eigen::LLT<Eigen::MatrixXd> llt;
  const double uz[2] = {0, 0};
  const double tan_alpha = std::tan(m.geometry.alpha_wt);
  int col = 0;
  for (int i = 0; i < kPositions; ++i) {
    // gear 1's roll distance; gear 2's moves the other way on an external pair, the same way on a ring
    const double s1 = m.geometry.path_start + (m.geometry.path_end - m.geometry.path_start) * i / (kPositions - 1);
    const double rho[2] = {s1, L.base_radius[1] * tan_alpha - L.sign * (s1 - L.base_radius[0] * tan_alpha)};
    for (ContactSlice& c : slices) {
      c.roll[0] = rho[0];
      c.roll[1] = rho[1];
    }
    for (int a = 0; a < S; ++a)
      for (int b = 0; b <= a; ++b)
        C(a, b) = C(b, a) = fe_pair_compliance(fe_view(m), slices[std::size_t(a)], slices[std::size_t(b)], uz);
    // the local law there, as the evaluation makes it (laws.hpp): a flank contact at the
    // databases' depth, with the tip corners' near field where the path ends by a tip
    SliceLaw law;
    build_laws(m, slices.data(), &law, 1, true);
    const LocalLawKernel kern = local_law_kernel(law.local);
    for (int l = 0; l < loads; ++l) {
      A = C;
      A.diagonal().array() += local_law_jet(kern, kLoads[l] * law.local.width).slope;
      llt.compute(A);
      if (llt.info() != Eigen::Success) return {};
      for (int j = 0; j < degrees; ++j) {
        Eigen::VectorXd v = llt.solve(P.col(j));
        const double norm = v.norm();
        if (!(norm > 0) || !std::isfinite(norm)) return {};
        R.col(col++) = v / norm;
      }
    }
  }
  // per family of approaches (the uniform one's responses; the tilts' and their bendings'), the
  // leading left singular vectors of its samples: the span that holds them best (least squares).
  // The uniform family gives min(K, kUniform) columns, the tilts the rest; each scaled to a
  // largest entry of 1.
  constexpr int kMax = FaceBasis::kMaxShapes;
  std::vector<double> phi(static_cast<std::size_t>(S) * kMax, 0.0);
  const int samples = kPositions * loads, K_used = std::min(K, S);
  int k = 0;
  for (int family = 0; family < 2 && k < K_used; ++family) {
    // R's columns are (sample, degree); the family's: degree 0, or degrees 1 and up
    const int lo = family == 0 ? 0 : 1, hi = family == 0 ? 1 : degrees;
    if (hi <= lo) break;
    // one shape: the samples at 100 kN/m only (about the line load of 150 N m on the paper's
    // pair; the span of one shape holds the zigzag at one load)
    Eigen::MatrixXd F(S, samples * (hi - lo));
    int c = 0;
    for (int sample = 0; sample < samples; ++sample)
      if (K > 1 || kLoads[sample % loads] == 1e5)
        for (int j = lo; j < hi; ++j) F.col(c++) = R.col(sample * degrees + j);
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(F.leftCols(c), Eigen::ComputeThinU);
    const int take = std::min(family == 0 ? std::min(K, kUniform) : K_used, K_used - k);
    for (int t = 0; t < take; ++t, ++k) {
      const Eigen::VectorXd u = svd.matrixU().col(t);
      const double mx = u.cwiseAbs().maxCoeff();
      if (!(mx > 0)) return {};
      for (int s = 0; s < S; ++s) phi[std::size_t(s) * kMax + std::size_t(k)] = u[s] / mx;
    }
  }
  return phi;
}

std::vector<double> face_shape_products(const std::vector<double>& shapes, int K) {
  constexpr std::size_t kMax = FaceBasis::kMaxShapes;
  const std::size_t S = shapes.size() / kMax;
  std::vector<double> out(S * FaceBasis::kOuter, 0.0);
  K = std::min(K, FaceBasis::kMaxShapes);
  for (std::size_t s = 0; s < S; ++s) {
    const double* shape = &shapes[s * kMax];
    double* o = &out[s * FaceBasis::kOuter];
    for (int k = 0; k < K; ++k)
      for (int l = 0; l <= k; ++l) *o++ = shape[k] * shape[l];
  }
  return out;
}

}  // namespace gm
