// compliance_tool CLI: one gear of a scene -> its compliance database (.gcdb).
//
//   compliance_tool --scene SCENE.toml --gear 1 --out gear1.gcdb [--param name=value ...]
//                   [--depth-mm 0.5] [--coupled 2] [--profile-elements 8] [--width-elements 6]
//                   [--fillet-elements 3] [--bore-mm R] [--note TEXT]
//
// The C++ side has no TOML parser: the scene's parameters come as --param name=value pairs, with
// the FMU's variable names and SI units (pair.normal_module=0.002, gear1.teeth=20, ...), applied
// on top of gm_default_params. The Python tooling (gearmesh.scene) calls the tool that way with
// the scene's parameters; --scene is then only recorded in the database note. Names of the FMU
// that do not change the gear body (friction, micro-geometry, solver, ...) are accepted and
// ignored; anything else is an error. Progress goes to stderr; exit status 0 on success, 1 on a
// bad parameter or failure (the message names the cause), 2 on bad usage.
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "compliance_build.hpp"
#include "compliance_db.hpp"
#include "gearmesh/gearmesh.h"

namespace {

void usage(FILE* f) {
  std::fprintf(f,
      "usage: compliance_tool --scene SCENE.toml --gear {1|2} --out FILE.gcdb\n"
      "         [--param name=value ...] [--depth-mm 0.5] [--coupled N] [--profile-elements 8]\n"
      "         [--width-elements 6] [--fillet-elements 3] [--bore-mm R] [--note TEXT]\n"
      "  --param: FMU parameter names in SI (pair.normal_module=0.002, gear1.teeth=20, ...),\n"
      "           on top of the defaults; the Python tooling passes the scene's parameters.\n"
      "  --coupled: neighbour teeth each side (default: model.coupled_teeth, else 1)\n");
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

}  // namespace

int main(int argc, char** argv) {
  gm_model_params p;
  gm_default_params(&p);
  gm::ctool::BuildOptions o;
  o.mesh.elements_along_profile = 8;
  o.mesh.elements_across_width = 6;
  std::string scene, out;
  int gear = 0, coupled = -1;
  double bore_mm = 0;
  std::vector<std::string> ignored;
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    auto next = [&](std::string& v) {
      if (a + 1 >= argc) return false;
      v = argv[++a];
      return true;
    };
    std::string v, err;
    double d = 0;
    int i = 0;
    bool ok = true;
    if (arg == "-h" || arg == "--help") {
      usage(stdout);
      return 0;
    } else if (arg == "--scene") ok = next(scene);
    else if (arg == "--out") ok = next(out);
    else if (arg == "--note") ok = next(o.note);
    else if (arg == "--gear") ok = next(v) && parse_int(v, gear) && (gear == 1 || gear == 2);
    else if (arg == "--coupled") ok = next(v) && parse_int(v, coupled) && coupled >= 0;
    else if (arg == "--depth-mm") ok = next(v) && parse_double(v, d) && d > 0, o.depth = d * 1e-3;
    else if (arg == "--bore-mm") ok = next(v) && parse_double(v, bore_mm) && bore_mm >= 0;
    else if (arg == "--profile-elements")
      ok = next(v) && parse_int(v, i) && i >= 1, o.mesh.elements_along_profile = i;
    else if (arg == "--width-elements")
      ok = next(v) && parse_int(v, i) && i >= 1, o.mesh.elements_across_width = i;
    else if (arg == "--fillet-elements")
      ok = next(v) && parse_int(v, i) && i >= 1, o.mesh.elements_in_fillet = i;
    else if (arg == "--param") {
      ok = next(v);
      const auto eq = v.find('=');
      if (ok && eq != std::string::npos && eq > 0) {
        const int r = set_param(p, v.substr(0, eq), v.substr(eq + 1), err);
        if (r < 0) {
          std::fprintf(stderr, "compliance_tool: --param %s\n", err.c_str());
          return 2;
        }
        if (r == 0) ignored.push_back(v.substr(0, eq));
      } else {
        ok = false;
      }
    } else {
      ok = false;
    }
    if (!ok) {
      std::fprintf(stderr, "compliance_tool: bad or incomplete argument '%s'\n", arg.c_str());
      usage(stderr);
      return 2;
    }
  }
  if (gear == 0 || out.empty()) {
    std::fprintf(stderr, "compliance_tool: --gear and --out are required\n");
    usage(stderr);
    return 2;
  }
  if (!ignored.empty())
    std::fprintf(stderr, "compliance_tool: %zu parameter(s) that do not change the body ignored\n",
                 ignored.size());
  o.coupled = coupled >= 0 ? coupled : (p.coupled_teeth > 0 ? p.coupled_teeth : 1);
  o.mesh.bore_radius = bore_mm * 1e-3;
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
  std::fprintf(stderr,
               "compliance_tool: wrote %s (%d x %d grid, n_c = %u; mesh %.2f s, assembly %.2f s, "
               "factorization %.2f s, solves %.2f s)\n",
               out.c_str(), int(db.roll.size()), int(db.face.size()), db.n_coupled, stats.mesh_seconds,
               stats.assembly_seconds, stats.factor_seconds, stats.solve_seconds);
  return 0;
}
