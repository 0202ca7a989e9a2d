// Stiffness level 5 (FE) with synthetic compliance databases: a database that holds the
// analytical tooth compliance of level 4 (no coupling) reproduces level 4's loaded TE; coupling
// between slices and neighbouring teeth makes the mesh more compliant, and the derivative along
// the TE follows the coupled mesh stiffness; the cached dynamic assembly equals the reference
// assembly over a rotation sweep; a database made for another gear is refused naming its
// parameter. (Directional derivatives against finite differences: test_jacobian.cpp.)
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "gearmesh/internal/compliance_db.hpp"
#include "fe_compliance.hpp"
#include "dense_solve.hpp"
#include "fe_synthetic.hpp"
#include "tooth_coupling.hpp"
#include "gearmesh/gearmesh.h"
#include "model.hpp"
#include "gearmesh/internal/geometry.hpp"
#include "test_support.hpp"
#include "gearmesh/internal/tooth_compliance.hpp"

namespace {

using namespace gm_test;

gm_model_params fe_paper(int slices) {
  gm_model_params p = paper();
  p.quasi_static = 1;
  p.slices = slices;
  for (auto& g : p.gear)
    for (auto& f : g.flank) {  // keep the tip edges off the mate (as test_forces does)
      f.tip_relief = 40e-6;
      f.tip_relief_length = 0.05e-3;
    }
  return p;
}

struct Coupling {
  double slice = 0;  // C_0 entry between different face nodes, relative to the diagonal's
  double tooth = 0;  // C_{+-1} relative to C_0
};

// Gear `gear`'s synthetic database: roll grid over the analytical section's table range, face
// nodes at the slice centres; C_0[(a, m)][(b, n)] = sqrt(c(rho_a) c(rho_b)) cos^2(beta_b) /
// Delta_face for m = n (smooth in roll, so that the roll reading reproduces c(rho);
// a roll-diagonal database would be a delta kernel, which no interpolation reproduces), times
// coupling.slice for m != n; C_{+-1} = coupling.tooth C_0; other offsets 0. Depth: the level 4
// depth at mid-profile.
gm::ComplianceDb synthetic_db(const gm_model_params& p, int gear, const Coupling& coupling,
                              int n_roll = 41) {
  std::string msg;
  gm_pair_geometry g{};
  EXPECT_EQ(gm::compute_pair_geometry(p, g, msg), GM_OK) << msg;
  gm::ToothSection sec;
  EXPECT_EQ(gm::build_tooth_section(p, g, gear, gm::ToothSectionOptions{}, sec, msg), GM_OK) << msg;
  gm::ComplianceDb db;
  const gm_gear_params& gp = p.gear[gear];
  gm::record_gear(db, p, g, gear);
  db.bore_radius = sec.foundation.bore_radius;
  db.mesh_size = 1e-3;
  const double cb = std::cos(g.beta_b);
  db.depth = gm::tooth_contact_depth(sec, 0.5 * (sec.rho_min + sec.rho_max)) * cb;
  db.note = "synthetic (test_fe_level.cpp)";
  db.n_coupled = std::max(1, p.coupled_teeth);
  const int nf = p.slices;
  const double dz = gp.face_width / nf;
  for (int a = 0; a < n_roll; ++a)
    db.roll.push_back(sec.rho_min + (sec.rho_max - sec.rho_min) * a / (n_roll - 1));
  for (int m = 0; m < nf; ++m) db.face.push_back(-0.5 * gp.face_width + (m + 0.5) * dz);
  const std::size_t ng = db.n_grid();
  std::vector<double> c0(ng * ng, 0.0);
  for (int a = 0; a < n_roll; ++a)
    for (int b = 0; b < n_roll; ++b)
      for (int m = 0; m < nf; ++m)
        for (int n = 0; n < nf; ++n) {
          const double v = std::sqrt(gm::tooth_compliance(sec, db.roll[a]) *
                                     gm::tooth_compliance(sec, db.roll[b])) *
                           cb * cb / dz;
          c0[(a * nf + m) * ng + b * nf + n] = m == n ? v : coupling.slice * v;
        }
  for (int d = -int(db.n_coupled); d <= int(db.n_coupled); ++d) {
    std::vector<double> block(ng * ng, 0.0);
    if (d == 0) block = c0;
    if (std::abs(d) == 1)
      for (std::size_t k = 0; k < block.size(); ++k) block[k] = coupling.tooth * c0[k];
    db.blocks.push_back(block);
  }
  return db;
}

struct FeFiles {
  std::string path[2];
};

FeFiles fe_files(const gm_model_params& p, const std::string& tag, const Coupling& c = {}) {
  FeFiles f;
  for (int g = 0; g < 2; ++g)
    f.path[g] = write_db(tag + "_g" + std::to_string(g + 1) + ".gcdb", synthetic_db(p, g, c));
  return f;
}

gm_model_params at_level5(gm_model_params p, const FeFiles& f) {
  p.stiffness_level = GM_STIFFNESS_FE;
  p.compliance[0] = f.path[0].c_str();
  p.compliance[1] = f.path[1].c_str();
  return p;
}

// Loaded TE over one base pitch, n poses.
std::vector<gm_result> over_a_pitch(Instance& in, double torque, int n) {
  std::vector<gm_result> out;
  for (int s = 0; s < n; ++s) {
    const double phi1 = in.geo().p_bt / in.rb(0) * (s + 0.5) / n;
    out.push_back(in.loaded(phi1, torque));
  }
  return out;
}

TEST(FeLevel, UncoupledSyntheticDatabaseReproducesLevel4) {
  for (int slices : {1, 3}) {
    gm_model_params p4 = fe_paper(slices);
    p4.stiffness_level = GM_STIFFNESS_ANALYTICAL;
    p4.coupled_teeth = 0;  // level 4 without its tooth coupling, as the database
    const FeFiles f = fe_files(p4, "uncoupled" + std::to_string(slices));
    Instance a4(p4), a5(at_level5(p4, f));
    const double torque = 300;
    const int n = 40;
    const std::vector<gm_result> r4 = over_a_pitch(a4, torque, n), r5 = over_a_pitch(a5, torque, n);
    double worst = 0, te_max = 0;
    for (int s = 0; s < n; ++s) {
      te_max = std::max(te_max, std::fabs(r4[s].te));
      worst = std::max(worst, std::fabs(r5[s].te - r4[s].te));
      EXPECT_EQ(r5[s].pairs_in_contact, r4[s].pairs_in_contact) << s;
      EXPECT_NEAR(r5[s].normal_force, r4[s].normal_force, 1e-6 * r4[s].normal_force) << s;
      EXPECT_NEAR(r5[s].stiffness, r4[s].stiffness, 0.05 * r4[s].stiffness) << s;
    }
    std::printf("slices %d: level 4 loaded TE up to %.4g um, level 5 - level 4 up to %.3g um "
                "(%.3g %%)\n",
                slices, te_max * 1e6, worst * 1e6, 100 * worst / te_max);
    EXPECT_GT(te_max, 1e-6);
    // measured 1.12 % of the peak TE (0.166 um of 14.85 um at 300 N m), at the tooth's entry and
    // exit: the database's one Hertz depth h against level 4's, which follows the profile (0.43 %
    // over the pitch), and near the tip corners also the corner's near field, blended over a
    // length in proportion to h (laws.hpp); the rest from the roll interpolation of sqrt(c) on 41
    // nodes
    EXPECT_LT(worst, 0.015 * te_max);
  }
}

// The roll reading of a database (fe_compliance.cpp, roll_spot): compliance_tool's flank grid is
// the nodes of quadratic elements (corner, mid, corner), so a slice reads its element's three
// nodes with the element's shape functions, which reproduce a compliance quadratic in the roll
// over each element exactly; a database that declares linear elements (mesh_order 1) or an even
// node count is read linearly between two nodes. The database here: C_0[(a, m)][(b, n)] =
// f(rho_a) f(rho_b) / Delta_face for m = n, 0 otherwise, f(rho) = c (1 + 0.8 u + 0.6 u^2),
// u = (rho - rho_mid) / (rho_max - rho_min), 17 nodes (8 elements). A slice at roll rho_g on gear
// g's grid then has the self-compliance sum_g f_g(rho_g)^2 / Delta_face,g (closed form) when read
// quadratically, and (sum_a r_a f_a)^2 / Delta with the linear weights r when read linearly,
// which differs from the closed form by up to 1.2e-3 of it here; the derivative along gear 1's
// roll is 2 f f' / Delta, at the nodes too (there the neighbours' weights are 0 but move: a
// reading that left them out, as one did, had the derivative wrong at every node).
TEST(FeLevel, RollReadingIsTheElementsShapeFunctions) {
  gm_model_params p = fe_paper(3);
  p.coupled_teeth = 0;
  const auto f_of = [](const gm::ComplianceDb& db, double rho) {
    const double lo = db.roll.front(), hi = db.roll.back();
    const double u = (rho - 0.5 * (lo + hi)) / (hi - lo);
    return 2e-11 * (1 + 0.8 * u + 0.6 * u * u);
  };
  const auto df_of = [](const gm::ComplianceDb& db, double rho) {
    const double lo = db.roll.front(), hi = db.roll.back();
    const double u = (rho - 0.5 * (lo + hi)) / (hi - lo);
    return 2e-11 * (0.8 + 1.2 * u) / (hi - lo);
  };
  for (int order : {2, 1}) {
    gm::ComplianceDb db[2];
    std::string path[2];
    for (int g = 0; g < 2; ++g) {
      db[g] = synthetic_db(p, g, {}, 17);
      db[g].mesh_order = std::uint32_t(order);
      const int nr = int(db[g].roll.size()), nf = int(db[g].face.size());
      const std::size_t ng = db[g].n_grid();
      const double dz = p.gear[g].face_width / nf;
      std::vector<double>& c0 = db[g].blocks[std::size_t(db[g].n_coupled)];  // offset 0
      std::fill(c0.begin(), c0.end(), 0.0);
      for (int a = 0; a < nr; ++a)
        for (int b = 0; b < nr; ++b)
          for (int m = 0; m < nf; ++m)
            c0[(std::size_t(a) * nf + m) * ng + std::size_t(b) * nf + m] =
                f_of(db[g], db[g].roll[a]) * f_of(db[g], db[g].roll[b]) / dz;
      path[g] = write_db("roll_reading" + std::to_string(order) + "_g" + std::to_string(g + 1) + ".gcdb", db[g]);
    }
    gm_model_params q = p;
    q.stiffness_level = GM_STIFFNESS_FE;
    q.compliance[0] = path[0].c_str();
    q.compliance[1] = path[1].c_str();
    Instance I(q);
    const gm_model& m = *I.m;
    std::vector<gm::ContactSliceT<gm::Dual>> slices(static_cast<std::size_t>(m.slice_capacity));
    gm::KinematicsT<gm::Dual> k{};
    k.phi[0] = gm::Dual(0.0);
    k.phi[1] = gm::Dual(3e-6 / I.rb(1));
    std::string msg;
    ASSERT_GT(gm::detect_contacts(m.layout, k, slices.data(), m.slice_capacity, msg), 0) << msg;
    gm::ContactSliceT<gm::Dual> s = slices[0];
    const gm::Dual uz[2] = {gm::Dual(0.0), gm::Dual(0.0)};
    double worst = 0, worst_slope = 0, apart = 0;
    for (int t = 0; t <= 160; ++t) {  // nodes, element middles and in between, both grids
      double rho[2], expected = 0, slope = 0;
      for (int g = 0; g < 2; ++g) {
        const double lo = db[g].roll.front(), hi = db[g].roll.back();
        rho[g] = lo + (hi - lo) * (g == 0 ? t : 160 - t) / 160.0;
        const double dz = p.gear[g].face_width / int(db[g].face.size());
        double f = f_of(db[g], rho[g]);
        if (order == 1) {  // the linear weights, computed here
          const auto& R = db[g].roll;
          const int a = std::min(int(std::upper_bound(R.begin(), R.end(), rho[g]) - R.begin()) - 1, int(R.size()) - 2);
          const double w = (R[a + 1] - rho[g]) / (R[a + 1] - R[a]);
          f = w * f_of(db[g], R[a]) + (1 - w) * f_of(db[g], R[a + 1]);
        }
        expected += f * f / dz;
        if (g == 0 && order == 2) slope = 2 * f * df_of(db[g], rho[g]) / dz;
      }
      s.roll[0] = gm::Dual(rho[0], 1.0);
      s.roll[1] = gm::Dual(rho[1], 0.0);
      const gm::Dual c = gm::fe_pair_compliance(gm::fe_view(m), s, s, uz);
      worst = std::max(worst, std::fabs(c.v - expected) / expected);
      if (order == 2 && t > 0 && t < 160)  // inside the grid (held at its ends: slope 0)
        worst_slope = std::max(worst_slope, std::fabs(c.d - slope) / std::fabs(slope));
      if (order == 2) {  // the linear reading would differ from the closed form here
        double lin = 0;
        for (int g = 0; g < 2; ++g) {
          const auto& R = db[g].roll;
          const int a = std::min(int(std::upper_bound(R.begin(), R.end(), rho[g]) - R.begin()) - 1, int(R.size()) - 2);
          const double w = (R[a + 1] - rho[g]) / (R[a + 1] - R[a]);
          const double f = w * f_of(db[g], R[a]) + (1 - w) * f_of(db[g], R[a + 1]);
          lin += f * f / (p.gear[g].face_width / int(db[g].face.size()));
        }
        apart = std::max(apart, std::fabs(lin - expected) / expected);
      }
    }
    std::printf("mesh_order %d: self-compliance within %.2e of the closed form, slope within %.2e (the linear "
                "reading %.2e off)\n",
                order, worst, worst_slope, apart);
    if (order == 2) EXPECT_GT(apart, 1e-4) << "the test cannot tell the readings apart";
    EXPECT_LT(worst, 1e-13) << "mesh_order " << order;
    if (order == 2) EXPECT_LT(worst_slope, 1e-9);
  }
}

// Level 4's tooth coupling against level 5 on a synthetic database that holds it: C_0 as above
// (level 4's own compliance), C_d for 0 < |d| <= 2 the coupling surrogate's kernel at the roll
// nodes, face-uniform: the response to a unit point load anywhere on the face is the kernel's
// displacement under the line load of that force spread over the face, k_d(h_a, h_b) / b, taken
// from coupling_coefficients (not from the core's slice mapping). Level 5 maps slices to teeth and
// offsets with fe_compliance.cpp's conventions (checked against the geometry in
// test_fe_mapping.cpp); so the two levels agree only if level 4 reads the same offsets, gears
// and flanks (load on flank A and on flank B). The difference left is the database's one Hertz
// depth and the roll interpolation, as in the uncoupled test.
TEST(FeLevel, CoupledSyntheticDatabaseReproducesCoupledLevel4) {
  gm_model_params p4 = fe_paper(3);
  p4.stiffness_level = GM_STIFFNESS_ANALYTICAL;
  p4.coupled_teeth = 2;
  FeFiles f;
  for (int g = 0; g < 2; ++g) {
    gm::ComplianceDb db = synthetic_db(p4, g, Coupling{});
    std::string msg;
    gm_pair_geometry geo{};
    ASSERT_EQ(gm::compute_pair_geometry(p4, geo, msg), GM_OK) << msg;
    const double mn = p4.pair.normal_module, rb = 0.5 * geo.gear[g].d_b, r = 0.5 * geo.gear[g].d;
    const gm::CouplingCoefficients k =
        gm::coupling_coefficients(p4.gear[g].teeth, p4.gear[g].face_width / mn);
    const int nr = int(db.roll.size()), nf = int(db.face.size()), ng = nr * nf;
    const double scale = 1.0 / (p4.gear[g].youngs_modulus * p4.gear[g].face_width);
    for (int d = -2; d <= 2; ++d) {
      if (d == 0) continue;
      std::vector<double>& block = db.blocks[std::size_t(d + int(db.n_coupled))];
      for (int a = 0; a < nr; ++a) {
        for (int b = 0; b < nr; ++b) {
          const double ha = (std::hypot(db.roll[a], rb) - r) / mn;
          const double hb = (std::hypot(db.roll[b], rb) - r) / mn;
          const double* c = k.c[std::abs(d) - 1];
          const double x = d > 0 ? ha : hb, y = d > 0 ? hb : ha;  // receiver, load (table's)
          const double v = scale * (c[0] + c[1] * x + c[2] * y + c[3] * x * y);
          for (int m = 0; m < nf; ++m)
            for (int n = 0; n < nf; ++n) block[std::size_t((a * nf + m) * ng + b * nf + n)] = v;
        }
      }
    }
    f.path[g] = write_db("coupled4_g" + std::to_string(g + 1) + ".gcdb", db);
  }
  Instance a4(p4), a5(at_level5(p4, f));
  gm_model_params p0 = p4;
  p0.coupled_teeth = 0;
  Instance a0(p0);
  for (double torque : {300.0, -300.0}) {
    const int n = 40;
    const std::vector<gm_result> r4 = over_a_pitch(a4, torque, n), r5 = over_a_pitch(a5, torque, n),
                                 r0 = over_a_pitch(a0, torque, n);
    double worst = 0, te_max = 0, effect = 0;
    for (int s = 0; s < n; ++s) {
      te_max = std::max(te_max, std::fabs(r4[s].te));
      worst = std::max(worst, std::fabs(r5[s].te - r4[s].te));
      effect = std::max(effect, std::fabs(r4[s].te - r0[s].te));
      EXPECT_EQ(r5[s].pairs_in_contact, r4[s].pairs_in_contact) << s;
      EXPECT_NEAR(r5[s].stiffness, r4[s].stiffness, 0.05 * r4[s].stiffness) << s;
    }
    std::printf("torque %g: coupled level 4 TE up to %.4g um, the coupling moves it up to %.3g um, "
                "level 5 - level 4 up to %.3g um (%.3g %%)\n",
                torque, te_max * 1e6, effect * 1e6,
                worst * 1e6, 100 * worst / te_max);
    EXPECT_GT(effect, 1e-6);  // the coupling matters here (2.4 um measured)
    // and both levels read it alike: what is left (0.15 um measured) is the uncoupled test's
    // difference, a sixteenth of the coupling's effect; a wrong offset, gear or flank moves the TE
    // by the order of that effect
    EXPECT_LT(worst, 0.015 * te_max);
    EXPECT_LT(worst, 0.1 * effect);
  }
}

TEST(FeLevel, CouplingMakesTheMeshMoreCompliantAndTheSolverConverges) {
  gm_model_params p = fe_paper(3);
  p.stiffness_level = GM_STIFFNESS_ANALYTICAL;  // for the databases' tooth sections
  const FeFiles plain = fe_files(p, "plain3");
  const FeFiles coupled = fe_files(p, "coupled3", Coupling{0.4, 0.2});
  Instance u(at_level5(p, plain)), c(at_level5(p, coupled));
  const double torque = 300;
  const int n = 20;
  const std::vector<gm_result> ru = over_a_pitch(u, torque, n), rc = over_a_pitch(c, torque, n);
  double ratio_min = 1e9, ratio_max = 0;
  for (int s = 0; s < n; ++s) {
    EXPECT_GT(rc[s].te, ru[s].te) << s;
    EXPECT_LT(rc[s].stiffness, ru[s].stiffness) << s;
    EXPECT_GT(rc[s].solver_iterations, 0) << s;
    EXPECT_LT(rc[s].solver_residual, p.solver_tolerance) << s;
    EXPECT_NEAR(rc[s].normal_force, torque / c.rb(1), 1e-6 * torque / c.rb(1)) << s;
    ratio_min = std::min(ratio_min, rc[s].te / ru[s].te);
    ratio_max = std::max(ratio_max, rc[s].te / ru[s].te);
  }
  std::printf("coupled / uncoupled loaded TE: %.4f .. %.4f\n", ratio_min, ratio_max);
  // plain mode at the same pose, cold and warm: converged, positive forces
  gm_model_params pp = at_level5(p, coupled);
  pp.quasi_static = 0;
  Instance q(pp);
  const gm_result r1 = q.at(rc[n / 2].te, c.geo().p_bt / c.rb(0) * (n / 2 + 0.5) / n);
  EXPECT_GT(r1.solver_iterations, 0);
  EXPECT_LT(r1.solver_residual, p.solver_tolerance);
  EXPECT_NEAR(r1.normal_force, torque / c.rb(1), 1e-3 * torque / c.rb(1));
  const gm_result r2 = q.at(rc[n / 2].te, c.geo().p_bt / c.rb(0) * (n / 2 + 0.5) / n);
  EXPECT_LE(r2.solver_iterations, 1);  // warm start from the same candidates' forces
  EXPECT_NEAR(r2.normal_force, r1.normal_force, 1e-9 * r1.normal_force);
  // the derivative along a pure TE direction (gear 2's spin): the normal force moves with the
  // coupled mesh stiffness, plus the compliance's change as gear 2's contact points roll (small)
  gm_kinematics at{}, seed{};
  at.phi[0] = c.geo().p_bt / c.rb(0) * (n / 2 + 0.5) / n;
  at.phi[1] = (rc[n / 2].te - c.rb(0) * at.phi[0]) / c.rb(1);
  const gm_result r3 = q.eval(at);
  seed.phi[1] = 1e-6 / c.rb(1);  // dTE = 1 um
  gm_result dr{};
  ASSERT_EQ(gm_directional_derivative(q.m, q.d, &at, &seed, &dr), GM_OK) << gm_data_message(q.d);
  EXPECT_NEAR(dr.te, 1e-6, 1e-18);
  EXPECT_NEAR(dr.normal_force, r3.stiffness * 1e-6, 0.03 * r3.stiffness * 1e-6);
  // and leaves the warm start as it was: the next evaluation repeats the last one bit for bit
  const gm_result r4 = q.eval(at);
  EXPECT_EQ(r4.normal_force, r3.normal_force);
}

// Level 5 parameters with each gear's smooth synthetic database (fe_synthetic.hpp) on disk.
struct SmoothFe {
  std::string path[2];
  gm_model_params p;
  SmoothFe(gm_model_params base, const std::string& tag, const gm_test::SmoothDbShape& shape = {}) {
    base.stiffness_level = GM_STIFFNESS_FE;
    base.compliance[0] = base.compliance[1] = nullptr;
    for (int g = 0; g < 2; ++g) {
      std::string msg;
      const gm::ComplianceDb db = gm_test::smooth_db(base, g, shape, msg);
      EXPECT_TRUE(msg.empty()) << msg;
      path[g] = write_db(tag + "_smooth_g" + std::to_string(g + 1) + ".gcdb", db);
    }
    p = base;
    p.compliance[0] = path[0].c_str();
    p.compliance[1] = path[1].c_str();
  }
};

// The sweeps' pair on smooth databases read with mesh_order `order`: fe_paper(6), spur or, at
// beta (deg) != 0, helical as bench_evaluate's (unshifted, a little backlash).
SmoothFe sweep_fe(double beta, std::uint32_t order, const std::string& tag) {
  gm_model_params base = fe_paper(6);
  base.pair.helix_angle = beta * kPi / 180;
  if (beta != 0) {
    base.gear[0].profile_shift = base.gear[1].profile_shift = 0;
    base.pair.center_distance = 0.0026 / std::cos(base.pair.helix_angle) * 57 + 50e-6;
  }
  gm_test::SmoothDbShape shape;
  shape.mesh_order = order;
  return SmoothFe(base, tag + std::to_string(int(beta)) + "_" + std::to_string(order), shape);
}

// The cached dynamic assembly against the straightforward reference over a rotation sweep that
// crosses mesh events (pairs entering and leaving), spur and helical (slices at different roll
// distances), with an axial motion in the middle (the face strips change: that call computes
// directly, and the cache is rebuilt): equal to round-off; and a fresh assembly (nothing cached)
// gives the very same bits as the long-lived one at every pose.
// FMU state at level 5: the warm start (previous forces, kept tangent) and the assembly cache
// are not part of the state; gm_data_state_load makes the next solve start cold. So the result
// after a restore is a function of the state and the inputs alone (two instances restored from
// one blob agree bit for bit), and differs from the warm continuation that saved it only within
// the solver's tolerance.
TEST(FeLevel, RestoredStateIsDeterministicAndWithinToleranceOfTheWarmRun) {
  gm_model_params p = fe_paper(3);
  p.stiffness_level = GM_STIFFNESS_ANALYTICAL;  // for the databases' tooth sections
  const FeFiles coupled = fe_files(p, "state3", Coupling{0.4, 0.2});
  const gm_model_params p5 = at_level5(p, coupled);
  Instance a(p5), b(p5);
  const double torque = 300;
  const int n = 12;
  auto phi1 = [&](int s) { return a.geo().p_bt / a.rb(0) * (s + 0.5) / n; };
  for (int s = 0; s < n / 2; ++s) a.loaded(phi1(s), torque);
  std::vector<unsigned char> blob(gm_data_state_size(a.m, a.d));
  ASSERT_EQ(gm_data_state_save(a.m, a.d, blob.data(), blob.size()), GM_OK);
  const gm_result warm = a.loaded(phi1(n / 2), torque);
  ASSERT_EQ(gm_data_state_load(a.m, a.d, blob.data(), blob.size()), GM_OK) << gm_data_message(a.d);
  ASSERT_EQ(gm_data_state_load(b.m, b.d, blob.data(), blob.size()), GM_OK) << gm_data_message(b.d);
  const gm_result ra = a.loaded(phi1(n / 2), torque), rb = b.loaded(phi1(n / 2), torque);
  EXPECT_EQ(ra.te, rb.te);
  EXPECT_EQ(ra.normal_force, rb.normal_force);
  EXPECT_EQ(ra.stiffness, rb.stiffness);
  EXPECT_EQ(ra.force[0][1], rb.force[0][1]);
  std::printf("restored - warm: TE %.3g m, normal force %.3g N, stiffness %.3g relative\n",
              ra.te - warm.te, ra.normal_force - warm.normal_force,
              ra.stiffness / warm.stiffness - 1);
  // the solver stops at 1e-15 m + 1e-10 |Delta| (Delta ~ 15 um here, so ~2e-15 m) per slice
  EXPECT_NEAR(ra.te, warm.te, 1e-13);
  EXPECT_NEAR(ra.normal_force, warm.normal_force, 1e-9 * warm.normal_force);
  EXPECT_NEAR(ra.stiffness, warm.stiffness, 1e-6 * warm.stiffness);
}

// Level 5 quasi-static: a run over poses starts each pass loop from the TE extrapolated from
// the last two solves (dense_solve.cpp, predicted_te). The answer is the pass loop's fixed point
// whatever the start: an instance reset before every pose (starting from TE = 0, no history)
// gives the same TE and forces within the solver's tolerance, in more solver iterations; a load
// change drops the extrapolation (the two runs then agree as well).
TEST(FeLevel, QuasiStaticTeExtrapolationReachesTheSameAnswer) {
  gm_model_params p = fe_paper(3);
  p.stiffness_level = GM_STIFFNESS_ANALYTICAL;  // for the databases' tooth sections
  const FeFiles coupled = fe_files(p, "extrap3", Coupling{0.4, 0.2});
  const gm_model_params p5 = at_level5(p, coupled);
  Instance run(p5), cold(p5);
  const int n = 16;
  int it_run = 0, it_cold = 0;
  double worst_te = 0, worst_f = 0;
  for (int s = 0; s < n; ++s) {
    const double torque = s < 12 ? 300 : 200;
    const double phi1 = run.geo().p_bt / run.rb(0) * (s + 0.5) / 10;  // across a mesh event
    const gm_result a = run.loaded(phi1, torque);
    gm_data_reset(cold.m, cold.d);
    const gm_result b = cold.loaded(phi1, torque);
    it_run += a.solver_iterations;
    it_cold += b.solver_iterations;
    worst_te = std::max(worst_te, std::fabs(a.te - b.te));
    worst_f = std::max(worst_f, std::fabs(a.normal_force / b.normal_force - 1));
    EXPECT_NEAR(a.te, b.te, 1e-13) << s;
    EXPECT_NEAR(a.normal_force, b.normal_force, 1e-9 * b.normal_force) << s;
    EXPECT_NEAR(a.force[1][1], b.force[1][1], 1e-9 * std::fabs(b.normal_force)) << s;
    EXPECT_NEAR(a.stiffness, b.stiffness, 1e-6 * b.stiffness) << s;
  }
  std::printf("extrapolated - cold start: TE up to %.3g m, normal force %.3g relative; solver "
              "iterations %d (extrapolated) vs %d (cold)\n",
              worst_te, worst_f, it_run, it_cold);
}

TEST(FeLevel, CachedAssemblyMatchesTheReferenceOverARotationSweep) {
  for (std::uint32_t order : {2u, 1u})  // the roll read quadratically and linearly
    for (double beta : {0.0, 15.0}) {
      const SmoothFe fe = sweep_fe(beta, order, "sweep");
      Instance I(fe.p);
      const gm_model& m = *I.m;
      const int cap = m.slice_capacity;
      std::vector<gm::ContactSlice> slices(std::size_t(cap), gm::ContactSlice{});
      std::vector<int> index(static_cast<std::size_t>(cap), 0);
      Eigen::MatrixXd Cc(cap, cap), Cf(cap, cap), Cr(cap, cap);
      gm::FeAssembly cached;
      int events = 0, cached_calls = 0, direct_calls = 0, last_pairs = -1, checked = 0, flank_b = 0;
      double worst = 0;
      const int steps = 150;
      for (int s = 0; s < steps; ++s) {
        gm_kinematics k{};
        k.phi[0] = 2.5 * 2 * kPi / 57 * s / steps;  // two and a half pitches
        k.phi[1] = (3e-6 - I.rb(0) * k.phi[0]) / I.rb(1);
        if (s >= 70 && s < 75) k.u[1][2] = 20e-6 * (s - 69);  // axial motion of gear 2
        std::string msg;
        const int n = gm::detect_contacts(m.layout, k, slices.data(), cap, msg);
        ASSERT_GE(n, 0) << msg;
        int na = 0, pairs = 0, last = -1;
        for (int i = 0; i < n; ++i) {
        // near candidates, flank B too (its face is read reversed through a helical mirror)
          if (slices[std::size_t(i)].approach <= -100e-6) continue;
          flank_b += slices[std::size_t(i)].flank < 0;
          index[std::size_t(na++)] = i;
          if (slices[std::size_t(i)].pair != last) ++pairs, last = slices[std::size_t(i)].pair;
        }
        if (na == 0) continue;
        if (pairs != last_pairs) ++events;
        last_pairs = pairs;
        const double uz[2] = {k.u[0][2], k.u[1][2]};
        cached.assemble(gm::fe_view(m), slices.data(), index.data(), na, uz, Cc);
        (cached.cached(0) && cached.cached(1) ? cached_calls : direct_calls)++;
        gm::FeAssembly fresh;
        fresh.assemble(gm::fe_view(m), slices.data(), index.data(), na, uz, Cf);
        gm::fe_assemble_reference(gm::fe_view(m), slices.data(), index.data(), na, uz, Cr);
        const double scale = Cr.topLeftCorner(na, na).cwiseAbs().maxCoeff();
        ASSERT_GT(scale, 0);
        for (int a = 0; a < na; ++a)
          for (int b = 0; b < na; ++b) {
            worst = std::max(worst, std::fabs(Cc(a, b) - Cr(a, b)) / scale);
            ASSERT_EQ(Cc(a, b), Cf(a, b)) << "beta " << beta << " pose " << s << " (" << a << ", " << b << ")";
            ASSERT_EQ(Cc(a, b), Cc(b, a));
          }
        ++checked;
      }
      std::printf("mesh_order %u, beta %g: %d poses (%d flank B slices), %d set changes, %d cached / %d direct "
                  "calls, cached - reference up to %.3g of the largest entry, %zu values cached\n",
                  order, beta, checked, flank_b, events, cached_calls, direct_calls, worst, cached.cached_values());
      EXPECT_LT(worst, 1e-14);
      EXPECT_GE(events, 4);
      EXPECT_GE(direct_calls, 6);  // the first call and each axial move
      EXPECT_GE(cached_calls, checked - 10);
    }
}

// The derivative's assembly (FeDualAssembly) against fe_pair_compliance<Dual> entry by entry
// (lower triangle, mirrored), values and derivatives bit for bit, over a sweep of two and a half pitches with tooth changes,
// flank B and axial motion, spur and helical, along the spin and along the axial displacement.
TEST(FeLevel, DualAssemblyMatchesThePairwiseReferenceBitForBit) {
  for (std::uint32_t order : {2u, 1u})  // the roll read quadratically and linearly
    for (double beta : {0.0, 15.0}) {
      const SmoothFe fe = sweep_fe(beta, order, "dual_sweep");
      Instance I(fe.p);
      const gm_model& m = *I.m;
      const int cap = m.slice_capacity;
      std::vector<gm::ContactSliceT<gm::Dual>> slices(static_cast<std::size_t>(cap));
      std::vector<int> index(static_cast<std::size_t>(cap), 0);
      Eigen::MatrixXd C(cap, cap), dC(cap, cap);
      gm::FeDualAssembly assembly;
      assembly.reserve(gm::fe_view(m), cap);
      int checked = 0, moving = 0;
      for (int s = 0; s < 60; ++s) {
        gm::KinematicsT<gm::Dual> k{};
        const double phi1 = 2.5 * 2 * kPi / 57 * s / 60;
        k.phi[0] = gm::Dual(phi1, s % 2 == 0 ? 1.0 : 0.0);
        k.phi[1] = gm::Dual((3e-6 - I.rb(0) * phi1) / I.rb(1));
        k.u[1][2] = gm::Dual(s >= 30 && s < 35 ? 20e-6 * (s - 29) : 0.0, s % 2 == 0 ? 0.0 : 1.0);
        std::string msg;
        const int n = gm::detect_contacts(m.layout, k, slices.data(), cap, msg);
        ASSERT_GE(n, 0) << msg;
        int na = 0;
        for (int i = 0; i < n; ++i)
          if (slices[std::size_t(i)].approach > -100e-6) index[std::size_t(na++)] = i;
        if (na == 0) continue;
        const gm::Dual uz[2] = {k.u[0][2], k.u[1][2]};
        assembly.assemble(gm::fe_view(m), slices.data(), index.data(), na, uz, C, dC);
      // the lower triangle from the reference (receiver a, load b), mirrored, as the derivative
      // assembled it before
        for (int a = 0; a < na; ++a)
          for (int b = 0; b <= a; ++b) {
            const gm::Dual r = gm::fe_pair_compliance(gm::fe_view(m), slices[std::size_t(index[std::size_t(a)])],
                                                      slices[std::size_t(index[std::size_t(b)])], uz);
            ASSERT_EQ(C(a, b), r.v) << "beta " << beta << " pose " << s << " (" << a << ", " << b << ")";
            ASSERT_EQ(dC(a, b), r.d) << "beta " << beta << " pose " << s << " (" << a << ", " << b << ")";
            ASSERT_EQ(C(b, a), r.v);
            ASSERT_EQ(dC(b, a), r.d);
            moving += r.d != 0;
          }
        ++checked;
      }
      EXPECT_GE(checked, 50);
      EXPECT_GT(moving, 0);  // the derivatives are not all zero
    }
}

// Level 5 on p's own synthetic databases, gear `gear`'s replaced by db (written as `name`).
gm_model_params with_database(const gm_model_params& p, const FeFiles& f, int gear, const gm::ComplianceDb& db,
                              const std::string& name, std::string& path) {
  path = write_db(name, db);
  gm_model_params q = at_level5(p, f);
  q.compliance[gear] = path.c_str();
  return q;
}

// gm_model_create's refusal of q: GM_ERR_PARAMETER, no model, and its message.
std::string refusal(const gm_model_params& q) {
  gm_model* m = nullptr;
  char msg[512] = "";
  EXPECT_EQ(gm_model_create(&q, &m, msg, sizeof msg), GM_ERR_PARAMETER);
  EXPECT_EQ(m, nullptr);
  gm_model_free(m);
  return msg;
}

TEST(FeLevel, DatabaseOfAnotherGearIsRefusedNamingItsParameter) {
  gm_model_params p = fe_paper(1);
  p.stiffness_level = GM_STIFFNESS_ANALYTICAL;
  const FeFiles f = fe_files(p, "mismatch");
  gm::ComplianceDb other = synthetic_db(p, 0, {});
  other.teeth = 40;  // made for another gear
  std::string path;
  const std::string msg = refusal(with_database(p, f, 0, other, "other_z.gcdb", path));
  EXPECT_EQ(msg.rfind("gear1.compliance", 0), 0u) << msg;
  EXPECT_NE(msg.find("z = 40"), std::string::npos) << msg;
  // a database at another level is refused too
  gm_model_params r = p;
  r.compliance[1] = f.path[1].c_str();
  EXPECT_EQ(refusal(r).rfind("gear2.compliance", 0), 0u);
}

// A database value beyond 1e-3 m/N (a gear body's compliance is about 1e-10 .. 1e-7 m/N), or a
// depth outside the gear, is refused at model creation naming the gear, field and range: databases
// scaled by 1e200 gave forces near 1e-300 N whose local Hertz law made the outputs and derivatives
// NaN, and so did a depth of 7.5e168 m at 144 N and one of 5.2e-310 m at 7.5 kN
// (tests/fuzz/fuzz_fe_model). Negative and zero values stay allowed (coupling terms, a rigid gear).
TEST(FeLevel, DatabaseValuesBeyondTheirPhysicalRangeAreRefused) {
  gm_model_params p = fe_paper(2);
  p.stiffness_level = GM_STIFFNESS_ANALYTICAL;
  const FeFiles f = fe_files(p, "values");
  gm::ComplianceDb soft = synthetic_db(p, 1, {});
  std::string path;
  soft.blocks[1][5] = 1e212;
  std::string msg = refusal(with_database(p, f, 1, soft, "values_soft.gcdb", path));
  EXPECT_NE(msg.find("gear2.compliance: block 1 entry 5 = 1e+212 m/N; allowed |value| <= 0.001 m/N"),
            std::string::npos)
      << msg;
  soft.blocks[1][5] = -1e-3;  // the range's end, and negative
  gm_model* m = nullptr;
  char text[512] = "";
  const gm_model_params edge = with_database(p, f, 1, soft, "values_edge.gcdb", path);
  ASSERT_EQ(gm_model_create(&edge, &m, text, sizeof text), GM_OK) << text;
  gm_model_free(m);
  for (double depth : {7.5e168, 5.2e-310}) {  // beyond the gear's tip radius; subnormal
    soft.depth = depth;
    msg = refusal(with_database(p, f, 1, soft, "values_depth.gcdb", path));
    EXPECT_NE(msg.find("m; allowed [1e-09, 0.07761"), std::string::npos) << msg;
    EXPECT_EQ(msg.rfind("gear2.compliance: depth = ", 0), 0u) << msg;
  }
  soft = synthetic_db(p, 1, {});
  soft.roll[1] = std::nextafter(soft.roll[0], 1.0);  // a grid step of one ulp
  msg = refusal(with_database(p, f, 1, soft, "values_step.gcdb", path));
  EXPECT_NE(msg.find("gear2.compliance: roll[1] = "), std::string::npos) << msg;
  EXPECT_NE(msg.find("at least 1e-09 m after the previous value"), std::string::npos) << msg;
}

// The quasi-static start TE (dense_solve.cpp, predicted_te) from the solved history: exact for a
// parabola in gear 1's angle once three solves at the same torque are held (steps alike within
// 4x), the line through the last two otherwise (two solves, unequal steps, another torque
// before), the last TE after a step more than twice the last one or a restored state.
TEST(FeLevel, QuasiStaticStartTeIsTheParabolaThroughTheLastThreeSolves) {
  gm_model_params p = fe_paper(3);
  p.stiffness_level = GM_STIFFNESS_ANALYTICAL;
  const FeFiles files = fe_files(p, "predict", Coupling{0.4, 0.2});
  Instance in(at_level5(p, files));
  gm_data& d = *in.d;
  const auto te_of = [](double phi) { return 3e-6 + 2e-5 * phi - 4e-3 * phi * phi; };
  const auto record = [&](double phi, double torque) {
    d.te_estimate = te_of(phi);
    gm::record_te(d, phi, d.te_estimate, torque);
  };
  d.dense_prev_n = 0;  // a warm solver: the history is valid
  record(0.010, 300);
  record(0.011, 300);
  const double line = te_of(0.011) + (te_of(0.011) - te_of(0.010)) / 0.001 * 0.001;
  EXPECT_NEAR(gm::predicted_te(d, 0.012, 300), line, 1e-18);  // two solves: the line
  record(0.012, 300);
  EXPECT_NEAR(gm::predicted_te(d, 0.0133, 300), te_of(0.0133), 1e-18);  // three: exact
  EXPECT_EQ(gm::predicted_te(d, 0.016, 300), te_of(0.012));  // more than twice the last step
  record(0.0125, 300);  // a step of 0.5 after 1 (within 4x): still the parabola
  EXPECT_NEAR(gm::predicted_te(d, 0.013, 300), te_of(0.013), 1e-18);
  record(0.01255, 300);  // 0.05 after 0.5: 10x apart, the line through the last two
  const double line2 = te_of(0.01255) + (te_of(0.01255) - te_of(0.0125)) / 0.00005 * 0.00005;
  EXPECT_NEAR(gm::predicted_te(d, 0.0126, 300), line2, 1e-18);
  record(0.0127, 250);  // another torque
  EXPECT_EQ(gm::predicted_te(d, 0.0128, 300), te_of(0.0127));
  record(0.0128, 250);
  EXPECT_NEAR(gm::predicted_te(d, 0.0129, 250),
              te_of(0.0128) + (te_of(0.0128) - te_of(0.0127)) / 0.0001 * 0.0001, 1e-18);
  d.dense_prev_n = -1;  // reset or restored state
  EXPECT_EQ(gm::predicted_te(d, 0.0129, 250), te_of(0.0128));
}

}  // namespace

