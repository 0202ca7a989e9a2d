// Level 4's low-rank coupled force solve (coupled_forces.hpp).
#include "coupled_forces.hpp"

#include <algorithm>
#include <cmath>

namespace gm {
namespace {

// Solve A x = b in place (A r x r row-major, destroyed; b becomes x), partial pivoting.
// false when A is singular.
bool dense_solve(double* A, double* b, int r) {
  for (int k = 0; k < r; ++k) {
    int p = k;
    for (int i = k + 1; i < r; ++i)
      if (std::fabs(A[i * r + k]) > std::fabs(A[p * r + k])) p = i;
    if (!(std::fabs(A[p * r + k]) > 0)) return false;
    if (p != k) {
      for (int j = 0; j < r; ++j) std::swap(A[k * r + j], A[p * r + j]);
      std::swap(b[k], b[p]);
    }
    const double inv = 1 / A[k * r + k];
    for (int i = k + 1; i < r; ++i) {
      const double f = A[i * r + k] * inv;
      if (f == 0) continue;
      for (int j = k + 1; j < r; ++j) A[i * r + j] -= f * A[k * r + j];
      b[i] -= f * b[k];
    }
  }
  for (int k = r - 1; k >= 0; --k) {
    double s = b[k];
    for (int j = k + 1; j < r; ++j) s -= A[k * r + j] * b[j];
    b[k] = s / A[k * r + k];
  }
  return true;
}

// Column of gear g, pair P, component k (0: the force, 1: its height moment).
inline int col(int g, int P, int k, int pairs) { return (g * pairs + P) * 2 + k; }

// Solve J x = b (J r x r row-major, b becomes x) where the rows of the pairs without a loaded
// slice (loaded[p] false) are those of the identity: x = b there, and the rest is the reduced
// system over the loaded pairs' columns. Jr: scratch of r x r, idx of r. false if singular.
bool solve_loaded(const double* J, double* b, int r, int pairs, const bool* loaded, double* Jr,
                  int* idx) {
  int ra = 0;
  for (int q = 0; q < 2; ++q)
    for (int p = 0; p < pairs; ++p)
      if (loaded[p])
        for (int k = 0; k < 2; ++k) idx[ra++] = col(q, p, k, pairs);
  if (ra == 0) return true;
  double* rhs = Jr + ra * ra;  // after the reduced matrix (Jr holds r (r + 1))
  for (int a = 0; a < ra; ++a) {
    double s = b[idx[a]];
    for (int j = 0; j < r; ++j)  // inactive unknowns are already b_j
      if (!loaded[(j / 2) % pairs]) s -= J[idx[a] * r + j] * b[j];
    rhs[a] = s;
    for (int c = 0; c < ra; ++c) Jr[a * ra + c] = J[idx[a] * r + idx[c]];
  }
  if (!dense_solve(Jr, rhs, ra)) return false;
  for (int a = 0; a < ra; ++a) b[idx[a]] = rhs[a];
  return true;
}

}  // namespace

void CoupledWorkspace::reserve(int capacity) {
  const int r = 4 * kMaxPairs;
  group.assign(std::size_t(capacity), 0);
  height.assign(2 * std::size_t(capacity), 0.0);
  original.assign(std::size_t(capacity), 0.0);
  B.assign(std::size_t(r) * r, 0.0);
  J.assign(std::size_t(r) * r, 0.0);
  Jr.assign(std::size_t(r) * (r + 1), 0.0);
  index.assign(std::size_t(r), 0);
  for (auto* x : {&m, &v, &G, &a, &c, &y}) x->assign(std::size_t(r), 0.0);
}

CoupledSolveResult solve_coupled(const ToothCoupling& coupling, const SliceLaw* laws,
                                 ContactSlice* slices, const double* balance, int n, bool quasi,
                                 double load, double lambda_start, double tol, int max_iterations,
                                 double* approach, double* force, double* stiffness,
                                 CoupledWorkspace& w) {
  CoupledSolveResult out;
  // the tooth pairs (groups) and each candidate's heights
  int P = 0;
  for (int i = 0; i < n; ++i) {
    const ContactSlice& s = slices[i];
    w.original[i] = quasi ? s.approach : approach[i];
    // plain mode: a slice handed in open stays open (no law is built for it; the coupling only
    // opens slices further): not part of the solve
    w.group[i] = -1;
    if (!quasi && !(w.original[i] > 0)) continue;
    int g = 0;
    while (g < P && !(w.pair_key[g][0] == s.tooth[0] && w.pair_key[g][1] == s.tooth[1] &&
                      w.pair_key[g][2] == s.flank))
      ++g;
    if (g == P) {
      if (P == CoupledWorkspace::kMaxPairs) {
        out.fallback = true;
        out.solve.converged = false;
        return out;
      }
      w.pair_key[P][0] = s.tooth[0];
      w.pair_key[P][1] = s.tooth[1];
      w.pair_key[P][2] = s.flank;
      ++P;
    }
    w.group[i] = g;
    for (int q = 0; q < 2; ++q) w.height[2 * i + q] = coupling_height(coupling.gear[q], s.roll[q]);
  }
  const int r = 4 * P;
  double* B = w.B.data();
  std::fill(B, B + r * r, 0.0);
  for (int q = 0; q < 2; ++q) {
    const ToothCouplingGear& cg = coupling.gear[q];
    for (int p1 = 0; p1 < P; ++p1) {
      for (int p2 = 0; p2 < P; ++p2) {
        if (p1 == p2 || w.pair_key[p1][2] != w.pair_key[p2][2]) continue;
        const int d = coupling_table_offset(coupling, q, w.pair_key[p1][2], w.pair_key[p1][q],
                                            w.pair_key[p2][q]);
        if (d == 0) continue;
        const double* k = cg.k.c[std::abs(d) - 1];
        // receiver row [1, h_a] against load moments [M0, M1]: d > 0 [[c00 c01][c10 c11]] in
        // the table's (h_a, h_b) order, d < 0 its transpose (tooth_coupling.hpp)
        const double A00 = k[0], A01 = d > 0 ? k[2] : k[1], A10 = d > 0 ? k[1] : k[2], A11 = k[3];
        const int i0 = col(q, p1, 0, P), j0 = col(q, p2, 0, P);
        B[i0 * r + j0] = cg.scale * A00;
        B[i0 * r + j0 + 1] = cg.scale * A01;
        B[(i0 + 1) * r + j0] = cg.scale * A10;
        B[(i0 + 1) * r + j0 + 1] = cg.scale * A11;
      }
    }
  }
  double scale = 0;
  for (int i = 0; i < n; ++i) scale = std::max(scale, std::fabs(w.original[i]));
  const double tol_outer = std::min(tol, 1e-15 + 1e-10 * scale);
  double* m = w.m.data();
  double* v = w.v.data();
  double* G = w.G.data();
  std::fill(m, m + r, 0.0);
  double lambda = lambda_start;

  // the separable solve at the approaches Delta - Phi B m (v = B m on entry)
  const auto inner = [&]() -> bool {
    for (int i = 0; i < n; ++i) {
      const int g = w.group[i];
      double u = 0;
      for (int q = 0; q < 2 && g >= 0; ++q)
        u += v[col(q, g, 0, P)] + w.height[2 * i + q] * v[col(q, g, 1, P)];
      const double shifted = w.original[i] - u;
      if (quasi) slices[i].approach = shifted; else approach[i] = shifted;
    }
    ForceSolve s;
    if (quasi) {
      s = solve_separable_total(laws, slices, balance, n, load, lambda, tol, max_iterations,
                                approach, force, stiffness);
      lambda = s.lambda;
    } else {
      s = solve_separable(laws, approach, n, tol, max_iterations, force, stiffness);
    }
    out.solve.iterations += s.iterations;
    out.solve.residual = std::max(out.solve.residual, s.residual);
    if (!s.converged) out.solve.message = s.message;
    return s.converged;
  };
  const auto restore = [&]() {
    for (int i = 0; i < n; ++i) {
      if (quasi) {
        slices[i].approach = w.original[i];
        approach[i] = w.original[i] + slices[i].te_gain * lambda;
      } else {
        approach[i] = w.original[i];
      }
    }
  };
  // v = B x for an r-vector x
  const auto apply_B = [&](const double* x, double* to) {
    for (int i = 0; i < r; ++i) {
      double s = 0;
      for (int j = 0; j < r; ++j) s += B[i * r + j] * x[j];
      to[i] = s;
    }
  };
  // J = I + (Phi^T K Phi) B, Phi^T K Phi block diagonal by pair (4 x 4 over gear, component)
  const auto tangent = [&](double* J) {
    std::fill(J, J + r * r, 0.0);
    for (int p = 0; p < P; ++p) {
      double blk[4][4] = {};
      for (int i = 0; i < n; ++i) {
        if (w.group[i] != p || !(stiffness[i] > 0)) continue;
        const double phi[4] = {1, w.height[2 * i], 1, w.height[2 * i + 1]};
        for (int a = 0; a < 4; ++a)
          for (int b = 0; b < 4; ++b) blk[a][b] += stiffness[i] * phi[a] * phi[b];
      }
      const int idx[4] = {col(0, p, 0, P), col(0, p, 1, P), col(1, p, 0, P), col(1, p, 1, P)};
      for (int a = 0; a < 4; ++a)
        for (int j = 0; j < r; ++j) {
          double s = 0;
          for (int b = 0; b < 4; ++b) s += blk[a][b] * B[idx[b] * r + j];
          J[idx[a] * r + j] = s;
        }
    }
    for (int i = 0; i < r; ++i) J[i * r + i] += 1;
  };
  // Phi^T x over the candidates into an r-vector
  const auto phi_t = [&](const double* x, double* to) {
    std::fill(to, to + r, 0.0);
    for (int i = 0; i < n; ++i) {
      const int g = w.group[i];
      if (x[i] == 0 || g < 0) continue;
      for (int q = 0; q < 2; ++q) {
        to[col(q, g, 0, P)] += x[i];
        to[col(q, g, 1, P)] += w.height[2 * i + q] * x[i];
      }
    }
  };

  const auto mark_loaded = [&]() {
    for (int p = 0; p < P; ++p) w.loaded[p] = false;
    for (int i = 0; i < n; ++i)
      if (w.group[i] >= 0 && stiffness[i] > 0) w.loaded[w.group[i]] = true;
  };
  std::fill(v, v + r, 0.0);
  if (!inner()) {
    restore();
    out.solve.converged = false;
    return out;
  }
  bool converged = false;
  int extra = 0;
  for (int it = 0; it < max_iterations; ++it) {
    // G = m - Phi^T F, and the gap residual Phi B G
    phi_t(force, G);
    for (int j = 0; j < r; ++j) G[j] = m[j] - G[j];
    apply_B(G, w.a.data());
    double res = 0;
    for (int i = 0; i < n; ++i) {
      const int g = w.group[i];
      if (g < 0) continue;
      double e = 0;
      for (int q = 0; q < 2; ++q)
        e += w.a[col(q, g, 0, P)] + w.height[2 * i + q] * w.a[col(q, g, 1, P)];
      res = std::max(res, std::fabs(e));
    }
    if (res <= tol_outer) {
      // one more step when it is cheap to reach rounding (quadratic convergence)
      if (res <= 1e-3 * tol_outer || extra++ > 0) {
        converged = true;
        break;
      }
    }
    // Newton step on m
    tangent(w.J.data());
    if (quasi) {
      // rank-one term of the balance: -(Phi^T K w)(b^T K Phi B)/(b^T K w)
      double s = 0;
      for (int i = 0; i < n; ++i) s += balance[i] * stiffness[i] * slices[i].te_gain;
      if (s != 0) {
        for (int i = 0; i < n; ++i) approach[i] = stiffness[i] * slices[i].te_gain;  // scratch
        phi_t(approach, w.c.data());                                              // Phi^T K w
        for (int i = 0; i < n; ++i) approach[i] = stiffness[i] * balance[i];
        phi_t(approach, w.y.data());                                              // Phi^T K b
        for (int j = 0; j < r; ++j) {  // (B^T Phi^T K b)_j = (b^T K Phi B)_j
          double t = 0;
          for (int i = 0; i < r; ++i) t += B[i * r + j] * w.y[i];
          for (int i = 0; i < r; ++i) w.J[i * r + j] -= w.c[i] * t / s;
        }
      }
    }
    for (int j = 0; j < r; ++j) G[j] = -G[j];
    mark_loaded();
    if (!solve_loaded(w.J.data(), G, r, P, w.loaded, w.Jr.data(), w.index.data())) break;
    for (int j = 0; j < r; ++j) m[j] += G[j];
    apply_B(m, v);
    if (!inner()) break;
    out.solve.iterations += 1;
  }
  restore();
  if (!converged) {
    out.fallback = true;
    out.solve.converged = false;
    return out;
  }
  // tangent stiffness of each slice: x = K (1 - Phi B y), J y = Phi^T K 1
  tangent(w.J.data());
  phi_t(stiffness, w.y.data());
  mark_loaded();
  if (solve_loaded(w.J.data(), w.y.data(), r, P, w.loaded, w.Jr.data(), w.index.data())) {
    apply_B(w.y.data(), w.a.data());
    for (int i = 0; i < n; ++i) {
      const int g = w.group[i];
      if (!(stiffness[i] > 0) || g < 0) continue;
      double e = 0;
      for (int q = 0; q < 2; ++q)
        e += w.a[col(q, g, 0, P)] + w.height[2 * i + q] * w.a[col(q, g, 1, P)];
      stiffness[i] *= 1 - e;
    }
  }
  out.solve.lambda = lambda;
  out.solve.converged = true;
  return out;
}

}  // namespace gm
