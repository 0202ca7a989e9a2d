// gm_directional_derivative against central finite differences of gm_evaluate: every double
// output, along random input directions, at random poses away from active-set changes, for the
// levels 0-4, spur/helical/internal, tilted, micro-geometry (design and measured), friction,
// damping, tables, plain and quasi-static; plus closed-form checks that fail if the implicit
// derivative of the slice forces is dropped.
#include <algorithm>
#include <cstdio>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "gearmesh/internal/compliance_db.hpp"
#include "fe_synthetic.hpp"
#include "detection.hpp"
#include "model.hpp"
#include "test_support.hpp"

namespace {

using gm_test::Instance;
using gm_test::kPi;

std::string repo_file(const char* relative) {
  std::string here = __FILE__;  // .../tests/core/test_jacobian.cpp
  return here.substr(0, here.rfind("tests/core/")) + relative;
}

// Gear 2's spin for TE te at gear 1's spin phi1 (docs/physics.md §0).
double phi2(const Instance& I, double te, double phi1) {
  return (te - I.rb(0) * phi1) / (I.sign() * I.rb(1));
}

// The double outputs of gm_result as a vector, with a group per entry (relative scales).
constexpr int kOutputs = 19;
const char* const kNames[kOutputs] = {
    "force1x", "force1y", "force1z", "force2x", "force2y", "force2z", "moment1x", "moment1y",
    "moment1z", "moment2x", "moment2y", "moment2z", "te", "te_angle", "normal_force",
    "stiffness", "friction_power", "max_line_load", "max_load_share"};
const int kGroup[kOutputs] = {0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 2, 3, 0, 4, 5, 6, 7};

std::vector<double> outputs(const gm_result& r) {
  std::vector<double> y;
  for (int i = 0; i < 2; ++i)
    for (int a = 0; a < 3; ++a) y.push_back(r.force[i][a]);
  for (int i = 0; i < 2; ++i)
    for (int a = 0; a < 3; ++a) y.push_back(r.moment[i][a]);
  y.insert(y.end(), {r.te, r.te_angle, r.normal_force, r.stiffness, r.friction_power,
                     r.max_line_load, r.max_load_share});
  return y;
}

double y0_of(const gm_result& r, int j) { return outputs(r)[j]; }

constexpr int kNormalForce = 14, kForceGroup = 0, kShareGroup = 7;

// The load share is a ratio of forces, d share = (dF_max - share dF) / F: its difference
// inherits the forces' difference error divided by the normal force, so its scale includes
// the force group's scale over F.
void add_share_scale(std::vector<double>& scale, const std::vector<double>& y0) {
  if (y0[kNormalForce] > 0)
    scale[kShareGroup] = std::max(scale[kShareGroup], scale[kForceGroup] / y0[kNormalForce]);
}

// k + t s over every input.
gm_kinematics along(const gm_kinematics& k, const gm_kinematics& s, double t) {
  gm_kinematics out = k;
  for (int i = 0; i < 2; ++i) {
    for (int a = 0; a < 3; ++a) {
      out.u[i][a] += t * s.u[i][a];
      out.v[i][a] += t * s.v[i][a];
    }
    for (int a = 0; a < 2; ++a) {
      out.r[i][a] += t * s.r[i][a];
      out.w[i][a] += t * s.w[i][a];
    }
    out.phi[i] += t * s.phi[i];
    out.omega[i] += t * s.omega[i];
  }
  out.load_torque += t * s.load_torque;
  return out;
}

// A random direction; each input kind at a physical scale so that the finite-difference step
// (kStep times the direction) is ~1e-7 relative to that input's typical size.
gm_kinematics random_seed(std::mt19937& rng, bool tilts) {
  std::uniform_real_distribution<double> U(-1, 1);
  gm_kinematics s{};
  for (int i = 0; i < 2; ++i) {
    for (int a = 0; a < 3; ++a) {
      s.u[i][a] = 1e-5 * U(rng);  // m (inputs ~10 um)
      s.v[i][a] = 1e-1 * U(rng);  // m/s
    }
    for (int a = 0; a < 2; ++a) {
      s.r[i][a] = tilts ? 1e-3 * U(rng) : 0.0;  // rad (inputs ~1 mrad; 0 keeps aligned poses)
      s.w[i][a] = 1.0 * U(rng);                 // rad/s
    }
    s.phi[i] = 1e-3 * U(rng);  // rad
    s.omega[i] = 10 * U(rng);  // rad/s
  }
  s.load_torque = 100 * U(rng);  // N m
  return s;
}

// Step along the direction: ~1e-7 relative per input kind (plain); quasi-static 10x larger, to
// keep the load balance's convergence floor (~1e-14 m of TE) out of the differences. Level 5's
// reference solves to ~1e-17 m (fe_level): its quasi-static step can stay small, which keeps the
// differences in their asymptotic range where a lightly loaded coupled slice curves strongly
// (one such pose of the helical case is 5x the tolerance off at 1e-3, well within at 2.5e-4).
double step_for(const gm_model_params& p) {
  if (!p.quasi_static) return 1e-4;
  return p.stiffness_level == GM_STIFFNESS_FE ? 2.5e-4 : 1e-3;
}

struct Stats {
  int checked = 0, skipped = 0;
  double worst = 0;  // largest error / allowed
};

// Compare at one pose along one direction. Returns false (skipped) if the pose sits at an
// active-set change: the one-sided differences disagree or the integer outputs change.
bool compare(Instance& I, const gm_kinematics& at, const gm_kinematics& seed, Stats& st,
             const std::string& what) {
  const double kStep = step_for(*gm_model_parameters(I.m));
  gm_result r0 = I.eval(at);
  for (int k = 0; k < 3 && gm_model_parameters(I.m)->quasi_static; ++k) r0 = I.eval(at);
  gm_result dr{};
  if (gm_directional_derivative(I.m, I.d, &at, &seed, &dr) != GM_OK) {
    ADD_FAILURE() << what << ": " << gm_data_message(I.d);
    return true;
  }
  // quasi-static: gm_evaluate stops its detection passes after six; where the micro-geometry
  // slows their convergence, repeating the call (warm-started) takes the TE to its floor
  const auto eval = [&](double t) {
    gm_result r = I.eval(along(at, seed, t));
    if (gm_model_parameters(I.m)->quasi_static)
      for (int k = 0; k < 3; ++k) r = I.eval(along(at, seed, t));
    return r;
  };
  const gm_result rp = eval(kStep), rm = eval(-kStep), rp2 = eval(0.5 * kStep),
                  rm2 = eval(-0.5 * kStep);
  I.eval(at);  // leave the warm start at the pose
  if (rp.pairs_in_contact != r0.pairs_in_contact || rm.pairs_in_contact != r0.pairs_in_contact ||
      rp.flank != r0.flank || rm.flank != r0.flank) {
    ++st.skipped;
    return false;
  }
  const std::vector<double> y0 = outputs(r0), yp = outputs(rp), ym = outputs(rm),
                            yp2 = outputs(rp2), ym2 = outputs(rm2), ad = outputs(dr);
  std::vector<double> fd(kOutputs), fwd(kOutputs), bwd(kOutputs), scale(8, 0.0);
  for (int j = 0; j < kOutputs; ++j) {
    // Richardson's extrapolation of the central differences at h and h/2: error O(h^4)
    fd[j] = (4 * (yp2[j] - ym2[j]) / kStep - (yp[j] - ym[j]) / (2 * kStep)) / 3;
    fwd[j] = (yp[j] - y0[j]) / kStep;
    bwd[j] = (y0[j] - ym[j]) / kStep;
    scale[kGroup[j]] = std::max({scale[kGroup[j]], std::fabs(fd[j]), std::fabs(ad[j]),
                                 1e-3 * std::fabs(y0[j])});
  }
  add_share_scale(scale, y0);
  // a kink within the step: the one-sided differences of some output disagree by far more than
  // their O(step) curvature term (checked on halving: a smooth output halves the gap)
  for (int j = 0; j < kOutputs; ++j) {
    const double gap = std::fabs(fwd[j] - bwd[j]);
    const double gap2 = std::fabs((yp2[j] - y0[j]) - (y0[j] - ym2[j])) / (0.5 * kStep);
    const double noise = 1e-6 * scale[kGroup[j]] + 1e-9;
    if (gap > noise && gap2 > 0.75 * gap) {  // does not shrink with the step: not smooth here
      ++st.skipped;
      return false;
    }
  }
  // the reference itself must be converged in the step: the central differences at h and h/2
  // agree to well within the tolerance (else a slice is within a few steps of touching, where
  // f'(F) -> infinity, and no finite step resolves the derivative)
  for (int j = 0; j < kOutputs; ++j) {
    const double c1 = (yp[j] - ym[j]) / (2 * kStep), c2 = (yp2[j] - ym2[j]) / kStep;
    const double allowed = 1e-5 * std::fabs(fd[j]) + 1e-6 * scale[kGroup[j]] + 1e-12;
    if (std::fabs(c1 - c2) > 30 * allowed) {
      ++st.skipped;
      return false;
    }
  }
  for (int j = 0; j < kOutputs; ++j) {
    const double allowed = 1e-5 * std::max(std::fabs(fd[j]), std::fabs(ad[j])) +
                           1e-6 * scale[kGroup[j]] + 1e-12;
    const double err = std::fabs(ad[j] - fd[j]);
    st.worst = std::max(st.worst, err / allowed);
    EXPECT_LE(err, allowed) << what << ": d " << kNames[j] << " = " << ad[j]
                            << ", central difference " << fd[j] << " (value " << y0[j] << ")";
  }
  ++st.checked;
  return true;
}

struct Case {
  const char* name;
  std::function<void(gm_model_params&)> edit;
  bool tilt = false;
  bool quasi = false;
};

gm_model_params with_micro(gm_model_params p) {
  for (int g = 0; g < 2; ++g) {
    for (int f = 0; f < 2; ++f) {
      gm_flank_modification& m = p.gear[g].flank[f];
      m.profile_crowning = 3e-6;
      m.tip_relief = 8e-6;
      m.tip_relief_length = 2e-3;
      m.tip_relief_parabolic = g;
      m.root_relief = 4e-6;
      m.root_relief_length = 1.5e-3;
      m.profile_slope = 1e-6 * (g ? -1 : 1);
      m.lead_crowning = 4e-6;
      m.helix_slope = 2e-6;
      m.end_relief = 3e-6;
      m.end_relief_length = 3e-3;
    }
  }
  return p;
}

// Level 5 with solver.face_shapes: the poses whose evaluation took the reduced face basis.
int* g_face_used = nullptr;

void run_case(const Case& c, Stats& total) {
  gm_model_params p = gm_test::paper();
  p.slices = 7;
  // the reference needs converged solves: the quasi-static TE to its floor ~1e-14 m (the default 1e-10 m
  // would put k 1e-10 ~ 0.05 N of solver noise into each force); the derivative does not use it
  p.solver_tolerance = 1e-15;
  c.edit(p);
  p.quasi_static = c.quasi;
  Instance I(p);
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> U(0, 1);
  const double tau1 = 2 * kPi / p.gear[0].teeth;
  Stats st;
  for (int pose = 0; pose < 12; ++pose) {
    gm_kinematics at{};
    at.phi[0] = tau1 * (pose + U(rng));
    const double te = (c.quasi ? 0 : 2e-6 + 8e-6 * U(rng));
    at.phi[1] = phi2(I, te, at.phi[0]);
    for (int i = 0; i < 2; ++i) {
      for (int a = 0; a < 3; ++a) {
        at.u[i][a] = 5e-6 * (2 * U(rng) - 1);
        at.v[i][a] = 0.05 * (2 * U(rng) - 1);
      }
      for (int a = 0; a < 2; ++a) {
        at.r[i][a] = c.tilt ? 3e-4 * (2 * U(rng) - 1) : 0.0;
        at.w[i][a] = 0.5 * (2 * U(rng) - 1);
      }
    }
    at.omega[0] = 100 * (0.5 + U(rng));
    at.omega[1] = -I.sign() * at.omega[0] * I.rb(0) / I.rb(1) * (1 + 0.01 * (2 * U(rng) - 1));
    at.load_torque = c.quasi ? 200 + 800 * U(rng) : 0.0;
    I.eval(at);  // warm start
    if (g_face_used && I.d->face.used) ++*g_face_used;
    for (int k = 0; k < 3; ++k) {
      // an aligned pose is a kink along tilts (one-sided derivatives differ): tilt only tilted ones
      const gm_kinematics seed = random_seed(rng, c.tilt);
      compare(I, at, seed, st, std::string(c.name) + ", pose " + std::to_string(pose));
    }
  }
  std::printf("  %-52s checked %2d skipped %2d worst error/allowed %.3g\n", c.name, st.checked,
              st.skipped, st.worst);
  EXPECT_GE(st.checked, 24) << c.name << ": too many poses at active-set changes";
  total.checked += st.checked;
  total.skipped += st.skipped;
  total.worst = std::max(total.worst, st.worst);
}

const std::string& stiffness_table() {
  static const std::string s = repo_file("scenarios/user_stiffness_example.txt");
  return s;
}
const std::string& te_table() {
  static const std::string s = repo_file("scenarios/user_te_example.txt");
  return s;
}
const std::string& deviations() {
  static const std::string s = repo_file("scenarios/deviations_example.txt");
  return s;
}

// Level 5: each gear's smooth synthetic database (fe_synthetic.hpp: 17 x 13 grid, n_c = 2),
// written for the gears of p as edited so far (kept for the process).
void fe_level(gm_model_params& p, int coupled_teeth) {
  static std::vector<std::string> paths;
  p.stiffness_level = GM_STIFFNESS_FE;
  p.coupled_teeth = coupled_teeth;
  // the reference's coupled solves to ~1e-17 m (the derivative does not use the tolerance)
  p.solver_tolerance = 1e-17;
  p.compliance[0] = p.compliance[1] = nullptr;
  for (int g = 0; g < 2; ++g) {
    std::string msg;
    const gm::ComplianceDb db = gm_test::smooth_db(p, g, gm_test::SmoothDbShape{}, msg);
    EXPECT_TRUE(msg.empty()) << msg;
    paths.push_back(gm_test::write_db("jacobian_fe_" + std::to_string(paths.size()) + ".gcdb", db));
  }
  p.compliance[0] = (paths.end() - 2)->c_str();
  p.compliance[1] = paths.back().c_str();
}

std::vector<Case> cases() {
  const auto level = [](int l) {
    return [l](gm_model_params& p) {
      p.stiffness_level = l;
      if (l == 1) p.stiffness_table = stiffness_table().c_str();
    };
  };
  const auto helical = [](gm_model_params& p) {
    p.pair.helix_angle = (p.pair.internal ? 12 : 15) * kPi / 180;
    if (!p.pair.internal) {  // as bench_evaluate: unshifted, a little backlash
      p.gear[0].profile_shift = p.gear[1].profile_shift = 0;
      p.pair.center_distance = 0.0026 / std::cos(p.pair.helix_angle) * 57 + 50e-6;
    }
  };
  const auto effects = [](gm_model_params& p) {
    p.friction_coefficient = 0.05;
    p.friction_velocity = 0.05;
    p.damping = 2e3;
  };
  std::vector<Case> out;
  for (int l = 0; l <= 4; ++l) {
    for (int q = 0; q < 2; ++q) {
      out.push_back({"", level(l), false, q == 1});
      out.push_back({"", [=](gm_model_params& p) { level(l)(p); helical(p); effects(p); }, true, q == 1});
    }
  }
  out.push_back({"", [=](gm_model_params& p) {
                   p = with_micro(p);
                   level(4)(p);
                   helical(p);
                   effects(p);
                   p.te_table = te_table().c_str();
                 },
                 true, false});
  out.push_back({"", [=](gm_model_params& p) {
                   p = with_micro(p);
                   level(2)(p);
                   p.gear[0].deviations = deviations().c_str();
                   p.gear[1].deviations = deviations().c_str();
                   effects(p);
                 },
                 true, true});
  out.push_back({"", [=](gm_model_params& p) {
                   p = gm_test::ring();
                   p.slices = 5;
                   level(2)(p);
                   helical(p);
                   effects(p);
                 },
                 true, false});
  out.push_back({"", [=](gm_model_params& p) {
                   p = with_micro(gm_test::ring());
                   p.slices = 5;
                   level(0)(p);
                   effects(p);
                 },
                 false, true});
  // level 5 (FE): coupled slices and teeth, single and double contact over the random poses
  out.push_back({"", [](gm_model_params& p) { fe_level(p, 2); }, false, false});
  out.push_back({"", [](gm_model_params& p) { fe_level(p, 2); }, false, true});
  out.push_back({"", [=](gm_model_params& p) { helical(p); effects(p); fe_level(p, 2); }, true, false});
  out.push_back({"", [=](gm_model_params& p) { helical(p); effects(p); fe_level(p, 1); }, true, true});
  out.push_back({"", [=](gm_model_params& p) {
                   p = with_micro(p);
                   effects(p);
                   p.te_table = te_table().c_str();
                   fe_level(p, 0);
                 },
                 true, false});
  static std::vector<std::string> names;
  names.clear();
  for (std::size_t i = 0; i < out.size(); ++i) {
    const int l = i < 20 ? static_cast<int>(i / 4) : -1;
    std::string n;
    if (l >= 0) {
      n = "level " + std::to_string(l) + ((i % 2) ? ", helical tilted friction damping" : ", spur aligned");
    } else {
      const char* const extra[9] = {"level 4 helical tilted micro-geometry TE table friction",
                                    "level 2 spur tilted micro-geometry deviations",
                                    "internal level 2 helical tilted friction damping",
                                    "internal level 0 micro-geometry",
                                    "level 5 spur aligned, +-2 coupled teeth",
                                    "level 5 spur aligned, +-2 coupled teeth",
                                    "level 5 helical tilted friction damping, +-2 teeth",
                                    "level 5 helical tilted friction damping, +-1 tooth",
                                    "level 5 spur tilted micro-geometry TE table, uncoupled"};
      n = extra[i - 20];
    }
    n += out[i].quasi ? ", quasi-static" : ", plain";
    names.push_back(n);
  }
  for (std::size_t i = 0; i < out.size(); ++i) out[i].name = names[i].c_str();
  return out;
}

bool is_fe(const Case& c) { return std::string(c.name).rfind("level 5", 0) == 0; }

TEST(Jacobian, MatchesCentralDifferencesEverywhere) {
  Stats total;
  for (const Case& c : cases())
    if (!is_fe(c)) run_case(c, total);
  std::printf("  all: checked %d skipped %d worst error/allowed %.3g\n", total.checked,
              total.skipped, total.worst);
}

// Level 5 (FE): the implicit derivative of the coupled solve on its loaded set, with the
// derivative of the interpolated compliance (roll slopes, face shares) and of the local Hertz
// law, plain and quasi-static, against the same Richardson differences and tolerance.
TEST(Jacobian, Level5MatchesCentralDifferences) {
  Stats total;
  for (const Case& c : cases())
    if (is_fe(c)) run_case(c, total);
  std::printf("  level 5: checked %d skipped %d worst error/allowed %.3g\n", total.checked,
              total.skipped, total.worst);
}

// Level 5 on the reduced face basis (solver.face_shapes, face_basis.hpp): the derivative of the
// reduced equations on the model's fixed shapes (face_shapes.hpp) against the same differences;
// with two or three shapes most poses of the spur cases take the reduced basis, with one shape
// (made at 100 kN/m) the poses near its line load.
TEST(Jacobian, Level5FaceBasisMatchesCentralDifferences) {
  for (int shapes : {1, 2, 3}) {
    Stats total;
    int used = 0, poses = 0;
    g_face_used = &used;
    for (const Case& c : cases()) {
      if (!is_fe(c)) continue;
      Case r = c;
      r.edit = [&c, shapes](gm_model_params& p) {
        c.edit(p);
        p.solver_face_shapes = shapes;
      };
      run_case(r, total);
      poses += 12;
    }
    g_face_used = nullptr;
    std::printf("  level 5, %d face shapes: checked %d skipped %d worst error/allowed %.3g; reduced at %d of %d "
                "poses\n",
                shapes, total.checked, total.skipped, total.worst, used, poses);
    EXPECT_GE(used, shapes == 1 ? 5 : poses / 3) << shapes << " face shapes: the reduced basis was hardly used";
  }
}

// A pure TE direction (gear 2's spin only) at level 0, spur, aligned, one slice: the normal
// force moves with the mesh stiffness, d(normal_force) = stiffness d(TE), and the forces with it.
// Replacing the implicit derivative by zero (or dropping dDelta) fails here.
TEST(Jacobian, TeDirectionMovesTheForceWithTheMeshStiffness) {
  for (int level : {0, 2, 4}) {
    gm_model_params p = gm_test::paper();
    p.stiffness_level = level;
    Instance I(p);
    gm_kinematics at{};
    at.phi[0] = 0.0;  // single contact at the pitch point: flank contact only
    at.phi[1] = phi2(I, 2e-6, at.phi[0]);
    const gm_result r = I.eval(at);
    ASSERT_GT(r.normal_force, 0);
    gm_kinematics seed{};
    seed.phi[1] = 1e-6 / I.rb(1);  // dTE = 1 um
    gm_result dr{};
    ASSERT_EQ(gm_directional_derivative(I.m, I.d, &at, &seed, &dr), GM_OK);
    EXPECT_NEAR(dr.te, 1e-6, 1e-18);
    EXPECT_GT(dr.normal_force, 0) << "level " << level;
    // level 0: exact; levels 2 and 4 add the stiffness's change along the path (the contact
    // point moves by half the TE step), a small correction
    EXPECT_NEAR(dr.normal_force, r.stiffness * 1e-6, (level == 0 ? 1e-9 : 2e-2) * r.stiffness * 1e-6)
        << "level " << level;
    EXPECT_NEAR(std::hypot(dr.force[1][0], dr.force[1][1]), dr.normal_force,
                1e-9 * dr.normal_force);
  }
}

// Quasi-static, no friction, level 0: the load balance makes d(TE)/d(load torque) = 1/(r_b2 k)
// with k the mesh stiffness along the line of action, and d(normal_force) = d(load)/r_b2 (level 4
// adds the compliance's change along the path: close, not equal).
TEST(Jacobian, QuasiStaticLoadDirectionFollowsTheCompliance) {
  for (int level : {0, 4}) {
    gm_model_params p = gm_test::paper();
    p.stiffness_level = level;
    p.quasi_static = 1;
    Instance I(p);
    const gm_result r = I.loaded(0.021, 500);
    gm_kinematics at{};
    at.phi[0] = 0.021;
    at.load_torque = 500;
    gm_kinematics seed{};
    seed.load_torque = 1;
    gm_result dr{};
    ASSERT_EQ(gm_directional_derivative(I.m, I.d, &at, &seed, &dr), GM_OK) << gm_data_message(I.d);
    const double rb2 = I.rb(1);
    EXPECT_NEAR(dr.normal_force, 1 / rb2, 1e-9 / rb2) << "level " << level;
    EXPECT_NEAR(dr.te, 1 / (rb2 * r.stiffness), (level == 0 ? 1e-9 : 1e-2) / (rb2 * r.stiffness))
        << "level " << level;
  }
}

// The axial overlap of equal face widths at equal axial positions is a kink: it shrinks
// whichever way gear 2 moves axially. The derivative there is the one along +seed (gearmesh.h),
// the forward difference along the seed, for every output, for the seed and its opposite,
// aligned and with gear 2 tilted by 1 mrad (where the two one-sided derivatives of the moments
// differ), plain and quasi-static. Taking either gear's face end regardless of the seed (the tie
// broken to gear 1's, the old behaviour) gave d(gear1.mx)/d(gear2.uz) = 0 aligned, and outside
// the range of the one-sided differences when tilted.
TEST(Jacobian, AtEqualFaceEndsTheAxialDerivativeIsTheOneAlongTheSeed) {
  for (int quasi = 0; quasi < 2; ++quasi) {
    for (double tilt : {0.0, 1e-3}) {
      if (quasi && tilt != 0) continue;
      gm_model_params p = gm_test::paper();
      p.slices = 7;
      p.solver_tolerance = 1e-15;
      p.quasi_static = quasi;
      Instance I(p);
      gm_kinematics at{};
      at.phi[0] = 0.01;
      at.phi[1] = phi2(I, 5e-6, at.phi[0]);
      at.r[1][0] = tilt;
      at.load_torque = 300;
      const auto eval = [&](const gm_kinematics& k) {
        gm_result r = I.eval(k);
        for (int n = 0; quasi && n < 3; ++n) r = I.eval(k);  // the TE to its floor
        return outputs(r);
      };
      const std::vector<double> y0 = eval(at);
      // one-sided steps: small enough for the curvature (Richardson removes its first order),
      // large enough for rounding; the quasi-static TE floor (~1e-14 m) needs a larger one
      const double h = quasi ? 1e-6 : 2e-7;
      for (int gear = 0; gear < 2; ++gear) {
        for (double dir : {1.0, -1.0}) {
          gm_kinematics seed{};
          seed.u[gear][2] = dir;
          gm_result dr{};
          ASSERT_EQ(gm_directional_derivative(I.m, I.d, &at, &seed, &dr), GM_OK) << gm_data_message(I.d);
          const std::vector<double> ad = outputs(dr), y1 = eval(along(at, seed, 0.5 * h)),
                                    y2 = eval(along(at, seed, h));
          std::vector<double> fd(kOutputs), scale(8, 0.0);
          for (int j = 0; j < kOutputs; ++j) {
            // second-order one-sided (Richardson) difference along the seed
            fd[j] = 2 * (y1[j] - y0[j]) / (0.5 * h) - (y2[j] - y0[j]) / h;
            scale[kGroup[j]] = std::max(scale[kGroup[j]], std::fabs(fd[j]));
          }
          add_share_scale(scale, y0);
          for (int j = 0; j < kOutputs; ++j) {
            const double allowed =
                (quasi ? 1e-4 : 1e-5) * scale[kGroup[j]] + 1e-14 * std::fabs(y0[j]) / h + 1e-9;
            EXPECT_NEAR(ad[j], fd[j], allowed)
                << (quasi ? "quasi-static" : "plain") << ", gear 2 tilt " << tilt << ", seed "
                << dir << " gear" << gear + 1 << ".uz: d " << kNames[j];
          }
        }
      }
    }
  }
}

// Level 4 with tilts and axial displacements (the slices' positions, widths and roll distances
// all move with uz and the tilts): every input column against Richardson central differences to
// 1e-6 of the output group's scale, spur and helical, friction and damping on, without
// (model.coupled_teeth = 0) and with the tooth coupling. All slices stay loaded and away from the
// path ends, so every output is smooth at the pose. The steps sit where both errors of the
// differences are below the bound: the evaluation's rounding noise (about 2e-12 of the normal
// force, the same with and without the coupling: detection's coordinates are ~0.1 m) over the
// step, and the h^4 truncation. Measured worst error/allowed over the four runs: 0.84 / 1.21
// (uncoupled / coupled spur) at a third of these steps (noise-limited: 3.8 at a thirtieth), 0.16 /
// 0.23 at these, 0.25 / 0.27 at 3x, 20 / 21 at 10x (truncation-limited).
TEST(Jacobian, Level4TiltedWithAxialDisplacementEveryColumn) {
  for (int run = 0; run < 4; ++run) {
    const int helical = run % 2, coupled = run / 2 ? 2 : 0;
    gm_model_params p = gm_test::paper();
    p.stiffness_level = GM_STIFFNESS_ANALYTICAL;
    p.coupled_teeth = coupled;
    p.slices = 7;
    p.solver_tolerance = 1e-15;
    p.friction_coefficient = 0.05;
    p.friction_velocity = 0.05;
    p.damping = 2e3;
    if (helical) {
      p.pair.helix_angle = 15 * kPi / 180;
      p.gear[0].profile_shift = p.gear[1].profile_shift = 0;
      p.pair.center_distance = 0.0026 / std::cos(p.pair.helix_angle) * 57 + 50e-6;
    }
    Instance I(p);
    gm_kinematics at{};
    at.phi[0] = 0.013;
    at.phi[1] = phi2(I, 12e-6, at.phi[0]);
    at.u[0][2] = -0.4e-3;
    at.u[1][2] = 1.5e-3;
    at.u[1][0] = 2e-6;
    at.r[1][0] = 2e-4;
    at.r[1][1] = -1e-4;
    at.r[0][0] = 5e-5;
    at.v[0][1] = 0.02;
    at.w[1][0] = 0.3;
    at.omega[0] = 100;
    at.omega[1] = -101;
    const gm_result r0 = I.eval(at);
    ASSERT_GT(r0.normal_force, 0);
    // (input, step): each input kind at ~3e-7..3e-6 of its scale
    struct Column {
      double* (*field)(gm_kinematics&);
      const char* name;
      double step;
    };
    const Column columns[] = {
        {[](gm_kinematics& k) { return &k.u[0][0]; }, "gear1.ux", 3e-8},
        {[](gm_kinematics& k) { return &k.u[0][1]; }, "gear1.uy", 3e-8},
        {[](gm_kinematics& k) { return &k.u[0][2]; }, "gear1.uz", 3e-7},
        {[](gm_kinematics& k) { return &k.u[1][0]; }, "gear2.ux", 3e-8},
        {[](gm_kinematics& k) { return &k.u[1][1]; }, "gear2.uy", 3e-8},
        {[](gm_kinematics& k) { return &k.u[1][2]; }, "gear2.uz", 3e-7},
        {[](gm_kinematics& k) { return &k.r[0][0]; }, "gear1.rx", 3e-6},
        {[](gm_kinematics& k) { return &k.r[0][1]; }, "gear1.ry", 3e-6},
        {[](gm_kinematics& k) { return &k.r[1][0]; }, "gear2.rx", 3e-6},
        {[](gm_kinematics& k) { return &k.r[1][1]; }, "gear2.ry", 3e-6},
        {[](gm_kinematics& k) { return &k.phi[0]; }, "gear1.phi", 3e-7},
        {[](gm_kinematics& k) { return &k.phi[1]; }, "gear2.phi", 3e-7},
        {[](gm_kinematics& k) { return &k.v[0][0]; }, "gear1.vx", 3e-4},
        {[](gm_kinematics& k) { return &k.v[1][2]; }, "gear2.vz", 3e-4},
        {[](gm_kinematics& k) { return &k.w[0][1]; }, "gear1.wy", 3e-3},
        {[](gm_kinematics& k) { return &k.w[1][0]; }, "gear2.wx", 3e-3},
        {[](gm_kinematics& k) { return &k.omega[0]; }, "gear1.omega", 3e-2},
        {[](gm_kinematics& k) { return &k.omega[1]; }, "gear2.omega", 3e-2},
    };
    double worst = 0;
    for (const Column& c : columns) {
      gm_kinematics seed{};
      *c.field(seed) = 1;
      gm_result dr{};
      ASSERT_EQ(gm_directional_derivative(I.m, I.d, &at, &seed, &dr), GM_OK) << gm_data_message(I.d);
      const auto y = [&](double t) { return outputs(I.eval(along(at, seed, t))); };
      const std::vector<double> ad = outputs(dr), yp = y(c.step), ym = y(-c.step),
                                yp2 = y(0.5 * c.step), ym2 = y(-0.5 * c.step);
      std::vector<double> fd(kOutputs), scale(8, 0.0);
      for (int j = 0; j < kOutputs; ++j) {
        fd[j] = (4 * (yp2[j] - ym2[j]) / c.step - (yp[j] - ym[j]) / (2 * c.step)) / 3;
        scale[kGroup[j]] = std::max(scale[kGroup[j]], std::fabs(fd[j]));
      }
      add_share_scale(scale, outputs(r0));
      for (int j = 0; j < kOutputs; ++j) {
        const double allowed = 1e-6 * scale[kGroup[j]] + 1e-12;
        worst = std::max(worst, std::fabs(ad[j] - fd[j]) / allowed);
        EXPECT_NEAR(ad[j], fd[j], allowed) << (helical ? "helical" : "spur") << ": d " << kNames[j]
                                           << "/d " << c.name << " (value " << y0_of(r0, j) << ")";
      }
    }
    std::printf("  level 4 %s tilted, uz != 0, coupled_teeth %d: worst error/allowed %.3g\n",
                helical ? "helical" : "spur", coupled, worst);
  }
}

TEST(Jacobian, RefusesBadInputsAndLeavesTheWarmStart) {
  gm_model_params p = gm_test::paper();
  p.quasi_static = 1;
  Instance I(p);
  gm_kinematics at{};
  at.load_torque = 300;
  I.eval(at);
  const size_t n = gm_data_state_size(I.m, I.d);
  std::vector<unsigned char> before(n), after(n);
  ASSERT_EQ(gm_data_state_save(I.m, I.d, before.data(), n), GM_OK);
  gm_kinematics seed{};
  seed.u[0][1] = 1e-6;
  gm_result dr{};
  ASSERT_EQ(gm_directional_derivative(I.m, I.d, &at, &seed, &dr), GM_OK);
  ASSERT_EQ(gm_data_state_save(I.m, I.d, after.data(), n), GM_OK);
  EXPECT_EQ(before, after);
  seed.omega[1] = NAN;
  EXPECT_EQ(gm_directional_derivative(I.m, I.d, &at, &seed, &dr), GM_ERR_INPUT);
  EXPECT_NE(std::string(gm_data_message(I.d)).find("seed"), std::string::npos);
  EXPECT_EQ(gm_directional_derivative(I.m, I.d, &at, nullptr, &dr), GM_ERR_ARGUMENT);
}

}  // namespace

