// Gear-body mesher (compliance_tool/src/gear_mesh.hpp): volume against the exact section area,
// flank nodes on the involute, element counts from the options, bore nodes on the bore, helix.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <tuple>

#include <Eigen/Geometry>
#include <cstdio>
#include <string>

#include <gmsh.h>

#include "gear_mesh.hpp"
#include "gearmesh/gearmesh.h"
#include "gearmesh/internal/tooth_compliance.hpp"

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Gear {
  gm_model_params p;
  gm_pair_geometry g;
};

// z1 = 20 (the gear under test), z2 = 40, m 2 mm, b 10 mm, x = 0, optional helix.
Gear small_gear(double beta = 0) {
  Gear G;
  gm_default_params(&G.p);
  G.p.pair.normal_module = 0.002;
  G.p.pair.helix_angle = beta;
  G.p.gear[0].teeth = 20;
  G.p.gear[1].teeth = 40;
  for (int i = 0; i < 2; ++i) {
    G.p.gear[i].profile_shift = 0;
    G.p.gear[i].face_width = 0.010;
    G.p.gear[i].tip_diameter = 0;
  }
  G.p.pair.center_distance = 0.5 * 0.002 / std::cos(beta) * 60;
  char msg[512];
  EXPECT_EQ(gm_compute_geometry(&G.p, &G.g, msg, sizeof msg), GM_OK) << msg;
  return G;
}

gm::mesh::GearBodyMesh mesh_of(const Gear& G, const gm::mesh::GearBodyOptions& o) {
  gm::mesh::GearBodyMesh m;
  std::string msg;
  EXPECT_EQ(gm::mesh::build_gear_body(G.p, G.g, 0, o, m, msg), GM_OK) << msg;
  return m;
}

// Exact area of the section from a dense polygon of the core's own profile (independent of the
// mesher's spline construction): all teeth, minus the bore.
double exact_area(const Gear& G, double bore) {
  gm::ToothSection s;
  std::string msg;
  gm::ToothSectionOptions so;
  EXPECT_EQ(gm::build_tooth_section(G.p, G.g, 0, so, s, msg), GM_OK) << msg;
  const int z = G.p.gear[0].teeth, n = 2000;
  std::vector<std::pair<double, double>> half;  // flank A from root to tip (x, y)
  for (int i = 0; i <= n; ++i) {
    const gm::BeamStation b = gm::tooth_fillet_station(s, s.fillet_end * i / n);
    half.push_back({b.y, b.half_thickness});
  }
  const double aa = std::acos(s.base_radius / s.tip_radius);
  for (int i = 1; i <= n; ++i) {
    const gm::BeamStation b =
        gm::tooth_involute_station(s, s.form_pressure_angle + (aa - s.form_pressure_angle) * i / n);
    half.push_back({b.y, b.half_thickness});
  }
  std::vector<std::pair<double, double>> poly;
  for (int k = 0; k < z; ++k) {
    const double a = 2 * kPi * k / z, c = std::cos(a), sn = std::sin(a);
    auto put = [&](double x, double y) { poly.push_back({c * x - sn * y, sn * x + c * y}); };
    for (const auto& q : half) put(q.first, -q.second);  // flank B up
    const double th = std::atan2(half.back().second, half.back().first);
    for (int i = 1; i < n; ++i) {  // tip arc
      const double t = -th + 2 * th * i / n;
      put(s.tip_radius * std::cos(t), s.tip_radius * std::sin(t));
    }
    for (auto it = half.rbegin(); it != half.rend(); ++it) put(it->first, it->second);  // A down
    const double tf = std::atan2(half.front().second, half.front().first);
    for (int i = 1; i < n; ++i) {  // root arc
      const double t = tf + (2 * kPi / z - 2 * tf) * i / n;
      put(s.root_radius * std::cos(t), s.root_radius * std::sin(t));
    }
  }
  double A = 0;
  for (size_t i = 0; i < poly.size(); ++i) {
    const auto& p0 = poly[i];
    const auto& p1 = poly[(i + 1) % poly.size()];
    A += p0.first * p1.second - p1.first * p0.second;
  }
  return 0.5 * A - kPi * bore * bore;
}

