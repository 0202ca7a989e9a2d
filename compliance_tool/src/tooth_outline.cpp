#include "tooth_outline.hpp"

#include <algorithm>
#include <cmath>

namespace gm::mesh {

gm_status build_tooth_outline(const gm_model_params& p, const gm_pair_geometry& g, int gear,
                              int fillet_points, int involute_points, ToothOutline& out,
                              std::string& msg) {
  out = ToothOutline{};
  msg.clear();
  if (gear == 1 && p.pair.internal) {
    msg = "gear mesher: internal ring gears are not yet supported";
    return GM_ERR_PARAMETER;
  }
  ToothSectionOptions so;
  so.table_points = 4;  // the compliance table is not used here
  so.panels = 1;
  const gm_status st = build_tooth_section(p, g, gear, so, out.section, msg);
  if (st != GM_OK) {
    msg = "gear mesher: " + msg;
    return st;
  }
  const ToothSection& s = out.section;
  fillet_points = std::max(2, fillet_points);
  involute_points = std::max(2, involute_points);

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
