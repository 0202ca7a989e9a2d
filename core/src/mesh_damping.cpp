// The contact damping that gives the mesh mode a damping ratio (gearmesh.h,
// gm_mesh_damping_for_ratio; docs/dynamics.md, "Mesh damping").
//
// The mesh mode: the two gears moving apart on the line of action, TE = r_b1 phi_1 + s r_b2 phi_2,
// with the equivalent mass m_eq = 1 / (r_b1^2 / J_1 + r_b2^2 / J_2). Its damping ratio zeta takes
// the viscous coefficient c = 2 zeta sqrt(k m_eq) on the TE rate, k the mesh stiffness. Both k
// and c vary over a mesh period (pairs entering and leaving, the loaded contact reaching beyond
// the nominal path): the ratio is set on their means over a base pitch, as the element itself
// has them at ISO 6336-1's reference line load of 100 N/mm (its TE there from ISO's c_gamma_alpha,
// only to choose the load). The element damps each loaded slice with model.damping x width x
// normal approach rate (resultants.hpp), so c is linear in model.damping: a probe model with
// model.damping = 1 N s/m^2 gives c per unit damping as its damping power over the TE rate squared.
#include <algorithm>
#include <cmath>
#include <string>

#include "params.hpp"
#include "stiffness_iso.hpp"

namespace {

constexpr int kPositions = 24;  // over a base pitch

// TE and TE rate held, gear 1 at phi1: the spins.
gm_kinematics at_te(const gm_pair_geometry& g, int sign, double phi1, double te, double te_rate) {
  const double rb1 = 0.5 * g.gear[0].d_b, rb2 = 0.5 * g.gear[1].d_b;
  gm_kinematics k{};
  k.phi[0] = phi1;
  k.phi[1] = (te - rb1 * phi1) / (sign * rb2);
  k.omega[1] = te_rate / (sign * rb2);
  return k;
}

}  // namespace

extern "C" gm_status gm_mesh_damping_for_ratio(const gm_model_params* p, const double inertia[2], double ratio,
                                               double* damping, char* msg, size_t msg_size) {
  std::string text;
  const auto done = [&](gm_status status) {
    if (msg && msg_size) {
      const size_t n = std::min(text.size(), msg_size - 1);
      text.copy(msg, n);
      msg[n] = '\0';
    }
    return status;
  };
  if (!p || !inertia || !damping) return text = "NULL argument", done(GM_ERR_ARGUMENT);
  gm_model* probe = nullptr;
  gm_data* data = nullptr;
  const auto finish = [&](gm_status status) {
    gm_data_free(data);
    gm_model_free(probe);
    return done(status);
  };
  try {
    const char* const ratio_name = GM_HOST_PARAM_NAME(mesh_damping_ratio);
    if (!gm::check_range(ratio_name, ratio, text) ||
        !gm::check_range(GM_DYNAMICS_PARAM_NAME(inertia[0]), inertia[0], text) ||
        !gm::check_range(GM_DYNAMICS_PARAM_NAME(inertia[1]), inertia[1], text))
      return done(GM_ERR_PARAMETER);
    *damping = 0;
    if (ratio == 0) return done(GM_OK);
    gm_model_params q = *p;
    q.damping = 1.0;
    q.quasi_static = 0;
    char buf[1024] = "";
    gm_status st = gm_model_create(&q, &probe, buf, sizeof buf);
    if (st != GM_OK) return text = buf, finish(st);
    if (gm_data_create(probe, &data) != GM_OK) return text = "out of memory", finish(GM_ERR_MEMORY);
    const gm_pair_geometry& g = *gm_model_geometry(probe);
    gm::IsoStiffness iso;
    st = gm::iso_stiffness(q, g, gm::IsoGearBlank{}, iso, text);
    if (st != GM_OK) return text = std::string(ratio_name) + ": " + text, finish(st);
    const double te = gm::kIsoReferenceLineLoad / iso.c_gamma_alpha / std::cos(g.beta_b);
    const double rate = 1e-3;  // m/s of TE rate
    const int sign = q.pair.internal ? -1 : 1;
    const double rb1 = 0.5 * g.gear[0].d_b, rb2 = 0.5 * g.gear[1].d_b;
    double k_sum = 0, c_sum = 0;
    for (int i = 0; i < kPositions; ++i) {
      const double phi1 = g.p_bt / rb1 * (i + 0.5) / kPositions;
      gm_result r;
      gm_kinematics k = at_te(g, sign, phi1, te, 0.0);
      if ((st = gm_evaluate(probe, data, &k, &r)) != GM_OK) return text = gm_data_message(data), finish(st);
      k_sum += r.stiffness;
      k = at_te(g, sign, phi1, te, rate);
      if ((st = gm_evaluate(probe, data, &k, &r)) != GM_OK) return text = gm_data_message(data), finish(st);
      c_sum += r.damping_power / (rate * rate);
    }
    const double m_eq = 1.0 / (rb1 * rb1 / inertia[0] + rb2 * rb2 / inertia[1]);
    if (!(k_sum > 0 && c_sum > 0))
      return text = std::string(ratio_name) + ": the mesh carries no load at ISO's reference line load",
             finish(GM_ERR_PARAMETER);
    *damping = 2.0 * ratio * std::sqrt(k_sum / kPositions * m_eq) / (c_sum / kPositions);
    return finish(GM_OK);
  } catch (const std::exception& e) {
    text = e.what();
    return finish(GM_ERR_MEMORY);
  }
}
