// The force-solve stage of level 5: the coupled solve over the candidates (NlcpSolver on the
// compliance C of the databases, assembled by FeAssembly), plain and quasi-static, and the
// quasi-static TE history.
#include "dense_solve.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "face_basis.hpp"
#include "params.hpp"

namespace gm {
namespace {

constexpr double kNlcpRelativeTolerance = 1e-10;  // NlcpOptions' default
// The reduced face basis's Newton iterations: it starts from the last answer or the solve without
// the local laws and converges in 2-4; one that needs more is a slice unloading, which the solve
// over the slices then answers
constexpr int kFaceIterations = 12;

// The solved set (every candidate with `all`, else those with Delta > 0) in d.dense_index; its
// number. Zeroes d.forces and d.slice_stiffness of all n candidates.
int dense_select(gm_data& d, int n, bool all) {
  int na = 0;
  for (int i = 0; i < n; ++i) {
    d.forces[i] = 0;
    d.slice_stiffness[i] = 0;
    if (all || d.approach[i] > 0) d.dense_index[na++] = i;
  }
  return na;
}

// Quasi-static under load at level 5: keep in d.dense_index only the candidates of the flank that
// the load closes (te_gain * load > 0); their flank, or 0 (nothing left out) when both flanks
// have such candidates. The databases never couple flank A with flank B (fe_compliance.hpp), so
// a candidate of the other flank that stays open at the solved approach carries no force and
// changes nothing of the solve (its gap is its approach, -Delta_i >= 0): the answer on the
// smaller system is the answer on all of them, which dense_others_open confirms after the solve.
int dense_loaded_flank(gm_data& d, int& na, double load) {
  const ContactSlice* S = d.slices.data();
  int flank = 0;
  for (int a = 0; a < na; ++a) {
    const ContactSlice& s = S[d.dense_index[a]];
    if (s.te_gain * load > 0) {
      if (flank != 0 && s.flank != flank) return 0;
      flank = s.flank;
    }
  }
  int kept = 0;
  for (int a = 0; a < na && flank != 0; ++a)
    if (S[d.dense_index[a]].flank == flank) d.dense_index[kept++] = d.dense_index[a];
  if (flank != 0) na = kept;
  return flank;
}

// Whether every candidate off `flank` is open (Delta <= 0) at the solved approaches d.approach.
bool dense_others_open(const gm_data& d, int n, int flank) {
  for (int i = 0; i < n; ++i)
    if (d.slices[i].flank != flank && d.approach[i] > 0) return false;
  return true;
}

// Level 4 with tooth coupling: C between the solved slices, each slice's own law on the diagonal
// (Weber/Sainsot of both teeth) and the tooth coupling between slices of different tooth pairs.
void coupled_assemble(const gm_model& m, gm_data& d, int na) {
  const ContactSlice* S = d.slices.data();
  double* h = d.dense_height.data();
  for (int a = 0; a < na; ++a)
    for (int g = 0; g < 2; ++g) h[2 * a + g] = coupling_height(m.coupling.gear[g], S[d.dense_index[a]].roll[g]);
  auto& C = d.dense_c;
  for (int a = 0; a < na; ++a) {
    const ContactSlice& sa = S[d.dense_index[a]];
    C(a, a) = d.laws[d.dense_index[a]].compliance;
    for (int b = 0; b < a; ++b)
      C(a, b) = C(b, a) = coupling_compliance(m.coupling, sa, h + 2 * a, S[d.dense_index[b]], h + 2 * b);
  }
}

// The solved set's identities, local laws, approaches and TE gains, its compliance C (cached
// assembly; level 5 with `prepare_only` only FeAssembly's first stage: the reduced face basis may
// need no C, dense_fill_c makes it where it does), and the warm start: the previous call's forces
// when the candidates are the same.
void dense_gather(const gm_model& m, gm_data& d, const gm_kinematics& kin, int na, bool prepare_only = false) {
  const ContactSlice* S = d.slices.data();
  for (int a = 0; a < na; ++a) {
    const ContactSlice& sa = S[d.dense_index[a]];
    d.dense_key[a] = ((static_cast<long long>(sa.tooth[0]) * 100003 + sa.tooth[1]) * 2 +
                      (sa.flank > 0)) *
                         4099 +
                     a;
    d.dense_laws[a] = d.laws[d.dense_index[a]].local;
    d.dense_delta[a] = d.approach[d.dense_index[a]];
    d.dense_weights[a] = sa.te_gain;
  }
  if (m.level.database) {
    const double uz[2] = {kin.u[0][2], kin.u[1][2]};
    if (prepare_only)
      d.fe_assembly.prepare(fe_view(m), S, d.dense_index.data(), na, uz);
    else
      d.fe_assembly.assemble(fe_view(m), S, d.dense_index.data(), na, uz, d.dense_c);
  } else {
    coupled_assemble(m, d, na);
  }
  bool same = d.dense_prev_n == na;
  for (int a = 0; same && a < na; ++a) same = d.dense_key[a] == d.dense_prev_key[a];
  if (!m.level.database) {
    // Level 4: start from the uncoupled answer (each slice alone under its own law), not from
    // the previous call's forces, so that a result does not depend on the call history (FMU
    // get/set state, dynamics state copies stay bit for bit, as the separable levels' do)
    for (int a = 0; a < na; ++a) {
      const int i = d.dense_index[a];
      const double delta = std::max(d.dense_delta[a], 0.0);
      SeparableProblem sp;
      sp.laws = &d.laws[i];
      sp.approach = &delta;
      sp.n = 1;
      sp.tol = m.params.solver_tolerance;
      sp.max_iterations = m.params.solver_max_iterations;
      const ForceSolve one = solve_separable(sp, SeparableAnswer{d.dense_force.data() + a, d.dense_work.data() + a});
      if (!one.converged) d.dense_force[a] = 0;
    }
  } else if (!same) {
    d.dense_force.head(na).setZero();
  }
  for (int a = 0; a < na; ++a) d.dense_prev_key[a] = d.dense_key[a];
  d.dense_prev_n = na;
}

// The solver's options for this call.
void dense_set_options(const gm_model& m, gm_data& d, int na) {
  NlcpOptions opt = d.nlcp->options();
  // NlcpSolver's own tolerances (1e-15 m + 1e-10 |Delta|): model.solver_tolerance (1e-10 m by
  // default) on the rigid approach would leave the load balance ~1e-5 off
  opt.tolerance = std::min(opt.tolerance, m.params.solver_tolerance);
  // The relative part on the approaches that can load a slice: the open candidates of the
  // quasi-static solve (backlash gaps of ~100 um) would loosen it by their size. A
  // model.solver_tolerance below the absolute part (1e-15 m) tightens it in proportion.
  double closing = 0, all_max = 0;
  for (int a = 0; a < na; ++a) {
    closing = std::max(closing, d.dense_delta[a]);
    all_max = std::max(all_max, std::fabs(d.dense_delta[a]));
  }
  double rel = kNlcpRelativeTolerance * std::min(1.0, m.params.solver_tolerance / 1e-15);
  // Level 4 (tooth coupling): model.solver_tolerance as the separable solve of the uncoupled
  // levels reads it, relative to its default 1e-10 m, down to the rounding floor of the gap
  // (directional derivatives are compared with finite differences at a 1e-15 m tolerance)
  if (!m.level.database) {
    rel = std::max(1e-14, kNlcpRelativeTolerance * std::min(1.0, m.params.solver_tolerance / 1e-10));
    opt.tolerance = std::min(1e-15, 1e-3 * m.params.solver_tolerance);
  }
  opt.relative_tolerance = all_max > 0 && closing > 0 ? rel * closing / all_max : rel;
  opt.max_iterations = m.params.solver_max_iterations;
  // level 4: no factorization carried over from the previous call (history independence)
  opt.reuse_tangent = m.level.database;
  // C is symmetric by construction (FeAssembly and coupled_assemble mirror every entry)
  opt.check_symmetry = false;
  d.nlcp->set_options(opt);
}

// Quasi-static at zero load: the rigid approach at which the first slice a positive load would
// close touches; no force.
double dense_touch_lambda(gm_data& d, int na) {
  double lambda = std::numeric_limits<double>::infinity();
  for (int a = 0; a < na; ++a)
    if (d.dense_weights[a] > 0) lambda = std::min(lambda, -d.dense_delta[a] / d.dense_weights[a]);
  if (!std::isfinite(lambda)) lambda = 0;
  d.dense_force.head(na).setZero();
  return lambda;
}

// Quasi-static under load: w^T F = total with w = sign(load) te_gain; the balance b (with
// friction) differs from w, so total is rescaled until sum b_i F_i = load. out.lambda is the
// rigid approach.
NlcpResult dense_solve_balanced(gm_data& d, int na, double load, ForceSolve& out) {
  const auto Cn = d.dense_c.topLeftCorner(na, na);
  const double sgn = load > 0 ? 1.0 : -1.0;
  d.dense_weights.head(na) *= sgn;
  double total = std::fabs(load), lambda = 0;
  NlcpResult res;
  for (int outer = 0; outer < 30; ++outer) {
    lambda = 0;
    res = d.nlcp->solve_total(Cn, d.dense_delta.head(na), d.dense_laws.data(), d.dense_weights.head(na),
                              total, d.dense_force.head(na), lambda);
    out.iterations += res.iterations;
    if (res.status != NlcpStatus::converged) break;
    double bal = 0;
    for (int a = 0; a < na; ++a) bal += d.balance[d.dense_index[a]] * d.dense_force[a];
    if (!(bal * sgn > 0)) break;
    if (std::fabs(bal - load) <= 1e-12 * std::fabs(load)) break;
    total *= load / bal;
  }
  out.lambda = sgn * lambda;
  return res;
}

// Level 4 quasi-static at zero load on a wedged mesh (a flank overlaps at the touch position
// lambda_0 of dense_touch_lambda, so no free position exists): the preloaded balance
// sum_i b_i F_i(Delta + lambda w) = 0 (w = te_gain), increasing in lambda, bracketed by lambda_0
// (no flank-A force: the sum is < 0) and the lambda where every flank-B slice opens (>= 0);
// Illinois regula falsi over plain coupled solves. d.dense_delta holds Delta + lambda w on return;
// out.lambda is lambda.
NlcpResult dense_solve_wedged(gm_data& d, int na, double lambda0, ForceSolve& out) {
  const auto Cn = d.dense_c.topLeftCorner(na, na);
  auto base = d.dense_work.head(na);
  base = d.dense_delta.head(na);
  double hi = lambda0;
  for (int a = 0; a < na; ++a)
    if (d.dense_weights[a] < 0) hi = std::max(hi, -base[a] / d.dense_weights[a]);
  NlcpResult res;
  const auto balance_at = [&](double lambda) {
    for (int a = 0; a < na; ++a) d.dense_delta[a] = base[a] + lambda * d.dense_weights[a];
    res = d.nlcp->solve(Cn, d.dense_delta.head(na), d.dense_laws.data(), d.dense_force.head(na));
    out.iterations += res.iterations;
    double bal = 0;
    for (int a = 0; a < na; ++a) bal += d.balance[d.dense_index[a]] * d.dense_force[a];
    return bal;
  };
  double lo = lambda0, f_lo = balance_at(lo), f_hi = balance_at(hi), lambda = hi, f = f_hi;
  double scale = std::fabs(f_lo);
  int side = 0;
  for (int it = 0; it < 100 && res.status == NlcpStatus::converged; ++it) {
    if (std::fabs(f) <= 1e-12 * scale || hi - lo <= 1e-15 * (std::fabs(lo) + 1e-6)) break;
    lambda = f_hi != f_lo ? (lo * f_hi - hi * f_lo) / (f_hi - f_lo) : 0.5 * (lo + hi);
    f = balance_at(lambda);
    if (f < 0) {
      lo = lambda;
      f_lo = f;
      if (side == -1) f_hi *= 0.5;
      side = -1;
    } else {
      hi = lambda;
      f_hi = f;
      if (side == 1) f_lo *= 0.5;
      side = 1;
    }
  }
  out.lambda = lambda;
  return res;
}

// Forces, and (tangent) each loaded slice's tangent stiffness: row sums of
// (C_AA + diag f'_A)^-1, so that their sum is the mesh stiffness under a uniform approach.
// Without: the solve's last factorization is kept for the next solve instead, where it has one.
void dense_store(gm_data& d, int na, bool tangent) {
  const auto Cn = d.dense_c.topLeftCorner(na, na);
  if (!tangent && d.nlcp->keep_last_factorization(d.dense_force.head(na)))
    d.dense_work.head(na).setZero();
  else
    d.nlcp->loaded_row_sums(Cn, d.dense_force.head(na), d.dense_work.head(na));
  // U = sum_i [F_i (Delta_i + f_i)/2 - P_i] (resultants.hpp, elastic_energy) from the laws the
  // solve holds at its answer, at the final approaches
  double energy = 0;
  for (int a = 0; a < na; ++a) {
    const int i = d.dense_index[a];
    const double F = d.dense_force[a];
    d.forces[i] = F;
    d.slice_stiffness[i] = d.dense_work[a];
    if (F > 0) {
      const LocalLawJet& law = d.nlcp->law_at_answer(a);
      energy += 0.5 * F * (d.approach[i] + law.approach) - law.energy;
    }
  }
  d.dense_energy = energy;
}

// Level 5 after dense_gather's prepare_only: C from FeAssembly's second stage.
void dense_fill_c(const gm_model& m, gm_data& d, int na) {
  d.fe_assembly.fill(fe_view(m), d.slices.data(), d.dense_index.data(), na, d.dense_c);
}

// Level 5 with solver.face_shapes > 0: the solve on the reduced face basis (face_basis.hpp) over
// the gathered set (FeAssembly prepared; C Phi and Phi^T C Phi projected where FeAssembly can,
// else C filled: `filled` tells); true with the answer stored as dense_store stores it (quasi:
// d.approach moved by the solved lambda), false (nothing changed) where the caller solves over
// the slices.
bool dense_face_solve(const gm_model& m, gm_data& d, const ForceProblem& p, int na, int flank, ForceSolve& out,
                      bool& filled) {
  const NlcpOptions& opt = d.nlcp->options();
  double all_max = 0;
  for (int a = 0; a < na; ++a) all_max = std::max(all_max, std::fabs(d.dense_delta[a]));
  FaceProblem fp;
  fp.n = na;
  fp.index = d.dense_index.data();
  fp.slices = d.slices.data();
  fp.C = d.dense_c.data();
  fp.ld = static_cast<int>(d.dense_c.rows());
  fp.delta = d.dense_delta.data();
  fp.laws = d.dense_laws.data();
  fp.shapes = m.params.solver_face_shapes;
  fp.shape_table = m.face_shapes.data();
  fp.shape_products = m.face_shape_products.data();
  fp.tolerance = opt.tolerance + opt.relative_tolerance * all_max;
  fp.max_iterations = std::min(m.params.solver_max_iterations, kFaceIterations);
  fp.quasi = p.quasi;
  fp.gain = d.dense_weights.data();
  fp.balance = d.balance.data();
  fp.load = p.load;
  if (!group_face_pairs(d.face, fp)) return false;
  if (d.face.branch == 1) {
    fp.slice_tolerance = std::numeric_limits<double>::infinity();  // the evaluation's branch
  } else if (!face_basis_may_hold(d.face, fp)) {
    return false;
  }
  if (d.fe_assembly.project(fe_view(m), d.slices.data(), d.dense_index.data(), na, d.face.all_CP, d.face.all_PCP,
                            fp.groups)) {
    fp.all_CP = &d.face.all_CP;
    fp.all_PCP = &d.face.all_PCP;
  } else {
    dense_fill_c(m, d, na);
    filled = true;
  }
  const FaceAnswer fa = solve_face_basis(d.face, fp, d.dense_work.data(), d.dense_tangent.data());
  if (!fa.accepted) return false;
  const int n = p.n;
  if (p.quasi) {
    for (int i = 0; i < n; ++i) d.approach[i] += fa.lambda * d.slices[i].te_gain;
    if (flank != 0 && !dense_others_open(d, n, flank)) {  // wedging: the full solve decides
      for (int i = 0; i < n; ++i) d.approach[i] = d.slices[i].approach;
      d.face.used = false;
      return false;
    }
  }
  const bool tangent = !(p.quasi && std::fabs(fa.lambda) > p.next_pass_above);
  for (int a = 0; a < na; ++a) {
    const int i = d.dense_index[a];
    d.forces[i] = d.dense_work[a];
    d.slice_stiffness[i] = tangent ? d.dense_tangent.data()[a] : 0.0;
    d.dense_force[a] = d.dense_work[a];  // the full solve's warm start, should a later call need it
  }
  d.dense_energy = fa.energy;
  out.lambda = fa.lambda;
  out.iterations += fa.iterations;
  out.residual = fa.residual;
  return true;
}

}  // namespace

ForceSolve solve_dense(const gm_model& m, gm_data& d, const ForceProblem& p) {
  const gm_kinematics& kin = *p.pose;
  const int n = p.n;
  const bool all = p.all, quasi = p.quasi;
  const double load = p.load;
  ForceSolve out;
  const ContactSlice* S = d.slices.data();
  int na = dense_select(d, n, all);
  if (na == 0) {
    if (quasi) {  // no candidate: nothing to balance
      out.converged = false;
      out.message = "no candidate slice to carry the load";
    }
    d.dense_prev_n = 0;
    return out;
  }
  const int flank = quasi && load != 0 && m.level.database
                        ? dense_loaded_flank(d, na, load)
                        : 0;
  // the reduced face basis first (m.face_shapes: none on a helical pair, whose contact lines end
  // inside the face, which unloads slices at most poses: the slices answer there)
  const bool reduced = m.level.database && !m.face_shapes.empty() && !(quasi && load == 0) && d.face.branch != 0;
  dense_gather(m, d, kin, na, reduced);
  dense_set_options(m, d, na);
  d.face.used = false;
  if (reduced) {
    bool filled = false;
    if (dense_face_solve(m, d, p, na, flank, out, filled)) return out;
    if (!filled) dense_fill_c(m, d, na);
  }
  NlcpResult res;
  if (!quasi) {
    const auto Cn = d.dense_c.topLeftCorner(na, na);
    res = d.nlcp->solve(Cn, d.dense_delta.head(na), d.dense_laws.data(), d.dense_force.head(na));
    out.iterations = res.iterations;
  } else if (load == 0) {
    out.lambda = dense_touch_lambda(d, na);
    bool wedged = false;  // level 4: a flank overlaps at the touch position
    for (int a = 0; a < na && !m.level.database; ++a)
      wedged = wedged || d.dense_delta[a] + out.lambda * d.dense_weights[a] > 0;
    if (!wedged) {
      for (int i = 0; i < n; ++i) d.approach[i] += out.lambda * S[i].te_gain;
      return out;
    }
    res = dense_solve_wedged(d, na, out.lambda, out);
    for (int i = 0; i < n; ++i) d.approach[i] += out.lambda * S[i].te_gain;
  } else {
    res = dense_solve_balanced(d, na, load, out);
    for (int i = 0; i < n; ++i) d.approach[i] += out.lambda * S[i].te_gain;
    if (flank != 0 && res.status == NlcpStatus::converged && !dense_others_open(d, n, flank)) {
      // the other flank closes (wedging): solve over every candidate
      for (int i = 0; i < n; ++i) d.approach[i] = S[i].approach;
      na = dense_select(d, n, all);
      dense_gather(m, d, kin, na);
      dense_set_options(m, d, na);
      res = dense_solve_balanced(d, na, load, out);
      for (int i = 0; i < n; ++i) d.approach[i] += out.lambda * S[i].te_gain;
    }
  }
  out.residual = res.residual;
  if (res.status != NlcpStatus::converged) {
    out.converged = false;
    // the cap is the model's parameter; a static text built once (a char array: nothing for exit
    // to destroy after an importer unloaded the FMU, contact_forces.cpp)
    static char capped[128];
    static const bool built =
        std::snprintf(capped, sizeof capped, "the coupled force solve did not converge within %s iterations; raise it",
                      GM_PARAM_NAME(solver_max_iterations)) > 0;
    out.message = res.capped && built           ? capped
                  : res.message && *res.message ? res.message
                                                : "the coupled force solve did not converge";
    return out;
  }
  dense_store(d, na, !(quasi && std::fabs(out.lambda) > p.next_pass_above));
  return out;
}

// Level 5 quasi-static: the TE to detect at first. The solved TE is a smooth function of gear
// 1's angle between mesh events, so it is extrapolated from the last solves made at the same load
// torque when this step is no longer than twice the last one: by the parabola through the last
// three (their steps alike within a factor of 4), else the line through the last two; else the
// last solved TE. Only where the pass loop starts: the answer is the same fixed point (to the
// pass loop's tolerance), reached with fewer solver iterations and passes.
double predicted_te(gm_data& d, double phi, double load_torque) {
  gm_data::TeHistory& h = d.te_history;
  if (d.dense_prev_n < 0) h.n = 0;  // reset or restored state: cold
  if (h.n < 2 || h.load[0] != load_torque || h.load[1] != load_torque) return d.te_estimate;
  const double step = h.phi[0] - h.phi[1];
  if (step == 0 || std::fabs(phi - h.phi[0]) > 2 * std::fabs(step)) return d.te_estimate;
  const double slope = (h.te[0] - h.te[1]) / step;
  double te = d.te_estimate + slope * (phi - h.phi[0]);
  const double before = h.phi[1] - h.phi[2];
  if (h.n == 3 && h.load[2] == load_torque && before != 0 && before * step > 0 &&
      std::fabs(before) <= 4 * std::fabs(step) && std::fabs(step) <= 4 * std::fabs(before)) {
    const double curvature = (slope - (h.te[1] - h.te[2]) / before) / (h.phi[0] - h.phi[2]);
    te += curvature * (phi - h.phi[0]) * (phi - h.phi[1]);
  }
  return te;
}

void record_te(gm_data& d, double phi, double te, double load_torque) {
  gm_data::TeHistory& h = d.te_history;
  if (h.n > 0 && phi == h.phi[0] && load_torque == h.load[0]) {  // the same pose again
    h.te[0] = te;
    return;
  }
  for (int k = 2; k > 0; --k) {
    h.phi[k] = h.phi[k - 1];
    h.te[k] = h.te[k - 1];
    h.load[k] = h.load[k - 1];
  }
  h.phi[0] = phi;
  h.te[0] = te;
  h.load[0] = load_torque;
  h.n = std::min(h.n + 1, 3);
}

}  // namespace gm
