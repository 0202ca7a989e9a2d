// compliance_tool CLI: one gear of a scene -> its compliance database (.gcdb).
//
//   compliance_tool --scene SCENE.toml --gear 1 --out gear1.gcdb [--param name=value ...]
//                   [body, mesh and load flags: see usage() below]
//
// The C++ side has no TOML parser: the scene's parameters come as --param name=value pairs, with
// the FMU's variable names and SI units (pair.normal_module=0.002, gear1.teeth=20, ...), applied
// on top of gm_default_params. The Python tooling (gearmesh.scene) calls the tool that way with
// the scene's parameters; --scene is then only recorded in the database note. Names of the FMU
// that do not change the gear body (friction, micro-geometry, solver, ...) are accepted and
// ignored; anything else is an error. Body flags are in mm and give DIAMETERS.
// Progress goes to stderr; on success one summary line goes to stdout:
//   compliance_tool: nodes=N elements=N dofs=N grid=N tooth_sets=N loaded=N solves=N mesh_s=X
//   locate_s=X assembly_s=X factor_s=X solve_s=X total_s=X peak_rss_MiB=X
// Exit status 0 on success; 2 on bad usage (unknown flag, missing value, a value outside its
// fixed range: the message names the flag, the value and the allowed range); 1 on a value that
// does not fit the gear (e.g. a bore larger than the root circle; the message names the flag) or
// any failure of the build (the message names the cause).
#include <dlfcn.h>
#include <sys/resource.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include "compliance_build.hpp"
#include "gearmesh/internal/compliance_db.hpp"
#include "gearmesh/gearmesh.h"

