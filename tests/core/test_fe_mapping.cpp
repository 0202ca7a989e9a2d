// Level 5 (FE): which database entry a pair of contact slices reads, checked against the
// database's own conventions (compliance_db.hpp, compliance_build.hpp, gear_mesh.hpp) from
// geometry alone, for gear 1, gear 2 of an external pair and the ring of an internal pair, spur
// and helical, flank A and flank B, mirrored and explicit flank-B sets, cyclic and per-tooth
// databases.
//
// THE INDEPENDENT SIDE. For every candidate slice the test locates the contact in each gear's
// body frame from the slice's contact point, its force direction and the gear's pose only (not
// from slice.tooth, not from fe_compliance.cpp):
//   * side: the flank faces counter-clockwise (database flank A, the tooth's +theta side) when
//     the gear's outward surface normal there has a positive e_theta component; the outward
//     normal is the direction of the force on the MATE (slice.normal for gear 1, -normal for
//     gear 2). This holds for an external tooth and for a ring's tooth alike.
//   * tooth: on an involute flank point P at radius r (roll alpha, inv alpha) the tooth's centre
//     line at face coordinate y lies at theta_P - side (C - kappa inv alpha) with C = eta (half
//     base angle of an external tooth; kappa = +1) or tau/2 - eta_space (ring tooth: the space's
//     walls are involutes of the space; kappa = -1); the database twists the centre line by
//     hand y tan(beta_b)/r_b (hand = sign of the database's helix_angle), so the centre line at
//     mid-face is theta_P - hand y tan(beta_b)/r_b - side (C - kappa inv alpha) and the tooth
//     number is its distance from tooth 0 in pitches. Tooth 0 (the anchor of the body frame, a
//     labelling choice) is the core's tooth 0 at layout.theta0 (ring: the tooth half a pitch
//     counter-clockwise of space 0). The fractional part must vanish: that checks side, hand and
//     the sign of the face coordinate on each gear (a reversed face axis or hand leaves the
//     helical slices of one tooth pitches apart by fractions). A ring's database counts spaces
//     (compliance_tool/src/gear_mesh.hpp, "Internal ring": flank A the ccw wall of space k), so
//     the located ring tooth's cw flank is flank A of the space clockwise of it, its ccw flank
//     flank B of the space counter-clockwise of it; which wall a ring database's entry belongs to
//     is checked against CalculiX in tests/python/test_compliance_db_fe.py.
//   * roll = sqrt(r^2 - r_b^2), face y = z - c_z - axial offset.
// The expected coupling entry is then read by the database's stated rules (flank A set: offset
// d = receiver - load counted counter-clockwise; flank B: its own set, or through the mirror:
// flank A's set with -d, tooth set -t and, helical, the face coordinate reversed) from an
// analytic kernel that the synthetic database samples: bilinear in the two roll distances (so
// the core's linear roll interpolation is exact), linear in the face coordinates, with face nodes
// at the slice centres (face shares are 1), different for offsets +d and -d (C_{-d} = C_d^T,
// Maxwell-Betti, C_d itself not symmetric), and face-asymmetric. Every wrong rule (offset sign,
// flank side, face flip, tooth set) changes the expected entries: the test checks that it would.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "gearmesh/internal/compliance_db.hpp"
#include "detection.hpp"
#include "fe_compliance.hpp"
#include "fe_synthetic.hpp"
#include "gearmesh/gearmesh.h"
#include "gearmesh/internal/geometry.hpp"
#include "model.hpp"
#include "test_support.hpp"