// Angle of a flank node from the involute of its tooth and flank, times its radius: the
// distance from the exact involute (helix removed), m.
double involute_error(const gm::mesh::GearBodyMesh& m, int k, int f, const Eigen::Vector3d& x) {
  const double R = std::hypot(x.x(), x.y());
  const double rb = m.base_radius;
  const double al = std::acos(std::min(1.0, rb / R));
  const double eta = m.eta_b - (std::tan(al) - al);
  const double centre = 2 * kPi * k / m.teeth + m.hand * m.twist_rate * x.z();
  const double expect = centre + (f == 0 ? eta : -eta);
  double d = std::atan2(x.y(), x.x()) - expect;
  d = std::remainder(d, 2 * kPi);
  return std::abs(d) * R;
}

TEST(GearMesh, SpurVolumeFlanksBore) {
  const Gear G = small_gear();
  gm::mesh::GearBodyOptions o;
  o.bore_radius = 0.008;
  const auto m = mesh_of(G, o);
  ASSERT_FALSE(m.tets.empty());
  const double V = gm::mesh::tet10_volume(m.nodes, m.tets);
  const double Vx = exact_area(G, o.bore_radius) * 0.010;
  EXPECT_NEAR(V / Vx, 1.0, 0.005) << "V " << V << " exact " << Vx;
  // Bounds: between the root and tip discs.
  EXPECT_GT(V, kPi * (m.root_radius * m.root_radius - 0.008 * 0.008) * 0.010);
  EXPECT_LT(V, kPi * (m.tip_radius * m.tip_radius - 0.008 * 0.008) * 0.010);
  // Bore nodes on the bore, spanning the face.
  ASSERT_FALSE(m.clamped_nodes.empty());
  double zmin = 1, zmax = -1;
  for (int id : m.clamped_nodes) {
    const auto& x = m.nodes[id];
    EXPECT_NEAR(std::hypot(x.x(), x.y()), 0.008, 1e-9);
    zmin = std::min(zmin, x.z());
    zmax = std::max(zmax, x.z());
  }
  EXPECT_NEAR(zmin, -0.005, 1e-12);
  EXPECT_NEAR(zmax, 0.005, 1e-12);
  // Flank nodes on the involute within 1 um, roll and face consistent, all teeth, both flanks.
  ASSERT_EQ(static_cast<int>(m.flanks.size()), 20);
  double worst = 0;
  for (int k = 0; k < 20; ++k)
    for (int f = 0; f < 2; ++f) {
      ASSERT_FALSE(m.flanks[k][f].empty());
      for (const auto& fn : m.flanks[k][f]) {
        const auto& x = m.nodes[fn.node];
        worst = std::max(worst, involute_error(m, k, f, x));
        const double R = std::hypot(x.x(), x.y());
        EXPECT_NEAR(fn.roll, std::sqrt(R * R - m.base_radius * m.base_radius), 1e-12);
        EXPECT_GE(R, m.form_radius - 1e-9);
        EXPECT_LE(R, m.tip_radius + 1e-9);
        EXPECT_EQ(fn.face, x.z());
      }
    }
  EXPECT_LT(worst, 1e-6);
  // Quadratic nodes: (8 + 1 + 8 mid) along the profile x (6 + 1 + 6 mid) across the width.
  EXPECT_EQ(m.flanks[0][0].size(), static_cast<size_t>(17 * 13));
  // Every tet positively oriented at its corners (gmsh ordering).
  for (const auto& t : m.tets) {
    const Eigen::Vector3d a = m.nodes[t[1]] - m.nodes[t[0]], b = m.nodes[t[2]] - m.nodes[t[0]],
                          c = m.nodes[t[3]] - m.nodes[t[0]];
    ASSERT_GT(a.cross(b).dot(c), 0.0);
  }
  // Mid-edge node 4 between corners 0 and 1 (straight edges inside: within the edge's length).
  const auto& t = m.tets.front();
  EXPECT_LT((m.nodes[t[4]] - 0.5 * (m.nodes[t[0]] + m.nodes[t[1]])).norm(),
            0.25 * (m.nodes[t[1]] - m.nodes[t[0]]).norm());
}