// Along gear 1's spin at 80 poses over a pitch, where every contact passes the tip corners' near
// field (laws.hpp) and, with set B's profile crowning, where the crowned flanks touch off the
// conjugate point (touch_point.hpp): the random poses above meet those only by chance. Levels 4
// and 5, the same differences and tolerance.
TEST(Jacobian, AlongTheSpinOverAPitchThroughTheCornersAndTheTouchPoints) {
  for (int level : {4, 5}) {
    for (double crowning : {0.0, 10e-6}) {
      gm_model_params p = gm_test::paper();
      p.slices = 7;
      p.solver_tolerance = 1e-15;
      p.stiffness_level = GM_STIFFNESS_ANALYTICAL;
      for (int g = 0; g < 2; ++g)
        for (auto& f : p.gear[g].flank) f.profile_crowning = crowning * (g + 1) / 2;
      if (level == 5) fe_level(p, 2);
      Instance I(p);
      Stats st;
      for (int pose = 0; pose < 80; ++pose) {
        gm_kinematics at{};
        at.phi[0] = 2 * kPi / p.gear[0].teeth * (pose + 0.5) / 80;
        at.phi[1] = phi2(I, 6e-6 + crowning, at.phi[0]);
        at.omega[0] = 100;
        at.omega[1] = -I.sign() * at.omega[0] * I.rb(0) / I.rb(1);
        I.eval(at);
        gm_kinematics seed{};
        seed.phi[0] = 1e-3;
        const std::string what = "level " + std::to_string(level) + ", crowning " + std::to_string(crowning);
        compare(I, at, seed, st, what + ", pose " + std::to_string(pose));
      }
      std::printf("  level %d, crowning %g um: checked %d skipped %d worst error/allowed %.3g\n", level,
                  crowning * 1e6, st.checked, st.skipped, st.worst);
      EXPECT_GE(st.checked, 70);
    }
  }
}