namespace {

void usage(FILE* f) {
  std::fprintf(f,
      "usage: compliance_tool --scene SCENE.toml --gear {1|2} --out FILE.gcdb [--param name=value ...]\n"
      "  --param NAME=VALUE        FMU parameter in SI (pair.normal_module=0.002, gear1.teeth=20, ...)\n"
      "                            on top of the defaults; the Python tooling passes the scene's\n"
      "  gear body (mm, diameters; default a solid disc with a bore of 0.4 d_f):\n"
      "  --bore-diameter-mm D      bore (clamped) diameter, 0 < D < root diameter\n"
      "  --rim-inner-diameter-mm D inner diameter of the rim = outer of the web (with --hub-diameter-mm)\n"
      "  --hub-diameter-mm D       outer diameter of the hub = inner of the web\n"
      "  --web-thickness-mm T      axial web thickness, 0 < T <= face width (default: full width)\n"
      "  --web-offset-mm O         axial offset of the web's mid-plane from mid-face (default 0)\n"
      "  --holes N                 lightening holes, 0..1000 (with --hole-diameter-mm and\n"
      "  --hole-diameter-mm D        --hole-circle-diameter-mm), equally spaced, hole 0 on tooth 0\n"
      "  --hole-circle-diameter-mm D\n"
      "  --ring-outer-diameter-mm D  outer diameter of an internal ring gear (pair.internal=1, gear 2)\n"
      "  --mesh FILE               user-supplied mesh instead of the generated body (treated as\n"
      "                            not cyclic: every tooth is loaded)\n"
      "  mesh and FE:\n"
      "  --profile-elements N      along the involute, 1..200 (default 8)\n"
      "  --width-elements N        layers across the face width, 1..200 (default 6)\n"
      "  --fillet-elements N       along each fillet, 1..200 (default 3)\n"
      "  --body-size-mm S          target element size in the body, > 0 (default 2 m_n)\n"
      "  --depth-mm H              depth of the responses below the flank, > 0 (default 0.5)\n"
      "  --coupled N               neighbour teeth each side, 0..20 (default model.coupled_teeth, else 1)\n"
      "  --every-tooth             load every distinct tooth even on a cyclic body (cyclic = 0)\n"
      "  --load-fraction F         share of the flank grid loaded, 0 < F <= 1 (default 1); the other\n"
      "                            columns come from the reduction space of the loaded ones\n"
      "  --threads N               threads for gmsh and the BLAS under CHOLMOD, 1..256\n"
      "  --note TEXT               appended to the database note\n"
      "  --write-mesh FILE         also write the body mesh used (gmsh .msh; --mesh reads it back)\n");
}

bool parse_double(const std::string& s, double& v) {
  char* end = nullptr;
  errno = 0;
  v = std::strtod(s.c_str(), &end);
  return !s.empty() && end && *end == 0 && errno == 0 && std::isfinite(v);
}
bool parse_int(const std::string& s, int& v) {
  double d;
  if (!parse_double(s, d) || d != std::floor(d) || std::fabs(d) > 1e9) return false;
  v = int(d);
  return true;
}

// Set one parameter by its FMU name. 1 set, 0 known but irrelevant (ignored), -1 unknown/bad.
int set_param(gm_model_params& p, const std::string& name, const std::string& value, std::string& err) {
  double d = 0;
  int i = 0;
  auto real = [&](double& f) {
    if (!parse_double(value, d)) return err = name + " = " + value + ": not a finite number", -1;
    f = d;
    return 1;
  };
  auto integer = [&](int& f) {
    if (!parse_int(value, i)) return err = name + " = " + value + ": not an integer", -1;
    f = i;
    return 1;
  };
  if (name == "pair.center_distance") return real(p.pair.center_distance);
  if (name == "pair.normal_module") return real(p.pair.normal_module);
  if (name == "pair.pressure_angle") return real(p.pair.pressure_angle);
  if (name == "pair.helix_angle") return real(p.pair.helix_angle);
  if (name == "pair.internal") return integer(p.pair.internal);
  if (name == "pair.rack_addendum") return real(p.pair.rack_addendum);
  if (name == "pair.rack_dedendum") return real(p.pair.rack_dedendum);
  if (name == "pair.rack_tip_radius") return real(p.pair.rack_tip_radius);
  if (name == "model.coupled_teeth") return integer(p.coupled_teeth);
  for (int n = 0; n < 2; ++n) {
    const std::string g = "gear" + std::to_string(n + 1) + ".";
    if (name.compare(0, g.size(), g) != 0) continue;
    const std::string f = name.substr(g.size());
    gm_gear_params& gp = p.gear[n];
    if (f == "teeth") return integer(gp.teeth);
    if (f == "profile_shift") return real(gp.profile_shift);
    if (f == "face_width") return real(gp.face_width);
    if (f == "tip_diameter") return real(gp.tip_diameter);
    if (f == "thickness_allowance") return real(gp.thickness_allowance);
    if (f == "axial_offset") return real(gp.axial_offset);
    if (f == "youngs_modulus") return real(gp.youngs_modulus);
    if (f == "poisson_ratio") return real(gp.poisson_ratio);
    return 0;  // micro-geometry, deviations, compliance file: not the body
  }
  for (const char* prefix : {"model.", "solver.", "pair."})
    if (name.compare(0, std::strlen(prefix), prefix) == 0) return 0;
  err = "unknown parameter '" + name + "' (expected FMU names: pair.*, gear1.*, gear2.*, model.*)";
  return -1;
}


// A bad flag value: name it, its value and the allowed range.
int bad_value(const std::string& flag, const std::string& value, const std::string& allowed) {
  std::fprintf(stderr, "compliance_tool: %s %s: allowed %s\n", flag.c_str(), value.c_str(), allowed.c_str());
  return 2;
}

double peak_rss_mib() {
  struct rusage ru {};
  getrusage(RUSAGE_SELF, &ru);
  return double(ru.ru_maxrss) / 1024.0;  // Linux: KiB
}

// The BLAS under CHOLMOD (OpenBLAS if that is what is loaded): set its thread count if it has
// the call; other BLAS builds keep their own setting.
void set_blas_threads(int n) {
  using Fn = void (*)(int);
  if (void* f = dlsym(RTLD_DEFAULT, "openblas_set_num_threads")) reinterpret_cast<Fn>(f)(n);
}

}  // namespace

