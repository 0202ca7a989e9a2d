// gm_directional_derivative: the evaluation's pipeline (pipeline.hpp) over dual numbers, with
// the force solve in double and the implicit derivative of the solved forces (never
// differentiating Newton iterations); levels 0-4 slice by slice, level 5 on the loaded set of
// the coupled solve; quasi-static mode from two passes and the load balance.
#include "evaluate.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>

#include <Eigen/Cholesky>

#include "dual.hpp"
#include "fe_compliance.hpp"
#include "inputs.hpp"
#include "pipeline.hpp"
#include "resultants.hpp"

namespace gm {
namespace {

// The inputs as dual numbers: values from `at`, derivatives from `seed`.
KinematicsT<Dual> dual_kinematics(const gm_kinematics& at, const gm_kinematics& seed) {
  KinematicsT<Dual> k;
  for (int i = 0; i < 2; ++i) {
    for (int a = 0; a < 3; ++a) {
      k.u[i][a] = Dual(at.u[i][a], seed.u[i][a]);
      k.v[i][a] = Dual(at.v[i][a], seed.v[i][a]);
    }
    for (int a = 0; a < 2; ++a) {
      k.r[i][a] = Dual(at.r[i][a], seed.r[i][a]);
      k.w[i][a] = Dual(at.w[i][a], seed.w[i][a]);
    }
    k.phi[i] = Dual(at.phi[i], seed.phi[i]);
    k.omega[i] = Dual(at.omega[i], seed.omega[i]);
  }
  k.load_torque = Dual(at.load_torque, seed.load_torque);
  return k;
}

// One pass of the evaluation over dual numbers at the pose kin (gear 2's spin included):
// detection, laws, the force solve in double with the implicit derivative of each loaded
// slice, c F + f(F) = Delta => dF = (dDelta - F dc - df/dp dp)/(c + f'(F)) (never
// differentiating Newton iterations), and the resultants. `all`: laws of every slice (the
// quasi-static solve's setting). Quasi-static extras: the load balance sum_i b_i F_i, and for a
// free mesh (no slice loaded) the approach of the flank-A slice that touches first.
struct DualPass {
  ResultT<Dual> r;
  Dual balance;   // sum_i b_i F_i, N (normal forces before damping)
  Dual touch;     // approach of the first-touching slice (free mesh), m
  bool loaded = false;
  bool has_touch = false;
};

// Levels 0-4: the value problem solved as gm_evaluate solves it, then the implicit derivative
// of each loaded slice (the slices are independent).
gm_status separable_dual_forces(const gm_model& m, gm_data& d, int n) {
  const ContactSliceT<Dual>* slices = d.dual_slices.data();
  // the value problem, solved as gm_evaluate solves it
  for (int i = 0; i < n; ++i) {
    const SliceLawT<Dual>& dl = d.dual_laws[i];
    SliceLaw& law = d.laws[i];
    law.compliance = dl.compliance.v;
    law.local.width = dl.local.width.v;
    law.local.reduced_radius = dl.local.reduced_radius.v;
    law.local.corner_slope = dl.local.corner_slope.v;
    for (int g = 0; g < 2; ++g) {
      law.local.body[g].youngs_modulus = dl.local.body[g].youngs_modulus;
      law.local.body[g].poisson_ratio = dl.local.body[g].poisson_ratio;
      law.local.body[g].depth = dl.local.body[g].depth.v;
      law.local.body[g].near_field = dl.local.body[g].near_field.v;
    }
    d.approach[i] = slices[i].approach.v;
  }
  ForceProblem p;
  p.n = n;
  const ForceSolve fs = solve_separable(m, d, p);
  if (!fs.converged) {
    d.message = fs.message;
    return GM_ERR_SOLVER;
  }
  // implicit derivative of each loaded slice; open slices stay at F = 0
  for (int i = 0; i < n; ++i) {
    const double F = d.forces[i];
    if (!(F > 0)) {
      d.dual_forces[i] = Dual(0);
      d.dual_stiffness[i] = Dual(0);
      continue;
    }
    const SliceLawT<Dual>& law = d.dual_laws[i];
    if (!has_local_law(d.laws[i].local)) {
      d.dual_forces[i] = Dual(F, (slices[i].approach.d - F * law.compliance.d) / law.compliance.v);
      d.dual_stiffness[i] = 1.0 / law.compliance;
      continue;
    }
    Dual f, fp;
    local_law_approach_slope(law.local, Dual(F, 0), f, fp);  // f.d = (df/dp) dp at fixed F
    const double dF = (slices[i].approach.d - F * law.compliance.d - f.d) / (law.compliance.v + fp.v);
    d.dual_forces[i] = Dual(F, dF);
    local_law_approach_slope(law.local, d.dual_forces[i], f, fp);  // f' along F and p
    d.dual_stiffness[i] = 1.0 / (law.compliance + fp);
  }
  return GM_OK;
}

// Level 5: the value problem as gm_evaluate solves it (detection, laws and the coupled solve in
// double at the values; the same candidates in the same order as the dual detection), then the
// implicit derivative on the loaded set A, where C_AA F_A + f_A(F_A) = Delta_A holds:
//   (C_AA + diag f'_A) dF_A = dDelta_A - dC_AA F_A - (df/dp)_A dp,
// dC from the database interpolation over dual numbers (roll weights: the slope of the linear
// interpolation; face shares: of the slice's interval), df/dp of the local Hertz law at fixed F.
// The tangent stiffness of each loaded slice, x = (C_AA + diag f'_A)^-1 1, moves with
// dx = -(C_AA + diag f'_A)^-1 (dC_AA + diag df'_A) x.
// The values of dual kinematics.
gm_kinematics values_of(const KinematicsT<Dual>& kin) {
  gm_kinematics kv{};
  for (int i = 0; i < 2; ++i) {
    for (int a = 0; a < 3; ++a) {
      kv.u[i][a] = kin.u[i][a].v;
      kv.v[i][a] = kin.v[i][a].v;
    }
    for (int a = 0; a < 2; ++a) {
      kv.r[i][a] = kin.r[i][a].v;
      kv.w[i][a] = kin.w[i][a].v;
    }
    kv.phi[i] = kin.phi[i].v;
    kv.omega[i] = kin.omega[i].v;
  }
  kv.load_torque = kin.load_torque.v;
  return kv;
}

// Whether the double detection (d.slices, nv candidates) found the dual one's n candidates.
bool same_candidates(const gm_data& d, int nv, int n) {
  const ContactSliceT<Dual>* S = d.dual_slices.data();
  bool same = nv == n;
  for (int i = 0; same && i < n; ++i)
    same = d.slices[i].tooth[0] == S[i].tooth[0] && d.slices[i].tooth[1] == S[i].tooth[1] &&
           d.slices[i].flank == S[i].flank;
  return same;
}

// The loaded set's system: H = C_AA + diag f'_A (in d.dense_tangent), dC_AA (d.dense_dual_c) and the
// right-hand side dDelta_A - dC_AA F_A - (df/dp)_A dp (d.dense_delta).
void coupled_dual_system(const gm_model& m, gm_data& d, const KinematicsT<Dual>& kin, int na) {
  const ContactSliceT<Dual>* S = d.dual_slices.data();
  const Dual uz[2] = {kin.u[0][2], kin.u[1][2]};
  auto H = d.dense_tangent.topLeftCorner(na, na);
  auto dC = d.dense_dual_c.topLeftCorner(na, na);
  if (m.level.database) {
    d.fe_dual_assembly.assemble(fe_view(m), S, d.dense_index.data(), na, uz, d.dense_tangent, d.dense_dual_c);
  } else {
    for (int p = 0; p < na; ++p) {
      const ContactSliceT<Dual>& sp = S[d.dense_index[p]];
      Dual hp[2];
      for (int g = 0; g < 2; ++g) hp[g] = coupling_height(m.coupling.gear[g], sp.roll[g]);
      for (int q = 0; q <= p; ++q) {
        const ContactSliceT<Dual>& sq = S[d.dense_index[q]];
        Dual c;
        if (p == q) {  // level 4 coupled: the slice's own law, no self-coupling
          c = d.dual_laws[d.dense_index[p]].compliance;
        } else {
          Dual hq[2];
          for (int g = 0; g < 2; ++g) hq[g] = coupling_height(m.coupling.gear[g], sq.roll[g]);
          c = coupling_compliance(m.coupling, sp, hp, sq, hq);
        }
        H(p, q) = H(q, p) = c.v;
        dC(p, q) = dC(q, p) = c.d;
      }
    }
  }
  auto rhs = d.dense_delta.head(na);
  for (int p = 0; p < na; ++p) {
    const int i = d.dense_index[p];
    double fd = 0;
    if (has_local_law(d.laws[i].local)) {
      Dual f, fp;
      local_law_approach_slope(d.dual_laws[i].local, Dual(d.forces[i], 0), f, fp);
      H(p, p) += fp.v;
      fd = f.d;
    }
    double dcf = 0;
    for (int q = 0; q < na; ++q) dcf += dC(p, q) * d.forces[d.dense_index[q]];
    rhs[p] = S[i].approach.d - dcf - fd;
  }
}

// The loaded slices' dual forces F + dF eps (dF: dF_A, in the loaded set's order) into
// d.dual_forces, and dHx = dH x = (dC_AA + diag df'_A) x, df' the laws' slopes' derivative at
// those forces (dC_AA in d.dense_dual_c).
void dual_forces_and_dHx(gm_data& d, int na, const Eigen::Ref<const Eigen::VectorXd>& dF,
                         const Eigen::Ref<const Eigen::VectorXd>& x, Eigen::Ref<Eigen::VectorXd> dHx) {
  auto dC = d.dense_dual_c.topLeftCorner(na, na);
  for (int p = 0; p < na; ++p) {
    const int i = d.dense_index[p];
    d.dual_forces[i] = Dual(d.forces[i], dF[p]);
    double dfp = 0;
    if (has_local_law(d.laws[i].local)) {
      Dual f, fp;
      local_law_approach_slope(d.dual_laws[i].local, d.dual_forces[i], f, fp);
      dfp = fp.d;
    }
    dHx[p] = dfp * x[p];
    for (int q = 0; q < na; ++q) dHx[p] += dC(p, q) * x[q];
  }
}

// The loaded set's dF_A and tangent stiffnesses from the system of coupled_dual_system.
gm_status coupled_dual_solve(gm_data& d, int na) {
  auto H = d.dense_tangent.topLeftCorner(na, na);
  auto rhs = d.dense_delta.head(na);
  auto x = d.dense_work.head(na);
  auto dx = d.dense_weights.head(na);
  Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt(H);
  if (llt.info() != Eigen::Success) {
    d.message = "level 5 (FE): C + diag(f') is not positive definite on the loaded slices";
    return GM_ERR_SOLVER;
  }
  llt.solveInPlace(rhs);  // dF_A
  x.setOnes();
  llt.solveInPlace(x);
  dual_forces_and_dHx(d, na, rhs, x, dx);
  llt.solveInPlace(dx);
  for (int p = 0; p < na; ++p) d.dual_stiffness[d.dense_index[p]] = Dual(x[p], -dx[p]);
  return GM_OK;
}

// The same on the reduced face basis of the evaluation's solve (solver.face_shapes,
// face_basis.hpp): F = Phi alpha with Phi^T g = 0, g = C F + f(F) - Delta, and Phi the model's
// fixed shapes (face_shapes.hpp: no derivative of their own), so
//   A dalpha = Phi^T rhs,  A = Phi^T H Phi,  H = C + diag f'(F),  dF = Phi dalpha;
// the tangent stiffnesses x = Phi y, y = A^-1 Phi^T 1, and dx = -Phi A^-1 Phi^T (dH x).
gm_status face_dual_solve(gm_data& d, int na) {
  FaceBasis& w = d.face;
  const int r = w.columns;
  auto H = d.dense_tangent.topLeftCorner(na, na);
  auto rhs = d.dense_delta.head(na);
  auto Phi = w.Phi.topLeftCorner(na, r);
  Phi.setZero();
  for (int p = 0; p < na; ++p) {
    const int i = d.dense_index[p];
    if (w.cand_col[i] < 0) {
      d.message = "level 5 (FE): a loaded slice outside the reduced face basis (internal error)";
      return GM_ERR_SOLVER;
    }
    for (int k = 0; k < w.cand_dim[i]; ++k)
      Phi(p, w.cand_col[i] + k) = w.cand_phi[std::size_t(i) * FaceBasis::kMaxShapes + k];
  }
  // A = Phi^T H Phi
  auto HP = w.CP.topLeftCorner(na, r);
  HP.noalias() = H.lazyProduct(Phi);
  auto A = w.A.topLeftCorner(r, r);
  A.noalias() = Phi.transpose().lazyProduct(HP);
  if (!face_cholesky(w.A, r)) {
    d.message = "level 5 (FE): the reduced face basis's matrix is not positive definite";
    return GM_ERR_SOLVER;
  }

  auto v = w.v.head(na);
  auto y = w.x1.head(r);
  auto c = w.x2.head(r);
  y.noalias() = Phi.transpose().lazyProduct(rhs);
  face_cholesky_solve(w.A, r, y.data());
  rhs.noalias() = Phi.lazyProduct(y);  // dF_A
  // tangent stiffnesses
  for (int k = 0; k < r; ++k) y[k] = Phi.col(k).sum();
  face_cholesky_solve(w.A, r, y.data());
  auto x = d.dense_work.head(na);
  x.noalias() = Phi.lazyProduct(y);
  auto dHx = d.dense_weights.head(na);
  dual_forces_and_dHx(d, na, rhs, x, dHx);
  c.noalias() = -(Phi.transpose().lazyProduct(dHx));
  face_cholesky_solve(w.A, r, c.data());
  v.noalias() = Phi.lazyProduct(c);
  for (int p = 0; p < na; ++p) d.dual_stiffness[d.dense_index[p]] = Dual(x[p], v[p]);
  return GM_OK;
}

gm_status coupled_dual_forces(const gm_model& m, gm_data& d, const KinematicsT<Dual>& kin, int n,
                              bool all) {
  const gm_kinematics kv = values_of(kin);
  const int nv = prepare_slices(m, d, kv, all);
  if (nv < 0) return GM_ERR_INPUT;
  if (!same_candidates(d, nv, n)) {
    d.message = "level 5 (FE): the derivative's detection found other candidates than the "
                "evaluation's (internal error)";
    return GM_ERR_SOLVER;
  }
  ForceProblem p;
  p.pose = &kv;
  p.n = n;
  p.all = all;
  const ForceSolve fs = solve_forces(m, d, p);
  if (!fs.converged) {
    d.message = fs.message;
    return GM_ERR_SOLVER;
  }
  int na = 0;
  for (int i = 0; i < n; ++i) {
    d.dual_forces[i] = Dual(0);
    d.dual_stiffness[i] = Dual(0);
    if (d.forces[i] > 0) d.dense_index[na++] = i;
  }
  if (na == 0) return GM_OK;
  coupled_dual_system(m, d, kin, na);
  return d.face.used ? face_dual_solve(d, na) : coupled_dual_solve(d, na);
}

gm_status dual_pass(const gm_model& m, gm_data& d, const KinematicsT<Dual>& kin, bool all,
                    DualPass& out) {
  const int n = prepare_slices(m, d, kin, all);
  if (n < 0) return GM_ERR_INPUT;
  ContactSliceT<Dual>* slices = d.dual_slices.data();
  if (m.level.coupled) {
    const gm_status st = coupled_dual_forces(m, d, kin, n, all);
    if (st != GM_OK) return st;
  } else {
    const gm_status st = separable_dual_forces(m, d, n);
    if (st != GM_OK) return st;
  }
  out = DualPass{};
  if (all) {
    balance_weights(m, d, kin, n);
    double closest = std::numeric_limits<double>::infinity();
    for (int i = 0; i < n; ++i) {
      out.balance += d.dual_balance[i] * d.dual_forces[i];
      out.loaded = out.loaded || d.forces[i] > 0;
      // gm::evaluate at zero load on a free mesh: the TE where the first slice with a positive
      // TE gain touches (approach 0)
      if (slices[i].te_gain.v > 0 && std::fabs(slices[i].approach.v) < closest) {
        closest = std::fabs(slices[i].approach.v);
        out.touch = slices[i].approach;
        out.has_touch = true;
      }
    }
  }
  const Dual energy = elastic_energy<Dual>(d, n);
  resultants(m, d, kin, n, out.r);
  out.r.elastic_energy = energy;
  return GM_OK;
}

// Level 5: saves the coupled solve's warm start (previous forces and candidates) and restores
// it when the derivative returns, so that gm_evaluate's next result does not depend on it; and
// hands the solve its branch choice back (FaceBasis::branch).
class CoupledWarmStartGuard {
 public:
  CoupledWarmStartGuard(gm_data& d, bool active)
      : d_(d), active_(active), n_(d.dense_prev_n), face_(d.face.warm) {
    for (int a = 0; active_ && a < n_; ++a) {
      d_.dense_saved_force[a] = d_.dense_force[a];
      d_.dense_saved_key[a] = d_.dense_prev_key[a];
    }
  }
  ~CoupledWarmStartGuard() {
    d_.face.branch = -1;
    if (!active_) return;
    for (int a = 0; a < n_; ++a) {
      d_.dense_force[a] = d_.dense_saved_force[a];
      d_.dense_prev_key[a] = d_.dense_saved_key[a];
    }
    d_.dense_prev_n = n_;
    d_.face.warm = face_;
  }
  CoupledWarmStartGuard(const CoupledWarmStartGuard&) = delete;
  CoupledWarmStartGuard& operator=(const CoupledWarmStartGuard&) = delete;