TEST(GearMesh, ElementCountsFollowOptions) {
  const Gear G = small_gear();
  gm::mesh::GearBodyOptions o;
  o.body_size = 0.004;
  o.elements_along_profile = 6;
  o.elements_across_width = 1;
  const auto a = mesh_of(G, o);
  o.elements_along_profile = 12;
  const auto b = mesh_of(G, o);
  o.elements_across_width = 3;
  const auto c = mesh_of(G, o);
  EXPECT_EQ(a.flanks[3][1].size(), static_cast<size_t>(13 * 3));
  EXPECT_EQ(b.flanks[3][1].size(), static_cast<size_t>(25 * 3));
  EXPECT_EQ(c.flanks[3][1].size(), static_cast<size_t>(25 * 7));
  EXPECT_GT(b.tets.size(), a.tets.size());
  EXPECT_GT(c.tets.size(), b.tets.size());
  // Deterministic.
  o.elements_along_profile = 6;
  o.elements_across_width = 1;
  const auto a2 = mesh_of(G, o);
  ASSERT_EQ(a2.nodes.size(), a.nodes.size());
  ASSERT_EQ(a2.tets.size(), a.tets.size());
  EXPECT_EQ(a2.tets.back(), a.tets.back());
  EXPECT_EQ(a2.nodes.back(), a.nodes.back());
}

TEST(GearMesh, HelicalTwist) {
  const double beta = 15 * kPi / 180;
  const Gear G = small_gear(beta);
  gm::mesh::GearBodyOptions o;
  o.bore_radius = 0.008;
  o.elements_across_width = 3;
  const auto m = mesh_of(G, o);
  ASSERT_FALSE(m.tets.empty());
  EXPECT_EQ(m.hand, 1);
  EXPECT_NEAR(m.twist_rate, std::tan(beta) / (0.5 * G.g.gear[0].d), 1e-9);
  const double V = gm::mesh::tet10_volume(m.nodes, m.tets);
  EXPECT_NEAR(V / (exact_area(G, 0.008) * 0.010), 1.0, 0.005);
  // The flank nodes follow the helix: on the involute of the section turned by z tan(beta_b)/r_b.
  double worst = 0, worst_spur = 0;
  for (int k = 0; k < m.teeth; ++k)
    for (int f = 0; f < 2; ++f)
      for (const auto& fn : m.flanks[k][f]) {
        worst = std::max(worst, involute_error(m, k, f, m.nodes[fn.node]));
        gm::mesh::GearBodyMesh spur = {};
        spur.teeth = m.teeth;
        spur.base_radius = m.base_radius;
        spur.eta_b = m.eta_b;
        worst_spur = std::max(worst_spur, involute_error(spur, k, f, m.nodes[fn.node]));
      }
  EXPECT_LT(worst, 1e-6);
  // Without the helix the face ends are off by about r (b/2) tan(beta)/r = 1.3 mm.
  EXPECT_GT(worst_spur, 1e-3);
}

TEST(GearMesh, WebHubAndHoles) {
  const Gear G = small_gear();
  gm::mesh::GearBodyOptions o;
  o.bore_radius = 0.004;
  o.hub_radius = 0.008;
  o.rim_inner_radius = 0.014;
  o.web_thickness = 0.004;
  o.web_offset = 0.001;
  o.holes = 4;
  o.hole_radius = 0.002;
  o.hole_circle_radius = 0.011;
  o.body_size = 0.0015;
  o.elements_along_profile = 6;
  const auto m = mesh_of(G, o);
  ASSERT_FALSE(m.tets.empty());
  const double b = 0.010, rr = 0.014, rh = 0.008;
  const double Vx = exact_area(G, rr) * b + kPi * (rh * rh - 0.004 * 0.004) * b +
                    (kPi * (rr * rr - rh * rh) - 4 * kPi * 0.002 * 0.002) * 0.004;
  const double V = gm::mesh::tet10_volume(m.nodes, m.tets);
  EXPECT_NEAR(V / Vx, 1.0, 0.005) << V << " " << Vx;
  // Conforming: no two nodes at the same place (the regions share their interfaces).
  std::set<std::tuple<long, long, long>> seen;
  for (const auto& x : m.nodes)
    EXPECT_TRUE(seen.insert({std::lround(x.x() * 1e8), std::lround(x.y() * 1e8),
                             std::lround(x.z() * 1e8)}).second);
  // Flanks still right with a staged extrusion: 6 layers over 10 mm split at the web.
  double worst = 0;
  for (int k = 0; k < m.teeth; ++k)
    for (int f = 0; f < 2; ++f)
      for (const auto& fn : m.flanks[k][f]) worst = std::max(worst, involute_error(m, k, f, m.nodes[fn.node]));
  EXPECT_LT(worst, 1e-6);
  for (int id : m.clamped_nodes) EXPECT_NEAR(std::hypot(m.nodes[id].x(), m.nodes[id].y()), 0.004, 1e-9);
}

