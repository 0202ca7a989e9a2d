// Output hashes for behaviour-preserving refactors: one FNV-1a hash per case of the bit patterns
// of every gm_result field of gm_evaluate and of gm_directional_derivative along several seeds, at
// poses over two pitches, and of a few large-step advances. A refactor that must not change
// results runs it before and after and compares the lines (`diff`); the hashes depend on the
// compiler and the machine, so they are compared within one build setting, never stored.
//
//   output_hashes [REPO]   REPO: the source tree (scenarios/ for level 1's table, TE table)
//
// The cases: levels 0-5 (level 4 also without tooth coupling; level 5 on both gears' synthetic
// databases, tests/core/fe_synthetic.hpp, also on the reduced face basis), each plain and
// quasi-static, spur and helical, and without or with effects (friction, damping, crowning, a
// tilt, a TE excitation table).
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "fe_synthetic.hpp"
#include "gearmesh/gearmesh.h"

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Hash {
  std::uint64_t h = 1469598103934665603ull;
  void bytes(const void* p, std::size_t n) {
    const auto* c = static_cast<const unsigned char*>(p);
    for (std::size_t i = 0; i < n; ++i) h = (h ^ c[i]) * 1099511628211ull;
  }
  void result(const gm_result& r) {
    bytes(r.force, sizeof r.force);
    bytes(r.moment, sizeof r.moment);
    for (double x : {r.te, r.te_angle, r.normal_force, r.stiffness, r.friction_power, r.max_line_load,
                     r.max_load_share, r.solver_residual, r.elastic_energy, r.damping_power})
      bytes(&x, sizeof x);
    for (int x : {r.pairs_in_contact, r.flank, r.solver_iterations}) bytes(&x, sizeof x);
  }
  void status(int s) { bytes(&s, sizeof s); }
};

// A deterministic seed direction (xorshift), every input moved.
gm_kinematics seed_of(unsigned k) {
  std::uint64_t s = 0x9E3779B97F4A7C15ull * (k + 1);
  auto next = [&s] {
    s ^= s << 13;
    s ^= s >> 7;
    s ^= s << 17;
    return double(s >> 11) / double(1ull << 53) - 0.5;
  };
  gm_kinematics d{};
  for (int i = 0; i < 2; ++i) {
    for (int a = 0; a < 3; ++a) {
      d.u[i][a] = 1e-6 * next();
      d.v[i][a] = 1e-3 * next();
    }
    for (int a = 0; a < 2; ++a) {
      d.r[i][a] = 1e-5 * next();
      d.w[i][a] = 1e-3 * next();
    }
    d.phi[i] = 1e-5 * next();
    d.omega[i] = next();
  }
  d.load_torque = 10 * next();
  return d;
}

struct Setting {
  std::string name;
  gm_model_params p;
  double tilt = 0;
};

std::string repo = ".";
std::vector<std::string> keep;  // paths the params point to

const char* kept(const std::string& s) {
  keep.push_back(s);
  return keep.back().c_str();
}

