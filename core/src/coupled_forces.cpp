// Level 4's low-rank coupled force solve (coupled_forces.hpp).
#include "coupled_forces.hpp"

#include <algorithm>
#include <cmath>

#include "model.hpp"

namespace gm {
namespace {

using W = CoupledWorkspace;

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

// The pair of candidate s (a new one when unseen); -1 when the workspace holds no more pairs.
int pair_of(W& w, int& pairs, const ContactSlice& s) {
  for (int g = 0; g < pairs; ++g)
    if (w.pair_key[g][0] == s.tooth[0] && w.pair_key[g][1] == s.tooth[1] &&
        w.pair_key[g][2] == s.flank)
      return g;
  if (pairs == W::kMaxPairs) return -1;
  w.pair_key[pairs][0] = s.tooth[0];
  w.pair_key[pairs][1] = s.tooth[1];
  w.pair_key[pairs][2] = s.flank;
  w.pair_slices[pairs] = 0;
  return pairs++;
}

// A coupled solve over the candidates of one flank (flank = +-1) or of both (0).
struct FlankProblem : ForceProblem {
  int flank = 0;
};

// The solved candidates as distinct slices (w.rep, and the per-slice arrays), and the pairs.
// Returns the number of distinct slices, or -1 when there are more pairs than the workspace
// holds. Plain mode: a slice handed in open stays open (no law is built for it; the coupling
// only opens slices further): not part of the solve. p.flank != 0: that flank's candidates alone.
int gather(const gm_model& model, gm_data& d, const FlankProblem& p, int& pairs) {
  const ToothCoupling& coupling = model.coupling;
  const SliceLaw* laws = d.laws.data();
  const ContactSlice* slices = d.slices.data();
  const double* balance = d.balance.data();
  const double* approach = d.approach.data();
  const int n = p.n;
  const bool quasi = p.quasi;
  const int flank = p.flank;
  W& w = d.coupled;
  int nu = 0, last = -1;  // last: the distinct slice of the previous candidate
  pairs = 0;
  for (int i = 0; i < n; ++i) {
    const ContactSlice& s = slices[i];
    const double base = quasi ? s.approach : approach[i];
    w.rep[i] = -1;
    if ((!quasi && !(base > 0)) || (flank != 0 && s.flank != flank)) {
      last = -1;
      continue;
    }
    const ContactSlice* prev = last >= 0 ? &slices[i - 1] : nullptr;
    const bool same_pair = prev && prev->tooth[0] == s.tooth[0] && prev->tooth[1] == s.tooth[1] &&
                           prev->flank == s.flank;
    const int g = same_pair ? w.group[last] : pair_of(w, pairs, s);
    if (g < 0) return -1;
    if (same_pair && w.base[last] == base && prev->roll[0] == s.roll[0] &&
        prev->roll[1] == s.roll[1] && same_law(w.laws[last], laws[i]) &&
        (!quasi || (w.gain[last] == s.te_gain && w.balance[last] == balance[i]))) {
      w.rep[i] = last;
      w.weight[last] += 1;
      w.balance_sum[last] += w.balance[last];
      continue;
    }
    const int u = nu++;
    w.rep[i] = last = u;
    w.group[u] = g;
    w.weight[u] = 1;
    w.base[u] = base;
    w.gain[u] = s.te_gain;
    w.balance[u] = w.balance_sum[u] = quasi ? balance[i] : 0.0;
    w.laws[u] = laws[i];
    w.force[u] = 0;
    // the basis [1, h_1, h_2] (reduced to [1] below where the pair has one distinct slice)
    double* phi = &w.basis[W::kBasis * u];
    phi[0] = 1;
    for (int q = 0; q < 2; ++q) phi[1 + q] = coupling_height(coupling.gear[q], s.roll[q]);
    w.pair_slices[g] += 1;
  }
  return nu;
}

// Each pair's basis size and first column; returns r.
int assign_columns(W& w, int pairs) {
  int r = 0;
  for (int p = 0; p < pairs; ++p) {
    w.pair_dim[p] = w.pair_slices[p] == 1 ? 1 : W::kBasis;
    w.pair_col[p] = r;
    r += w.pair_dim[p];
  }
  return r;
}

// The basis heights of pair p where it is reduced to [1]: those of its one distinct slice.
const double* pair_heights(const W& w, int nu, int p) {
  for (int u = 0; u < nu; ++u)
    if (w.group[u] == p) return &w.basis[W::kBasis * u];
  return nullptr;
}

// B in the pairs' bases: the 3 x 3 block of receiver pair p1 and load pair p2 in [1, h_1, h_2]
// (gear g's s_g A_d on the rows [1, h_g] and columns [force, h_g force]), reduced through
// T = [1, h_1, h_2]^T where a pair has the basis [1].
void build_coupling_matrix(const ToothCoupling& coupling, W& w, int nu, int pairs, int r) {
  double* B = w.B.data();
  std::fill(B, B + r * r, 0.0);
  for (int p1 = 0; p1 < pairs; ++p1) {
    for (int p2 = 0; p2 < pairs; ++p2) {
      if (p1 == p2 || w.pair_key[p1][2] != w.pair_key[p2][2]) continue;
      double full[3][3] = {};
      bool any = false;
      for (int q = 0; q < 2; ++q) {
        const int d = coupling_table_offset(coupling, q, w.pair_key[p1][2], w.pair_key[p1][q],
                                            w.pair_key[p2][q]);
        if (d == 0) continue;
        const double* k = coupling.gear[q].k.c[std::abs(d) - 1];
        const double s = coupling.gear[q].scale;
        // receiver [1, h_a] against load [F, h_b F]: d > 0 [[c00 c01][c10 c11]] in the
        // table's (h_a, h_b) order, d < 0 its transpose (tooth_coupling.hpp)
        full[0][0] += s * k[0];
        full[0][1 + q] += s * (d > 0 ? k[2] : k[1]);
        full[1 + q][0] += s * (d > 0 ? k[1] : k[2]);
        full[1 + q][1 + q] += s * k[3];
        any = true;
      }
      if (!any) continue;
      const double* t1 = w.pair_dim[p1] == 1 ? pair_heights(w, nu, p1) : nullptr;
      const double* t2 = w.pair_dim[p2] == 1 ? pair_heights(w, nu, p2) : nullptr;
      for (int a = 0; a < w.pair_dim[p1]; ++a)
        for (int b = 0; b < w.pair_dim[p2]; ++b) {
          double e = 0;
          for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
              e += (t1 ? t1[i] : double(i == a)) * full[i][j] * (t2 ? t2[j] : double(j == b));
          B[(w.pair_col[p1] + a) * r + w.pair_col[p2] + b] = e;
        }
    }
  }
}

// The solve's state over the distinct slices: the Newton steps' linear algebra.
struct LowRank {
  W& w;
  int nu, pairs, r;