// The tetrahedra whose centroid lies at a radius in [r0, r1]: how many, and their longest
// in-plane corner edge.
struct Band {
  int tets = 0;
  double longest = 0;
};
Band band_between(const gm::mesh::GearBodyMesh& m, double r0, double r1) {
  Band out;
  for (const auto& t : m.tets) {
    const Eigen::Vector3d c = 0.25 * (m.nodes[t[0]] + m.nodes[t[1]] + m.nodes[t[2]] + m.nodes[t[3]]);
    const double R = std::hypot(c.x(), c.y());
    if (R < r0 || R > r1) continue;
    ++out.tets;
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b)
        out.longest = std::max(out.longest, (m.nodes[t[a]] - m.nodes[t[b]]).head<2>().norm());
  }
  return out;
}

// The annulus of the lightening holes is meshed at a tenth of the hole diameter by default
// (gear_mesh.hpp, "Size field"), whatever the body size; hole_band_size sets it; a body
// without holes is meshed as before.
TEST(GearMesh, HoleBandSize) {
  const Gear G = small_gear();
  gm::mesh::GearBodyOptions o;
  o.bore_radius = 0.004;
  o.holes = 4;
  o.hole_radius = 0.002;
  o.hole_circle_radius = 0.010;
  o.body_size = 0.004;
  o.elements_along_profile = 6;
  o.elements_across_width = 2;
  const double r0 = 0.008, r1 = 0.012, h_h = 0.2 * o.hole_radius;
  const Band def = band_between(mesh_of(G, o), r0, r1);
  // gmsh's triangles reach about 1.5 times the target size along their longest edge.
  EXPECT_LT(def.longest, 1.6 * h_h);
  o.hole_band_size = 0.004;  // = body_size: no band
  const Band coarse = band_between(mesh_of(G, o), r0, r1);
  EXPECT_GT(coarse.longest, 2.0 * h_h);
  EXPECT_GT(def.tets, 3 * coarse.tets);
  o.hole_band_size = 1e-3;
  const Band mid = band_between(mesh_of(G, o), r0, r1);
  EXPECT_LT(mid.longest, 1.6e-3);
  EXPECT_GT(mid.longest, 1.6 * h_h);
  // Without holes the option changes nothing.
  o.holes = 0;
  o.hole_band_size = 0;
  const auto plain = mesh_of(G, o);
  o.hole_band_size = 0.5e-3;
  const auto plain2 = mesh_of(G, o);
  EXPECT_EQ(plain.tets.size(), plain2.tets.size());
  o.hole_band_size = -1e-3;
  gm::mesh::GearBodyMesh m;
  std::string msg;
  EXPECT_NE(gm::mesh::build_gear_body(G.p, G.g, 0, o, m, msg), GM_OK);
  EXPECT_NE(msg.find("hole_band_size"), std::string::npos) << msg;
}

// Internal pair 21/62, m 2 mm, b 10 mm; gear 2 is the ring.
Gear ring_pair() {
  Gear G;
  gm_default_params(&G.p);
  G.p.pair.internal = 1;
  G.p.pair.normal_module = 0.002;
  G.p.gear[0].teeth = 21;
  G.p.gear[1].teeth = 62;
  for (int i = 0; i < 2; ++i) {
    G.p.gear[i].profile_shift = 0;
    G.p.gear[i].thickness_allowance = -30e-6;
    G.p.gear[i].face_width = 0.010;
    G.p.gear[i].tip_diameter = 0;
  }
  G.p.pair.center_distance = 0.041;
  char buf[512];
  EXPECT_EQ(gm_compute_geometry(&G.p, &G.g, buf, sizeof buf), GM_OK) << buf;
  return G;
}

