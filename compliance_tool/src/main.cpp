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
//   locate_s=X assembly_s=X factor_s=X solve_s=X total_s=X cpu_s=X peak_rss_MiB=X
// Exit status 0 on success; 2 on bad usage (unknown flag, missing value, a value outside its
// fixed range: the message names the flag, the value and the allowed range); 1 on a value that
// does not fit the gear (e.g. a bore larger than the root circle; the message names the flag) or
// any failure of the build (the message names the cause).
#include <dlfcn.h>
#include <strings.h>
#include <sys/resource.h>
#include <unistd.h>

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
#include "gearmesh/parameters.h"

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
               "  --width-elements N        layers across the face width, 1..200 (default 4)\n"
               "  --fillet-elements N       along each fillet, 1..200 (default 3)\n"
               "  --body-size-mm S          target element size in the body, > 0 (default 4 m_n)\n"
               "  --hole-band-size-mm S     element size around lightening holes, > 0 (default hole diameter / 10)\n"
               "  --depth-mm H              depth of the responses below the flank, > 0 (default 0.5)\n"
               "  --coupled N               neighbour teeth each side, 0..20 (default model.coupled_teeth, else 1)\n"
               "  --every-tooth             load every distinct tooth even on a cyclic body (cyclic = 0)\n"
               "  --plane-strain            hold every node's axial displacement (a plane-strain slab, to\n"
               "                            compare with plane models; not for the product)\n"
               "  --load-fraction F         share of the flank grid loaded, 0 < F <= 1 (default 1); the other\n"
               "                            columns come from the reduction space of the loaded ones\n"
               "  --threads N               threads for gmsh and the BLAS under CHOLMOD, 1..256\n"
               "  --note TEXT               appended to the database note\n"
               "  --check                   check the parameters and the body against the gear, build\n"
               "                            nothing (exit 0: they fit; 1: what does not fit; --out not needed)\n"
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

