#include "gear_mesh.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cmath>
#include <map>
#include <stdexcept>
#include <unordered_map>

#include <Eigen/Dense>
#include <gmsh.h>

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

gm_status build_gear_body(const gm_model_params& p, const gm_pair_geometry& g, int gear,
                          const GearBodyOptions& o, GearBodyMesh& out, std::string& msg) {
  out = GearBodyMesh{};
  msg.clear();
  auto fail = [&msg](const std::string& text) {
    msg = "gear mesher: " + text;
    return GM_ERR_PARAMETER;
  };
  if (gear != 0 && gear != 1) return fail("gear index must be 0 or 1");
  if (o.order != 2) return fail("only quadratic elements (order 2) are supported");
  if (o.elements_along_profile < 1 || o.elements_across_width < 1 || o.elements_in_fillet < 1 ||
      o.elements_on_tip < 0)
    return fail("element counts must be >= 1");

  ToothOutline to;
  const int samples = std::max(8, o.samples_per_piece);
  if (build_tooth_outline(p, g, gear, samples, samples, to, msg) != GM_OK) return GM_ERR_PARAMETER;
  const ToothSection& s = to.section;
  const int z = p.gear[gear].teeth;
  const double b = p.gear[gear].face_width, m_n = p.pair.normal_module;
  const int hand1 = p.pair.helix_angle > 0 ? 1 : (p.pair.helix_angle < 0 ? -1 : 0);
  const int hand = gear == 0 ? hand1 : (p.pair.internal ? hand1 : -hand1);
  const double twist_rate = std::tan(g.beta_b) / s.base_radius;

  const double r_f = s.root_radius;
  const double bore = o.bore_radius > 0 ? o.bore_radius : 0.4 * r_f;
  const bool has_web = o.rim_inner_radius > 0;
  if (!(bore < r_f)) return fail(fmt("bore_radius %g m must be below the root radius %g m", bore, r_f));
  if (has_web && !(bore < o.hub_radius && o.hub_radius < o.rim_inner_radius && o.rim_inner_radius < r_f))
    return fail(fmt("rim and web need bore_radius < hub_radius < rim_inner_radius < root radius "
                    "(%g, %g, root %g m)",
                    o.hub_radius, o.rim_inner_radius, r_f));
  const double ann_in = has_web ? o.hub_radius : bore, ann_out = has_web ? o.rim_inner_radius : r_f;
  if (o.holes > 0) {
    if (!(o.hole_radius > 0) || o.hole_circle_radius - o.hole_radius <= ann_in ||
        o.hole_circle_radius + o.hole_radius >= ann_out ||
        2 * o.hole_radius >= 2 * o.hole_circle_radius * std::sin(kPi / o.holes))
      return fail(fmt("lightening holes (radius %g m on radius %g m) must lie inside the web "
                      "annulus and not overlap (annulus %g m ..)",
                      o.hole_radius, o.hole_circle_radius, ann_in));
  }
  // Axial stages: split at the web's faces when the web is narrower than the face.
  std::vector<double> zs = {-0.5 * b, 0.5 * b};
  int web_stage = -1;  // the stage that holds the web (-1: every stage)
  if (has_web && o.web_thickness > 0 && o.web_thickness < b) {
    const double w0 = o.web_offset - 0.5 * o.web_thickness, w1 = o.web_offset + 0.5 * o.web_thickness;
    if (w0 < -0.5 * b - 1e-12 || w1 > 0.5 * b + 1e-12)
      return fail(fmt("the web (offset %g m, thickness %g m) must lie within the face width %g m",
                      o.web_offset, o.web_thickness, b));
    const double tol = 1e-9 * b;
    zs.clear();
    zs.push_back(-0.5 * b);
    if (w0 > -0.5 * b + tol) zs.push_back(w0);
    web_stage = static_cast<int>(zs.size()) - 1;
    if (w1 < 0.5 * b - tol) zs.push_back(w1);
    zs.push_back(0.5 * b);
  }
  const int stages = static_cast<int>(zs.size()) - 1;

  out.teeth = z;
  out.hand = hand;
  out.face_width = b;
  out.base_radius = s.base_radius;
  out.root_radius = r_f;
  out.form_radius = s.form_radius;
  out.tip_radius = s.tip_radius;
  out.bore_radius = bore;
  out.eta_b = s.eta_b;
  out.twist_rate = twist_rate;

  const auto t_start = std::chrono::steady_clock::now();
  try {
    GmshSession session;
    gmsh::model::add("gear_body");
    gmsh::option::setNumber("General.NumThreads", std::max(1, o.threads));
    gmsh::option::setNumber("Mesh.Algorithm", 6);
    gmsh::option::setNumber("Mesh.MeshSizeFromCurvature", 0);
    gmsh::option::setNumber("Mesh.MeshSizeExtendFromBoundary", 1);
    gmsh::option::setNumber("Mesh.MeshSizeFromPoints", 1);
    gmsh::option::setNumber("Mesh.ElementOrder", 2);
    gmsh::option::setNumber("Mesh.SecondOrderLinear", 0);
    gmsh::option::setNumber("Mesh.HighOrderOptimize", 0);
    gmsh::option::setNumber("Mesh.RandomSeed", 1);

    namespace geo = gmsh::model::geo;
    Builder B;
    B.z0 = zs.front();
    B.centre = geo::addPoint(0, 0, B.z0);
    const double rot0 = -hand * twist_rate * 0.5 * b;  // section at z = -b/2

    const double h_t = polyline_length(to.involute) / o.elements_along_profile;
    const double h_b = o.body_size > 0 ? o.body_size : 1.5 * m_n;

    // The tooth outline, all teeth, counter-clockwise.
    std::vector<int> outline;
    std::vector<std::array<int, 2>> involute_curve(z);  // [A, B] per tooth
    auto place = [&](const Eigen::Vector2d& v, double a, bool flank_b) {
      return rot(flank_b ? Eigen::Vector2d(v.x(), -v.y()) : v, a);
    };
    std::vector<int> root_b(z), root_a(z);
    std::vector<int> first_root_b(1);
    const double tip_land = 2.0 * to.tip_half_angle * s.tip_radius;
    const int n_tip = o.elements_on_tip > 0 ? o.elements_on_tip
                                            : std::max(1, static_cast<int>(std::lround(tip_land / h_t)));
    for (int k = 0; k < z; ++k) {
      const double a = rot0 + 2.0 * kPi * k / z;
      auto spline = [&](const std::vector<Eigen::Vector2d>& pts, bool flank_b, bool reverse,
                        int first, int last) {
        std::vector<int> tags;
        const int n = static_cast<int>(pts.size());
        for (int i = 0; i < n; ++i) {
          const int j = reverse ? n - 1 - i : i;
          if (i == 0 && first) tags.push_back(first);
          else if (i == n - 1 && last) tags.push_back(last);
          else tags.push_back(B.point(place(pts[j], a, flank_b), h_t));
        }
        return std::make_pair(geo::addSpline(tags), tags);
      };
      // Flank B: fillet (root -> form), involute (form -> tip).
      auto fb = spline(to.fillet, true, false, 0, 0);
      auto ib = spline(to.involute, true, false, fb.second.back(), 0);
      // Flank A: involute (tip -> form), fillet (form -> root).
      auto ia = spline(to.involute, false, true, 0, 0);
      auto fa = spline(to.fillet, false, true, ia.second.back(), 0);
      const int tip = geo::addCircleArc(ib.second.back(), B.centre, ia.second.front());
      root_b[k] = fb.second.front();
      root_a[k] = fa.second.back();
      outline.insert(outline.end(), {fb.first, ib.first, tip, ia.first, fa.first});
      involute_curve[k] = {ia.first, ib.first};
      geo::mesh::setTransfiniteCurve(fb.first, o.elements_in_fillet + 1);
      geo::mesh::setTransfiniteCurve(fa.first, o.elements_in_fillet + 1);
      geo::mesh::setTransfiniteCurve(ib.first, o.elements_along_profile + 1);
      geo::mesh::setTransfiniteCurve(ia.first, o.elements_along_profile + 1);
      geo::mesh::setTransfiniteCurve(tip, n_tip + 1);
    }
    // Root arcs from flank A's root of tooth k to flank B's root of tooth k+1, inserted after
    // tooth k's five curves.
    std::vector<int> loop;
    const double root_land = (2.0 * kPi / z - 2.0 * to.root_half_angle) * r_f;
    const int n_root = std::max(1, static_cast<int>(std::lround(root_land / h_t)));
    for (int k = 0; k < z; ++k) {
      loop.insert(loop.end(), outline.begin() + 5 * k, outline.begin() + 5 * k + 5);
      const int arc = geo::addCircleArc(root_a[k], B.centre, root_b[(k + 1) % z]);
      geo::mesh::setTransfiniteCurve(arc, n_root + 1);
      loop.push_back(arc);
    }

    // Regions.
    std::vector<Region> regions;
    const std::vector<int> bore_c = B.circle(bore, std::min(h_b, 2.0 * kPi * bore / 24.0));
    std::vector<std::vector<int>> holes;
    for (int h = 0; h < o.holes; ++h) {
      const double ah = rot0 + 2.0 * kPi * h / o.holes;
      holes.push_back(B.circle_at({o.hole_circle_radius * std::cos(ah), o.hole_circle_radius * std::sin(ah)},
                                  o.hole_radius, std::min(h_b, 2.0 * kPi * o.hole_radius / 12.0)));
    }
    int web_region = -1, outer_region = 0, bore_region = 0;
    if (has_web) {
      const std::vector<int> rim_c = B.circle(o.rim_inner_radius, std::min(h_b, 2.0 * kPi * o.rim_inner_radius / 24.0));
      const std::vector<int> hub_c = B.circle(o.hub_radius, std::min(h_b, 2.0 * kPi * o.hub_radius / 24.0));
      regions.push_back({{loop, rim_c}, 0});
      Region web{{rim_c, hub_c}, 0};
      for (const auto& hl : holes) web.loops.push_back(hl);
      regions.push_back(web);
      regions.push_back({{hub_c, bore_c}, 0});
      web_region = 1;
      bore_region = 2;
    } else {
      Region disc{{loop, bore_c}, 0};
      for (const auto& hl : holes) disc.loops.push_back(hl);
      regions.push_back(disc);
    }
    for (Region& r : regions) {
      std::vector<int> wires;
      for (const auto& l : r.loops) wires.push_back(geo::addCurveLoop(l));
      r.surface = geo::addPlaneSurface(wires);
    }

    // Layers per stage, proportional to the stage's length.
    std::vector<int> layers(stages);
    for (int st = 0; st < stages; ++st)
      layers[st] = std::max(1, static_cast<int>(std::lround(o.elements_across_width * (zs[st + 1] - zs[st]) / b)));

    // Extrude stage by stage. laterals[region][curve index] collects the lateral surfaces.
    std::vector<std::vector<std::vector<int>>> laterals(regions.size());
    for (size_t r = 0; r < regions.size(); ++r) laterals[r].resize(regions[r].curves().size());
    std::vector<int> volumes, dropped;
    for (int st = 0; st < stages; ++st) {
      gmsh::vectorpair in, res;
      for (const Region& r : regions) in.push_back({2, r.surface});
      const double dz = zs[st + 1] - zs[st];
      const double angle = hand * twist_rate * dz;
      if (hand != 0)
        geo::twist(in, 0, 0, 0, 0, 0, dz, 0, 0, 1, angle, res, {layers[st]}, {1.0}, false);
      else
        geo::extrude(in, 0, 0, dz, res, {layers[st]}, {1.0}, false);
      size_t pos = 0;
      for (size_t r = 0; r < regions.size(); ++r) {
        const size_t nc = laterals[r].size();
        if (pos + 2 + nc > res.size() || res[pos].first != 2 || res[pos + 1].first != 3)
          throw std::runtime_error("unexpected extrusion result");
        regions[r].surface = res[pos].second;
        const bool keep = !(static_cast<int>(r) == web_region && web_stage >= 0 && st != web_stage);
        (keep ? volumes : dropped).push_back(res[pos + 1].second);
        for (size_t c = 0; c < nc; ++c) laterals[r][c].push_back(res[pos + 2 + c].second);
        pos += 2 + nc;
      }
    }
    if (!dropped.empty()) {
      gmsh::vectorpair d;
      for (int v : dropped) d.push_back({3, v});
      geo::remove(d, false);
    }
    geo::synchronize();
    gmsh::model::mesh::generate(3);
    gmsh::model::mesh::setOrder(2);

    // Nodes and TET10 elements of the kept volumes.
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
    if (conn.empty()) throw std::runtime_error("gmsh produced no TET10 elements");
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

    auto surface_nodes = [&](const std::vector<int>& surfaces) {
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
    };
    // Bore: the laterals of the bore circle's arcs (the last loop of its region before holes).
    {
      const std::vector<int> curves = regions[bore_region].curves();
      std::vector<int> surf;
      for (size_t c = 0; c < curves.size(); ++c)
        if (std::find(bore_c.begin(), bore_c.end(), curves[c]) != bore_c.end())
          surf.insert(surf.end(), laterals[bore_region][c].begin(), laterals[bore_region][c].end());
      out.bore_nodes = surface_nodes(surf);
    }
    // Flanks.
    out.flanks.resize(z);
    {
      const std::vector<int> curves = regions[outer_region].curves();
      std::map<int, size_t> curve_pos;
      for (size_t c = 0; c < curves.size(); ++c) curve_pos[curves[c]] = c;
      for (int k = 0; k < z; ++k)
        for (int f = 0; f < 2; ++f) {
          const std::vector<int> ids =
              surface_nodes(laterals[outer_region][curve_pos.at(involute_curve[k][f])]);
          for (int id : ids) {
            const Eigen::Vector3d& x = out.nodes[id];
            const double R = std::hypot(x.x(), x.y());
            FlankNode fn;
            fn.node = id;
            fn.roll = std::sqrt(std::max(0.0, R * R - s.base_radius * s.base_radius));
            fn.face = x.z();
            out.flanks[k][f].push_back(fn);
          }
        }
    }
  } catch (const std::exception& e) {
    out.nodes.clear();
    out.tets.clear();
    return fail(std::string("gmsh failed: ") + e.what());
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

}  // namespace gm::mesh
