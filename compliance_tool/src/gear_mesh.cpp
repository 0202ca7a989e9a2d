#include "gear_mesh.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cmath>
#include <fstream>
#include <map>
#include <stdexcept>
#include <unordered_map>

#include <Eigen/Dense>
#include <gmsh.h>

#include "gearmesh/internal/geometry.hpp"
#include "tooth_outline.hpp"

namespace gm::mesh {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kTet10 = 11;  // gmsh element type

std::string fmt(const char* f, double a, double b = 0, double c = 0) {
  char buf[256];
  std::snprintf(buf, sizeof buf, f, a, b, c);
  return buf;
}

gm_status fail_with(std::string& msg, const std::string& text) {
  msg = "gear mesher: " + text;
  return GM_ERR_PARAMETER;
}

// gmsh is process-global: initialize/finalize around one build, also on exceptions.
struct GmshSession {
  GmshSession() {
    gmsh::initialize(0, nullptr, false, false);
    gmsh::option::setNumber("General.Terminal", 0);
    gmsh::option::setNumber("General.Verbosity", 0);
  }
  ~GmshSession() { gmsh::finalize(); }
  GmshSession(const GmshSession&) = delete;
  GmshSession& operator=(const GmshSession&) = delete;
};

Eigen::Vector2d rot(const Eigen::Vector2d& v, double a) {
  const double c = std::cos(a), s = std::sin(a);
  return {c * v.x() - s * v.y(), s * v.x() + c * v.y()};
}

double polyline_length(const std::vector<Eigen::Vector2d>& pts) {
  double L = 0;
  for (size_t i = 1; i < pts.size(); ++i) L += (pts[i] - pts[i - 1]).norm();
  return L;
}

struct Builder {
  double z0 = 0;
  int centre = 0;
  int point(const Eigen::Vector2d& p, double size) {
    return gmsh::model::geo::addPoint(p.x(), p.y(), z0, size);
  }
  // Full circle as four arcs (counter-clockwise).
  std::vector<int> circle(double R, double size) {
    int pts[4];
    for (int k = 0; k < 4; ++k)
      pts[k] = point({R * std::cos(0.5 * kPi * k), R * std::sin(0.5 * kPi * k)}, size);
    std::vector<int> c;
    for (int k = 0; k < 4; ++k) c.push_back(gmsh::model::geo::addCircleArc(pts[k], centre, pts[(k + 1) % 4]));
    return c;
  }
  std::vector<int> circle_at(const Eigen::Vector2d& c0, double R, double size) {
    const int c = point(c0, size);
    int pts[4];
    for (int k = 0; k < 4; ++k)
      pts[k] = point(c0 + Eigen::Vector2d(R * std::cos(0.5 * kPi * k), R * std::sin(0.5 * kPi * k)), size);
    std::vector<int> out;
    for (int k = 0; k < 4; ++k) out.push_back(gmsh::model::geo::addCircleArc(pts[k], c, pts[(k + 1) % 4]));
    return out;
  }
};

// A region of the section: its curve loops (outer first) and the current surface tag.
struct Region {
  std::vector<std::vector<int>> loops;
  int surface = 0;
  std::vector<int> curves() const {
    std::vector<int> c;
    for (const auto& l : loops) c.insert(c.end(), l.begin(), l.end());
    return c;
  }
};

}  // namespace

namespace {

// Geometry shared by the mesher and the mesh-file reader.
struct BodyGeometry {
  int z = 0, hand = 0;
  bool ring = false;
  double b = 0, m_n = 0, twist_rate = 0;
  double clamped = 0;  // bore radius (external) or outer rim radius (ring)
};

gm_status body_geometry(const gm_model_params& p, const gm_pair_geometry& g, int gear,
                        const GearBodyOptions& o, const ToothOutline& to, BodyGeometry& bg,
                        GearBodyMesh& out, std::string& msg) {
  auto fail = [&msg](const std::string& text) { return fail_with(msg, text); };
  bg.z = p.gear[gear].teeth;
  bg.ring = to.ring;
  bg.b = p.gear[gear].face_width;
  bg.m_n = p.pair.normal_module;
  const int hand1 = p.pair.helix_angle > 0 ? 1 : (p.pair.helix_angle < 0 ? -1 : 0);
  bg.hand = gear == 0 ? hand1 : (p.pair.internal ? hand1 : -hand1);
  bg.twist_rate = std::tan(g.beta_b) / to.base_radius;
  const double r_f = to.root_radius;
  if (bg.ring) {
    if (o.bore_radius > 0 || o.rim_inner_radius > 0 || o.hub_radius > 0 || o.holes > 0 ||
        o.web_thickness > 0)
      return fail("bore_radius, rim_inner_radius, hub_radius, web_thickness and holes apply to "
                  "external gears; an internal ring is clamped on its outer rim (outer_radius)");
    bg.clamped = o.outer_radius > 0 ? o.outer_radius : r_f + 3.0 * bg.m_n;
    if (!(bg.clamped > r_f))
      return fail(fmt("outer_radius %g m of the ring must exceed its root radius %g m", bg.clamped, r_f));
  } else {
    if (o.outer_radius > 0)
      return fail("outer_radius applies to internal rings only; an external gear is clamped on its "
                  "bore (bore_radius)");
    bg.clamped = o.bore_radius > 0 ? o.bore_radius : 0.4 * r_f;
    if (!(bg.clamped < r_f))
      return fail(fmt("bore_radius %g m must be below the root radius %g m", bg.clamped, r_f));
  }
  out.teeth = bg.z;
  out.ring = bg.ring;
  out.hand = bg.hand;
  out.face_width = bg.b;
  out.base_radius = to.base_radius;
  out.root_radius = r_f;
  out.form_radius = to.form_radius;
  out.tip_radius = to.tip_radius;
  out.clamped_radius = bg.clamped;
  out.eta_b = to.eta_b;
  out.twist_rate = bg.twist_rate;
  return GM_OK;
}

gm_status read_mesh_file(const GearBodyOptions& o, const BodyGeometry& bg, GearBodyMesh& out,
                         std::string& msg);

}  // namespace

