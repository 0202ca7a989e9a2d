// The reduced face basis's shapes, made once per model (face_shapes.hpp).
#include "face_shapes.hpp"

#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "face_basis.hpp"
#include "fe_compliance.hpp"
#include "gearmesh/internal/hertz.hpp"
#include "model.hpp"

namespace gm {

std::vector<double> reference_face_shapes(const gm_model& m) {
  const MeshLayout& L = m.layout;
  const int K = m.params.solver_face_shapes, S = L.slices;
  if (!m.level.database || K <= 0 || L.tan_beta_b != 0 || S < 1) return {};
  // the slices of tooth pair (0, 0) on flank A at the pitch point, as detection places them
  // across the axial overlap of the faces
  const double tan_alpha = std::tan(m.geometry.alpha_wt);
  const double rho[2] = {L.base_radius[0] * tan_alpha, L.base_radius[1] * tan_alpha};
  const double zlo = std::fmax(L.axial_offset[0] - 0.5 * L.face_width[0], L.axial_offset[1] - 0.5 * L.face_width[1]);
  const double zhi = std::fmin(L.axial_offset[0] + 0.5 * L.face_width[0], L.axial_offset[1] + 0.5 * L.face_width[1]);
  const double width = (zhi - zlo) / S;
  std::vector<ContactSlice> slices(static_cast<std::size_t>(S));
  for (int s = 0; s < S; ++s) {
    ContactSlice& c = slices[static_cast<std::size_t>(s)];
    c.flank = 1;
    c.slice = s;
    c.roll[0] = rho[0];
    c.roll[1] = rho[1];
    c.point.z() = zlo + (s + 0.5) * width;
    c.width = width;
  }
  const double uz[2] = {0, 0};
  Eigen::MatrixXd C(S, S);
  for (int a = 0; a < S; ++a)
    for (int b = 0; b <= a; ++b)
      C(a, b) = C(b, a) = fe_pair_compliance(fe_view(m), slices[std::size_t(a)], slices[std::size_t(b)], uz);
  // the local law there (laws.hpp, build_level_laws: a flank contact, the databases' depth)
  LocalLaw law;
  const double cb = L.cos_beta_b;
  law.width = width / cb;
  law.reduced_radius = 1 / (cb / rho[0] + L.sign * cb / rho[1]);
  for (int g = 0; g < 2; ++g) {
    law.body[g].youngs_modulus = m.params.gear[g].youngs_modulus;
    law.body[g].poisson_ratio = m.params.gear[g].poisson_ratio;
    law.body[g].depth = m.compliance[g].depth;
  }
  const LocalLawKernel kern = local_law_kernel(law);
  constexpr int kMax = FaceBasis::kMaxShapes;
  std::vector<double> phi(static_cast<std::size_t>(S) * kMax, 0.0);
  Eigen::LLT<Eigen::MatrixXd> llt;
  for (int k = 0; k < std::min(K, kMax); ++k) {
    const FaceShape shape = face_shape(k, K);
    if (k == 0 || shape.line_load != face_shape(k - 1, K).line_load) {
      Eigen::MatrixXd A = C;
      A.diagonal().array() += shape_slope(kern, shape.line_load);
      llt.compute(A);
      if (llt.info() != Eigen::Success) return {};
    }
    Eigen::VectorXd p(S);
    for (int s = 0; s < S; ++s) {
      // Legendre polynomial P_j(x) of the slice's position x in [-1, 1]:
      // (j + 1) P_{j+1} = (2j + 1) x P_j - j P_{j-1}
      const double x = S > 1 ? (s - 0.5 * (S - 1)) / (0.5 * (S - 1)) : 0.0;
      double p0 = 1, p1 = x;
      for (int j = 1; j < shape.degree; ++j) {
        const double p2 = ((2 * j + 1) * x * p1 - j * p0) / (j + 1);
        p0 = p1;
        p1 = p2;
      }
      p[s] = shape.degree == 0 ? 1.0 : p1;
    }
    const Eigen::VectorXd v = llt.solve(p);
    const double mx = v.cwiseAbs().maxCoeff();
    if (!(mx > 0) || !std::isfinite(mx)) return {};
    for (int s = 0; s < S; ++s) phi[std::size_t(s) * kMax + std::size_t(k)] = v[s] / mx;
  }
  return phi;
}

}  // namespace gm
