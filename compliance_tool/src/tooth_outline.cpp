#include "tooth_outline.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "gearmesh/internal/geometry.hpp"

namespace gm::mesh {
namespace {

constexpr double kPi = 3.14159265358979323846;

// The ring's space outline (see the header), flank A (+y) in the space's frame.
gm_status ring_outline(const gm_model_params& p, const gm_pair_geometry& g, int fillet_points,
                       int involute_points, ToothOutline& out, std::string& msg) {
  const gm_gear_geometry& q = g.gear[1];
  const int z = p.gear[1].teeth;
  out.ring = true;
  const double rb = 0.5 * q.d_b, ra = 0.5 * q.d_a, rf = 0.5 * q.d_f, rF = 0.5 * q.d_Ff;
  out.base_radius = rb;
  out.root_radius = rf;
  out.form_radius = rF;
  out.tip_radius = ra;
  out.eta_b = q.eta_b;
  char buf[320];
  if (!(rF < rf)) {
    std::snprintf(buf, sizeof buf, "gear mesher: the ring's form circle (d_Ff %.6g m) is not inside "
                  "its root circle (d_f %.6g m): no room for a root fillet", q.d_Ff, q.d_f);
    msg = buf;
    return GM_ERR_PARAMETER;
  }
  // Involute of flank A, form circle -> tip circle, uniform in roll distance.
  const double rho0 = std::sqrt(rF * rF - rb * rb), rho1 = std::sqrt(ra * ra - rb * rb);
  out.tip_pressure_angle = std::acos(rb / ra);
  for (int k = 0; k < involute_points; ++k) {
    const double rho = rho0 + (rho1 - rho0) * k / (involute_points - 1);
    const double al = std::atan2(rho, rb), R = std::hypot(rb, rho);
    const double phi = q.eta_b - involute(al);
    out.involute.emplace_back(R * std::cos(phi), R * std::sin(phi));
  }
  // Circular fillet: tangent to the involute at P_F (normal into the space: from P_F back towards
  // its base tangency point T) and to the root circle from inside.
  const Eigen::Vector2d P = out.involute.front();
  const double alF = std::atan2(rho0, rb), phiF = std::atan2(P.y(), P.x());
  const Eigen::Vector2d T(rb * std::cos(phiF - alF), rb * std::sin(phiF - alF));
  const Eigen::Vector2d n_space = (T - P).normalized();
  const double rc = (rf * rf - rF * rF) / (2.0 * (rf - rho0));
  out.fillet_radius = rc;
  const Eigen::Vector2d C = P + rc * n_space;
  const Eigen::Vector2d Q = C * (rf / C.norm());
  const double a0 = std::atan2(Q.y() - C.y(), Q.x() - C.x());
  const double da = std::remainder(std::atan2(P.y() - C.y(), P.x() - C.x()) - a0, 2.0 * kPi);
  for (int k = 0; k < fillet_points; ++k) {
    const double a = a0 + da * k / (fillet_points - 1);
    out.fillet.emplace_back(C.x() + rc * std::cos(a), C.y() + rc * std::sin(a));
  }
  out.fillet.front() = Q;
  out.fillet.back() = P;
  out.root_half_angle = std::atan2(Q.y(), Q.x());
  out.tip_half_angle = std::atan2(out.involute.back().y(), out.involute.back().x());
  if (!(out.root_half_angle > 0.0)) {
    msg = "gear mesher: the ring's root fillets of one space overlap (no root land)";
    return GM_ERR_PARAMETER;
  }
  if (!(out.tip_half_angle > 0.0) || !(out.tip_half_angle < kPi / z)) {
    msg = "gear mesher: the ring's teeth are pointed at the tip (inner) diameter (no tip land)";
    return GM_ERR_PARAMETER;
  }
  return GM_OK;
}

}  // namespace

gm_status build_tooth_outline(const gm_model_params& p, const gm_pair_geometry& g, int gear,
                              int fillet_points, int involute_points, ToothOutline& out,
                              std::string& msg) {
  out = ToothOutline{};
  msg.clear();
  fillet_points = std::max(2, fillet_points);
  involute_points = std::max(2, involute_points);
  if (gear == 1 && p.pair.internal)
    return ring_outline(p, g, fillet_points, involute_points, out, msg);
  ToothSectionOptions so;
  so.table_points = 4;  // the compliance table is not used here
  so.panels = 1;
  const gm_status st = build_tooth_section(p, g, gear, so, out.section, msg);
  if (st != GM_OK) {
    msg = "gear mesher: " + msg;
    return st;
  }
  const ToothSection& s = out.section;
  out.base_radius = s.base_radius;
  out.root_radius = s.root_radius;
  out.form_radius = s.form_radius;
  out.tip_radius = s.tip_radius;
  out.eta_b = s.eta_b;

  for (int k = 0; k < fillet_points; ++k) {
    const BeamStation b = tooth_fillet_station(s, s.fillet_end * k / (fillet_points - 1));
    out.fillet.emplace_back(b.y, b.half_thickness);
  }
  const double rb = s.base_radius;
  out.tip_pressure_angle = std::acos(rb / s.tip_radius);
  const double rho0 = std::tan(s.form_pressure_angle) * rb;
  const double rho1 = std::tan(out.tip_pressure_angle) * rb;
  for (int k = 0; k < involute_points; ++k) {
    const double rho = rho0 + (rho1 - rho0) * k / (involute_points - 1);
    const BeamStation b = tooth_involute_station(s, std::atan2(rho, rb));
    out.involute.emplace_back(b.y, b.half_thickness);
  }
  out.root_half_angle = std::atan2(out.fillet.front().y(), out.fillet.front().x());
  out.tip_half_angle = std::atan2(out.involute.back().y(), out.involute.back().x());
  if (!(out.tip_half_angle > 0.0)) {
    msg = "gear mesher: the tooth is pointed (no tip land at the tip diameter)";
    return GM_ERR_PARAMETER;
  }
  const int z = p.gear[gear].teeth;
  if (!(out.root_half_angle > 0.0) || !(2.0 * out.root_half_angle < 2.0 * 3.14159265358979323846 / z)) {
    msg = "gear mesher: the fillets of neighbouring teeth overlap at the root circle";
    return GM_ERR_PARAMETER;
  }
  return GM_OK;
}

}  // namespace gm::mesh
