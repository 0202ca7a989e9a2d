// gm_evaluate: one pipeline for both modes (pipeline.hpp). Plain mode runs one pass at the
// given pose; quasi-static mode runs the same pass at the TE estimate, solving the load balance,
// until the solved move no longer changes what detection sees. Then the resultants and the TE.
#include "evaluate.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "dense_solve.hpp"
#include "inputs.hpp"
#include "pipeline.hpp"
#include "resultants.hpp"

namespace gm {

namespace {

// One gm_evaluate at the pose `given`: the pose it detects at and what its passes solved, in and
// out of each stage.
struct Evaluation {
  Evaluation(const MeshLayout& L, const gm_kinematics& given)
      : kin(reduced_pose(L, given, &phi2_offset)), phi1_in(given.phi[0]) {}
  double phi2_offset = 0;  // quasi-static: gear 2's whole-turn-reduced spin offset, rad (first:
                           // reduced_pose writes it)
  gm_kinematics kin;       // the pose reduced (reduced_pose); quasi-static: gear 2's spin solved
  double phi1_in;          // gear 1's spin as given, rad
  int n = 0;               // candidates of the last pass
  double te = 0;           // quasi-static: the solved TE, m
  gm_result r{};           // solver iterations and residual, then the outputs
};

// Plain mode: one pass at the pose as given.
gm_status plain_solve(const gm_model& m, gm_data& d, Evaluation& e) {
  ForceProblem problem;
  problem.pose = &e.kin;
  const PassResult pr = solve_pass(m, d, problem);
  e.n = pr.n;
  if (pr.status != GM_OK) return pr.status;
  e.r.solver_iterations = pr.solve.iterations;
  e.r.solver_residual = pr.solve.residual;
  return GM_OK;
}

constexpr int kMaxPasses = 6;  // quasi-static passes per evaluation

// Quasi-static mode (docs/physics.md §6): gear 2's spin follows from the load torque. Detect at
// the TE estimate, solve the load balance for the rigid approach lambda, move there, and repeat
// while the move changes what detection sees (tip edges); the estimate carries over calls.
// e.kin: gear 2's spin is set to the solved TE's; e.te: the solved TE, m.
gm_status quasi_static_solve(const gm_model& m, gm_data& d, Evaluation& e) {
  const MeshLayout& L = m.layout;
  const bool coupled = m.level.coupled;
  const double s = L.sign, rb1 = L.base_radius[0], rb2 = L.base_radius[1];
  gm_kinematics& kin = e.kin;
  double& te = e.te;
  ForceProblem problem;
  problem.pose = &kin;  // gear 2's spin set before each pass
  problem.all = problem.quasi = true;
  problem.load = kin.load_torque / rb2;  // the TE coordinate's force, N
  const double settled = std::max(m.params.solver_tolerance, 1e-12 * L.base_pitch);  // m
  te = coupled ? predicted_te(d, e.phi1_in, kin.load_torque) : d.te_estimate;
  for (int pass = 0; pass < kMaxPasses; ++pass) {
    kin.phi[1] = (te - rb1 * kin.phi[0]) / (s * rb2) + e.phi2_offset;
    problem.next_pass_above = pass + 1 < kMaxPasses ? settled : std::numeric_limits<double>::infinity();
    const PassResult pr = solve_pass(m, d, problem);  // detection redone every pass
    e.n = pr.n;
    if (pr.status != GM_OK) return pr.status;
    e.r.solver_iterations += pr.solve.iterations;
    e.r.solver_residual = pr.solve.residual;
    te += pr.solve.lambda;
    if (std::fabs(pr.solve.lambda) <= settled) break;
  }
  kin.phi[1] = (te - rb1 * kin.phi[0]) / (s * rb2) + e.phi2_offset;
  d.te_estimate = te;
  if (coupled) record_te(d, e.phi1_in, te, kin.load_torque);
  // The last pass ends at the solved pose; its slice forces belong to approach + gain lambda.
  for (int i = 0; i < e.n; ++i) d.slices[i].approach = d.approach[i];
  return GM_OK;
}

// The outputs of the solved slices.
void store_resultants(const gm_model& m, gm_data& d, Evaluation& e) {
  const int n = e.n;
  gm_result& r = e.r;
  ResultT<double> rt;
  rt.elastic_energy = std::isnan(d.dense_energy) ? elastic_energy<double>(d, n) : d.dense_energy;  // before damping
  resultants(m, d, e.kin, n, rt);
  store_result(rt, r);
  int loaded = 0;  // the loaded slices, for gm_data_load_distribution
  for (int i = 0; i < n; ++i) {
    const ContactSlice& s = d.slices[i];
    if (d.forces[i] > 0)
      d.loaded[loaded++] = {s.pair, s.slice, s.run, s.flank, d.forces[i], s.width, s.path_position, s.approach};
  }
  d.loaded_count = loaded;
}

}  // namespace

gm_status evaluate(const gm_model& m, gm_data& d, const gm_kinematics& kin_in, gm_result& res) {
  d.loaded_count = 0;
  if (!inputs_valid(kin_in, d.message)) return GM_ERR_INPUT;
  const MeshLayout& L = m.layout;
  Evaluation e(L, kin_in);
  const gm_status st = m.params.quasi_static ? quasi_static_solve(m, d, e) : plain_solve(m, d, e);
  if (st != GM_OK) return st;
  store_resultants(m, d, e);
  gm_result& r = e.r;
  // TE from the spin angles as given, as encoders measure it; solved in quasi-static mode.
  r.te = m.params.quasi_static
             ? e.te
             : L.base_radius[0] * kin_in.phi[0] + L.sign * L.base_radius[1] * kin_in.phi[1];
  r.te_angle = r.te / L.base_radius[1];
  res = r;
  d.message.clear();
  return GM_OK;
}

}  // namespace gm