// An internal pair's flanks conform, so loaded tip corners carry far past the path's ends, where
// their local law takes its width from the angle between the flanks (docs/physics.md §4): along
// gear 1's spin over a pitch at a high approach (the 21/62 ring at about 100 N m), level 5 (the
// one tooth law a ring has).
TEST(Jacobian, RingCornersFarPastThePathsEnds) {
  gm_model_params p = gm_test::ring();
  p.slices = 3;
  fe_level(p, 2);
  Instance I(p);
  Stats st;
  int corners = 0;
  std::vector<gm::ContactSlice> c(256);
  for (int pose = 0; pose < 40; ++pose) {
    gm_kinematics at{};
    at.phi[0] = 2 * kPi / p.gear[0].teeth * (pose + 0.5) / 40;
    at.phi[1] = phi2(I, 15e-6, at.phi[0]);
    at.omega[0] = 100;
    at.omega[1] = -I.sign() * at.omega[0] * I.rb(0) / I.rb(1);
    I.eval(at);
    std::string msg;
    const int n = gm::detect_contacts(I.m->layout, at, c.data(), int(c.size()), msg);
    for (int i = 0; i < n; ++i)
      corners += c[std::size_t(i)].kind != gm::kFlankContact && c[std::size_t(i)].approach > 0;
    gm_kinematics seed{};
    seed.phi[0] = 1e-3;
    compare(I, at, seed, st, "pose " + std::to_string(pose));
  }
  std::printf("  checked %d skipped %d, overlapping corner slices %d, worst error/allowed %.3g\n", st.checked,
              st.skipped, corners, st.worst);
  EXPECT_GE(st.checked, 34);
  EXPECT_GT(corners, 20);
}
