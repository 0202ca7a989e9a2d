// Contact detection for aligned spur pairs, external and internal (PHYSICS.md section 3).
#include "detection.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "geometry.hpp"

namespace gm {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Integer part n and fraction f of x / period with x = n period + f, 0 <= f < period.
void split_periods(double x, double period, double& n, double& f) {
  n = std::floor(x / period);
  f = x - n * period;
  if (f < 0) f = 0;
  if (f >= period) f = std::nextafter(period, 0.0);
}

// Tooth index in [0, z) of the tooth m periods after the reference one.
int tooth_index(double n, double m, int sigma, int z) {
  double k = std::fmod(sigma * (m - n), static_cast<double>(z));
  if (k < 0) k += z;
  return static_cast<int>(k) % z;
}

}  // namespace

MeshLayout make_mesh_layout(const gm_model_params& p, const gm_pair_geometry& g) {
  MeshLayout L;
  L.sign = p.pair.internal ? -1 : 1;
  L.base_pitch = g.p_bt;
  L.center_distance = p.pair.center_distance;
  L.slices = p.slices;
  const double inv_w = involute(g.alpha_wt);
  for (int i = 0; i < 2; ++i) {
    const gm_gear_geometry& gi = g.gear[i];
    L.teeth[i] = p.gear[i].teeth;
    L.base_radius[i] = 0.5 * gi.d_b;
    L.eta[i] = gi.eta_b;
    L.rho_tip[i] = gi.rho_a;
    L.rho_form[i] = gi.rho_Ff;
    L.face_width[i] = p.gear[i].face_width;
    L.axial_offset[i] = p.gear[i].axial_offset;
    // External: the mesh lies at +x of gear 1 and at -x of gear 2. Internal: the pinion sits
    // inside the ring at the ring's -x side, so both see the mesh at -x.
    L.zeta[i] = (i == 0 && L.sign > 0) ? 0.0 : kPi;
    // Reference configuration (PHYSICS 0): at phi = 0 the flank A involutes of tooth 0 and of
    // tooth (space) 0 meet at the pitch point, rho_i = r_bi tan alpha_wt.
    L.theta0[i] = L.zeta[i] + inv_w - L.eta[i];
  }
  return L;
}

int slice_capacity(const MeshLayout& L) {
  // Tooth pairs per flank: the active span of gear 1's flank in base pitches, plus margin.
  const double span1 = L.rho_tip[0] - L.rho_form[0];
  const double span2 = std::fabs(L.rho_tip[1] - L.rho_form[1]);
  const int pairs = static_cast<int>(std::ceil(std::min(span1, span2) / L.base_pitch)) + 3;
  return 2 * pairs * L.slices;
}

