// Level 5's coupled solve on a reduced face basis (face_basis.hpp).
#include "face_basis.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>

namespace gm {

void FaceBasis::reserve(int capacity) {
  const int c = std::max(capacity, 1);
  cand_col.assign(c, -1);
  cand_dim.assign(c, 0);
  cand_phi.assign(std::size_t(c) * kMaxShapes, 0.0);
  pair_of.assign(c, -1);
  member.assign(c, 0);
  phi.assign(std::size_t(c) * kMaxShapes, 0.0);
  slice_of.assign(c, 0);
  // r: the columns one call can have
  const int r = std::min(c, kMaxPairs * kMaxShapes);
  CP.resize(c, r);
  PCP.resize(r, r);
  all_CP.resize(c, r);
  all_PCP.resize(r, r);
  A.resize(r, r);
  alpha.resize(r);
  step.resize(r);
  G.resize(r);
  x1.resize(r);
  x2.resize(r);
  F.resize(c);
  trial.resize(c);
  inv_norm.resize(r);
  Phi.resize(c, r);
  v.resize(c);
  kern.resize(c);
  jet.resize(c);
}

namespace {

// Calls f(std::integral_constant<int, D>{}) with D = d (1 .. kMaxShapes): the per-pair loops
// with the pair's shape count a constant, so that they unroll.
template <int D = 1, class F>
void with_dim(int d, F&& f) {
  if constexpr (D == FaceBasis::kMaxShapes) {
    f(std::integral_constant<int, D>{});
  } else {
    if (d == D) return f(std::integral_constant<int, D>{});
    with_dim<D + 1>(d, f);
  }
}

// In-place Cholesky of the leading r x r block of A (lower triangle, leading dimension ld); false
// if not positive definite. R > 0: r = R, a constant (the loops unroll; the same operations in
// the same order).
template <int R>
bool cholesky_block(double* A, int ld, int r) {
  if constexpr (R > 0) r = R;
  // column by column (left-looking), every inner loop down a column
  for (int j = 0; j < r; ++j) {
    double* aj = A + std::size_t(j) * ld;
    for (int k = 0; k < j; ++k) {
      const double* ak = A + std::size_t(k) * ld;
      const double f = ak[j];
      for (int i = j; i < r; ++i) aj[i] -= ak[i] * f;
    }
    if (!(aj[j] > 0)) return false;
    const double d = std::sqrt(aj[j]), inv = 1.0 / d;
    aj[j] = d;
    for (int i = j + 1; i < r; ++i) aj[i] *= inv;
  }
  return true;
}

// x := (L L^T)^-1 x on the factor of cholesky_block.
template <int R>
void cholesky_solve_block(const double* L, int ld, int r, double* x) {
  if constexpr (R > 0) r = R;
  for (int k = 0; k < r; ++k) {
    const double* lk = L + std::size_t(k) * ld;
    const double xk = x[k] / lk[k];
    x[k] = xk;
    for (int i = k + 1; i < r; ++i) x[i] -= lk[i] * xk;
  }
  for (int i = r - 1; i >= 0; --i) {
    const double* li = L + std::size_t(i) * ld;
    double s = x[i];
    for (int k = i + 1; k < r; ++k) s -= li[k] * x[k];
    x[i] = s / li[i];
  }
}

// f(std::integral_constant<int, R>{}) with R = r for the orders up to 12 (two or three aligned
// spur pairs of up to four shapes), R = 0 (the general loops) beyond.
template <int R = 1, class F>
auto with_order(int r, F&& f) {
  if constexpr (R > 12) {
    return f(std::integral_constant<int, 0>{});
  } else {
    if (r == R) return f(std::integral_constant<int, R>{});
    return with_order<R + 1>(r, f);
  }
}

bool cholesky(Eigen::MatrixXd& A, int r) {
  return with_order(r, [&](auto R) { return cholesky_block<R()>(A.data(), int(A.rows()), r); });
}

void cholesky_solve(const Eigen::MatrixXd& L, int r, double* x) {
  with_order(r, [&](auto R) { cholesky_solve_block<R()>(L.data(), int(L.rows()), r, x); });
}

}  // namespace

bool group_face_pairs(FaceBasis& w, const FaceProblem& p) {
  w.pairs = 0;
  if (p.n == 0 || p.shapes <= 0 || !p.shape_table) return false;
  for (int a = 0; a < p.n; ++a) {
    const ContactSlice& s = p.slices[p.index[a]];
    int q = 0;
    while (q < w.pairs && !(w.key[q][0] == s.tooth[0] && w.key[q][1] == s.tooth[1] && w.key[q][2] == s.flank)) ++q;
    if (q == w.pairs) {
      if (w.pairs == FaceBasis::kMaxPairs) return false;
      w.key[q][0] = s.tooth[0];
      w.key[q][1] = s.tooth[1];
      w.key[q][2] = s.flank;
      w.key[q][3] = s.slice;
      w.count[q] = 0;
      ++w.pairs;
    }
    w.pair_of[a] = q;
    ++w.count[q];
  }
  int at = 0;
  for (int q = 0; q < w.pairs; ++q) {
    w.first[q] = at;
    at += w.count[q];
    w.count[q] = 0;
  }
  for (int a = 0; a < p.n; ++a) {
    const int q = w.pair_of[a];
    w.member[w.first[q] + w.count[q]++] = a;
  }
  for (int q = 0; q < w.pairs; ++q) {
    int lo = 1 << 30, hi = -(1 << 30);
    for (int m = w.first[q]; m < w.first[q] + w.count[q]; ++m) {
      const int s = p.slices[p.index[w.member[m]]].slice;
      lo = std::min(lo, s);
      hi = std::max(hi, s);
    }
    w.key[q][3] = lo;
    w.dim[q] = std::min(p.shapes, w.count[q]);
    for (int m = w.first[q]; m < w.first[q] + w.count[q]; ++m) {
      const int s = p.slices[p.index[w.member[m]]].slice;
      w.slice_of[m] = s;
      const double* shape = p.shape_table + std::size_t(s) * FaceBasis::kMaxShapes;
      std::copy(shape, shape + w.dim[q], &w.phi[std::size_t(m) * FaceBasis::kMaxShapes]);
    }
  }
  return true;
}

namespace {

// Columns of the active pairs; C Phi and Phi^T C Phi over them. The number of columns.
int build_projection(FaceBasis& w, const FaceProblem& p) {
  int r = 0;
  for (int q = 0; q < w.pairs; ++q) {
    w.col[q] = r;
    if (w.active[q]) r += w.dim[q];
  }
  const int n = p.n;
  if (p.all_CP) {  // the projections as FeAssembly made them: the active pairs' columns
    const int K = p.shapes;
    for (int q = 0; q < w.pairs; ++q) {
      if (!w.active[q]) continue;
      for (int k = 0; k < w.dim[q]; ++k) {
        w.CP.col(w.col[q] + k).head(n) = p.all_CP->col(q * K + k).head(n);
        for (int e = 0; e < w.pairs; ++e) {
          if (!w.active[e]) continue;
          for (int l = 0; l < w.dim[e]; ++l) w.PCP(w.col[q] + k, w.col[e] + l) = (*p.all_PCP)(q * K + k, e * K + l);
        }
      }
    }
    return r;
  }
  w.CP.topLeftCorner(n, r).setZero();
  for (int q = 0; q < w.pairs; ++q) {
    if (!w.active[q]) continue;
    for (int m = w.first[q]; m < w.first[q] + w.count[q]; ++m) {
      const int b = w.member[m];
      const double* cb = p.C + std::size_t(b) * p.ld;
      const double* ph = &w.phi[std::size_t(m) * FaceBasis::kMaxShapes];
      for (int k = 0; k < w.dim[q]; ++k) {
        double* out = &w.CP(0, w.col[q] + k);
        const double f = ph[k];
        for (int a = 0; a < n; ++a) out[a] += f * cb[a];
      }
    }
  }
  for (int q = 0; q < w.pairs; ++q) {
    if (!w.active[q]) continue;
    for (int k = 0; k < w.dim[q]; ++k)
      for (int c = 0; c < r; ++c) {
        double s = 0;
        for (int m = w.first[q]; m < w.first[q] + w.count[q]; ++m)
          s += w.phi[std::size_t(m) * FaceBasis::kMaxShapes + k] * w.CP(w.member[m], c);
        w.PCP(w.col[q] + k, c) = s;
      }
  }
  // symmetric in exact arithmetic: mirror the lower triangle
  for (int c = 0; c < r; ++c)
    for (int e = c + 1; e < r; ++e) w.PCP(c, e) = w.PCP(e, c);
  return r;
}

// F_a = (Phi alpha)_a on the active pairs' slices (0 elsewhere), from alpha (or alpha + s step).
// false: a slice of an active pair is not positive.
bool forces_of(FaceBasis& w, const FaceProblem& p, const Eigen::VectorXd& alpha, const Eigen::VectorXd* step,
               double s, Eigen::VectorXd& F) {
  for (int a = 0; a < p.n; ++a) F[a] = 0;
  bool positive = true;
  for (int q = 0; q < w.pairs && positive; ++q) {
    if (!w.active[q]) continue;
    double coef[FaceBasis::kMaxShapes];
    for (int k = 0; k < w.dim[q]; ++k) {
      const int c = w.col[q] + k;
      coef[k] = step ? alpha[c] + s * (*step)[c] : alpha[c];
    }
    with_dim(w.dim[q], [&](auto D) {
      for (int m = w.first[q]; m < w.first[q] + w.count[q]; ++m) {
        const double* ph = &w.phi[std::size_t(m) * FaceBasis::kMaxShapes];
        double f = 0;
        for (int k = 0; k < D(); ++k) f += ph[k] * coef[k];
        if (!(f > 0)) {
          positive = false;
          return;
        }
        F[w.member[m]] = f;
      }
    });
  }
  return positive;
}

// The Newton matrix Phi^T (C + diag f') Phi at the jets in w.jet into w.A (factorized), the
// diagonal part from the shapes' products per slice (p.shape_products).
bool newton_matrix(FaceBasis& w, const FaceProblem& p, int r) {
  for (int c = 0; c < r; ++c)
    for (int e = c; e < r; ++e) w.A(e, c) = w.PCP(e, c);
  for (int q = 0; q < w.pairs; ++q) {
    if (!w.active[q]) continue;
    const int c0 = w.col[q];
    with_dim(w.dim[q], [&](auto D) {
      constexpr int nkl = D() * (D() + 1) / 2;
      double acc[nkl] = {};
      for (int m = w.first[q]; m < w.first[q] + w.count[q]; ++m) {
        const double* o = p.shape_products + std::size_t(w.slice_of[m]) * FaceBasis::kOuter;
        const double fp = w.jet[w.member[m]].slope;
        for (int kl = 0; kl < nkl; ++kl) acc[kl] += fp * o[kl];
      }
      for (int k = 0, kl = 0; k < D(); ++k)
        for (int l = 0; l <= k; ++l) w.A(c0 + k, c0 + l) += acc[kl++];
    });
  }
  return cholesky(w.A, r);
}

// Phi^T v over the active pairs into out (r).
void project(const FaceBasis& w, const double* v, double* out) {
  for (int q = 0; q < w.pairs; ++q) {
    if (!w.active[q]) continue;
    with_dim(w.dim[q], [&](auto D) {
      double s[D()] = {};
      for (int m = w.first[q]; m < w.first[q] + w.count[q]; ++m) {
        const double* ph = &w.phi[std::size_t(m) * FaceBasis::kMaxShapes];
        const double x = v[w.member[m]];
        for (int k = 0; k < D(); ++k) s[k] += ph[k] * x;
      }
      for (int k = 0; k < D(); ++k) out[w.col[q] + k] = s[k];
    });
  }
}

// Quasi-static, the load balance's border on the factorized A (w.A), with w.x1 = A^-1 Phi^T v
// given: w.x2 := A^-1 Phi^T w (w the TE gains), w.G := Phi^T b (b the balance weights), and the
// balance row's products u1 = G . x1, u2 = G . x2. false: u2 = 0 (the border is singular).
bool balance_row(FaceBasis& w, const FaceProblem& p, int r, double& u1, double& u2) {
  project(w, p.gain, w.x2.data());
  cholesky_solve(w.A, r, w.x2.data());
  for (int a = 0; a < p.n; ++a) w.trial[a] = p.balance[p.index[a]];
  project(w, w.trial.data(), w.G.data());
  u1 = w.G.head(r).dot(w.x1.head(r));
  u2 = w.G.head(r).dot(w.x2.head(r));
  return u2 != 0;
}

}  // namespace

bool face_basis_may_hold(FaceBasis& w, const FaceProblem& p) {
  const int tilts = p.shapes - kUniformShapes;  // Legendre degrees beyond the uniform approach
  if (tilts >= 2) return true;
  for (int q = 0; q < w.pairs; ++q) {
    const int f0 = w.first[q], np = w.count[q];
    double top = 0, mean = 0, sx = 0, sxx = 0, sxd = 0;
    int lo = 1 << 30, hi = -(1 << 30);
    for (int m = f0; m < f0 + np; ++m) {
      const int s = p.slices[p.index[w.member[m]]].slice;
      lo = std::min(lo, s);
      hi = std::max(hi, s);
    }
    const double mid = 0.5 * (lo + hi);
    for (int m = f0; m < f0 + np; ++m) {
      const double dlt = p.delta[w.member[m]], x = p.slices[p.index[w.member[m]]].slice - mid;
      top = std::max(top, dlt);
      mean += dlt / np;
      sx += x;
      sxx += x * x;
      sxd += x * dlt;
    }
    if (!(top > 0)) continue;  // quasi-static far from the load's approach: the solve decides
    // the approaches less their mean, and with a tilt their least-squares line
    const double slope = tilts == 1 && sxx > 0 ? (sxd - sx * mean) / sxx : 0.0;
    for (int m = f0; m < f0 + np; ++m) {
      const double x = p.slices[p.index[w.member[m]]].slice - mid;
      if (std::fabs(p.delta[w.member[m]] - mean - slope * x) > p.slice_tolerance * top) return false;
    }
  }
  return true;
}

bool face_cholesky(Eigen::MatrixXd& A, int r) { return cholesky(A, r); }
void face_cholesky_solve(const Eigen::MatrixXd& L, int r, double* x) { cholesky_solve(L, r, x); }

FaceAnswer solve_face_basis(FaceBasis& w, const FaceProblem& p, double* force, double* stiffness) {
  FaceAnswer out;
  w.used = false;
  const int n = p.n;
  if (n == 0 || w.pairs == 0 || !p.shape_products) return out;
  if (p.all_CP) {  // FeAssembly's pairs, each a whole face: the same pairs in the same order
    if (w.pairs != p.groups) return out;
    for (int q = 0; q < w.pairs; ++q)
      if (w.count[q] != n / p.groups || w.member[w.first[q]] != q * (n / p.groups)) return out;
  }
  // the laws prepared once per distinct law (an aligned spur pair's slices share theirs)
  for (int a = 0; a < n; ++a)
    w.kern[a] = a > 0 && same_local_law(p.laws[a], p.laws[a - 1]) ? w.kern[a - 1] : local_law_kernel(p.laws[a]);
  // gap offsets: Delta_a (+ lambda w_a)
  const double* delta = p.delta;
  // the active pairs at first: those with a closed slice (plain: every solved slice is), else
  // the one closest to closing
  int closest = -1;
  double most = -std::numeric_limits<double>::infinity();
  for (int q = 0; q < w.pairs; ++q) {
    w.active[q] = false;
    for (int m = w.first[q]; m < w.first[q] + w.count[q]; ++m) {
      const int a = w.member[m];
      if (p.quasi && !(p.gain[a] * p.load > 0)) continue;
      if (delta[a] > 0) w.active[q] = true;
      if (delta[a] > most) {
        most = delta[a];
        closest = q;
      }
    }
  }
  bool any = false;
  for (int q = 0; q < w.pairs; ++q) any = any || w.active[q];
  if (!any) {
    if (closest < 0) return out;
    w.active[closest] = true;
  }
  if (p.quasi && p.load == 0) return out;  // the touch position: the full solve's own path
  double lambda = 0;
  Eigen::VectorXd& alpha = w.alpha;
  Eigen::VectorXd& F = w.F;
  for (int round = 0; round < 3; ++round) {
    const int r = build_projection(w, p);
    for (int q = 0; q < w.pairs; ++q) {  // 1 / sum_a |phi_ak|: a column's residual as a mean gap
      if (!w.active[q]) continue;
      for (int k = 0; k < w.dim[q]; ++k) {
        double norm = 0;
        for (int m = w.first[q]; m < w.first[q] + w.count[q]; ++m)
          norm += std::fabs(w.phi[std::size_t(m) * FaceBasis::kMaxShapes + k]);
        w.inv_norm[w.col[q] + k] = 1.0 / norm;
      }
    }
    // start: the last answer's shapes where every active pair has them, else the solve without
    // the local laws (quasi: with the load balance)
    bool warm = true;
    for (int q = 0; q < w.pairs && warm; ++q) {
      if (!w.active[q]) continue;
      int j = 0;
      while (j < w.warm.pairs && !(w.warm.key[j][0] == w.key[q][0] && w.warm.key[j][1] == w.key[q][1] &&
                                   w.warm.key[j][2] == w.key[q][2] && w.warm.key[j][3] == w.key[q][3] &&
                                   w.warm.key[j][4] == w.count[q]))
        ++j;
      if (j == w.warm.pairs) {
        warm = false;
        break;
      }
      for (int k = 0; k < w.dim[q]; ++k) alpha[w.col[q] + k] = w.warm.alpha[j][k];
    }
    if (round > 0 || !warm || !forces_of(w, p, alpha, nullptr, 0, F)) {
      w.A.topLeftCorner(r, r) = w.PCP.topLeftCorner(r, r);
      if (!cholesky(w.A, r)) return out;
      if (!p.quasi) {
        project(w, delta, alpha.data());
        cholesky_solve(w.A, r, alpha.data());
        alpha.head(r) *= 0.7;  // the local laws take part of the approach
      } else {
        for (int a = 0; a < n; ++a) w.trial[a] = -delta[a];
        project(w, w.trial.data(), w.x1.data());
        cholesky_solve(w.A, r, w.x1.data());
        double u1, u2;
        if (!balance_row(w, p, r, u1, u2)) return out;
        // alpha = x2 lambda - x1 with b^T Phi alpha = load
        lambda = (p.load + u1) / u2;
        alpha.head(r) = lambda * w.x2.head(r) - w.x1.head(r);
      }
      if (!forces_of(w, p, alpha, nullptr, 0, F)) {
        // a pair's linear answer is not positive throughout: start from its mean load alone
        for (int q = 0; q < w.pairs; ++q) {
          if (!w.active[q]) continue;
          const int c0 = w.col[q];
          for (int k = 1; k < w.dim[q]; ++k) alpha[c0 + k] = 0;
          if (!(alpha[c0] > 0)) return out;
        }
        if (!forces_of(w, p, alpha, nullptr, 0, F)) return out;
      }
    }
    // Newton on alpha (quasi: and lambda)
    bool converged = false;
    int it = 0;
    double res = 0;
    for (;; ++it) {
      for (int q = 0; q < w.pairs; ++q) {
        if (!w.active[q]) continue;
        for (int m = w.first[q]; m < w.first[q] + w.count[q]; ++m) {
          const int a = w.member[m];
          w.jet[a] = local_law_slope(w.kern[a], F[a]);
        }
      }
      // gaps of the active slices, g = C Phi alpha + f - Delta - lambda w, into trial
      // (column by column over every solved slice: the same sums in the same order per slice)
      for (int a = 0; a < n; ++a) w.trial[a] = 0;
      for (int q = 0; q < w.pairs; ++q) {
        if (!w.active[q]) continue;
        for (int m = w.first[q]; m < w.first[q] + w.count[q]; ++m) {
          const int a = w.member[m];
          w.trial[a] = w.jet[a].approach - delta[a] - (p.quasi ? lambda * p.gain[a] : 0.0);
        }
      }
      for (int c = 0; c < r; ++c) {
        const double* cp = &w.CP(0, c);
        const double x = alpha[c];
        for (int a = 0; a < n; ++a) w.trial[a] += cp[a] * x;
      }
      project(w, w.trial.data(), w.G.data());
      res = 0;
      for (int q = 0; q < w.pairs; ++q) {
        if (!w.active[q]) continue;
        for (int k = 0; k < w.dim[q]; ++k) {
          res = std::max(res, std::fabs(w.G[w.col[q] + k]) * w.inv_norm[w.col[q] + k]);
        }
      }
      double h = 0;
      if (p.quasi) {
        for (int a = 0; a < n; ++a) h += p.balance[p.index[a]] * F[a];
        h -= p.load;
      }
      if (res <= p.tolerance && std::fabs(h) <= 1e-12 * std::fabs(p.load)) {
        converged = true;
        break;
      }
      if (it >= p.max_iterations) break;
      if (!newton_matrix(w, p, r)) return out;
      for (int c = 0; c < r; ++c) w.step[c] = -w.G[c];
      cholesky_solve(w.A, r, w.step.data());
      double dlambda = 0;
      if (p.quasi) {
        for (int c = 0; c < r; ++c) w.x1[c] = w.G[c];
        cholesky_solve(w.A, r, w.x1.data());
        double u1, u2;
        if (!balance_row(w, p, r, u1, u2)) return out;
        dlambda = (u1 - h) / u2;
        w.step.head(r) = dlambda * w.x2.head(r) - w.x1.head(r);
      }
      // the step, shortened while a loaded slice would unload
      double s = 1;
      int cuts = 0;
      while (!forces_of(w, p, alpha, &w.step, s, w.trial)) {
        if (++cuts > 4) return out;  // a slice unloads: the slices decide
        s *= 0.5;
      }
      alpha.head(r) += s * w.step.head(r);
      lambda += s * dlambda;
      F.head(n) = w.trial.head(n);
    }
    out.iterations += it;
    if (!converged) return out;
    out.residual = res;
    // the basis must hold the answer slice by slice: every loaded slice's own gap (the error
    // the projection leaves, which the slices' forces would remove) within slice_tolerance of
    // the approach it closes
    double worst = 0, closing = 0;
    for (int q = 0; q < w.pairs; ++q) {
      if (!w.active[q]) continue;
      for (int m = w.first[q]; m < w.first[q] + w.count[q]; ++m) {
        const int a = w.member[m];
        worst = std::max(worst, std::fabs(w.trial[a]));
        closing = std::max(closing, delta[a] + (p.quasi ? lambda * p.gain[a] : 0.0));
      }
    }
    out.slice_gap = closing > 0 ? worst / closing : 1.0;
    if (!(worst <= p.slice_tolerance * closing)) return out;
    // the other pairs' slices must stay open: gap = (C Phi alpha)_a - Delta_a - lambda w_a >= 0
    bool closes = false;
    for (int q = 0; q < w.pairs; ++q) {
      if (w.active[q]) continue;
      for (int m = w.first[q]; m < w.first[q] + w.count[q]; ++m) {
        const int a = w.member[m];
        double g = -delta[a] - (p.quasi ? lambda * p.gain[a] : 0.0);
        for (int c = 0; c < r; ++c) g += w.CP(a, c) * alpha[c];
        if (g < -p.tolerance) {
          w.active[q] = true;
          closes = true;
          break;
        }
      }
    }
    if (closes) continue;
    // accepted: forces, energy, tangent, the basis for the derivative and the warm start
    double energy = 0;
    for (int a = 0; a < n; ++a) {
      force[a] = F[a];
      if (!(F[a] > 0)) continue;
      // the sweeps' jets carry no energy at a tip corner (local_law_slope): its full jet here
      const double P = w.kern[a].corner_stiffness > 0 ? local_law_jet(w.kern[a], F[a]).energy : w.jet[a].energy;
      energy += 0.5 * F[a] * (delta[a] + (p.quasi ? lambda * p.gain[a] : 0.0) + w.jet[a].approach) - P;
    }
    if (p.tangent && stiffness) {
      if (!newton_matrix(w, p, r)) return out;
      for (int q = 0; q < w.pairs; ++q) {
        if (!w.active[q]) continue;
        for (int k = 0; k < w.dim[q]; ++k) {
          double s = 0;
          for (int m = w.first[q]; m < w.first[q] + w.count[q]; ++m)
            s += w.phi[std::size_t(m) * FaceBasis::kMaxShapes + k];
          w.x1[w.col[q] + k] = s;
        }
      }
      cholesky_solve(w.A, r, w.x1.data());
      for (int a = 0; a < n; ++a) stiffness[a] = 0;
      for (int q = 0; q < w.pairs; ++q) {
        if (!w.active[q]) continue;
        for (int m = w.first[q]; m < w.first[q] + w.count[q]; ++m) {
          const double* ph = &w.phi[std::size_t(m) * FaceBasis::kMaxShapes];
          double s = 0;
          for (int k = 0; k < w.dim[q]; ++k) s += ph[k] * w.x1[w.col[q] + k];
          stiffness[w.member[m]] = s;
        }
      }
    }
    w.warm.pairs = 0;
    for (int q = 0; q < w.pairs; ++q) {
      if (!w.active[q]) continue;
      const int j = w.warm.pairs++;
      for (int e = 0; e < 4; ++e) w.warm.key[j][e] = w.key[q][e];
      w.warm.key[j][4] = w.count[q];
      for (int k = 0; k < w.dim[q]; ++k) w.warm.alpha[j][k] = alpha[w.col[q] + k];
      for (int m = w.first[q]; m < w.first[q] + w.count[q]; ++m) {
        const int i = p.index[w.member[m]];
        w.cand_col[i] = w.col[q];
        w.cand_dim[i] = w.dim[q];
        const double* ph = &w.phi[std::size_t(m) * FaceBasis::kMaxShapes];
        for (int k = 0; k < w.dim[q]; ++k) w.cand_phi[std::size_t(i) * FaceBasis::kMaxShapes + k] = ph[k];
      }
    }
    w.columns = r;
    w.shapes = p.shapes;
    w.used = true;
    out.accepted = true;
    out.lambda = lambda;
    out.energy = energy;
    return out;
  }
  return out;
}

}  // namespace gm