// Level 5 quasi-static solves the load balance over the candidates of the flank the load closes
// alone when the other flank stays open (the databases never couple the two flanks), and over
// every candidate when it closes too (gear 2 moved towards gear 1 until both flanks touch:
// wedging). Either way the answer is that of the plain solve at the solved TE: the same flanks
// in contact, the same forces, moments and stiffness within the pass loop's TE tolerance (the
// solved TE is good to ~1e-13 m here, a force error of ~1e-8 of the load through the mesh
// stiffness).
TEST(FeLevel, QuasiStaticAgreesWithThePlainSolveAtItsTeOpenAndWedged) {
  gm_model_params base = fe_paper(5);
  base.coupled_teeth = 2;
  const SmoothFe fe(base, "flanks5");
  gm_test::expect_quasi_static_equals_plain_at_its_te(fe.p);
}

// Level 5's elastic energy comes from the laws the coupled solve holds at its answer
// (dense_solve.cpp, dense_store), not from the laws evaluated again: it equals
// U = sum_i [F_i (Delta_i + f_i(F_i))/2 - P_i(F_i)] (resultants.hpp) recomputed here from the
// solved slices with hertz.cpp's evaluate_local_law, plain and quasi-static (final approaches),
// at poses with one and with two pairs in contact. (The potential property dU/dphi = -M of
// level 0's test does not hold here: C and the Hertz radii move with the roll, which adds
// -F^T dC F/2 and -dP/dR' dR' terms, ~3e-5 of the moment with this database.)
// That recomputation shares the code's laws. The independent expectation: U is the work done on
// the mesh loading it from zero, gear 1 held and gear 2 turned from inside the backlash to the
// TE, W = int -M_2,z dphi_2 from the moments alone (composite Simpson, 400 intervals), within
// 1e-4 of U. Measured 6e-7 to 3.1e-5: the roll moving with the TE (above); the quadrature's own
// error is below 6e-7 (against 1600 intervals).
double recomputed_energy(const gm_data& d) {
  double u = 0;
  for (int a = 0; a < d.dense_prev_n; ++a) {
    const int i = d.dense_index[std::size_t(a)];
    const double F = d.forces[std::size_t(i)];
    if (!(F > 0)) continue;
    const gm::LocalLawValue law = gm::evaluate_local_law(d.laws[std::size_t(i)].local, F);
    u += 0.5 * F * (d.slices[std::size_t(i)].approach + law.approach) - law.energy;
  }
  return u;
}

