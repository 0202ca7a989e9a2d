// Level 4's tooth coupling: the fitted table and its interpolation (tooth_coupling.hpp).
#include "tooth_coupling.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "params.hpp"

namespace gm {
namespace {

struct CouplingRow {
  int teeth;
  double width_over_module;
  double c[kCouplingMaxOffset][4];
};

// Rows sorted by teeth, then b/m_n; every tooth count has the same b/m_n values.
const CouplingRow kTable[] = {
#include "tooth_coupling_table.inc"
};
constexpr int kRows = int(sizeof(kTable) / sizeof(kTable[0]));

int widths_per_tooth_count() {
  int n = 1;
  while (n < kRows && kTable[n].teeth == kTable[0].teeth) ++n;
  return n;
}

// Index i and weight w (of i) for x on the increasing grid g[0..n) with stride; clamped.
void bracket(double x, const double* g, int n, int& i, double& w, bool& outside) {
  if (n == 1) {
    i = 0;
    w = 1;
    outside = outside || x != g[0];
    return;
  }
  if (x <= g[0] || x >= g[n - 1]) outside = outside || x < g[0] || x > g[n - 1];
  const double xc = std::min(std::max(x, g[0]), g[n - 1]);
  i = 0;
  while (i + 2 < n && xc > g[i + 1]) ++i;
  w = (g[i + 1] - xc) / (g[i + 1] - g[i]);
}

}  // namespace

void coupling_table_range(double& teeth_min, double& teeth_max, double& width_min,
                          double& width_max) {
  const int nw = widths_per_tooth_count();
  teeth_min = kTable[0].teeth;
  teeth_max = kTable[kRows - 1].teeth;
  width_min = kTable[0].width_over_module;
  width_max = kTable[nw - 1].width_over_module;
}

CouplingCoefficients coupling_coefficients(double teeth, double width_over_module) {
  const int nw = widths_per_tooth_count();
  const int nz = kRows / nw;
  // grids: 1/z decreasing with z, so interpolate over -1/z (increasing)
  double gz[64], gw[64];
  for (int a = 0; a < nz && a < 64; ++a) gz[a] = -1.0 / kTable[a * nw].teeth;
  for (int b = 0; b < nw && b < 64; ++b) gw[b] = kTable[b].width_over_module;
  CouplingCoefficients out;
  int iz = 0, iw = 0;
  double wz = 1, ww = 1;
  bracket(-1.0 / teeth, gz, std::min(nz, 64), iz, wz, out.extrapolated);
  // b/m_n beyond the table's widths: the edge's coefficients, not flagged (tooth_coupling.hpp)
  bool width_outside = false;
  bracket(width_over_module, gw, std::min(nw, 64), iw, ww, width_outside);
  const int z1 = nz > 1 ? iz + 1 : iz, w1 = nw > 1 ? iw + 1 : iw;
  for (int d = 0; d < kCouplingMaxOffset; ++d) {
    for (int q = 0; q < 4; ++q) {
      const double c00 = kTable[iz * nw + iw].c[d][q], c01 = kTable[iz * nw + w1].c[d][q];
      const double c10 = kTable[z1 * nw + iw].c[d][q], c11 = kTable[z1 * nw + w1].c[d][q];
      out.c[d][q] = wz * (ww * c00 + (1 - ww) * c01) + (1 - wz) * (ww * c10 + (1 - ww) * c11);
    }
  }
  return out;
}

gm_status build_tooth_coupling(const gm_model_params& p, const gm_pair_geometry& g,
                               ToothCoupling& out, std::string& warning, std::string& msg) {
  out = ToothCoupling{};
  warning.clear();
  if (p.coupled_teeth < 0 || p.coupled_teeth > kCouplingMaxOffset) {
    msg = std::string(GM_PARAM_NAME(coupled_teeth)) + " = " + std::to_string(p.coupled_teeth) +
          ": level 4 (analytical) couples at most " + std::to_string(kCouplingMaxOffset) +
          " neighbouring teeth each side (its fitted table, core/src/tooth_coupling_table.inc); "
          "allowed range [0, " +
          std::to_string(kCouplingMaxOffset) + "]";
    return GM_ERR_PARAMETER;
  }
  if (p.pair.internal) {
    msg = std::string(GM_PARAM_NAME(stiffness_level)) +
          " = 4 (analytical): the tooth coupling of an internal ring is not modelled (level 4 has no ring teeth)";
    return GM_ERR_PARAMETER;
  }
  out.offsets = p.coupled_teeth;
  const double mn = p.pair.normal_module;
  // the axial overlap of the two faces (mid-faces at their axial offsets)
  const double lo = std::max(p.gear[0].axial_offset - 0.5 * p.gear[0].face_width,
                             p.gear[1].axial_offset - 0.5 * p.gear[1].face_width);
  const double hi = std::min(p.gear[0].axial_offset + 0.5 * p.gear[0].face_width,
                             p.gear[1].axial_offset + 0.5 * p.gear[1].face_width);
  const double overlap = hi - lo;
  if (!(overlap > 0)) {
    msg = std::string(GM_GEAR_PARAM_NAME(0, axial_offset)) + ", " + GM_GEAR_PARAM_NAME(1, axial_offset) +
          ": the faces do not overlap axially";
    return GM_ERR_PARAMETER;
  }
  for (int i = 0; i < 2; ++i) {
    ToothCouplingGear& c = out.gear[i];
    c.teeth = p.gear[i].teeth;
    c.base_radius = 0.5 * g.gear[i].d_b;
    c.ref_radius = 0.5 * g.gear[i].d;
    c.inv_module = 1.0 / mn;
    c.scale = 1.0 / (p.gear[i].youngs_modulus * overlap);
    c.k = coupling_coefficients(p.gear[i].teeth, p.gear[i].face_width / mn);
    // a tooth offset reaching half-way round the gear: the coupling wraps, not modelled
    if (2 * out.offsets >= c.teeth) out.offsets = (c.teeth - 1) / 2;
    if (c.k.extrapolated && out.offsets > 0) {
      double z0, z1, w0, w1;
      coupling_table_range(z0, z1, w0, w1);
      char text[256];
      std::snprintf(text, sizeof text,
                    "%s = %d outside level 4's tooth-coupling table (z %g..%g; coefficients of its edge)",
                    GM_GEAR_PARAM_NAME(i, teeth), c.teeth, z0, z1);
      if (!warning.empty()) warning += "; ";
      warning += text;
    }
  }
  if (out.offsets > 0 && p.pair.helix_angle != 0) {
    // the face-uniform kernel (tooth_coupling.hpp) leaves the helical ripple as uncoupled:
    // measured in docs/model.md, "Tooth coupling at level 4"
    char text[256];
    std::snprintf(text, sizeof text,
                  "%s = %g deg: level 4's tooth coupling is validated for spur gears; on a helical pair it "
                  "corrects the mean TE, not the TE ripple",
                  GM_PARAM_NAME(pair.helix_angle), p.pair.helix_angle * 180 / 3.14159265358979323846);
    if (!warning.empty()) warning += "; ";
    warning += text;
  }
  return GM_OK;
}

}  // namespace gm