// Set one parameter by its FMU name (gearmesh/parameters.h): 1 set (a parameter of the gear body,
// GM_PARAM_BODY), 0 known but not the body's (ignored), -1 unknown or not a number.
int set_param(gm_model_params& p, const std::string& name, const std::string& value, std::string& err) {
  const gm_param_info* info = gm_parameter_find(name.c_str());
  if (!info) {
    err = "unknown parameter '" + name + "' (expected FMU parameter names: pair.*, gear1.*, gear2.*, model.*)";
    return -1;
  }
  if (!(info->flags & GM_PARAM_BODY)) return 0;
  double d = 0;
  int i = 0;
  if (info->type == GM_PARAM_Real ? !parse_double(value, d) : !parse_int(value, i)) {
    err = name + " = " + value + (info->type == GM_PARAM_Real ? ": not a finite number" : ": not an integer");
    return -1;
  }
  char msg[256];
  if (gm_parameter_set(&p, nullptr, name.c_str(), info->type == GM_PARAM_Real ? d : i, msg, sizeof msg) != GM_OK) {
    err = msg;
    return -1;
  }
  return 1;
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

// CPU time of the process so far (user + system, all threads), s.
double cpu_seconds() {
  struct rusage ru {};
  getrusage(RUSAGE_SELF, &ru);
  return double(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) + 1e-6 * double(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
}

// The BLAS under CHOLMOD (OpenBLAS if that is what is loaded): set its thread count if it has
// the call; other BLAS builds keep their own setting.
void set_blas_threads(int n) {
  using Fn = void (*)(int);
  if (void* f = dlsym(RTLD_DEFAULT, "openblas_set_num_threads")) reinterpret_cast<Fn>(f)(n);
}

// OpenBLAS (a DYNAMIC_ARCH build such as Debian's) picks its kernels from the CPU model when it is
// loaded; a model it does not know (0.3.21 on newer Xeons, or a CPU model a hypervisor hides)
// falls back to the generic SSE3 "Prescott" kernels, several times slower than the AVX2/AVX-512
// ones the CPU runs (the factorization and the solves are BLAS-3). OPENBLAS_CORETYPE chooses the
// kernels, but OpenBLAS reads it only when it is loaded: so if the kernels are the generic ones,
// the CPU has AVX-512 (or AVX2) and the user did not set OPENBLAS_CORETYPE, the tool sets it and
// runs itself again (same arguments). Anything unusual (not OpenBLAS, the exec fails) keeps going
// as it is.
void use_openblas_kernels_of_this_cpu(char** argv) {
  if (std::getenv("OPENBLAS_CORETYPE")) return;
  using Fn = char* (*)();
  void* f = dlsym(RTLD_DEFAULT, "openblas_get_corename");
  if (!f) return;
  const char* core = reinterpret_cast<Fn>(f)();
  if (!core || strcasecmp(core, "Prescott") != 0) return;
  __builtin_cpu_init();
  const char* want = nullptr;
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
      __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512vl"))
    want = "SkylakeX";
  else if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"))
    want = "Haswell";
  char self[4096];
  const ssize_t len = readlink("/proc/self/exe", self, sizeof self - 1);  // Linux
  if (!want || len <= 0 || setenv("OPENBLAS_CORETYPE", want, 1) != 0) return;
  self[len] = 0;
  execv(self, argv);
  unsetenv("OPENBLAS_CORETYPE");  // exec failed: go on with the kernels loaded
}

// Everything the command line says, as parsed.
struct Cli {
  gm_model_params p;
  gm::ctool::BuildOptions o;
  std::string scene, out, mesh_file;
  int gear = 0, coupled = -1, threads = 0;
  // Body flags in mm (diameters); < 0 = not given.
  double bore_d = -1, rim_d = -1, hub_d = -1, web_t = -1, web_o = 0, hole_d = -1, hole_circle_d = -1;
  double ring_d = -1, body_size = -1, hole_band_size = -1;
  int holes = 0;
  bool web_o_given = false;
  bool check_only = false;  // --check: the checks alone, no build
  std::vector<std::string> ignored;
  Cli() {
    gm_default_params(&p);
    o.mesh.elements_along_profile = 8;
    o.mesh.elements_across_width = 4;
  }
};

constexpr int kGoOn = -1;    // a flag's handler: parsing goes on (else the exit status)
constexpr double kBig = 1e6;  // mm

// Real > lo (or >= lo if closed), <= hi.
int real_flag(double& dst, const std::string& flag, const std::string& v, double lo, bool lo_closed,
              double hi, const char* allowed) {
  double d = 0;
  if (!parse_double(v, d) || (lo_closed ? d < lo : d <= lo) || d > hi) return bad_value(flag, v, allowed);
  dst = d;
  return kGoOn;
}
int int_flag(int& dst, const std::string& flag, const std::string& v, int lo, int hi) {
  int i = 0;
  if (!parse_int(v, i) || i < lo || i > hi)
    return bad_value(flag, v, "an integer " + std::to_string(lo) + ".." + std::to_string(hi));
  dst = i;
  return kGoOn;
}
int diameter_flag(double& dst, const std::string& flag, const std::string& v) {
  return real_flag(dst, flag, v, 0, false, kBig, "a diameter in mm > 0");
}

int param_flag(Cli& c, const std::string& flag, const std::string& v) {
  const auto eq = v.find('=');
  if (eq == std::string::npos || eq == 0) return bad_value(flag, v, "NAME=VALUE");
  std::string err;
  const int r = set_param(c.p, v.substr(0, eq), v.substr(eq + 1), err);
  if (r < 0) {
    std::fprintf(stderr, "compliance_tool: --param %s\n", err.c_str());
    return 2;
  }
  if (r == 0) c.ignored.push_back(v.substr(0, eq));
  return kGoOn;
}

// The flags: name, whether a value follows, and what it sets (kGoOn, or the exit status).
using S = const std::string&;
struct Flag {
  const char* name;
  bool valued;
  int (*set)(Cli& c, S flag, S v);
};
const Flag kFlags[] = {
    {"-h", false, [](Cli&, S, S) { usage(stdout); return 0; }},
    {"--help", false, [](Cli&, S, S) { usage(stdout); return 0; }},
    {"--every-tooth", false, [](Cli& c, S, S) { c.o.every_tooth = true; return kGoOn; }},
    {"--plane-strain", false, [](Cli& c, S, S) { c.o.plane_strain = true; return kGoOn; }},
    {"--check", false, [](Cli& c, S, S) { c.check_only = true; return kGoOn; }},
    {"--scene", true, [](Cli& c, S, S v) { c.scene = v; return kGoOn; }},
    {"--out", true, [](Cli& c, S, S v) { c.out = v; return kGoOn; }},
    {"--note", true, [](Cli& c, S, S v) { c.o.note = v; return kGoOn; }},
    {"--mesh", true, [](Cli& c, S, S v) { c.mesh_file = v; return kGoOn; }},
    {"--write-mesh", true, [](Cli& c, S, S v) { c.o.write_mesh = v; return kGoOn; }},
    {"--gear", true, [](Cli& c, S f, S v) { return int_flag(c.gear, f, v, 1, 2); }},
    {"--coupled", true,
     [](Cli& c, S f, S v) { return int_flag(c.coupled, f, v, 0, int(gm::kComplianceDbMaxCoupled)); }},
    {"--depth-mm", true,
     [](Cli& c, S f, S v) {
       double h = 0;
       const int rc = real_flag(h, f, v, 0, false, kBig, "a depth in mm > 0");
       c.o.depth = h * 1e-3;
       return rc;
     }},
    {"--profile-elements", true,
     [](Cli& c, S f, S v) { return int_flag(c.o.mesh.elements_along_profile, f, v, 1, 200); }},
    {"--width-elements", true,
     [](Cli& c, S f, S v) { return int_flag(c.o.mesh.elements_across_width, f, v, 1, 200); }},
    {"--fillet-elements", true,
     [](Cli& c, S f, S v) { return int_flag(c.o.mesh.elements_in_fillet, f, v, 1, 200); }},
    {"--param", true, param_flag},
    {"--bore-diameter-mm", true, [](Cli& c, S f, S v) { return diameter_flag(c.bore_d, f, v); }},
    {"--rim-inner-diameter-mm", true, [](Cli& c, S f, S v) { return diameter_flag(c.rim_d, f, v); }},
    {"--hub-diameter-mm", true, [](Cli& c, S f, S v) { return diameter_flag(c.hub_d, f, v); }},
    {"--web-thickness-mm", true,
     [](Cli& c, S f, S v) { return real_flag(c.web_t, f, v, 0, false, kBig, "a thickness in mm > 0"); }},
    {"--web-offset-mm", true,
     [](Cli& c, S f, S v) {
       const int rc = real_flag(c.web_o, f, v, -kBig, true, kBig, "an offset in mm (finite)");
       c.web_o_given = true;
       return rc;
     }},
    {"--holes", true, [](Cli& c, S f, S v) { return int_flag(c.holes, f, v, 0, 1000); }},
    {"--hole-diameter-mm", true, [](Cli& c, S f, S v) { return diameter_flag(c.hole_d, f, v); }},
    {"--hole-circle-diameter-mm", true,
     [](Cli& c, S f, S v) { return diameter_flag(c.hole_circle_d, f, v); }},
    {"--ring-outer-diameter-mm", true, [](Cli& c, S f, S v) { return diameter_flag(c.ring_d, f, v); }},
    {"--body-size-mm", true,
     [](Cli& c, S f, S v) { return real_flag(c.body_size, f, v, 0, false, kBig, "a size in mm > 0"); }},
    {"--hole-band-size-mm", true,
     [](Cli& c, S f, S v) { return real_flag(c.hole_band_size, f, v, 0, false, kBig, "a size in mm > 0"); }},
    {"--load-fraction", true,
     [](Cli& c, S f, S v) {
       return real_flag(c.o.load_fraction, f, v, 0, false, 1, "a fraction 0 < F <= 1");
     }},
    {"--threads", true, [](Cli& c, S f, S v) { return int_flag(c.threads, f, v, 1, 256); }},
};

// Parse argv into c: kGoOn, or the exit status (help, bad usage).
int parse_args(int argc, char** argv, Cli& c) {
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    const Flag* flag = nullptr;
    for (const Flag& f : kFlags)
      if (arg == f.name) flag = &f;
    if (!flag) {
      std::fprintf(stderr, "compliance_tool: unknown argument '%s'%s\n", arg.c_str(),
                   arg == "--bore-mm" ? " (now --bore-diameter-mm, a diameter in mm)" : "");
      usage(stderr);
      return 2;
    }
    if (flag->valued && a + 1 >= argc) {
      std::fprintf(stderr, "compliance_tool: %s needs a value\n", arg.c_str());
      usage(stderr);
      return 2;
    }
    const int rc = flag->set(c, arg, flag->valued ? std::string(argv[++a]) : std::string());
    if (rc != kGoOn) return rc;
  }
  if (c.gear == 0 || (c.out.empty() && !c.check_only)) {
    std::fprintf(stderr, "compliance_tool: --gear and --out are required (--out not with --check)\n");
    usage(stderr);
    return 2;
  }
  if (!c.ignored.empty())
    std::fprintf(stderr, "compliance_tool: %zu parameter(s) that do not change the body ignored\n",
                 c.ignored.size());
  return kGoOn;
}

int misfit(const std::string& text) {
  std::fprintf(stderr, "compliance_tool: %s\n", text.c_str());
  return 1;
}

std::string mm(double x) {
  std::ostringstream s;
  s << x << " mm";
  return s.str();
}

// Flags that must go together (exit 1: the value does not fit).
int check_combinations(const Cli& c) {
  if ((c.rim_d > 0) != (c.hub_d > 0))
    return misfit("--rim-inner-diameter-mm and --hub-diameter-mm go together (a web between hub and rim)");
  if ((c.web_t > 0 || c.web_o_given) && !(c.rim_d > 0))
    return misfit("--web-thickness-mm / --web-offset-mm need a web (--rim-inner-diameter-mm and --hub-diameter-mm)");
  if (c.holes > 0 && !(c.hole_d > 0 && c.hole_circle_d > 0))
    return misfit("--holes needs --hole-diameter-mm and --hole-circle-diameter-mm");
  if (c.holes == 0 && (c.hole_d > 0 || c.hole_circle_d > 0))
    return misfit("--hole-diameter-mm / --hole-circle-diameter-mm need --holes N (N >= 1)");
  const bool ring = c.p.pair.internal != 0 && c.gear == 2;
  if (c.ring_d > 0 && !ring)
    return misfit("--ring-outer-diameter-mm is for the internal ring gear (pair.internal=1, --gear 2)");
  return kGoOn;
}

// The web between hub and rim against the bore, the root diameter d_f and the face width b (mm).
int check_web(const Cli& c, double bore, double d_f, double b) {
  if (!(c.rim_d < d_f))
    return misfit("--rim-inner-diameter-mm " + mm(c.rim_d) + ": allowed below the root diameter " + mm(d_f));
  if (!(c.hub_d > bore && c.hub_d < c.rim_d))
    return misfit("--hub-diameter-mm " + mm(c.hub_d) + ": allowed between the bore " + mm(bore) +
                  " and the rim's inner diameter " + mm(c.rim_d));
  if (c.web_t > b) return misfit("--web-thickness-mm " + mm(c.web_t) + ": allowed up to the face width " + mm(b));
  const double wt = c.web_t > 0 ? c.web_t : b;
  if (std::fabs(c.web_o) + 0.5 * wt > 0.5 * b * (1 + 1e-9))
    return misfit("--web-offset-mm " + mm(c.web_o) + ": the web (thickness " + mm(wt) +
                  ") must stay within the face width " + mm(b) + ", |offset| <= " + mm(0.5 * (b - wt)));
  return kGoOn;
}

// The lightening holes inside the disc or web annulus, not overlapping (mm).
int check_holes(const Cli& c, double bore, double d_f) {
  using gm::mesh::HolesFit;
  const double in = c.rim_d > 0 ? c.hub_d : bore, outer = c.rim_d > 0 ? c.rim_d : d_f;
  const HolesFit fit = gm::mesh::holes_fit(c.holes, c.hole_d, c.hole_circle_d, in, outer);
  if (fit == HolesFit::kOutsideAnnulus)
    return misfit("--hole-circle-diameter-mm " + mm(c.hole_circle_d) + " with --hole-diameter-mm " +
                  mm(c.hole_d) + ": the holes must lie inside the " + (c.rim_d > 0 ? "web" : "disc") +
                  " annulus " + mm(in) + " .. " + mm(outer) + " (hole circle +- hole diameter)");
  if (fit == HolesFit::kOverlap)
    return misfit("--hole-diameter-mm " + mm(c.hole_d) + ": " + std::to_string(c.holes) +
                  " holes on the circle " + mm(c.hole_circle_d) + " overlap; allowed below " +
                  mm(gm::mesh::holes_overlap_limit(c.holes, c.hole_circle_d)));
  return kGoOn;
}

// The body flags against the gear (exit 1: the value does not fit).
int check_body_fits(const Cli& c) {
  const bool ring = c.p.pair.internal != 0 && c.gear == 2;
  gm_pair_geometry geo;
  {
    char cmsg[1024] = {0};
    if (gm_compute_geometry(&c.p, &geo, cmsg, sizeof cmsg) != GM_OK) return misfit(cmsg);
  }
  const double d_f = geo.gear[c.gear - 1].d_f * 1e3, b = c.p.gear[c.gear - 1].face_width * 1e3;
  if (!ring && c.mesh_file.empty()) {
    const double bore = c.bore_d > 0 ? c.bore_d : 0.4 * d_f;
    if (!(bore < d_f))
      return misfit("--bore-diameter-mm " + mm(c.bore_d) + ": allowed below the root diameter " + mm(d_f));
    if (c.rim_d > 0) {
      const int rc = check_web(c, bore, d_f, b);
      if (rc != kGoOn) return rc;
    }
    if (c.holes > 0) {
      const int rc = check_holes(c, bore, d_f);
      if (rc != kGoOn) return rc;
    }
  }
  if (ring && c.ring_d > 0 && !(c.ring_d > d_f))
    return misfit("--ring-outer-diameter-mm " + mm(c.ring_d) + ": allowed above the ring's root diameter " + mm(d_f));
  return kGoOn;
}

// The build options from the checked flags (SI).
void apply_body_options(Cli& c) {
  gm::ctool::BuildOptions& o = c.o;
  if (c.ring_d > 0) o.mesh.outer_radius = 0.5e-3 * c.ring_d;
  o.mesh.mesh_file = c.mesh_file;
  o.coupled = c.coupled >= 0 ? c.coupled : (c.p.coupled_teeth > 0 ? c.p.coupled_teeth : 1);
  if (c.bore_d > 0) o.mesh.bore_radius = 0.5e-3 * c.bore_d;
  if (c.rim_d > 0) o.mesh.rim_inner_radius = 0.5e-3 * c.rim_d;
  if (c.hub_d > 0) o.mesh.hub_radius = 0.5e-3 * c.hub_d;
  if (c.web_t > 0) o.mesh.web_thickness = 1e-3 * c.web_t;
  o.mesh.web_offset = 1e-3 * c.web_o;
  o.mesh.holes = c.holes;
  if (c.holes > 0) {
    o.mesh.hole_radius = 0.5e-3 * c.hole_d;
    o.mesh.hole_circle_radius = 0.5e-3 * c.hole_circle_d;
  }
  if (c.body_size > 0) o.mesh.body_size = 1e-3 * c.body_size;
  if (c.hole_band_size > 0) o.mesh.hole_band_size = 1e-3 * c.hole_band_size;
  if (c.threads > 0) {
    o.mesh.threads = c.threads;
    set_blas_threads(c.threads);
  }
  if (!c.scene.empty()) o.note = "scene " + c.scene + (o.note.empty() ? "" : "; " + o.note);
  o.progress = [](const std::string& s) { std::fprintf(stderr, "compliance_tool: %s\n", s.c_str()); };
}

// Build the database, write it and print the summary.
int build_and_write(const Cli& c, std::chrono::steady_clock::time_point t_start) {
  gm::ComplianceDb db;
  gm::ctool::BuildStats stats;
  std::string msg;
  gm_status st = gm::ctool::build_compliance_db(c.p, c.gear - 1, c.o, db, stats, msg);
  if (st != GM_OK) {
    std::fprintf(stderr, "compliance_tool: %s\n", msg.c_str());
    return 1;
  }
  st = gm::write_compliance_db(c.out.c_str(), db, msg);
  if (st != GM_OK) {
    std::fprintf(stderr, "compliance_tool: %s\n", msg.c_str());
    return 1;
  }
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  std::fprintf(stderr, "compliance_tool: wrote %s (%d x %d grid, n_c = %u, %s, %zu tooth set(s))\n",
               c.out.c_str(), int(db.roll.size()), int(db.face.size()), db.n_coupled,
               db.cyclic ? "cyclic" : "every tooth", db.tooth_sets());
  std::printf("compliance_tool: nodes=%d elements=%d dofs=%d grid=%d tooth_sets=%d loaded=%d solves=%d "
              "mesh_s=%.3f locate_s=%.3f assembly_s=%.3f factor_s=%.3f solve_s=%.3f total_s=%.3f "
              "cpu_s=%.3f peak_rss_MiB=%.1f\n",
              stats.nodes, stats.elements, stats.dofs, stats.grid, stats.tooth_sets, stats.loaded,
              stats.solves, stats.mesh_seconds, stats.locate_seconds, stats.assembly_seconds,
              stats.factor_seconds, stats.solve_seconds, total, cpu_seconds(), peak_rss_mib());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  use_openblas_kernels_of_this_cpu(argv);
  const auto t_start = std::chrono::steady_clock::now();
  Cli c;
  int rc = parse_args(argc, argv, c);
  if (rc == kGoOn) rc = check_combinations(c);
  if (rc == kGoOn) rc = check_body_fits(c);
  if (rc != kGoOn) return rc;
  if (c.check_only) return 0;  // the body fits the gear: what scene validation asks (gearmesh.compliance)
  apply_body_options(c);
  return build_and_write(c, t_start);
}