void run(const Setting& s) {
  char msg[1024];
  gm_model* m = nullptr;
  gm_data* d = nullptr;
  Hash h;
  if (gm_model_create(&s.p, &m, msg, sizeof msg) != GM_OK || gm_data_create(m, &d) != GM_OK) {
    std::printf("%-48s create failed: %s\n", s.name.c_str(), msg);
    return;
  }
  const gm_pair_geometry* g = gm_model_geometry(m);
  const double rb1 = 0.5 * g->gear[0].d_b, rb2 = 0.5 * g->gear[1].d_b;
  const double sign = s.p.pair.internal ? -1 : 1;
  const int z1 = s.p.gear[0].teeth;
  const double loads[] = {500, 0, -300, 120};
  const double te[] = {5e-6, 1e-6, -g->j_bt - 4e-6, 2e-5};
  for (int k = 0; k < 40; ++k) {
    gm_kinematics kin{};
    kin.phi[0] = 2 * kPi / z1 * (k / 20.0) + 1e-3;
    kin.phi[1] = (te[k % 4] - rb1 * kin.phi[0]) / (sign * rb2);
    kin.omega[0] = 100;
    kin.omega[1] = -sign * 100 * rb1 / rb2;
    kin.r[1][0] = kin.r[1][1] = s.tilt;
    kin.u[1][2] = 1e-5 * (k % 3);
    kin.v[0][1] = 1e-3;
    kin.load_torque = loads[k % 4];
    gm_result r{};
    h.status(gm_evaluate(m, d, &kin, &r));
    h.result(r);
    for (unsigned q = 0; q < 3; ++q) {
      const gm_kinematics seed = seed_of(q + 7 * unsigned(k));
      gm_result dr{};
      h.status(gm_directional_derivative(m, d, &kin, &seed, &dr));
      h.result(dr);
    }
  }
  std::printf("%-48s %016llx\n", s.name.c_str(), (unsigned long long)h.h);
  // the large-step mode (plain settings only): a few advances from a loaded start
  if (!s.p.quasi_static) {
    Hash hd;
    gm_dynamics_params dp;
    gm_dynamics_default_params(&dp);
    gm_dynamics_inputs in{};
    in.torque[0] = 200;
    in.torque[1] = sign * 200 * rb2 / rb1;
    gm_kinematics pose{};
    pose.phi[0] = 1e-3;
    pose.phi[1] = (5e-6 - rb1 * pose.phi[0]) / (sign * rb2);
    pose.omega[0] = 50;
    pose.omega[1] = -sign * 50 * rb1 / rb2;
    gm_dynamics_state st{};
    gm_result r{};
    hd.status(gm_dynamics_start(m, d, &dp, &pose, &in, &st, &r));
    hd.result(r);
    for (int k = 0; k < 4; ++k) {
      hd.status(gm_dynamics_advance(m, d, &dp, &pose, &in, 2e-4, &st, &r));
      hd.result(r);
      hd.bytes(st.phi, sizeof st.phi);
      hd.bytes(st.omega, sizeof st.omega);
      for (double x : {st.kinetic, st.elastic, st.work_in, st.work_out, st.friction, st.damping, st.parametric,
                       st.residual, st.step})
        hd.bytes(&x, sizeof x);
      hd.bytes(&st.steps, sizeof st.steps);
      hd.bytes(&st.rejected, sizeof st.rejected);
    }
    std::printf("%-48s %016llx\n", (s.name + " large-step").c_str(), (unsigned long long)hd.h);
  }
  gm_data_free(d);
  gm_model_free(m);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 1) repo = argv[1];
  keep.reserve(64);
  const std::string table = repo + "/scenarios/user_stiffness_example.txt";
  const std::string te_table = repo + "/scenarios/user_te_example.txt";
  int cases = 0;
  // 6: level 4 without tooth coupling; 7: level 5 on the reduced face basis (solver.face_shapes 2)
  for (int level = 0; level <= 7; ++level) {
    for (int helical = 0; helical < 2; ++helical) {
      for (int effects = 0; effects < 2; ++effects) {
        for (int quasi = 0; quasi < 2; ++quasi) {
          Setting s;
          gm_default_params(&s.p);
          s.p.stiffness_level = level == 6 ? GM_STIFFNESS_ANALYTICAL : level == 7 ? GM_STIFFNESS_FE
                                                                                  : level;
          if (level == 6) s.p.coupled_teeth = 0;
          if (level == 7) s.p.solver_face_shapes = 2;
          s.p.slices = 6;
          if (helical) {
            s.p.pair.helix_angle = 15 * kPi / 180;
            s.p.pair.center_distance = 0.1553;
          }
          if (level == 1) s.p.stiffness_table = kept(table);
          if (level == 2) s.p.rated_line_load = 2e5;
          if (effects) {
            s.p.friction_coefficient = 0.05;
            s.p.damping = 2e3;
            for (gm_gear_params& gp : s.p.gear)
              for (gm_flank_modification& f : gp.flank) {
                f.lead_crowning = 5e-6;
                f.tip_relief = 8e-6;
                f.tip_relief_length = 1e-3;
              }
            s.p.te_table = kept(te_table);
            s.tilt = 2e-4;
          }
          s.p.quasi_static = quasi;
          if (level == 5 || level == 7) {
            std::string msg;
            for (int gear = 0; gear < 2; ++gear) {
              const std::string path = gm_test::write_smooth_db(
                  s.p, gear, "gm_hash_" + std::to_string(helical) + "_" + std::to_string(gear) + ".gcdb", msg);
              if (path.empty()) {
                std::printf("level 5 database: %s\n", msg.c_str());
                return 1;
              }
              s.p.compliance[gear] = kept(path);
            }
          }
          s.name = "level " +
                   (level == 6   ? std::string("4 uncoupled")
                    : level == 7 ? std::string("5 face shapes")
                                 : std::to_string(level)) +
                   (helical ? " helical" : " spur") + (effects ? " effects" : " plain") +
                   (quasi ? " quasi-static" : " prescribed");
          run(s);
          ++cases;
        }
      }
    }
  }
  std::printf("cases: %d settings\n", cases);
  return 0;
}