// Exact area inside the ring's toothed inner outline, from the core's geometry (radii, eta_b of
// the space) by a dense polygon: per space the involute eta_b - inv(alpha) (both flanks), the
// fillet circle tangent to the involute at the form circle and to the root circle (found here by
// bisection on its radius, independently of the mesher's closed form), root and tip arcs.
double ring_hole_area(const gm_gear_geometry& q, int z) {
  const double rb = 0.5 * q.d_b, ra = 0.5 * q.d_a, rf = 0.5 * q.d_f, rF = 0.5 * q.d_Ff;
  auto inv = [](double a) { return std::tan(a) - a; };
  auto flank = [&](double R) {  // polar angle of flank A at radius R
    return q.eta_b - inv(std::acos(rb / R));
  };
  const int n = 2000;
  // Fillet: circle centre C = P + rc * n_s, n_s the unit normal into the space at P (form point).
  const double phF = flank(rF), alF = std::acos(rb / rF);
  const Eigen::Vector2d P(rF * std::cos(phF), rF * std::sin(phF));
  const Eigen::Vector2d T(rb * std::cos(phF - alF), rb * std::sin(phF - alF));
  const Eigen::Vector2d ns = (T - P).normalized();
  double lo = 0, hi = rf - rF + 1e-3;
  for (int it = 0; it < 200; ++it) {  // |C| + rc - rf changes sign
    const double mid = 0.5 * (lo + hi);
    ((P + mid * ns).norm() + mid < rf ? lo : hi) = mid;
  }
  const double rc = 0.5 * (lo + hi);
  const Eigen::Vector2d C = P + rc * ns;
  // Half outline of space 0 (flank A, +y), from the root point to the tip.
  std::vector<Eigen::Vector2d> half;
  const double a0 = std::atan2(C.y(), C.x());  // root tangency direction from C
  const double a1 = std::atan2(P.y() - C.y(), P.x() - C.x());
  const double da = std::remainder(a1 - a0, 2 * kPi);
  for (int i = 0; i <= n; ++i) {
    const double a = a0 + da * i / n;
    half.emplace_back(C.x() + rc * std::cos(a), C.y() + rc * std::sin(a));
  }
  for (int i = 1; i <= n; ++i) {
    const double R = rF + (ra - rF) * i / n;
    half.emplace_back(R * std::cos(flank(R)), R * std::sin(flank(R)));
  }
  std::vector<Eigen::Vector2d> poly;
  const double th_root = std::atan2(half.front().y(), half.front().x());
  const double th_tip = std::atan2(half.back().y(), half.back().x());
  for (int k = 0; k < z; ++k) {
    const Eigen::Rotation2Dd R(2 * kPi * k / z);
    for (auto it = half.rbegin(); it != half.rend(); ++it) poly.push_back(R * Eigen::Vector2d(it->x(), -it->y()));
    for (int i = 1; i < n; ++i) {  // root arc at the bottom of the space
      const double t = -th_root + 2 * th_root * i / n;
      poly.push_back(R * Eigen::Vector2d(rf * std::cos(t), rf * std::sin(t)));
    }
    for (const auto& q2 : half) poly.push_back(R * q2);
    for (int i = 1; i < n; ++i) {  // tip arc of the ring tooth
      const double t = th_tip + (2 * kPi / z - 2 * th_tip) * i / n;
      poly.push_back(R * Eigen::Vector2d(ra * std::cos(t), ra * std::sin(t)));
    }
  }
  double A = 0;
  for (size_t i = 0; i < poly.size(); ++i) {
    const auto& p0 = poly[i];
    const auto& p1 = poly[(i + 1) % poly.size()];
    A += p0.x() * p1.y() - p1.x() * p0.y();
  }
  return 0.5 * A;
}