namespace {

using namespace gm_test;

// ---- pairs ----

gm_model_params external_pair(double beta_deg) {
  gm_model_params p = paper();
  p.pair.normal_module = 0.002;
  p.pair.helix_angle = beta_deg * kPi / 180;
  p.gear[0].teeth = 23;
  p.gear[1].teeth = 37;
  for (auto& g : p.gear) {
    g.profile_shift = 0;
    g.thickness_allowance = -30e-6;
    g.face_width = 0.016;
  }
  p.pair.center_distance = p.pair.normal_module / std::cos(p.pair.helix_angle) * (23 + 37) / 2;
  p.slices = 5;
  p.coupled_teeth = 2;
  return p;
}

gm_model_params internal_pair(double beta_deg) {
  gm_model_params p = ring();  // 21 in 62, m 2 mm
  p.pair.helix_angle = beta_deg * kPi / 180;
  for (auto& g : p.gear) g.face_width = 0.016;
  p.pair.center_distance = p.pair.normal_module / std::cos(p.pair.helix_angle) * (62 - 21) / 2;
  p.slices = 5;
  p.coupled_teeth = 2;
  return p;
}

// ---- the analytic kernel the synthetic databases sample ----

struct Coef {
  double kappa, au, bu, av, bv;  // share, roll and face slopes of the receiver and load factors
};
// [flank set kind: 0 flank A, 1 explicit flank B][|d|]
constexpr Coef kCoef[2][3] = {
    {{1.0, 0.30, 0.40, -0.20, -0.35}, {0.30, 0.50, -0.30, -0.25, 0.35}, {0.10, -0.20, 0.25, 0.60, -0.45}},
    {{0.8, -0.15, -0.50, 0.45, 0.20}, {0.45, -0.40, 0.55, 0.30, -0.20}, {0.05, 0.35, -0.15, -0.50, 0.60}}};

struct Kernel {
  double c = 1e-11;       // m/N
  double roll_scale = 1;  // m
  double face_scale = 1;  // m
  // F(kind, d; receiver (rho_i, y_i); load (rho_j, y_j)); F_{-d}(i, j) = F_d(j, i).
  double operator()(int kind, int d, double ri, double yi, double rj, double yj) const {
    if (d < 0) return (*this)(kind, -d, rj, yj, ri, yi);
    const Coef& k = kCoef[kind][d];
    auto u = [&](double r, double y) { return 1 + k.au * r / roll_scale + k.bu * y / face_scale; };
    auto v = [&](double r, double y) { return 1 + k.av * r / roll_scale + k.bv * y / face_scale; };
    const double f = d == 0 ? 0.5 * (u(ri, yi) * v(rj, yj) + u(rj, yj) * v(ri, yi))
                            : u(ri, yi) * v(rj, yj);
    return c * k.kappa * f;
  }
};

// Scale of the coupling between (database) teeth t and t' of a per-tooth database: symmetric in
// the two, so that the whole database keeps Maxwell-Betti, and different for every tooth.
double pair_scale(bool cyclic, int t, int t2) { return cyclic ? 1.0 : 1.0 + 0.01 * (t + t2); }

int mod(int a, int z) { return ((a % z) + z) % z; }
int wrap_offset(int d, int z) {
  d = mod(d, z);
  return d > z / 2 ? d - z : d;
}

struct DbKind {
  bool cyclic, mirror;
  const char* name;
};

// Gear g's database of the kernel (zero: all blocks zero), face nodes at the slice centres.
gm::ComplianceDb kernel_db(const gm_model_params& p, int g, const DbKind& kind, const Kernel& F,
                           bool zero) {
  std::string msg;
  gm_pair_geometry geo{};
  EXPECT_EQ(gm::compute_pair_geometry(p, geo, msg), GM_OK) << msg;
  gm::ComplianceDb db;
  gm::record_gear(db, p, geo, g);
  db.bore_radius = 0.2 * geo.gear[g].d_f;
  db.mesh_size = 1e-3;
  db.depth = 0.5e-3;
  db.note = "convention probe (test_fe_mapping.cpp)";
  db.cyclic = kind.cyclic;
  db.mirror = kind.mirror;
  db.n_coupled = 2;
  // roll grid from 0 beyond every radius of the gear: every contact lies inside it
  const double r_max = 0.5 * std::max(geo.gear[g].d_a, geo.gear[g].d_f);
  for (int a = 0; a < 3; ++a) db.roll.push_back(r_max * a / 2);
  const double b = p.gear[g].face_width;
  for (int m = 0; m < p.slices; ++m) db.face.push_back(-0.5 * b + (m + 0.5) * b / p.slices);
  const int z = int(db.teeth), nf = int(db.face.size()), ng = int(db.n_grid());
  for (int t = 0; t < int(db.tooth_sets()); ++t)
    for (int f = 0; f < int(db.flank_sets()); ++f)
      for (int d = -2; d <= 2; ++d) {
        std::vector<double> block(std::size_t(ng) * std::size_t(ng), 0.0);
        if (!zero)
          for (int k = 0; k < ng; ++k)
            for (int j = 0; j < ng; ++j)
              block[std::size_t(k * ng + j)] =
                  pair_scale(kind.cyclic, t, mod(t + d, z)) *
                  F(f, d, db.roll[std::size_t(k / nf)], db.face[std::size_t(k % nf)],
                    db.roll[std::size_t(j / nf)], db.face[std::size_t(j % nf)]);
        db.blocks.push_back(std::move(block));
      }
  return db;
}

// ---- the contact located from geometry ----

struct Located {
  int side = 0;          // +1 the database's flank A (ccw side of the tooth; ring: of the
                         // space), -1 flank B
  int tooth = 0;         // the database's tooth (ring: space) number, 0 .. z-1
  double fraction = 0;   // distance of the located centre line from a whole pitch, pitches
                         // (P taken on the flank)
  double roll = 0, face = 0;
};

Located locate(const gm_model& m, int g, const gm_kinematics& k, const gm::ContactSlice& s) {
  const gm::MeshLayout& L = m.layout;
  const bool ring_gear = g == 1 && L.sign < 0;
  const double cx = (g == 1 ? L.center_distance : 0.0) + k.u[g][0], cy = k.u[g][1];
  const double dx = s.point.x() - cx, dy = s.point.y() - cy;
  const double theta_h = std::atan2(dy, dx), r = std::hypot(dx, dy);
  const double rb = L.base_radius[g];
  const double alpha = std::acos(rb / r), inv = std::tan(alpha) - alpha;
  Located out;
  out.roll = std::sqrt(r * r - rb * rb);
  out.face = s.point.z() - k.u[g][2] - L.axial_offset[g];
  const double sgn = g == 0 ? 1.0 : -1.0;  // outward normal of gear g = force on the mate
  const double et = sgn * (-std::sin(theta_h) * s.normal.x() + std::cos(theta_h) * s.normal.y());
  out.side = et > 0 ? 1 : -1;
  const int z = L.teeth[g];
  const double tau = 2 * kPi / z;
  const double C = ring_gear ? 0.5 * tau - L.eta[1] : L.eta[g];
  const double kappa = ring_gear ? -1.0 : 1.0;
  const double beta = m.compliance[g].helix_angle;
  const double hand = beta > 0 ? 1.0 : (beta < 0 ? -1.0 : 0.0);
  const double centre = theta_h - k.phi[g] - hand * out.face * L.tan_beta_b / rb -
                        out.side * (C - kappa * inv);
  const double anchor = L.theta0[g] + (ring_gear ? 0.5 * tau : 0.0);
  const double x = (centre - anchor) / tau;
  const double n = std::nearbyint(x);
  out.fraction = std::fabs(x - n);
  out.tooth = mod(int(n), z);
  if (ring_gear) {
    // The ring's database counts spaces, flank A the ccw wall of space k (gear_mesh.hpp,
    // "Internal ring"), space k clockwise of the anchor's tooth k: the tooth's clockwise flank is
    // the ccw wall of space n (flank A), its ccw flank the cw wall of space n + 1 (flank B).
    if (out.side > 0) out.tooth = mod(out.tooth + 1, z);
    out.side = -out.side;
  }
  return out;
}

// What a mapping mistake would read instead (for the test's own power check).
enum Wrong { kRight = 0, kOffsetSign, kNoFaceFlip, kSidesSwapped, kToothSetUnmirrored };

// The entry the database's rules give for receiver i, load j (0 when not coupled).
double expected_entry(const gm::ComplianceDb& db, int coupled, const Kernel& F, const Located& i,
                      const Located& j, Wrong wrong = kRight) {
  int side = i.side;
  if (side != j.side) return 0.0;
  if (wrong == kSidesSwapped) side = -side;
  const int z = int(db.teeth);
  int d = wrap_offset(i.tooth - j.tooth, z);
  int t = j.tooth;
  double yi = i.face, yj = j.face;
  int kind = 0;
  if (side < 0) {
    if (db.mirror) {
      d = -d;
      if (wrong != kToothSetUnmirrored) t = mod(-t, z);
      if (db.helix_angle != 0 && wrong != kNoFaceFlip) yi = -yi, yj = -yj;
    } else {
      kind = 1;
    }
  }
  if (wrong == kOffsetSign) d = -d;
  if (std::abs(d) > std::min<int>(coupled, int(db.n_coupled))) return 0.0;
  return pair_scale(db.cyclic, t, mod(t + d, z)) * F(kind, d, i.roll, yi, j.roll, yj);
}

struct Case {
  const char* name;
  gm_model_params p;
};

// ---- the test ----

TEST(FeMapping, EachSliceReadsTheDatabaseEntryItsGeometryNames) {
  const Case cases[] = {{"external spur", external_pair(0)},
                        {"external helical", external_pair(15)},
                        {"internal spur", internal_pair(0)},
                        {"internal helical", internal_pair(12)}};
  const DbKind kinds[] = {{true, true, "cyclic, mirrored"},
                          {true, false, "cyclic, explicit flank B"},
                          {false, false, "per tooth, explicit flank B"},
                          {false, true, "per tooth, mirrored"}};
  for (const Case& cs : cases) {
    for (int g = 0; g < 2; ++g) {
      for (const DbKind& kind : kinds) {
        const std::string what = std::string(cs.name) + ", gear " + std::to_string(g + 1) + ", " +
                                 kind.name;
        gm_model_params p = cs.p;
        p.stiffness_level = GM_STIFFNESS_FE;
        gm_pair_geometry geo{};
        std::string msg;
        ASSERT_EQ(gm::compute_pair_geometry(p, geo, msg), GM_OK) << msg;
        Kernel F;
        F.roll_scale = 0.5 * geo.gear[g].d_a;
        F.face_scale = p.gear[g].face_width;
        std::string path[2];
        for (int h = 0; h < 2; ++h) {
          const std::string tag = "map_" + std::to_string(&cs - cases) + "_" + std::to_string(g) +
                                  "_" + std::to_string(&kind - kinds) + "_db" + std::to_string(h);
          path[h] = write_db(tag + ".gcdb", kernel_db(p, h, kind, F, h != g));
          p.compliance[h] = path[h].c_str();
        }
        Instance I(p);
        const gm_model& m = *I.m;
        const gm::ComplianceDb& db = m.compliance[g];
        const int cap = m.slice_capacity;
        std::vector<gm::ContactSlice> slices(std::size_t(cap), gm::ContactSlice{});
        std::vector<int> index(std::size_t(cap), 0);
        Eigen::MatrixXd Cc(cap, cap), Cr(cap, cap);
        gm::FeAssembly assembly;
        int couplings[2][5] = {};   // [side A, B][d + 2]: nonzero expected entries between teeth
        int face_pairs = 0;         // same tooth, different face position, nonzero
        double worst = 0, worst_fraction = 0, scale = 0;
        double power[5] = {};       // largest |wrong - right| per mistake
        const int poses = 4;
        for (int s = 0; s < poses; ++s) {
          gm_kinematics k{};
          k.phi[0] = (s + 0.3) / poses * 2 * kPi / p.gear[0].teeth;
          k.phi[1] = phi2_for(m.layout, -2e-6, k.phi[0]);  // flank A just open: no tip contacts
          const int n = gm::detect_contacts(m.layout, k, slices.data(), cap, msg);
          ASSERT_GT(n, 0) << what << ": " << msg;
          for (int a = 0; a < n; ++a) index[std::size_t(a)] = a;
          const double uz[2] = {0, 0};
          assembly.assemble(gm::fe_view(m), slices.data(), index.data(), n, uz, Cc);
          gm::fe_assemble_reference(gm::fe_view(m), slices.data(), index.data(), n, uz, Cr);
          std::vector<Located> at;
          for (int a = 0; a < n; ++a) {
            const gm::ContactSlice& sa = slices[std::size_t(a)];
            ASSERT_EQ(sa.kind, gm::kFlankContact) << what;
            at.push_back(locate(m, g, k, sa));
            // the point lies midway between the two flanks on the line of action: each flank's
            // centre line is off by half the transverse approach over r_b (involutes of one base
            // circle are parallel curves), |Delta_t| / (2 p_bt) pitches
            const double off = std::fabs(sa.approach) / m.layout.cos_beta_b / (2 * m.layout.base_pitch);
            worst_fraction = std::max(worst_fraction, std::fabs(at.back().fraction - off));
            // the conventions themselves: pair flank A is the database's flank A on every gear
            // (the ccw side of a tooth; on a ring the ccw wall of a space, its tooth's cw side)
            ASSERT_EQ(at.back().side, sa.flank) << what << ", slice " << a << " flank " << sa.flank;
            // docs/physics.md §0: flank A resists gear 1 turning +phi: its force on gear 1 turns it back
            const double torque1 = -(sa.point.x() * sa.normal.y() - sa.point.y() * sa.normal.x());
            ASSERT_LT(sa.flank * torque1, 0) << what << ", slice " << a;
          }
          for (int a = 0; a < n; ++a)
            for (int b = 0; b < n; ++b) {
              const double e = expected_entry(db, p.coupled_teeth, F, at[a], at[b]);
              scale = std::max(scale, std::fabs(e));
              worst = std::max({worst, std::fabs(Cc(a, b) - e), std::fabs(Cr(a, b) - e)});
              if (e != 0 && at[a].tooth != at[b].tooth)
                ++couplings[at[a].side > 0 ? 0 : 1][wrap_offset(at[a].tooth - at[b].tooth, int(db.teeth)) + 2];
              if (e != 0 && at[a].tooth == at[b].tooth && at[a].face != at[b].face) ++face_pairs;
              for (int w = 1; w < 5; ++w)
                power[w] = std::max(power[w],
                                    std::fabs(expected_entry(db, p.coupled_teeth, F, at[a], at[b],
                                                             Wrong(w)) - e));
            }
        }
        ASSERT_GT(scale, 0) << what;
        std::printf("%-28s %-20s located to %.1e pitch; assembled - expected up to %.1e of "
                    "the largest; entries between teeth d=-2..2 A %d %d . %d %d, B %d %d . %d %d; "
                    "a wrong offset sign / face flip / flank side / tooth set moves them by "
                    "%.2f / %.2f / %.2f / %.2f\n",
                    (std::string(cs.name) + ", gear " + std::to_string(g + 1)).c_str(), kind.name,
                    worst_fraction, worst / scale, couplings[0][0], couplings[0][1],
                    couplings[0][3], couplings[0][4], couplings[1][0], couplings[1][1],
                    couplings[1][3], couplings[1][4], power[kOffsetSign] / scale,
                    power[kNoFaceFlip] / scale, power[kSidesSwapped] / scale,
                    power[kToothSetUnmirrored] / scale);
        // the geometry names whole teeth (side, hand and face sign consistent on this gear), off
        // by exactly the half approach
        EXPECT_LT(worst_fraction, 1e-9) << what;
        // the core reads exactly the entry the database's rules give
        EXPECT_LT(worst, 1e-12 * scale) << what;
        // and the cases exercised what could go wrong: couplings to the teeth on both sides
        // (ccw and cw) on both flanks, and across the face within one tooth
        for (int side = 0; side < 2; ++side)
          for (int d : {-1, 1}) EXPECT_GT(couplings[side][d + 2], 0) << what << " side " << side << " d " << d;
        EXPECT_GT(face_pairs, 0) << what;
        EXPECT_GT(power[kOffsetSign], 0.01 * scale) << what;
        EXPECT_GT(power[kSidesSwapped], 0.01 * scale) << what;
        if (db.mirror && db.helix_angle != 0) EXPECT_GT(power[kNoFaceFlip], 0.01 * scale) << what;
        if (db.mirror && !db.cyclic) EXPECT_GT(power[kToothSetUnmirrored], 0.001 * scale) << what;
      }
    }
  }
}

// End to end: a helical gear's mirrored database (cyclic = 1, mirror = 1) and the same body's
// database with flank B written out (mirror = 0, flank B's set = flank A's through the half turn:
// B_d[(a, m)][(b, n)] = A_{-d}[(a, m~)][(b, n~)], m~ the face node at -z_m) give the same loaded
// TE and tilting moment when flank B carries the load (torque < 0), and flank A is untouched; a
// flank-B set without the face reversal (what reading the mirror without flipping the face
// amounts to) does not.
// The blocks are fe_synthetic.hpp's smooth kernel made face-asymmetric (w_m w_n, w = 1 + 0.5 z/b)
// and offset-asymmetric (C_{+d} = D1 K_d D2, C_{-d} its transpose, D roll-dependent).
TEST(FeMapping, MirroredHelicalDatabaseEqualsItsExplicitFlankBUnderReverseLoad) {
  gm_model_params base = external_pair(15);
  base.quasi_static = 1;
  for (auto& g : base.gear)
    for (auto& f : g.flank) {  // keep the tip edges off the mate
      f.tip_relief = 30e-6;
      f.tip_relief_length = 0.05e-3;
    }
  enum { kMirrored = 0, kExplicit = 1, kUnflipped = 2 };
  std::string paths[3][2];
  for (int g = 0; g < 2; ++g) {
    std::string msg;
    SmoothDbShape shape;
    shape.n_roll = 9;
    shape.n_face = 9;
    gm::ComplianceDb a = smooth_db(base, g, shape, msg);
    ASSERT_TRUE(msg.empty()) << msg;
    const int nr = int(a.roll.size()), nf = int(a.face.size()), ng = int(a.n_grid());
    const int nc = int(a.n_coupled);
    const double b = base.gear[g].face_width;
    for (int d = -nc; d <= nc; ++d) {
      std::vector<double>& C = a.blocks[std::size_t(d + nc)];
      for (int k = 0; k < ng; ++k)
        for (int j = 0; j < ng; ++j) {
          const double uk = double(k / nf) / (nr - 1), uj = double(j / nf) / (nr - 1);
          const double wk = 1 + 0.5 * a.face[std::size_t(k % nf)] / b;
          const double wj = 1 + 0.5 * a.face[std::size_t(j % nf)] / b;
          const double d1 = d > 0 ? (1 + 0.3 * uk) * (1 - 0.3 * uj)
                                  : (d < 0 ? (1 - 0.3 * uk) * (1 + 0.3 * uj) : 1.0);
          C[std::size_t(k * ng + j)] *= wk * wj * d1;
        }
    }
    ASSERT_TRUE(a.mirror && a.cyclic);
    // flank B written out, with and without the face reversal
    gm::ComplianceDb e = a, u = a;
    e.mirror = u.mirror = 0;
    e.blocks.clear();
    u.blocks.clear();
    for (int d = -nc; d <= nc; ++d) e.blocks.push_back(a.blocks[std::size_t(d + nc)]);
    for (int d = -nc; d <= nc; ++d) u.blocks.push_back(a.blocks[std::size_t(d + nc)]);
    for (int d = -nc; d <= nc; ++d) {
      const std::vector<double>& A = a.blocks[std::size_t(-d + nc)];
      std::vector<double> B(A.size()), U(A);
      for (int k = 0; k < ng; ++k)
        for (int j = 0; j < ng; ++j) {
          const int kf = (k / nf) * nf + (nf - 1 - k % nf), jf = (j / nf) * nf + (nf - 1 - j % nf);
          B[std::size_t(k * ng + j)] = A[std::size_t(kf * ng + jf)];
        }
      e.blocks.push_back(B);
      u.blocks.push_back(U);
    }
    const std::string tag = "mirror_e2e_g" + std::to_string(g + 1);
    paths[kMirrored][g] = write_db(tag + "_m.gcdb", a);
    paths[kExplicit][g] = write_db(tag + "_e.gcdb", e);
    paths[kUnflipped][g] = write_db(tag + "_u.gcdb", u);
  }
  auto with = [&](int v) {
    gm_model_params p = base;
    p.stiffness_level = GM_STIFFNESS_FE;
    p.compliance[0] = paths[v][0].c_str();
    p.compliance[1] = paths[v][1].c_str();
    return p;
  };
  Instance M(with(kMirrored)), E(with(kExplicit)), U(with(kUnflipped));
  // compare the loaded TE and the tilting moment on gear 1 (the load's centre along the face,
  // which a face-asymmetric compliance moves), relative to its scale F b
  auto differ = [&](const gm_result& x, const gm_result& y) {
    const double fb = y.normal_force * base.gear[0].face_width;
    return std::max({std::fabs(x.te - y.te) / std::fabs(y.te),
                     std::fabs(x.moment[0][0] - y.moment[0][0]) / fb,
                     std::fabs(x.moment[0][1] - y.moment[0][1]) / fb});
  };
  const int n = 8;
  double same_b = 0, same_a = 0, unflipped_b = 0, unflipped_a = 0, te_max = 0;
  for (int s = 0; s < n; ++s) {
    const double phi1 = M.geo().p_bt / M.rb(0) * (s + 0.5) / n;
    for (double torque : {-100.0, 100.0}) {
      const gm_result rm = M.loaded(phi1, torque), re = E.loaded(phi1, torque),
                      ru = U.loaded(phi1, torque);
      ASSERT_EQ(rm.flank, torque < 0 ? 2 : 1) << s;  // 1 flank A, 2 flank B
      ASSERT_LT(rm.solver_residual, base.solver_tolerance) << s;
      te_max = std::max(te_max, std::fabs(rm.te));
      double& same = torque < 0 ? same_b : same_a;
      double& unflipped = torque < 0 ? unflipped_b : unflipped_a;
      same = std::max(same, differ(re, rm));
      unflipped = std::max(unflipped, differ(ru, rm));
    }
  }
  std::printf("loaded TE up to %.3g um; explicit flank B vs mirrored: flank B %.2e, flank A %.2e; "
              "flank B set without the face reversal: flank B %.3g %%, flank A %.2e (largest "
              "relative TE or moment / (F b) difference)\n",
              te_max * 1e6, same_b, same_a, 100 * unflipped_b, unflipped_a);
  EXPECT_LT(same_b, 1e-9);  // equal but for the face grid's round-off symmetry
  EXPECT_LT(same_a, 1e-9);
  EXPECT_LT(unflipped_a, 1e-9);  // flank A never reads the flank-B set
  EXPECT_GT(unflipped_b, 1e-2);
}

}  // namespace