int main(int argc, char** argv) {
  const auto t_start = std::chrono::steady_clock::now();
  gm_model_params p;
  gm_default_params(&p);
  gm::ctool::BuildOptions o;
  o.mesh.elements_along_profile = 8;
  o.mesh.elements_across_width = 6;
  std::string scene, out, mesh_file;
  int gear = 0, coupled = -1, threads = 0;
  // Body flags in mm (diameters); < 0 = not given.
  double bore_d = -1, rim_d = -1, hub_d = -1, web_t = -1, web_o = 0, hole_d = -1, hole_circle_d = -1;
  double ring_d = -1, body_size = -1;
  int holes = 0;
  bool web_o_given = false;
  std::vector<std::string> ignored;
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    if (arg == "-h" || arg == "--help") {
      usage(stdout);
      return 0;
    }
    if (arg == "--every-tooth") {
      o.every_tooth = true;
      continue;
    }
    static const char* const kValued[] = {
        "--scene", "--out", "--note", "--gear", "--coupled", "--depth-mm", "--profile-elements",
        "--width-elements", "--fillet-elements", "--param", "--bore-diameter-mm",
        "--rim-inner-diameter-mm", "--hub-diameter-mm", "--web-thickness-mm", "--web-offset-mm",
        "--holes", "--hole-diameter-mm", "--hole-circle-diameter-mm", "--ring-outer-diameter-mm",
        "--mesh", "--body-size-mm", "--load-fraction", "--threads", "--write-mesh"};
    if (std::find(std::begin(kValued), std::end(kValued), arg) == std::end(kValued)) {
      std::fprintf(stderr, "compliance_tool: unknown argument '%s'%s\n", arg.c_str(),
                   arg == "--bore-mm" ? " (now --bore-diameter-mm, a diameter in mm)" : "");
      usage(stderr);
      return 2;
    }
    if (a + 1 >= argc) {
      std::fprintf(stderr, "compliance_tool: %s needs a value\n", arg.c_str());
      usage(stderr);
      return 2;
    }
    const std::string v = argv[++a];
    double d = 0;
    int i = 0;
    // Real > lo (or >= lo if closed), <= hi.
    auto real = [&](double& dst, double lo, bool lo_closed, double hi, const char* allowed) {
      if (!parse_double(v, d) || (lo_closed ? d < lo : d <= lo) || d > hi) return bad_value(arg, v, allowed);
      dst = d;
      return 0;
    };
    auto integer = [&](int& dst, int lo, int hi) {
      if (!parse_int(v, i) || i < lo || i > hi)
        return bad_value(arg, v, "an integer " + std::to_string(lo) + ".." + std::to_string(hi));
      dst = i;
      return 0;
    };
    constexpr double big = 1e6;  // mm
    int rc = 0;
    if (arg == "--scene") scene = v;
    else if (arg == "--out") out = v;
    else if (arg == "--note") o.note = v;
    else if (arg == "--mesh") mesh_file = v;
    else if (arg == "--write-mesh") o.write_mesh = v;
    else if (arg == "--gear") rc = integer(gear, 1, 2);
    else if (arg == "--coupled") rc = integer(coupled, 0, int(gm::kComplianceDbMaxCoupled));
    else if (arg == "--depth-mm") {
      double h = 0;
      rc = real(h, 0, false, big, "a depth in mm > 0");
      o.depth = h * 1e-3;
    } else if (arg == "--profile-elements") rc = integer(o.mesh.elements_along_profile, 1, 200);
    else if (arg == "--width-elements") rc = integer(o.mesh.elements_across_width, 1, 200);
    else if (arg == "--fillet-elements") rc = integer(o.mesh.elements_in_fillet, 1, 200);
    else if (arg == "--bore-diameter-mm") rc = real(bore_d, 0, false, big, "a diameter in mm > 0");
    else if (arg == "--rim-inner-diameter-mm") rc = real(rim_d, 0, false, big, "a diameter in mm > 0");
    else if (arg == "--hub-diameter-mm") rc = real(hub_d, 0, false, big, "a diameter in mm > 0");
    else if (arg == "--web-thickness-mm") rc = real(web_t, 0, false, big, "a thickness in mm > 0");
    else if (arg == "--web-offset-mm") {
      rc = real(web_o, -big, true, big, "an offset in mm (finite)");
      web_o_given = true;
    } else if (arg == "--holes") rc = integer(holes, 0, 1000);
    else if (arg == "--hole-diameter-mm") rc = real(hole_d, 0, false, big, "a diameter in mm > 0");
    else if (arg == "--hole-circle-diameter-mm") rc = real(hole_circle_d, 0, false, big, "a diameter in mm > 0");
    else if (arg == "--ring-outer-diameter-mm") rc = real(ring_d, 0, false, big, "a diameter in mm > 0");
    else if (arg == "--body-size-mm") rc = real(body_size, 0, false, big, "a size in mm > 0");
    else if (arg == "--load-fraction") rc = real(o.load_fraction, 0, false, 1, "a fraction 0 < F <= 1");
    else if (arg == "--threads") rc = integer(threads, 1, 256);
    else if (arg == "--param") {
      const auto eq = v.find('=');
      if (eq == std::string::npos || eq == 0) return bad_value(arg, v, "NAME=VALUE");
      std::string err;
      const int r = set_param(p, v.substr(0, eq), v.substr(eq + 1), err);
      if (r < 0) {
        std::fprintf(stderr, "compliance_tool: --param %s\n", err.c_str());
        return 2;
      }
      if (r == 0) ignored.push_back(v.substr(0, eq));
    }
    if (rc != 0) return rc;
  }
  if (gear == 0 || out.empty()) {
    std::fprintf(stderr, "compliance_tool: --gear and --out are required\n");
    usage(stderr);
    return 2;
  }
  if (!ignored.empty())
    std::fprintf(stderr, "compliance_tool: %zu parameter(s) that do not change the body ignored\n",
                 ignored.size());

  // Flags that must go together, and values against the gear (exit 1: the value does not fit).
  auto misfit = [](const std::string& text) {
    std::fprintf(stderr, "compliance_tool: %s\n", text.c_str());
    return 1;
  };
  auto mm = [](double x) {
    std::ostringstream s;
    s << x << " mm";
    return s.str();
  };
  if ((rim_d > 0) != (hub_d > 0))
    return misfit("--rim-inner-diameter-mm and --hub-diameter-mm go together (a web between hub and rim)");
  if ((web_t > 0 || web_o_given) && !(rim_d > 0))
    return misfit("--web-thickness-mm / --web-offset-mm need a web (--rim-inner-diameter-mm and --hub-diameter-mm)");
  if (holes > 0 && !(hole_d > 0 && hole_circle_d > 0))
    return misfit("--holes needs --hole-diameter-mm and --hole-circle-diameter-mm");
  if (holes == 0 && (hole_d > 0 || hole_circle_d > 0))
    return misfit("--hole-diameter-mm / --hole-circle-diameter-mm need --holes N (N >= 1)");
  const bool ring = p.pair.internal != 0 && gear == 2;
  if (ring_d > 0 && !ring)
    return misfit("--ring-outer-diameter-mm is for the internal ring gear (pair.internal=1, --gear 2)");
  gm_pair_geometry geo;
  {
    char cmsg[1024] = {0};
    if (gm_compute_geometry(&p, &geo, cmsg, sizeof cmsg) != GM_OK) return misfit(cmsg);
  }
  const double d_f = geo.gear[gear - 1].d_f * 1e3, b = p.gear[gear - 1].face_width * 1e3;
  if (!ring && mesh_file.empty()) {
    const double bore = bore_d > 0 ? bore_d : 0.4 * d_f;
    if (!(bore < d_f))
      return misfit("--bore-diameter-mm " + mm(bore_d) + ": allowed below the root diameter " + mm(d_f));
    if (rim_d > 0) {
      if (!(rim_d < d_f))
        return misfit("--rim-inner-diameter-mm " + mm(rim_d) + ": allowed below the root diameter " + mm(d_f));
      if (!(hub_d > bore && hub_d < rim_d))
        return misfit("--hub-diameter-mm " + mm(hub_d) + ": allowed between the bore " + mm(bore) +
                      " and the rim's inner diameter " + mm(rim_d));
      if (web_t > b) return misfit("--web-thickness-mm " + mm(web_t) + ": allowed up to the face width " + mm(b));
      const double wt = web_t > 0 ? web_t : b;
      if (std::fabs(web_o) + 0.5 * wt > 0.5 * b * (1 + 1e-9))
        return misfit("--web-offset-mm " + mm(web_o) + ": the web (thickness " + mm(wt) +
                      ") must stay within the face width " + mm(b) + ", |offset| <= " + mm(0.5 * (b - wt)));
    }
    if (holes > 0) {
      const double in = rim_d > 0 ? hub_d : bore, outer = rim_d > 0 ? rim_d : d_f;
      if (!(hole_circle_d - hole_d > in && hole_circle_d + hole_d < outer))
        return misfit("--hole-circle-diameter-mm " + mm(hole_circle_d) + " with --hole-diameter-mm " +
                      mm(hole_d) + ": the holes must lie inside the " + (rim_d > 0 ? "web" : "disc") +
                      " annulus " + mm(in) + " .. " + mm(outer) + " (hole circle +- hole diameter)");
      if (!(hole_d < hole_circle_d * std::sin(3.14159265358979323846 / holes)))
        return misfit("--hole-diameter-mm " + mm(hole_d) + ": " + std::to_string(holes) +
                      " holes on the circle " + mm(hole_circle_d) + " overlap; allowed below " +
                      mm(hole_circle_d * std::sin(3.14159265358979323846 / holes)));
    }
  }
  if (ring && ring_d > 0 && !(ring_d > d_f))
    return misfit("--ring-outer-diameter-mm " + mm(ring_d) + ": allowed above the ring's root diameter " + mm(d_f));
  if (ring_d > 0) o.mesh.outer_radius = 0.5e-3 * ring_d;
  o.mesh.mesh_file = mesh_file;

  o.coupled = coupled >= 0 ? coupled : (p.coupled_teeth > 0 ? p.coupled_teeth : 1);
  if (bore_d > 0) o.mesh.bore_radius = 0.5e-3 * bore_d;
  if (rim_d > 0) o.mesh.rim_inner_radius = 0.5e-3 * rim_d;
  if (hub_d > 0) o.mesh.hub_radius = 0.5e-3 * hub_d;
  if (web_t > 0) o.mesh.web_thickness = 1e-3 * web_t;
  o.mesh.web_offset = 1e-3 * web_o;
  o.mesh.holes = holes;
  if (holes > 0) {
    o.mesh.hole_radius = 0.5e-3 * hole_d;
    o.mesh.hole_circle_radius = 0.5e-3 * hole_circle_d;
  }
  if (body_size > 0) o.mesh.body_size = 1e-3 * body_size;
  if (threads > 0) {
    o.mesh.threads = threads;
    set_blas_threads(threads);
  }
  if (!scene.empty()) o.note = "scene " + scene + (o.note.empty() ? "" : "; " + o.note);
  o.progress = [](const std::string& s) { std::fprintf(stderr, "compliance_tool: %s\n", s.c_str()); };

  gm::ComplianceDb db;
  gm::ctool::BuildStats stats;
  std::string msg;
  gm_status st = gm::ctool::build_compliance_db(p, gear - 1, o, db, stats, msg);
  if (st != GM_OK) {
    std::fprintf(stderr, "compliance_tool: %s\n", msg.c_str());
    return 1;
  }
  st = gm::write_compliance_db(out.c_str(), db, msg);
  if (st != GM_OK) {
    std::fprintf(stderr, "compliance_tool: %s\n", msg.c_str());
    return 1;
  }
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  std::fprintf(stderr, "compliance_tool: wrote %s (%d x %d grid, n_c = %u, %s, %zu tooth set(s))\n",
               out.c_str(), int(db.roll.size()), int(db.face.size()), db.n_coupled,
               db.cyclic ? "cyclic" : "every tooth", db.tooth_sets());
  std::printf("compliance_tool: nodes=%d elements=%d dofs=%d grid=%d tooth_sets=%d loaded=%d solves=%d "
              "mesh_s=%.3f locate_s=%.3f assembly_s=%.3f factor_s=%.3f solve_s=%.3f total_s=%.3f "
              "peak_rss_MiB=%.1f\n",
              stats.nodes, stats.elements, stats.dofs, stats.grid, stats.tooth_sets, stats.loaded,
              stats.solves, stats.mesh_seconds, stats.locate_seconds, stats.assembly_seconds,
              stats.factor_seconds, stats.solve_seconds, total, peak_rss_mib());
  return 0;
}