  const double* phi(int u) const { return &w.basis[W::kBasis * u]; }
  int dim(int u) const { return w.pair_dim[w.group[u]]; }
  int col(int u) const { return w.pair_col[w.group[u]]; }

  // (Phi x)_u for an r-vector x
  double at(const double* x, int u) const {
    const double* f = phi(u);
    const double* xs = x + col(u);
    double e = 0;
    for (int k = 0; k < dim(u); ++k) e += f[k] * xs[k];
    return e;
  }
  // Phi^T (weight x) over the distinct slices into an r-vector
  void phi_t(const double* x, double* to) const {
    std::fill(to, to + r, 0.0);
    for (int u = 0; u < nu; ++u) {
      if (x[u] == 0) continue;
      const double* f = phi(u);
      double* ts = to + col(u);
      for (int k = 0; k < dim(u); ++k) ts[k] += w.weight[u] * f[k] * x[u];
    }
  }
  void apply_B(const double* x, double* to) const {
    const double* B = w.B.data();
    for (int i = 0; i < r; ++i) {
      double s = 0;
      for (int j = 0; j < r; ++j) s += B[i * r + j] * x[j];
      to[i] = s;
    }
  }
  // J = I + (Phi^T K Phi) B; Phi^T K Phi is block diagonal by pair
  void tangent(double* J) const {
    const double* B = w.B.data();
    std::fill(J, J + r * r, 0.0);
    for (int p = 0; p < pairs; ++p) {
      const int kp = w.pair_dim[p], c0 = w.pair_col[p];
      double blk[W::kBasis][W::kBasis] = {};
      for (int u = 0; u < nu; ++u) {
        if (w.group[u] != p || !(w.stiffness[u] > 0)) continue;
        const double* f = phi(u);
        const double s = w.weight[u] * w.stiffness[u];
        for (int a = 0; a < kp; ++a)
          for (int b = 0; b < kp; ++b) blk[a][b] += s * f[a] * f[b];
      }
      for (int a = 0; a < kp; ++a)
        for (int j = 0; j < r; ++j) {
          double s = 0;
          for (int b = 0; b < kp; ++b) s += blk[a][b] * B[(c0 + b) * r + j];
          J[(c0 + a) * r + j] = s;
        }
    }
    for (int i = 0; i < r; ++i) J[i * r + i] += 1;
  }
  // Quasi-static: the balance's rank-one term -(Phi^T K w)(b^T K Phi B)/(b^T K w) added to J.
  void balance_term(double* J) const {
    double s = 0;
    for (int u = 0; u < nu; ++u) s += w.weight[u] * w.balance[u] * w.stiffness[u] * w.gain[u];
    if (s == 0) return;
    double* scratch = w.approach.data();  // free between the separable solves
    for (int u = 0; u < nu; ++u) scratch[u] = w.stiffness[u] * w.gain[u];
    phi_t(scratch, w.c.data());  // Phi^T K w
    for (int u = 0; u < nu; ++u) scratch[u] = w.stiffness[u] * w.balance[u];
    phi_t(scratch, w.y.data());  // Phi^T K b
    const double* B = w.B.data();
    for (int j = 0; j < r; ++j) {  // (B^T Phi^T K b)_j = (b^T K Phi B)_j
      double t = 0;
      for (int i = 0; i < r; ++i) t += B[i * r + j] * w.y[i];
      for (int i = 0; i < r; ++i) J[i * r + j] -= w.c[i] * t / s;
    }
  }
  void mark_loaded() const {
    for (int p = 0; p < pairs; ++p) w.loaded[p] = false;
    for (int u = 0; u < nu; ++u)
      if (w.stiffness[u] > 0) w.loaded[w.group[u]] = true;
  }
  // Solve J x = b (b becomes x) where the rows of the pairs without a loaded slice are those
  // of the identity: x = b there, and the rest is the reduced system over the loaded pairs'
  // columns. false if singular.
  bool solve_loaded(double* b) const {
    mark_loaded();
    const double* J = w.J.data();
    int* idx = w.index.data();
    unsigned char* active = w.active.data();
    int ra = 0;
    for (int p = 0; p < pairs; ++p)
      for (int k = 0; k < w.pair_dim[p]; ++k) {
        active[w.pair_col[p] + k] = w.loaded[p];
        if (w.loaded[p]) idx[ra++] = w.pair_col[p] + k;
      }
    if (ra == 0) return true;
    double* Jr = w.Jr.data();
    double* rhs = Jr + ra * ra;
    for (int a = 0; a < ra; ++a) {
      double s = b[idx[a]];
      for (int j = 0; j < r; ++j)  // inactive unknowns are already b_j
        if (!active[j]) s -= J[idx[a] * r + j] * b[j];
      rhs[a] = s;
      for (int c = 0; c < ra; ++c) Jr[a * ra + c] = J[idx[a] * r + idx[c]];
    }
    if (!dense_solve(Jr, rhs, ra)) return false;
    for (int a = 0; a < ra; ++a) b[idx[a]] = rhs[a];
    return true;
  }
};

}  // namespace

void CoupledWorkspace::reserve(int capacity) {
  const int r = kBasis * kMaxPairs;
  const std::size_t n = std::size_t(capacity);
  rep.assign(n, -1);
  group.assign(n, 0);
  for (auto* x : {&weight, &base, &gain, &balance, &balance_sum, &shifted, &approach, &force, &stiffness})
    x->assign(n, 0.0);
  basis.assign(kBasis * n, 0.0);
  laws.assign(n, SliceLaw{});
  B.assign(std::size_t(r) * r, 0.0);
  J.assign(std::size_t(r) * r, 0.0);
  Jr.assign(std::size_t(r) * (r + 1), 0.0);  // reduced matrix and its right-hand side
  index.assign(std::size_t(r), 0);
  active.assign(std::size_t(r), 0);
  for (auto* x : {&m, &v, &G, &a, &c, &y}) x->assign(std::size_t(r), 0.0);
}

namespace {

// solve_coupled over the candidates of p.flank.
CoupledSolveResult solve_flanks(const gm_model& model, gm_data& d, const FlankProblem& p) {
  const ToothCoupling& coupling = model.coupling;
  const ContactSlice* slices = d.slices.data();
  const int n = p.n;
  const bool quasi = p.quasi;
  const double load = p.load;
  const double tol = model.params.solver_tolerance;
  const int max_iterations = model.params.solver_max_iterations;
  double* approach = d.approach.data();
  double* force = d.forces.data();
  double* stiffness = d.slice_stiffness.data();
  CoupledWorkspace& w = d.coupled;
  CoupledSolveResult out;
  int pairs = 0;
  const int nu = gather(model, d, p, pairs);
  if (nu < 0) {
    out.fallback = true;
    out.solve.converged = false;
    return out;
  }
  const int r = assign_columns(w, pairs);
  build_coupling_matrix(coupling, w, nu, pairs, r);
  const LowRank L{w, nu, pairs, r};
  double scale = 0;
  for (int u = 0; u < nu; ++u) scale = std::max(scale, std::fabs(w.base[u]));
  // model.solver_tolerance, and at most 1e-8 of the largest approach (plain) or 1e-10 of it
  // (quasi-static: the load balance, to 1e-12 of the load, needs the forces that close)
  const double tol_outer = std::min(tol, 1e-15 + (quasi ? 1e-10 : 1e-8) * scale);
  // the separable solves well inside it: their gaps are the outer residual's noise floor (a
  // warm-started scalar Newton stops at its tolerance rather than far below it)
  const double tol_inner = 1e-2 * tol_outer;
  double* m = w.m.data();
  double* v = w.v.data();
  double* G = w.G.data();
  double* e = w.a.data();
  std::fill(m, m + r, 0.0);
  std::fill(v, v + r, 0.0);
  double lambda = p.lambda_start;
  bool warm = false;  // the first separable solve is the uncoupled one, from scratch
  bool settled = false;  // the last separable solve converged

  // the separable solve at the approaches Delta - Phi B m (v = B m on entry)
  const auto inner = [&]() -> bool {
    double* shifted = w.shifted.data();
    for (int u = 0; u < nu; ++u) {
      const double next = w.base[u] - L.at(v, u);
      // the warm start predicted along the slice's tangent: F + K (next - last approach)
      if (warm && w.force[u] > 0)
        w.force[u] = std::max(0.0, w.force[u] + w.stiffness[u] * (next - shifted[u]));
      shifted[u] = next;
    }
    SeparableProblem sp;
    sp.laws = w.laws.data();
    sp.approach = shifted;
    sp.n = nu;
    sp.tol = tol_inner;
    sp.max_iterations = max_iterations;
    sp.warm = warm;
    const SeparableAnswer sa{w.force.data(), w.stiffness.data(), w.approach.data()};
    ForceSolve s;
    if (quasi) {
      sp.gain = w.gain.data();
      sp.balance = w.balance_sum.data();
      sp.load = load;
      sp.lambda_start = lambda;
      s = solve_separable_total(sp, sa);
      lambda = s.lambda;
    } else {
      // the first (uncoupled) solve only roughly: two Newton steps from the upper bound give the
      // first outer step its tangents; the later solves converge it
      if (!warm) sp.max_iterations = 2;
      s = solve_separable(sp, sa);
    }
    settled = s.converged;
    if (!quasi && !warm) s.converged = true;  // rough on purpose
    warm = true;
    out.solve.iterations += s.iterations;
    if (settled) out.solve.residual = s.residual;
    if (!s.converged) out.solve.message = s.message;
    return s.converged;
  };

  bool converged = false;
  if (inner()) {
    for (int it = 0; it < max_iterations; ++it) {
      // G = m - Phi^T F, and the gap residual Phi B G
      L.phi_t(w.force.data(), G);
      for (int j = 0; j < r; ++j) G[j] = m[j] - G[j];
      L.apply_B(G, e);
      double res = 0;
      for (int u = 0; u < nu; ++u) res = std::max(res, std::fabs(L.at(e, u)));
      if (res <= tol_outer && settled) {
        converged = true;
        break;
      }
      if (res <= tol_outer) {  // the rough first solve alone: converge it
        if (!inner()) break;
        continue;
      }
      // Newton step on m
      L.tangent(w.J.data());
      if (quasi) L.balance_term(w.J.data());
      for (int j = 0; j < r; ++j) G[j] = -G[j];
      if (!L.solve_loaded(G)) break;
      for (int j = 0; j < r; ++j) m[j] += G[j];
      L.apply_B(m, v);
      if (!inner()) break;
      out.solve.iterations += 1;
    }
  }
  if (!converged) {
    for (int i = 0; i < n && quasi; ++i) approach[i] = slices[i].approach;
    out.fallback = true;
    out.solve.converged = false;
    return out;
  }
  // tangent stiffness of each slice: x = K (1 - Phi B y), J y = Phi^T K 1
  L.tangent(w.J.data());
  double* y = w.y.data();
  L.phi_t(w.stiffness.data(), y);
  if (L.solve_loaded(y)) {
    L.apply_B(y, e);
    for (int u = 0; u < nu; ++u)
      if (w.stiffness[u] > 0) w.stiffness[u] *= 1 - L.at(e, u);
  }
  // back onto the candidates
  for (int i = 0; i < n; ++i) {
    const int u = w.rep[i];
    force[i] = u >= 0 ? w.force[u] : 0.0;
    stiffness[i] = u >= 0 ? w.stiffness[u] : 0.0;
    if (quasi) approach[i] = slices[i].approach + slices[i].te_gain * lambda;
  }
  out.solve.lambda = lambda;
  out.solve.converged = true;
  return out;
}

}  // namespace

CoupledSolveResult solve_coupled(const gm_model& m, gm_data& d, const ForceProblem& p) {
  // Quasi-static under load: the flank the load closes alone (positive loads flank A; the flanks
  // never couple), as long as the other stays open at the solved rigid approach; else both.
  FlankProblem fp;
  static_cast<ForceProblem&>(fp) = p;
  fp.flank = p.quasi && p.load != 0 ? (p.load > 0 ? 1 : -1) : 0;
  if (fp.flank != 0) {
    const int closing = fp.flank;
    const CoupledSolveResult one = solve_flanks(m, d, fp);
    const ContactSlice* slices = d.slices.data();
    const double* approach = d.approach.data();
    bool open = true;
    for (int i = 0; i < p.n && open && one.solve.converged; ++i)
      open = slices[i].flank == closing || !(approach[i] > 0);
    if (one.fallback || (one.solve.converged && open)) return one;
  }
  fp.flank = 0;
  return solve_flanks(m, d, fp);
}

}  // namespace gm