namespace {

// What build_gear_body decides before gmsh runs: the axial stages, the fine sector and the
// element sizes of the size field (gear_mesh.hpp, "Size field").
struct BodyPlan {
  BodyGeometry g;                  // teeth, hand, ring, face width, twist, clamped radius
  bool has_web = false, all_fine = false;
  double r_f = 0;
  std::vector<double> zs;          // axial stage boundaries, -b/2 .. b/2
  int web_stage = -1;              // the stage that holds the web (-1: every stage)
  int fine_teeth = 0, elements_on_tip = 0;
  double h_t = 0, h_c = 0, h_b = 0, fine = 0, sector = 0, growth = 0;
  double h_h = 0, hole_in = 0, hole_out = 0;  // hole band: size (0 = none) and radii
  double tip_land = 0, root_land = 0;  // arc lengths of the tip and root lands, m
  double rot0 = 0;                 // turn of the meshed section (at z = -b/2)
  int stages() const { return static_cast<int>(zs.size()) - 1; }
  bool is_fine(int k) const { return all_fine || std::min(k, g.z - k) <= fine_teeth; }
  int n_tip(double h) const {
    return elements_on_tip > 0 ? elements_on_tip
                               : std::max(1, static_cast<int>(std::lround(tip_land / h)));
  }
  int n_root(double h) const { return std::max(1, static_cast<int>(std::lround(root_land / h))); }
};

// The gmsh model as it is built: the section's curves and regions, then the extruded volumes
// and, per region and section curve, the lateral surfaces of every stage.
struct BodyModel {
  Builder B;
  std::vector<int> loop;                            // the toothed outline
  std::vector<std::array<int, 2>> involute_curve;   // [A, B] per tooth
  std::vector<int> clamp_c;                         // the clamped circle's arcs
  std::vector<Region> regions;
  int web_region = -1, outer_region = 0, clamp_region = 0;
  std::vector<std::vector<std::vector<int>>> laterals;  // [region][curve][stage]
  std::vector<int> volumes;                         // the kept volumes
};

gm_status check_options(int gear, const GearBodyOptions& o, std::string& msg) {
  if (gear != 0 && gear != 1) return fail_with(msg, "gear index must be 0 or 1");
  if (o.order != 2) return fail_with(msg, "only quadratic elements (order 2) are supported");
  if (o.elements_along_profile < 1 || o.elements_across_width < 1 || o.elements_in_fillet < 1 ||
      o.elements_on_tip < 0)
    return fail_with(msg, "element counts must be >= 1");
  if (!(o.size_growth > 0) || !std::isfinite(o.size_growth))
    return fail_with(msg, fmt("size_growth %g must be > 0", o.size_growth));
  if (o.body_size < 0 || o.hole_band_size < 0 || o.fine_depth < 0 || o.mesh_tolerance < 0)
    return fail_with(msg, "body_size, hole_band_size, fine_depth and mesh_tolerance must be >= 0 (0 = default)");
  return GM_OK;
}

}  // namespace

HolesFit holes_fit(int holes, double hole, double circle, double inner, double outer) {
  if (!(hole > 0 && circle - hole > inner && circle + hole < outer)) return HolesFit::kOutsideAnnulus;
  if (!(hole < holes_overlap_limit(holes, circle))) return HolesFit::kOverlap;
  return HolesFit::kFits;
}

double holes_overlap_limit(int holes, double circle) {
  return circle * std::sin(kPi / holes);
}