// The work done on the mesh with gear 1 held at phi1 and gear 2 turned from TE = -0.5 um (no
// contact) to te: int -M_2,z dphi_2, composite Simpson in the TE (dphi_2 = dTE / (s r_b2)).
double loading_work(Instance& in, double phi1, double te, int intervals = 400) {
  const double from = -0.5e-6, h = (te - from) / intervals;
  double sum = 0;
  for (int k = 0; k <= intervals; ++k) {
    const double weight = k == 0 || k == intervals ? 1 : (k % 2 ? 4 : 2);
    sum += weight * -in.at(from + k * h, phi1).moment[1][2];
  }
  return sum * h / 3 / (in.sign() * in.rb(1));
}

TEST(FeLevel, ElasticEnergyIsTheSolvedSlicesEnergy) {
  gm_model_params p = fe_paper(5);
  p.quasi_static = 0;
  p.stiffness_level = GM_STIFFNESS_ANALYTICAL;  // for the databases' tooth sections
  const FeFiles files = fe_files(p, "energy", Coupling{0.4, 0.2});
  const gm_model_params p5 = at_level5(p, files);
  gm_model_params pq = p5;
  pq.quasi_static = 1;
  Instance plain(p5), quasi(pq);
  int pairs_seen[3] = {0, 0, 0};
  for (double phi1 : {0.0, 0.013, 0.031, 0.05}) {
    const gm_result r = plain.at(8e-6, phi1);
    ASSERT_GT(r.elastic_energy, 0);
    ++pairs_seen[std::min(r.pairs_in_contact, 2)];
    EXPECT_NEAR(r.elastic_energy, recomputed_energy(*plain.d), 1e-12 * r.elastic_energy) << phi1;
    const gm_result rq = quasi.loaded(phi1, 300);
    EXPECT_NEAR(rq.elastic_energy, recomputed_energy(*quasi.d), 1e-12 * rq.elastic_energy) << phi1;
    const gm_result rp = plain.at(rq.te, phi1);
    EXPECT_NEAR(rq.elastic_energy, rp.elastic_energy, 1e-8 * rp.elastic_energy) << phi1;
    const double work = loading_work(plain, phi1, 8e-6);
    EXPECT_NEAR(work, r.elastic_energy, 1e-4 * r.elastic_energy) << phi1;
  }
  EXPECT_GT(pairs_seen[1], 0);
  EXPECT_GT(pairs_seen[2], 0);
}