TEST(GearMesh, RingVolumeFlanksRim) {
  const Gear G = ring_pair();
  gm::mesh::GearBodyOptions o;
  o.elements_along_profile = 6;
  o.elements_across_width = 2;
  const double rf = 0.5 * G.g.gear[1].d_f;
  gm::mesh::GearBodyMesh m;
  std::string msg;
  ASSERT_EQ(gm::mesh::build_gear_body(G.p, G.g, 1, o, m, msg), GM_OK) << msg;
  EXPECT_TRUE(m.ring);
  const double Ro = rf + 3 * 0.002;  // the default rim
  EXPECT_NEAR(m.clamped_radius, Ro, 1e-12);
  const double Vx = (kPi * Ro * Ro - ring_hole_area(G.g.gear[1], 62)) * 0.010;
  const double V = gm::mesh::tet10_volume(m.nodes, m.tets);
  std::printf("[ring] %zu nodes; volume %.6g vs exact %.6g m^3 (%+.4f %%)\n", m.nodes.size(), V, Vx,
              100 * (V / Vx - 1));
  EXPECT_NEAR(V / Vx, 1.0, 0.005);
  // Bounds: between the annuli from the tip and from the root circle to the rim.
  EXPECT_GT(V, kPi * (Ro * Ro - rf * rf) * 0.010);
  EXPECT_LT(V, kPi * (Ro * Ro - m.tip_radius * m.tip_radius) * 0.010);
  ASSERT_FALSE(m.clamped_nodes.empty());
  for (int id : m.clamped_nodes) EXPECT_NEAR(std::hypot(m.nodes[id].x(), m.nodes[id].y()), Ro, 1e-9);
  // Flank nodes on the ring's involute (space k centred at 2 pi k / z), within 1 um, between the
  // tip (inner) and form circles; flank A on the +theta side of the space.
  ASSERT_EQ(static_cast<int>(m.flanks.size()), 62);
  double worst = 0;
  for (int k = 0; k < 62; ++k)
    for (int f = 0; f < 2; ++f) {
      ASSERT_FALSE(m.flanks[k][f].empty());
      for (const auto& fn : m.flanks[k][f]) {
        const auto& x = m.nodes[fn.node];
        worst = std::max(worst, involute_error(m, k, f, x));
        const double R = std::hypot(x.x(), x.y());
        EXPECT_GE(R, m.tip_radius - 1e-9);
        EXPECT_LE(R, m.form_radius + 1e-9);
      }
    }
  EXPECT_LT(worst, 1e-6);
  // Flank A of space 0 lies at +theta: its mid-radius node has a positive polar angle.
  const auto& fa = m.flanks[0][0];
  EXPECT_GT(std::atan2(m.nodes[fa[fa.size() / 2].node].y(), m.nodes[fa[fa.size() / 2].node].x()), 0.0);
  // Tooth 0 flank A (fine tooth): (6 + 1 + 6 mid) along the profile x (2 + 1 + 2) across.
  EXPECT_EQ(fa.size(), static_cast<size_t>(13 * 5));
  // Ring options are refused on external gears and vice versa.
  gm::mesh::GearBodyOptions bad = o;
  bad.bore_radius = 0.01;
  EXPECT_EQ(gm::mesh::build_gear_body(G.p, G.g, 1, bad, m, msg), GM_ERR_PARAMETER);
  EXPECT_NE(msg.find("outer rim"), std::string::npos) << msg;
  bad = o;
  bad.outer_radius = 0.5 * G.g.gear[1].d_f - 1e-4;
  EXPECT_EQ(gm::mesh::build_gear_body(G.p, G.g, 1, bad, m, msg), GM_ERR_PARAMETER);
  EXPECT_NE(msg.find("outer_radius"), std::string::npos) << msg;
}