namespace {

// Rim, web and holes: checked against each other and the root circle; the axial stages split at
// the web's faces when the web is narrower than the face.
gm_status plan_stages(const GearBodyOptions& o, BodyPlan& pl, std::string& msg) {
  const double b = pl.g.b, r_f = pl.r_f;
  pl.has_web = !pl.g.ring && o.rim_inner_radius > 0;
  if (pl.has_web && !(pl.g.clamped < o.hub_radius && o.hub_radius < o.rim_inner_radius && o.rim_inner_radius < r_f))
    return fail_with(msg, fmt("rim and web need bore_radius < hub_radius < rim_inner_radius < root radius "
                              "(%g, %g, root %g m)",
                              o.hub_radius, o.rim_inner_radius, r_f));
  const double ann_in = pl.has_web ? o.hub_radius : pl.g.clamped;
  const double ann_out = pl.has_web ? o.rim_inner_radius : r_f;
  if (o.holes > 0) {
    if (holes_fit(o.holes, o.hole_radius, o.hole_circle_radius, ann_in, ann_out) != HolesFit::kFits)
      return fail_with(msg, fmt("lightening holes (radius %g m on radius %g m) must lie inside the web "
                                "annulus and not overlap (annulus %g m ..)",
                                o.hole_radius, o.hole_circle_radius, ann_in));
  }
  pl.zs = {-0.5 * b, 0.5 * b};
  pl.web_stage = -1;
  if (pl.has_web && o.web_thickness > 0 && o.web_thickness < b) {
    const double w0 = o.web_offset - 0.5 * o.web_thickness, w1 = o.web_offset + 0.5 * o.web_thickness;
    if (w0 < -0.5 * b - 1e-12 || w1 > 0.5 * b + 1e-12)
      return fail_with(msg, fmt("the web (offset %g m, thickness %g m) must lie within the face width %g m",
                                o.web_offset, o.web_thickness, b));
    const double tol = 1e-9 * b;
    pl.zs.clear();
    pl.zs.push_back(-0.5 * b);
    if (w0 > -0.5 * b + tol) pl.zs.push_back(w0);
    pl.web_stage = static_cast<int>(pl.zs.size()) - 1;
    if (w1 < 0.5 * b - tol) pl.zs.push_back(w1);
    pl.zs.push_back(0.5 * b);
  }
  return GM_OK;
}

// Element sizes of the fine teeth, the far teeth and the body, and the fine sector.
gm_status plan_sizes(const GearBodyOptions& o, const ToothOutline& to, double m_n, BodyPlan& pl,
                     std::string& msg) {
  if (o.far_elements_along_profile < 1 || o.far_elements_in_fillet < 1)
    return fail_with(msg, "far_elements_along_profile and far_elements_in_fillet must be >= 1");
  const int z = pl.g.z;
  pl.fine_teeth = o.fine_teeth;
  pl.elements_on_tip = o.elements_on_tip;
  pl.all_fine = o.fine_teeth < 0 || 2 * o.fine_teeth + 1 >= z;
  pl.h_t = polyline_length(to.involute) / o.elements_along_profile;
  pl.h_c = pl.all_fine ? pl.h_t : polyline_length(to.involute) / o.far_elements_along_profile;
  pl.sector = pl.all_fine ? kPi : (o.fine_teeth + 0.5) * 2.0 * kPi / z;
  pl.h_b = o.body_size > 0 ? o.body_size : 4.0 * m_n;
  if (o.holes > 0) {
    pl.h_h = std::min(pl.h_b, o.hole_band_size > 0 ? o.hole_band_size : 0.2 * o.hole_radius);
    pl.hole_in = o.hole_circle_radius - o.hole_radius;
    pl.hole_out = o.hole_circle_radius + o.hole_radius;
  }
  pl.fine = o.fine_depth > 0 ? o.fine_depth : 1.0 * m_n;
  pl.growth = o.size_growth;
  pl.tip_land = 2.0 * (pl.g.ring ? kPi / z - to.tip_half_angle : to.tip_half_angle) * to.tip_radius;
  pl.root_land = 2.0 * (pl.g.ring ? to.root_half_angle : kPi / z - to.root_half_angle) * pl.r_f;
  pl.rot0 = -pl.g.hand * pl.g.twist_rate * 0.5 * pl.g.b;
  return GM_OK;
}

gm_status plan_body(const GearBodyOptions& o, const BodyGeometry& bg, const ToothOutline& to,
                    BodyPlan& pl, std::string& msg) {
  pl.g = bg;
  pl.r_f = to.root_radius;
  if (plan_stages(o, pl, msg) != GM_OK) return GM_ERR_PARAMETER;
  return plan_sizes(o, to, bg.m_n, pl, msg);
}

void set_mesh_options(int threads) {
  gmsh::option::setNumber("General.NumThreads", std::max(1, threads));
  gmsh::option::setNumber("Mesh.Algorithm", 6);
  // Quadratic elements whose curved edges (on the fillets, where big elements meet the curved
  // outline) would invert are repaired by gmsh's high-order optimization (it moves interior
  // high-order nodes of the invalid elements' neighbourhood only).
  gmsh::option::setNumber("Mesh.HighOrderOptimize", 1);
  gmsh::option::setNumber("Mesh.MeshSizeFromCurvature", 0);
  gmsh::option::setNumber("Mesh.MeshSizeExtendFromBoundary", 0);
  gmsh::option::setNumber("Mesh.MeshSizeFromPoints", 1);
  gmsh::option::setNumber("Mesh.ElementOrder", 2);
  gmsh::option::setNumber("Mesh.SecondOrderLinear", 0);
  gmsh::option::setNumber("Mesh.RandomSeed", 1);
}

// The size field of gear_mesh.hpp: radial, fine on the teeth and a band below the root circle.
void set_size_field(const BodyPlan& pl) {
  const bool ring = pl.g.ring;
  const double r_f = pl.r_f, fine = pl.fine, sector = pl.sector, rot_sec = pl.rot0;
  const double h_t = pl.h_t, h_c = pl.h_c, h_b = pl.h_b, growth = pl.growth;
  const double h_h = pl.h_h, hole_in = pl.hole_in, hole_out = pl.hole_out;
  gmsh::model::mesh::setSizeCallback(
      [=](int, int, double x, double y, double, double lc) {
        const double R = std::hypot(x, y);
        const double below = std::max(0.0, ring ? R - (r_f + fine) : (r_f - fine) - R);
        // Distance to the fine region F (see the header).
        const double th = std::remainder(std::atan2(y, x) - rot_sec, 2.0 * kPi);
        double d = below;
        if (std::fabs(th) > sector) {
          const Eigen::Vector2d e(std::cos(rot_sec + std::copysign(sector, th)),
                                  std::sin(rot_sec + std::copysign(sector, th)));
          const Eigen::Vector2d X(x, y);
          const double t = ring ? std::clamp(X.dot(e), 0.0, r_f + fine) : std::max(X.dot(e), r_f - fine);
          d = (X - t * e).norm();
        }
        auto ramp = [&](double h0, double dist) {
          return h_b >= h0 ? std::min(h_b, h0 + growth * dist) : std::max(h_b, h0 - growth * dist);
        };
        double h = std::min(lc, std::min(ramp(h_t, d), ramp(h_c, below)));
        if (h_h > 0) h = std::min(h, h_h + growth * std::max({0.0, hole_in - R, R - hole_out}));
        return h;
      });
}

// A spline through pts turned by a (mirrored for flank B, reversed if asked), reusing the point
// tag `first` as its start: the curve tag and its point tags.
std::pair<int, std::vector<int>> add_spline(Builder& B, const std::vector<Eigen::Vector2d>& pts,
                                            double a, bool flank_b, bool reverse, int first,
                                            double size) {
  std::vector<int> tags;
  const int n = static_cast<int>(pts.size());
  for (int i = 0; i < n; ++i) {
    const int j = reverse ? n - 1 - i : i;
    const Eigen::Vector2d v = flank_b ? Eigen::Vector2d(pts[j].x(), -pts[j].y()) : pts[j];
    if (i == 0 && first) tags.push_back(first);
    else tags.push_back(B.point(rot(v, a), size));
  }
  return {gmsh::model::geo::addSpline(tags), tags};
}

// Element counts along both fillets and both involutes.
void set_flank_counts(int fillet_a, int fillet_b, int involute_a, int involute_b, int n_fil, int n_prof) {
  namespace geo = gmsh::model::geo;
  geo::mesh::setTransfiniteCurve(fillet_b, n_fil + 1);
  geo::mesh::setTransfiniteCurve(fillet_a, n_fil + 1);
  geo::mesh::setTransfiniteCurve(involute_b, n_prof + 1);
  geo::mesh::setTransfiniteCurve(involute_a, n_prof + 1);
}

// Tooth k of the outline (external gear: tooth; ring: space): its five curves, counter-clockwise,
// external [fillet B, involute B, tip arc, involute A, fillet A], ring [involute B, fillet B,
// root arc, fillet A, involute A], then a slot for the arc to the next tooth. Returns the
// outline's first and last point tags of this tooth.
std::array<int, 2> draw_tooth(const BodyPlan& pl, const GearBodyOptions& o, const ToothOutline& to,
                              int k, BodyModel& m) {
  namespace geo = gmsh::model::geo;
  const double a = pl.rot0 + 2.0 * kPi * k / pl.g.z;
  const bool fk = pl.is_fine(k);
  const int n_prof = fk ? o.elements_along_profile : o.far_elements_along_profile;
  const int n_fil = fk ? o.elements_in_fillet : o.far_elements_in_fillet;
  const double hk = fk ? pl.h_t : pl.h_c, h_t = pl.h_t;
  Builder& B = m.B;
  if (!pl.g.ring) {
    auto fb = add_spline(B, to.fillet, a, true, false, 0, h_t);                   // root -> form
    auto ib = add_spline(B, to.involute, a, true, false, fb.second.back(), h_t);  // form -> tip
    auto ia = add_spline(B, to.involute, a, false, true, 0, h_t);                 // tip -> form
    auto fa = add_spline(B, to.fillet, a, false, true, ia.second.back(), h_t);    // form -> root
    const int tip = geo::addCircleArc(ib.second.back(), B.centre, ia.second.front());
    m.loop.insert(m.loop.end(), {fb.first, ib.first, tip, ia.first, fa.first, 0});
    m.involute_curve[k] = {ia.first, ib.first};
    set_flank_counts(fa.first, fb.first, ia.first, ib.first, n_fil, n_prof);
    geo::mesh::setTransfiniteCurve(tip, pl.n_tip(hk) + 1);
    return {fb.second.front(), fa.second.back()};
  }
  auto ib = add_spline(B, to.involute, a, true, true, 0, h_t);                  // tip -> form
  auto fb = add_spline(B, to.fillet, a, true, true, ib.second.back(), h_t);     // form -> root
  auto fa = add_spline(B, to.fillet, a, false, false, 0, h_t);                  // root -> form
  auto ia = add_spline(B, to.involute, a, false, false, fa.second.back(), h_t); // form -> tip
  const int root = geo::addCircleArc(fb.second.back(), B.centre, fa.second.front());
  m.loop.insert(m.loop.end(), {ib.first, fb.first, root, fa.first, ia.first, 0});
  m.involute_curve[k] = {ia.first, ib.first};
  set_flank_counts(fa.first, fb.first, ia.first, ib.first, n_fil, n_prof);
  geo::mesh::setTransfiniteCurve(root, pl.n_root(hk) + 1);
  return {ib.second.front(), ia.second.back()};
}

// The whole toothed outline, counter-clockwise; the ring's is reversed (it is a hole).
void draw_outline(const BodyPlan& pl, const GearBodyOptions& o, const ToothOutline& to, const ToothOutline& to_far,
                  BodyModel& m) {
  namespace geo = gmsh::model::geo;
  const int z = pl.g.z;
  m.involute_curve.resize(z);
  std::vector<int> first_pt(z), last_pt(z);
  for (int k = 0; k < z; ++k) {
    const std::array<int, 2> ends = draw_tooth(pl, o, pl.is_fine(k) ? to : to_far, k, m);
    first_pt[k] = ends[0];
    last_pt[k] = ends[1];
  }
  // The arcs between neighbouring teeth (external: root arcs; ring: tip arcs).
  for (int k = 0; k < z; ++k) {
    const int arc = geo::addCircleArc(last_pt[k], m.B.centre, first_pt[(k + 1) % z]);
    const double h = pl.is_fine(k) || pl.is_fine((k + 1) % z) ? pl.h_t : pl.h_c;
    geo::mesh::setTransfiniteCurve(arc, (pl.g.ring ? pl.n_tip(h) : pl.n_root(h)) + 1);
    m.loop[6 * k + 5] = arc;
  }
  // A hole's loop runs clockwise: reversed as given, gmsh would reverse it itself and the
  // lateral surfaces of the extrusion would then come in the reversed curve order.
  if (pl.g.ring) {
    std::reverse(m.loop.begin(), m.loop.end());
    for (int& c : m.loop) c = -c;
  }
}

// The section's regions (ring: one; disc: one with its holes; web: rim, web with holes, hub)
// and their plane surfaces.
void add_regions(const BodyPlan& pl, const GearBodyOptions& o, BodyModel& m) {
  namespace geo = gmsh::model::geo;
  Builder& B = m.B;
  const double h_b = pl.h_b;
  m.clamp_c = B.circle(pl.g.clamped, std::min(h_b, 2.0 * kPi * pl.g.clamped / 24.0));
  std::vector<std::vector<int>> holes;
  for (int h = 0; h < o.holes; ++h) {
    const double ah = pl.rot0 + 2.0 * kPi * h / o.holes;
    holes.push_back(B.circle_at({o.hole_circle_radius * std::cos(ah), o.hole_circle_radius * std::sin(ah)},
                                o.hole_radius, std::min(pl.h_h, 2.0 * kPi * o.hole_radius / 12.0)));
  }
  if (pl.g.ring) {
    m.regions.push_back({{m.clamp_c, m.loop}, 0});
  } else if (pl.has_web) {
    const std::vector<int> rim_c = B.circle(o.rim_inner_radius, std::min(h_b, 2.0 * kPi * o.rim_inner_radius / 24.0));
    const std::vector<int> hub_c = B.circle(o.hub_radius, std::min(h_b, 2.0 * kPi * o.hub_radius / 24.0));
    m.regions.push_back({{m.loop, rim_c}, 0});
    Region web{{rim_c, hub_c}, 0};
    for (const auto& hl : holes) web.loops.push_back(hl);
    m.regions.push_back(web);
    m.regions.push_back({{hub_c, m.clamp_c}, 0});
    m.web_region = 1;
    m.clamp_region = 2;
  } else {
    Region disc{{m.loop, m.clamp_c}, 0};
    for (const auto& hl : holes) disc.loops.push_back(hl);
    m.regions.push_back(disc);
  }
  for (Region& r : m.regions) {
    std::vector<int> wires;
    for (const auto& l : r.loops) wires.push_back(geo::addCurveLoop(l));
    r.surface = geo::addPlaneSurface(wires);
  }
}

// Extrude the regions stage by stage (layers proportional to the stage's length; twisted for
// helical gears), keep the web only in its stage, and collect the lateral surfaces.
void extrude_stages(const BodyPlan& pl, const GearBodyOptions& o, BodyModel& m) {
  namespace geo = gmsh::model::geo;
  const int stages = pl.stages();
  const std::vector<double>& zs = pl.zs;
  std::vector<int> layers(stages);
  for (int st = 0; st < stages; ++st)
    layers[st] = std::max(1, static_cast<int>(std::lround(o.elements_across_width * (zs[st + 1] - zs[st]) / pl.g.b)));
  m.laterals.assign(m.regions.size(), {});
  for (size_t r = 0; r < m.regions.size(); ++r) m.laterals[r].resize(m.regions[r].curves().size());
  std::vector<int> dropped;
  for (int st = 0; st < stages; ++st) {
    gmsh::vectorpair in, res;
    for (const Region& r : m.regions) in.push_back({2, r.surface});
    const double dz = zs[st + 1] - zs[st];
    const double angle = pl.g.hand * pl.g.twist_rate * dz;
    if (pl.g.hand != 0)
      geo::twist(in, 0, 0, 0, 0, 0, dz, 0, 0, 1, angle, res, {layers[st]}, {1.0}, false);
    else
      geo::extrude(in, 0, 0, dz, res, {layers[st]}, {1.0}, false);
    size_t pos = 0;
    for (size_t r = 0; r < m.regions.size(); ++r) {
      const size_t nc = m.laterals[r].size();
      if (pos + 2 + nc > res.size() || res[pos].first != 2 || res[pos + 1].first != 3)
        throw std::runtime_error("unexpected extrusion result");
      m.regions[r].surface = res[pos].second;
      const bool keep = !(static_cast<int>(r) == m.web_region && pl.web_stage >= 0 && st != pl.web_stage);
      (keep ? m.volumes : dropped).push_back(res[pos + 1].second);
      for (size_t c = 0; c < nc; ++c) m.laterals[r][c].push_back(res[pos + 2 + c].second);
      pos += 2 + nc;
    }
  }
  if (!dropped.empty()) {
    gmsh::vectorpair d;
    for (int v : dropped) d.push_back({3, v});
    geo::remove(d, false);
  }
  geo::synchronize();
}

// Which lateral surface belongs to which section curve: gmsh may start or orient a loop
// differently from the order given, so match them by their boundary (the section curve is an
// edge of its first-stage lateral; later stages follow in the same order).
void match_laterals(BodyModel& m) {
  for (size_t r = 0; r < m.regions.size(); ++r) {
    const std::vector<int> curves = m.regions[r].curves();
    std::map<int, size_t> owner;  // section curve -> position in laterals[r]
    for (size_t j = 0; j < m.laterals[r].size(); ++j) {
      gmsh::vectorpair bnd;
      gmsh::model::getBoundary({{2, m.laterals[r][j][0]}}, bnd, false, false, false);
      for (const auto& d : bnd) owner[std::abs(d.second)] = j;
    }
    std::vector<std::vector<int>> sorted(curves.size());
    for (size_t c = 0; c < curves.size(); ++c) {
      const auto it = owner.find(std::abs(curves[c]));
      if (it == owner.end()) throw std::runtime_error("a section curve has no lateral surface");
      sorted[c] = m.laterals[r][it->second];
    }
    m.laterals[r] = std::move(sorted);
  }
}

// Nodes and TET10 elements of the given gmsh volumes (-1: every entity), numbered from 0 in
// the order of gmsh's node tags; returns gmsh tag -> node index.
std::unordered_map<std::size_t, int> collect_tet10(const std::vector<int>& volumes, GearBodyMesh& out) {
  std::vector<std::size_t> ntags;
  std::vector<double> coord, param;
  gmsh::model::mesh::getNodes(ntags, coord, param, -1, -1, true, false);
  std::unordered_map<std::size_t, size_t> where;
  for (size_t i = 0; i < ntags.size(); ++i) where[ntags[i]] = i;
  std::vector<std::size_t> conn;
  for (int v : volumes) {
    std::vector<std::size_t> et, nt;
    gmsh::model::mesh::getElementsByType(kTet10, et, nt, v);
    conn.insert(conn.end(), nt.begin(), nt.end());
  }
  std::vector<std::size_t> used(conn);
  std::sort(used.begin(), used.end());
  used.erase(std::unique(used.begin(), used.end()), used.end());
  std::unordered_map<std::size_t, int> index;
  out.nodes.reserve(used.size());
  for (size_t i = 0; i < used.size(); ++i) {
    index[used[i]] = static_cast<int>(i);
    const size_t j = where.at(used[i]);
    out.nodes.emplace_back(coord[3 * j], coord[3 * j + 1], coord[3 * j + 2]);
  }
  out.tets.resize(conn.size() / 10);
  for (size_t e = 0; e < out.tets.size(); ++e)
    for (int a = 0; a < 10; ++a) out.tets[e][a] = index.at(conn[10 * e + a]);
  return index;
}

// The sorted node indices on the given surfaces.
std::vector<int> surface_nodes(const std::vector<int>& surfaces,
                               const std::unordered_map<std::size_t, int>& index) {
  std::vector<int> ids;
  for (int sf : surfaces) {
    std::vector<std::size_t> t;
    std::vector<double> c, pc;
    gmsh::model::mesh::getNodes(t, c, pc, 2, sf, true, false);
    for (std::size_t tag : t) {
      auto it = index.find(tag);
      if (it != index.end()) ids.push_back(it->second);
    }
  }
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  return ids;
}

// The clamped surface (the laterals of the bore's or the ring rim's arcs) and the flank nodes
// of every tooth with their roll distance and face coordinate.
void collect_node_sets(const BodyModel& m, const ToothOutline& to, int z,
                       const std::unordered_map<std::size_t, int>& index, GearBodyMesh& out) {
  {
    const std::vector<int> curves = m.regions[m.clamp_region].curves();
    std::vector<int> surf;
    for (size_t c = 0; c < curves.size(); ++c)
      if (std::find(m.clamp_c.begin(), m.clamp_c.end(), std::abs(curves[c])) != m.clamp_c.end())
        surf.insert(surf.end(), m.laterals[m.clamp_region][c].begin(), m.laterals[m.clamp_region][c].end());
    out.clamped_nodes = surface_nodes(surf, index);
  }
  out.flanks.resize(z);
  const std::vector<int> curves = m.regions[m.outer_region].curves();
  std::map<int, size_t> curve_pos;
  for (size_t c = 0; c < curves.size(); ++c) curve_pos[std::abs(curves[c])] = c;
  for (int k = 0; k < z; ++k)
    for (int f = 0; f < 2; ++f) {
      const std::vector<int> ids =
          surface_nodes(m.laterals[m.outer_region][curve_pos.at(m.involute_curve[k][f])], index);
      for (int id : ids) {
        const Eigen::Vector3d& x = out.nodes[id];
        const double R = std::hypot(x.x(), x.y());
        FlankNode fn;
        fn.node = id;
        fn.roll = std::sqrt(std::max(0.0, R * R - to.base_radius * to.base_radius));
        fn.face = x.z();
        out.flanks[k][f].push_back(fn);
      }
    }
}

// The gmsh part: model, outline, regions, extrusion, mesh, node sets.
void mesh_body(const BodyPlan& pl, const GearBodyOptions& o, const ToothOutline& to, const ToothOutline& to_far,
               GearBodyMesh& out) {
  GmshSession session;
  gmsh::model::add("gear_body");
  set_mesh_options(o.threads);
  set_size_field(pl);
  BodyModel m;
  m.B.z0 = pl.zs.front();
  m.B.centre = gmsh::model::geo::addPoint(0, 0, m.B.z0);
  draw_outline(pl, o, to, to_far, m);
  add_regions(pl, o, m);
  extrude_stages(pl, o, m);
  match_laterals(m);
  gmsh::model::mesh::generate(3);
  gmsh::model::mesh::setOrder(2);
  const std::unordered_map<std::size_t, int> index = collect_tet10(m.volumes, out);
  if (out.tets.empty()) throw std::runtime_error("gmsh produced no TET10 elements");
  collect_node_sets(m, to, pl.g.z, index, out);
}

}  // namespace