int detect_contacts(const MeshLayout& L, const gm_kinematics& kin, ContactSlice* out, int capacity,
                    std::string& msg) {
  const int s = L.sign;
  const Eigen::Vector3d c1(kin.u[0][0], kin.u[0][1], kin.u[0][2]);
  const Eigen::Vector3d c2(L.center_distance + kin.u[1][0], kin.u[1][1], kin.u[1][2]);
  const double dx = c2.x() - c1.x(), dy = c2.y() - c1.y();
  const double a = std::hypot(dx, dy);
  const double gamma = std::atan2(dy, dx);
  const double alpha_w =
      operating_pressure_angle(L.base_radius[0], L.base_radius[1], s < 0, a);
  if (!std::isfinite(alpha_w)) {
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "centre distance %.6g m (from gear1.ux/uy, gear2.ux/uy) is below the base-circle "
                  "limit %.6g m: the gears cannot mesh there",
                  a, s > 0 ? L.base_radius[0] + L.base_radius[1]
                           : L.base_radius[1] - L.base_radius[0]);
    msg = buf;
    return -1;
  }
  const double T1T2 = a * std::sin(alpha_w);

  // Axial overlap of the two face widths, split into equal slices.
  const double z1lo = c1.z() + L.axial_offset[0] - 0.5 * L.face_width[0];
  const double z2lo = c2.z() + L.axial_offset[1] - 0.5 * L.face_width[1];
  const double zlo = std::max(z1lo, z2lo);
  const double zhi = std::min(z1lo + L.face_width[0], z2lo + L.face_width[1]);
  if (zhi <= zlo) return 0;
  const double width = (zhi - zlo) / L.slices;

  // Active range of the contact position t (from T1 along the line of action): gear 1 between
  // its form and tip circles, gear 2 likewise, with rho_2 = T1T2 - s t.
  double t_lo = L.rho_form[0], t_hi = L.rho_tip[0];
  if (s > 0) {
    t_lo = std::max(t_lo, T1T2 - L.rho_tip[1]);
    t_hi = std::min(t_hi, T1T2 - L.rho_form[1]);
  } else {
    t_lo = std::max(t_lo, L.rho_tip[1] - T1T2);
    t_hi = std::min(t_hi, L.rho_form[1] - T1T2);
  }
  if (t_hi <= t_lo) return 0;

  const double pb = L.base_pitch;
  const double rb1 = L.base_radius[0], rb2 = L.base_radius[1];
  const double tau1 = 2 * kPi / L.teeth[0], tau2 = 2 * kPi / L.teeth[1];
  int count = 0, pair = 0;
  for (int sigma = 1; sigma >= -1; sigma -= 2) {
    // Reduce the unbounded angles to a period so that roll distances keep full precision.
    double n1, f1, n2, f2;
    split_periods(sigma * (L.theta0[0] + kin.phi[0] - gamma - L.zeta[0]), tau1, n1, f1);
    split_periods(sigma * (L.theta0[1] + kin.phi[1] - gamma - L.zeta[1]), tau2, n2, f2);
    const double base1 = rb1 * (f1 + L.eta[0] + alpha_w);  // rho_1 = base1 + m1 p_bt
    const double base2 = rb2 * (f2 + L.eta[1] + alpha_w);  // rho_2 = base2 + m2 p_bt
    const double m_first = std::ceil((t_lo - 0.5 * pb - base1) / pb);
    const double m_last = std::floor((t_hi + 0.5 * pb - base1) / pb);
    const double th_T1 = gamma + L.zeta[0] - sigma * alpha_w;
    const Eigen::Vector3d T1 = c1 + rb1 * Eigen::Vector3d(std::cos(th_T1), std::sin(th_T1), 0);
    const double cg = std::cos(gamma), sg = std::sin(gamma);
    const double nx = s * std::sin(alpha_w), ny = s * sigma * std::cos(alpha_w);
    const Eigen::Vector3d normal(cg * nx - sg * ny, sg * nx + cg * ny, 0);
    for (double m1 = m_first; m1 <= m_last; m1 += 1) {
      const double rho1 = base1 + m1 * pb;
      const double m2 = std::nearbyint((T1T2 - s * rho1 - base2) / pb);
      const double rho2 = base2 + m2 * pb;
      const double approach = rho1 + s * rho2 - s * T1T2;
      const double t = rho1 - 0.5 * approach;  // contact point midway between the two flanks
      if (t < t_lo || t > t_hi) continue;
      if (approach > 0.25 * pb) {
        char buf[240];
        std::snprintf(buf, sizeof buf,
                      "flank %c approach %.6g m exceeds the detection range (a quarter base "
                      "pitch, %.6g m): the spin angles gear1.phi/gear2.phi are not physical",
                      sigma > 0 ? 'A' : 'B', approach, 0.25 * pb);
        msg = buf;
        return -1;
      }
      const Eigen::Vector3d on_line = T1 + t * normal;
      for (int k = 0; k < L.slices; ++k) {
        if (count >= capacity) {
          msg = "internal error: more candidate slices than the model's capacity";
          return -1;
        }
        ContactSlice& c = out[count++];
        c.flank = sigma;
        c.tooth[0] = tooth_index(n1, m1, sigma, L.teeth[0]);
        c.tooth[1] = tooth_index(n2, m2, sigma, L.teeth[1]);
        c.pair = pair;
        c.approach = approach;
        c.width = width;
        c.roll[0] = t;
        c.roll[1] = T1T2 - s * t;
        c.point = Eigen::Vector3d(on_line.x(), on_line.y(), zlo + (k + 0.5) * width);
        c.normal = normal;
      }
      ++pair;
    }
  }
  return count;
}

}  // namespace gm