// User-supplied mesh: a generated mesh written with gmsh and read back gives the same nodes,
// clamped and flank sets and volume; a missing file, a TET4 file and a mesh of another gear are
// refused with messages naming the file and the problem.
TEST(GearMesh, MeshFileRoundTripAndRefusals) {
  const Gear G = small_gear();
  gm::mesh::GearBodyOptions o;
  o.bore_radius = 0.008;
  o.elements_along_profile = 4;
  o.elements_across_width = 2;
  const auto m = mesh_of(G, o);
  const std::string path = ::testing::TempDir() + "gm_gear_mesh_test.msh";
  std::string msg;
  ASSERT_EQ(gm::mesh::write_gear_body_msh(m, path, msg), GM_OK) << msg;
  gm::mesh::GearBodyOptions r;
  r.mesh_file = path;
  gm::mesh::GearBodyMesh back;
  ASSERT_EQ(gm::mesh::build_gear_body(G.p, G.g, 0, r, back, msg), GM_OK) << msg;
  ASSERT_EQ(back.nodes.size(), m.nodes.size());
  EXPECT_EQ(back.tets, m.tets);
  double dx = 0;
  for (size_t i = 0; i < m.nodes.size(); ++i) dx = std::max(dx, (back.nodes[i] - m.nodes[i]).norm());
  EXPECT_LT(dx, 1e-12);
  EXPECT_EQ(back.clamped_nodes, m.clamped_nodes);
  EXPECT_NEAR(back.clamped_radius, 0.008, 1e-9);
  EXPECT_NEAR(gm::mesh::tet10_volume(back.nodes, back.tets), gm::mesh::tet10_volume(m.nodes, m.tets), 1e-15);
  ASSERT_EQ(back.flanks.size(), m.flanks.size());
  for (size_t k = 0; k < m.flanks.size(); ++k)
    for (int f = 0; f < 2; ++f) {
      std::vector<int> a, b;
      for (const auto& fn : m.flanks[k][f]) a.push_back(fn.node);
      for (const auto& fn : back.flanks[k][f]) b.push_back(fn.node);
      std::sort(a.begin(), a.end());
      std::sort(b.begin(), b.end());
      EXPECT_EQ(a, b) << "tooth " << k << " flank " << f;
    }
  // A mesh of another gear (profile shift 0.3 instead of 0): refused.
  Gear other = small_gear();
  other.p.gear[0].profile_shift = 0.3;
  other.p.pair.center_distance += 0.0006;
  char buf[512];
  ASSERT_EQ(gm_compute_geometry(&other.p, &other.g, buf, sizeof buf), GM_OK) << buf;
  EXPECT_EQ(gm::mesh::build_gear_body(other.p, other.g, 0, r, back, msg), GM_ERR_PARAMETER);
  std::printf("[mesh file] wrong gear: %s\n", msg.c_str());
  EXPECT_NE(msg.find(path), std::string::npos) << msg;
  EXPECT_NE(msg.find("not of this gear"), std::string::npos) << msg;
  // Missing file.
  r.mesh_file = path + ".missing.msh";
  EXPECT_EQ(gm::mesh::build_gear_body(G.p, G.g, 0, r, back, msg), GM_ERR_PARAMETER);
  EXPECT_NE(msg.find("cannot be opened"), std::string::npos) << msg;
  // Linear tetrahedra: refused.
  gm::mesh::GearBodyMesh lin = m;
  const std::string p4 = ::testing::TempDir() + "gm_gear_mesh_tet4.msh";
  {
    gmsh::initialize(0, nullptr, false, false);
    gmsh::option::setNumber("General.Terminal", 0);
    gmsh::model::add("tet4");
    const int v = gmsh::model::addDiscreteEntity(3);
    std::vector<std::size_t> tags(m.nodes.size());
    std::vector<double> xyz;
    for (size_t i = 0; i < m.nodes.size(); ++i) {
      tags[i] = i + 1;
      xyz.insert(xyz.end(), {m.nodes[i].x(), m.nodes[i].y(), m.nodes[i].z()});
    }
    gmsh::model::mesh::addNodes(3, v, tags, xyz);
    std::vector<std::size_t> et, nt;
    for (size_t e = 0; e < m.tets.size(); ++e) {
      et.push_back(e + 1);
      for (int a = 0; a < 4; ++a) nt.push_back(m.tets[e][a] + 1);
    }
    gmsh::model::mesh::addElementsByType(v, 4, et, nt);
    gmsh::write(p4);
    gmsh::finalize();
  }
  r.mesh_file = p4;
  EXPECT_EQ(gm::mesh::build_gear_body(G.p, G.g, 0, r, back, msg), GM_ERR_PARAMETER);
  std::printf("[mesh file] TET4: %s\n", msg.c_str());
  EXPECT_NE(msg.find("TET10"), std::string::npos) << msg;
  EXPECT_NE(msg.find(p4), std::string::npos) << msg;
  std::remove(path.c_str());
  std::remove(p4.c_str());
}

}  // namespace