gm_status build_gear_body(const gm_model_params& p, const gm_pair_geometry& g, int gear,
                          const GearBodyOptions& o, GearBodyMesh& out, std::string& msg) {
  out = GearBodyMesh{};
  msg.clear();
  if (check_options(gear, o, msg) != GM_OK) return GM_ERR_PARAMETER;
  ToothOutline to, to_far;
  const int samples = std::max(8, o.samples_per_piece);
  if (build_tooth_outline(p, g, gear, samples, samples, to, msg) != GM_OK) return GM_ERR_PARAMETER;
  const int far_samples = std::max(8, std::min(samples, o.far_samples_per_piece));
  if (build_tooth_outline(p, g, gear, far_samples, far_samples, to_far, msg) != GM_OK) return GM_ERR_PARAMETER;
  BodyGeometry bg;
  if (body_geometry(p, g, gear, o, to, bg, out, msg) != GM_OK) return GM_ERR_PARAMETER;
  if (!o.mesh_file.empty()) {
    const auto t0 = std::chrono::steady_clock::now();
    const gm_status st = read_mesh_file(o, bg, out, msg);
    out.mesh_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return st;
  }
  BodyPlan pl;
  if (plan_body(o, bg, to, pl, msg) != GM_OK) return GM_ERR_PARAMETER;
  out.profile_size = pl.h_t;
  const auto t_start = std::chrono::steady_clock::now();
  try {
    mesh_body(pl, o, to, to_far, out);
  } catch (const std::exception& e) {
    out.nodes.clear();
    out.tets.clear();
    return fail_with(msg, std::string("gmsh failed: ") + e.what());
  }
  out.mesh_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return GM_OK;
}