 private:
  gm_data& d_;
  bool active_;
  int n_;
  FaceBasis::Warm face_;  // the reduced face basis's warm start
};

// One gm_directional_derivative at the pose at_in along seed: the poses, the pass and the TE.
struct Derivative {
  Derivative(const MeshLayout& L, const gm_kinematics& given, const gm_kinematics& seed_in)
      : at_in(given), seed(seed_in), at(reduced_pose(L, given, &phi2_offset)),
        kin(dual_kinematics(at, seed)) {}
  const gm_kinematics& at_in;  // the pose as given
  const gm_kinematics& seed;
  double phi2_offset = 0;  // quasi-static: gear 2's whole-turn-reduced spin offset (before `at`:
                           // reduced_pose writes it)
  gm_kinematics at;        // the pose as gm_evaluate detects it
  KinematicsT<Dual> kin;   // at as dual numbers along seed (quasi-static: gear 2 at the solved TE)
  DualPass pass;           // the pass (quasi-static: the combined one)
  Dual te;                 // the TE and its derivative
};

// Quasi-static: the solved TE at `at` (the warm start is restored afterwards), then two passes
// at that pose: A along the seed with the TE held, B along the TE alone. Every output is linear
// in the direction, so output' = A + dTE B with dTE from the load balance:
// d(sum b_i F_i) = d(load_torque)/r_b2 (or, on a free mesh at zero load, from the touching
// slice's approach staying 0). g.pass: the combined pass; g.te: the solved TE and its derivative.
gm_status quasi_static_dual(const gm_model& m, gm_data& d, Derivative& g) {
  const gm_kinematics &at_in = g.at_in, &at = g.at, &seed = g.seed;
  const double phi2_offset = g.phi2_offset;
  KinematicsT<Dual>& kin = g.kin;
  DualPass& p = g.pass;
  Dual& te = g.te;
  const MeshLayout& L = m.layout;
  const double s = L.sign, rb1 = L.base_radius[0], rb2 = L.base_radius[1];
  const double warm = d.te_estimate;
  const gm_data::TeHistory history = d.te_history;
  gm_result r0;
  const gm_status st0 = evaluate(m, d, at_in, r0);
  d.te_estimate = warm;
  d.te_history = history;
  if (st0 != GM_OK) return st0;
  d.face.branch = d.face.used ? 1 : 0;  // the passes answer as the evaluation did
  kin.phi[1] = Dual((r0.te - rb1 * at.phi[0]) / (s * rb2) + phi2_offset,
                    -rb1 * seed.phi[0] / (s * rb2));
  DualPass a, b;
  gm_status st = dual_pass(m, d, kin, true, a);
  if (st != GM_OK) return st;
  KinematicsT<Dual> kb = dual_kinematics(at, gm_kinematics{});
  kb.phi[1] = Dual(kin.phi[1].v, 1 / (s * rb2));
  st = dual_pass(m, d, kb, true, b);
  if (st != GM_OK) return st;
  double dte = 0;
  if (a.loaded && b.balance.d != 0) {
    dte = (seed.load_torque / rb2 - a.balance.d) / b.balance.d;
  } else if (a.has_touch && b.touch.d != 0) {
    dte = -a.touch.d / b.touch.d;
  }
  each_resultant(a.r, b.r, [dte](auto& x, const auto& y) {
    if constexpr (std::is_same_v<std::decay_t<decltype(y)>, Dual>) x.d += dte * y.d;
  });
  p = a;
  te = Dual(r0.te, dte);
  return GM_OK;
}

// The derivatives of the outputs from the pass and the TE.
gm_result derivative_outputs(const DualPass& p, const Dual& te, double rb2) {
  gm_result out{};  // the SOLVER outputs' derivative: 0
  store_derivative(p.r, out);
  const Dual te_angle = te / rb2;
  out.te = te.d;
  out.te_angle = te_angle.d;
  return out;
}

}  // namespace

gm_status directional_derivative(const gm_model& m, gm_data& d, const gm_kinematics& at_in,
                                 const gm_kinematics& seed, gm_result& res) {
  if (!inputs_valid(at_in, d.message)) return GM_ERR_INPUT;
  if (!inputs_finite(seed, d.message)) {
    d.message = "seed: " + d.message;
    return GM_ERR_INPUT;
  }
  // level 5: the coupled solve's warm start is the evaluation's, left as it was
  const CoupledWarmStartGuard guard(d, m.level.coupled);
  const MeshLayout& L = m.layout;
  Derivative g(L, at_in, seed);
  if (!m.params.quasi_static) {
    const gm_status st = dual_pass(m, d, g.kin, false, g.pass);
    if (st != GM_OK) return st;
    g.te = L.base_radius[0] * g.kin.phi[0] + L.sign * L.base_radius[1] * g.kin.phi[1];
  } else {
    const gm_status st = quasi_static_dual(m, d, g);
    if (st != GM_OK) return st;
  }
  res = derivative_outputs(g.pass, g.te, L.base_radius[1]);
  d.message.clear();
  return GM_OK;
}

}  // namespace gm