double tet10_volume(const std::vector<Eigen::Vector3d>& nodes,
                    const std::vector<std::array<int, 10>>& tets) {
  // Keast's degree-3 rule on the reference tetrahedron (volume 1/6).
  struct QP { double l[4]; double w; };
  std::vector<QP> qp;
  qp.push_back({{0.25, 0.25, 0.25, 0.25}, -4.0 / 5.0 / 6.0});
  for (int i = 0; i < 4; ++i) {
    QP q{{1.0 / 6, 1.0 / 6, 1.0 / 6, 1.0 / 6}, 9.0 / 20.0 / 6.0};
    q.l[i] = 0.5;
    qp.push_back(q);
  }
  static const int edge[6][2] = {{0, 1}, {1, 2}, {2, 0}, {3, 0}, {3, 2}, {3, 1}};
  const Eigen::Vector3d dL[4] = {{-1, -1, -1}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  double V = 0;
  for (const auto& t : tets)
    for (const QP& q : qp) {
      Eigen::Matrix3d J = Eigen::Matrix3d::Zero();
      for (int i = 0; i < 4; ++i) J += nodes[t[i]] * ((4 * q.l[i] - 1) * dL[i]).transpose();
      for (int e = 0; e < 6; ++e) {
        const int i = edge[e][0], j = edge[e][1];
        J += nodes[t[4 + e]] * (4 * (q.l[j] * dL[i] + q.l[i] * dL[j])).transpose();
      }
      V += q.w * J.determinant();
    }
  return V;
}

namespace {

// Nodes on faces that belong to one tetrahedron only (corner and mid-edge nodes).
std::vector<char> boundary_nodes(const GearBodyMesh& m) {
  // Faces of a TET10 in gmsh order: corners and the mid-edge nodes of their edges.
  static const int face[4][6] = {{0, 1, 2, 4, 5, 6}, {0, 1, 3, 4, 9, 7}, {0, 2, 3, 6, 8, 7},
                                 {1, 2, 3, 5, 8, 9}};
  std::vector<std::array<int, 5>> f;  // sorted corners, tet, face
  f.reserve(4 * m.tets.size());
  for (size_t e = 0; e < m.tets.size(); ++e)
    for (int k = 0; k < 4; ++k) {
      std::array<int, 3> c = {m.tets[e][face[k][0]], m.tets[e][face[k][1]], m.tets[e][face[k][2]]};
      std::sort(c.begin(), c.end());
      f.push_back({c[0], c[1], c[2], static_cast<int>(e), k});
    }
  std::sort(f.begin(), f.end());
  std::vector<char> on(m.nodes.size(), 0);
  for (size_t i = 0; i < f.size();) {
    size_t j = i + 1;
    while (j < f.size() && f[j][0] == f[i][0] && f[j][1] == f[i][1] && f[j][2] == f[i][2]) ++j;
    if (j - i == 1)
      for (int a = 0; a < 6; ++a) on[m.tets[f[i][3]][face[f[i][4]][a]]] = 1;
    i = j;
  }
  return on;
}

// A mesh file's refusals: the message names the file, and nothing is left in out.
struct MeshFileError {
  std::string text;
};

// The file's nodes and TET10 elements (it must hold TET10 volume elements only).
void open_mesh_file(const std::string& path, GearBodyMesh& out) {
  if (!std::ifstream(path).good()) throw MeshFileError{"cannot be opened (missing or unreadable)"};
  try {
    GmshSession session;
    gmsh::open(path);
    std::vector<int> types;
    gmsh::model::mesh::getElementTypes(types, 3);
    if (types.empty()) throw MeshFileError{"holds no volume elements; TET10 (gmsh element type 11) expected"};
    for (int t : types)
      if (t != kTet10) {
        std::string name;
        int dim = 0, order = 0, nn = 0, np = 0;
        std::vector<double> lc;
        gmsh::model::mesh::getElementProperties(t, name, dim, order, nn, lc, np);
        throw MeshFileError{"holds volume elements of type '" + name +
                            "'; only quadratic tetrahedra TET10 (gmsh element type 11) are accepted"};
      }
    collect_tet10({-1}, out);
  } catch (const std::exception& e) {
    throw MeshFileError{std::string("gmsh cannot read it: ") + e.what()};
  }
  if (out.tets.empty()) throw MeshFileError{"holds no TET10 elements"};
}

// The face width must be the gear's; the clamped surface is the innermost (bore) or, for a
// ring, the outermost cylinder, checked against the radius given.
void find_clamped_nodes(const GearBodyOptions& o, const BodyGeometry& bg, double tol, GearBodyMesh& out) {
  const double b = bg.b;
  double zmin = 1e300, zmax = -1e300, rmin = 1e300, rmax = 0;
  for (const auto& x : out.nodes) {
    zmin = std::min(zmin, x.z());
    zmax = std::max(zmax, x.z());
    const double R = std::hypot(x.x(), x.y());
    rmin = std::min(rmin, R);
    rmax = std::max(rmax, R);
  }
  if (std::fabs(zmin + 0.5 * b) > tol || std::fabs(zmax - 0.5 * b) > tol)
    throw MeshFileError{fmt("spans z = %g .. %g m; the body frame puts the face width at -b/2 .. +b/2 = "
                            "+-%g m (mesh in metres, z = 0 at mid-face)",
                            zmin, zmax, 0.5 * b)};
  const double rc = bg.ring ? rmax : rmin;
  const double given = bg.ring ? o.outer_radius : o.bore_radius;
  if (given > 0 && std::fabs(given - rc) > tol)
    throw MeshFileError{fmt(bg.ring ? "its outer rim has radius %g m, not the outer_radius %g m given"
                                    : "its bore has radius %g m, not the bore_radius %g m given",
                            rc, given)};
  if (bg.ring ? !(rc > out.root_radius) : !(rc < out.root_radius))
    throw MeshFileError{fmt(bg.ring ? "its outermost cylinder (radius %g m) is not outside the ring's root "
                                      "circle (radius %g m)"
                                    : "its innermost cylinder (radius %g m) is not inside the root circle "
                                      "(radius %g m)",
                            rc, out.root_radius)};
  out.clamped_radius = rc;
  for (size_t i = 0; i < out.nodes.size(); ++i)
    if (std::fabs(std::hypot(out.nodes[i].x(), out.nodes[i].y()) - rc) <= tol)
      out.clamped_nodes.push_back(static_cast<int>(i));
}

// The nearest flank to a point at radius R and section angle psi (turned back to z = 0):
// tooth, flank and distance along the circle.
struct NearestFlank {
  int tooth = 0, flank = 0;
  double distance = 1e300;
};

NearestFlank nearest_flank(const GearBodyMesh& out, double R, double psi) {
  const int z = out.teeth;
  const double pitch = 2.0 * kPi / z;
  const double e = out.eta_b - involute(std::acos(out.base_radius / R));
  NearestFlank best;
  for (int f = 0; f < 2; ++f) {
    const double u = psi - (f == 0 ? e : -e);  // tooth centre angle if on flank f
    const double d = std::remainder(u, pitch);
    if (std::fabs(d) * R < best.distance) {
      best.distance = std::fabs(d) * R;
      best.flank = f;
      best.tooth = static_cast<int>(std::lround((u - d) / pitch)) % z;
      if (best.tooth < 0) best.tooth += z;
    }
  }
  return best;
}

// Flank nodes: boundary nodes on the involute helicoids (see the header). A boundary node
// between the form and tip circles on no involute, or a flank without nodes, means the mesh is
// of another gear.
void find_flank_nodes(const BodyGeometry& bg, double tol, GearBodyMesh& out) {
  const std::vector<char> on = boundary_nodes(out);
  const int z = bg.z;
  const double rb = out.base_radius;
  const double r_lo = std::min(out.form_radius, out.tip_radius), r_hi = std::max(out.form_radius, out.tip_radius);
  const double margin = 0.02 * bg.m_n;
  out.flanks.assign(z, {});
  int off = 0, worst_node = -1;
  double worst = 0;
  for (size_t i = 0; i < out.nodes.size(); ++i) {
    if (!on[i]) continue;
    const Eigen::Vector3d& x = out.nodes[i];
    const double R = std::hypot(x.x(), x.y());
    if (R < r_lo - tol || R > r_hi + tol || R <= rb) continue;
    const double psi = std::atan2(x.y(), x.x()) - bg.hand * bg.twist_rate * x.z();
    const NearestFlank best = nearest_flank(out, R, psi);
    if (best.distance <= tol) {
      FlankNode fn;
      fn.node = static_cast<int>(i);
      fn.roll = std::sqrt(std::max(0.0, R * R - rb * rb));
      fn.face = x.z();
      out.flanks[best.tooth][best.flank].push_back(fn);
    } else if (R > r_lo + margin && R < r_hi - margin && std::fabs(x.z()) < 0.5 * bg.b - tol) {
      ++off;
      if (best.distance > worst) worst = best.distance, worst_node = static_cast<int>(i);
    }
  }
  if (off > 0) {
    const Eigen::Vector3d& x = out.nodes[worst_node];
    throw MeshFileError{std::to_string(off) + fmt(" surface node(s) between the form and tip circles lie off "
                        "this gear's involutes (worst %.3g m away, at (%g, %g", worst, x.x(), x.y()) +
                        fmt(", %g) m; tolerance %g m): the mesh is not of this gear (teeth, module, "
                            "profile shift, helix, or frame differ)", x.z(), tol)};
  }
  for (int k = 0; k < z; ++k)
    for (int f = 0; f < 2; ++f)
      if (out.flanks[k][f].empty())
        throw MeshFileError{"tooth " + std::to_string(k) + " flank " + (f == 0 ? "A" : "B") +
                            " has no surface nodes on its involute: the mesh is not of this gear"};
}

gm_status read_mesh_file(const GearBodyOptions& o, const BodyGeometry& bg, GearBodyMesh& out,
                         std::string& msg) {
  const double tol = o.mesh_tolerance > 0 ? o.mesh_tolerance : 1e-3 * bg.m_n;
  try {
    open_mesh_file(o.mesh_file, out);
    find_clamped_nodes(o, bg, tol, out);
    find_flank_nodes(bg, tol, out);
  } catch (const MeshFileError& e) {
    msg = "gear mesher: mesh file '" + o.mesh_file + "': " + e.text;
    out.nodes.clear();
    out.tets.clear();
    out.clamped_nodes.clear();
    out.flanks.clear();
    return GM_ERR_PARAMETER;
  }
  return GM_OK;
}

}  // namespace

gm_status write_gear_body_msh(const GearBodyMesh& m, const std::string& path, std::string& msg) {
  msg.clear();
  if (path.size() < 4 || path.compare(path.size() - 4, 4, ".msh") != 0) {
    msg = "gear mesher: '" + path + "': the mesh file name must end in .msh";
    return GM_ERR_ARGUMENT;
  }
  try {
    GmshSession session;
    gmsh::model::add("gear_body");
    const int v = gmsh::model::addDiscreteEntity(3);
    std::vector<std::size_t> tags(m.nodes.size());
    std::vector<double> xyz(3 * m.nodes.size());
    for (size_t i = 0; i < m.nodes.size(); ++i) {
      tags[i] = i + 1;
      for (int c = 0; c < 3; ++c) xyz[3 * i + c] = m.nodes[i](c);
    }
    gmsh::model::mesh::addNodes(3, v, tags, xyz);
    std::vector<std::size_t> et(m.tets.size()), nt(10 * m.tets.size());
    for (size_t e = 0; e < m.tets.size(); ++e) {
      et[e] = e + 1;
      for (int a = 0; a < 10; ++a) nt[10 * e + a] = static_cast<std::size_t>(m.tets[e][a]) + 1;
    }
    gmsh::model::mesh::addElementsByType(v, kTet10, et, nt);
    gmsh::option::setNumber("Mesh.MshFileVersion", 4.1);
    gmsh::write(path);
  } catch (const std::exception& e) {
    msg = "gear mesher: writing '" + path + "' failed: " + e.what();
    return GM_ERR_ARGUMENT;
  }
  if (!std::ifstream(path).good()) {
    msg = "gear mesher: writing '" + path + "' failed";
    return GM_ERR_ARGUMENT;
  }
  return GM_OK;
}

}  // namespace gm::mesh
