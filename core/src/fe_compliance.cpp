#include "fe_compliance.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>

#include "gearmesh/internal/compliance_db.hpp"
#include "face_basis.hpp"

// The stages of FeAssembly::assemble are inlined into it (hot path of level 5: out of line,
// the members they share would be reloaded through `this` after every call).
#if defined(__GNUC__)
#define GM_FE_STAGE inline __attribute__((always_inline))
#else
#define GM_FE_STAGE inline
#endif

namespace gm {
namespace {

// How many roll nodes a slice reads on database db: 3 (its element's corner, mid and corner node,
// quadratic shape functions) when the database is a quadratic mesh's flank nodes (mesh_order 2,
// an odd count: corners at even indices, compliance_tool's lattice), else 2 (linear), 1 for a
// single node.
int roll_reads(const ComplianceDb& db) {
  const int nr = int(db.roll.size());
  if (nr == 1) return 1;
  return db.mesh_order == 2 && nr >= 3 && nr % 2 == 1 ? 3 : 2;
}

// Where a slice sits along a gear's flank grid: the first of its `roll_reads` roll nodes and
// their weights (they sum to 1).
template <class T>
struct RollSpot {
  int node = 0;
  T w[3] = {T(1.0), T(0.0), T(0.0)};
};

// The roll nodes and weights of roll distance `roll` (clamped at the grid ends: weight 1 on the
// end node). Quadratic: the Lagrange polynomials of the element's three nodes in the roll
// distance, i.e. the element's shape functions, by which the FE's response to a load between
// nodes is exactly the nodal responses' combination (a unit point load at a flank point is the
// load vector of the shape functions there) and the displacement between nodes is read as the
// element interpolates it. The linear weights misread both: the database's diagonal zigzags
// between corner and mid nodes (docs/physics.md §5).
template <class T>
RollSpot<T> roll_spot(const ComplianceDb& db, const T& roll) {
  const std::vector<double>& R = db.roll;
  const int nr = int(R.size()), reads = roll_reads(db);
  RollSpot<T> p;
  if (reads == 1 || roll <= R[0]) return p;  // node 0, weight 1
  if (roll >= R[nr - 1]) {
    p.node = nr - reads;
    for (int k = 0; k < reads; ++k) p.w[k] = T(k == reads - 1 ? 1.0 : 0.0);
    return p;
  }
  const int a = int(std::upper_bound(R.begin(), R.end(), val(roll)) - R.begin()) - 1;
  if (reads == 2) {
    p.node = a;
    p.w[0] = (R[a + 1] - roll) / (R[a + 1] - R[a]);
    p.w[1] = 1 - p.w[0];
    return p;
  }
  const int e = std::min(a / 2, (nr - 1) / 2 - 1);  // the element
  p.node = 2 * e;
  const double x0 = R[std::size_t(2 * e)], x1 = R[std::size_t(2 * e + 1)], x2 = R[std::size_t(2 * e + 2)];
  const T d0 = roll - x0, d1 = roll - x1, d2 = roll - x2;
  p.w[0] = d1 * d2 / ((x0 - x1) * (x0 - x2));
  p.w[1] = d0 * d2 / ((x1 - x0) * (x1 - x2));
  p.w[2] = d0 * d1 / ((x2 - x0) * (x2 - x1));
  return p;
}

// Where a slice sits on a gear's flank grid: its roll nodes and weights, its face interval and
// the face nodes whose strips it touches.
template <class T>
struct FeSpot {
  RollSpot<T> roll;
  T lo = 0, hi = 0;  // face interval of the slice, m
  int face_lo = 0, face_hi = 0;
};

// Face nodes whose tributary strips the interval [lo, hi] touches.
void face_range(const std::vector<double>& Z, double lo, double hi, int& face_lo, int& face_hi) {
  const int nf = int(Z.size());
  face_lo = 0;
  while (face_lo + 1 < nf && 0.5 * (Z[face_lo] + Z[face_lo + 1]) <= lo) ++face_lo;
  face_hi = face_lo;
  while (face_hi + 1 < nf && 0.5 * (Z[face_hi] + Z[face_hi + 1]) < hi) ++face_hi;
}

// q_m: the share of [lo, hi] inside node m's strip.
template <class T>
T face_share(const std::vector<double>& Z, const T& lo, const T& hi, int m) {
  using std::max;
  using std::min;
  const int nf = int(Z.size());
  const double inf = std::numeric_limits<double>::infinity();
  const double s_lo = m == 0 ? -inf : 0.5 * (Z[m - 1] + Z[m]);
  const double s_hi = m == nf - 1 ? inf : 0.5 * (Z[m] + Z[m + 1]);
  const T top = hi < s_hi ? hi : T(s_hi);
  const T bottom = lo > s_lo ? lo : T(s_lo);
  const T overlap = top - bottom;
  return overlap > 0 ? overlap / (hi - lo) : T(0.0);
}

// ---- How a slice reads a gear's database (the conventions, derived) ----
//
// FRAMES. The core poses gear g by R_g = exp([r_x, r_y, 0]^) R_z(phi_g) (docs/physics.md §0): the body
// frame of BOTH gears has its z along the housing's z (gear 2's axis is not reversed; an
// external gear 2 merely turns the other way, phi_2 < 0 when driven), angles counter-clockwise
// seen from +z. The database's body frame (compliance_build.hpp, gear_mesh.hpp: z along the
// axis, z = 0 mid-face, tooth k at 2 pi k/|z| + hand z tan(beta_b)/r_b, angles ccw) is taken to
// be this very frame, turned about z so that the database's tooth k is the core's tooth k (ring:
// see below). Then:
// (1) Tooth index. detect_impl writes sigma (theta_c,0 - gamma - zeta) = n tau + f and puts
//     tooth m of the enumeration at rho = r_b (f + eta + alpha_w) + m p_bt =
//     r_b (sigma (theta_c - gamma - zeta) + eta + alpha_w) with theta_c = theta_c,0 +
//     sigma (m - n) tau and index sigma (m - n): tooth (ring: space) k's centre line lies at
//     theta0 + phi + k tau + h y tan(beta_b)/r_b on either flank, i.e. the index increases
//     counter-clockwise in the gear's body frame on gear 1, on gear 2 and on the ring, as the
//     database's tooth number (and its offset d = receiver - load) does. No sign change.
// (2) Face. The core turns gear g's section by h_g y tan(beta_b)/r_b with y = z - c_z along +z
//     and h_2 = -h_1 on an external pair, h_1 on an internal one; the database of gear g turns
//     it by hand z tan(beta_b)/r_b with hand = sign of ITS helix_angle, which record_gear writes
//     as -beta for an external gear 2 and +beta for a ring: the same law in the same frame, so
//     the database's face coordinate is the core's z - c_z - axial_offset with its sign, on both
//     gears. (Axis reversal would also reverse the tooth order of (1); it does not happen.)
// (3) Flank side. The pair's flank A carries load when gear 1 turns +phi_1 and drives. Gear 1's
//     tooth then moves counter-clockwise and pushes with its leading side: its ccw side, the
//     database's flank A (wherever the mesh lies). External gear 2: at its mesh side (zeta = pi,
//     e_theta = -e_y) gear 1's tooth moves +y and presses gear 2's tooth on its -y side, the
//     +theta side: again the ccw side, the database's flank A. (Detection agrees: flank sigma of
//     a tooth sits at theta_c + sigma (eta - inv alpha), see involute_penetration.) Ring (gear 2
//     of an internal pair): the core's index counts SPACES, and flank sigma of space s sits at
//     theta_s + sigma (eta_s - inv alpha), sigma = +1 its ccw wall. The database of a ring counts
//     spaces too, with flank A the ccw (+theta) wall of space k (compliance_tool/src/gear_mesh.hpp,
//     "Internal ring"): the same numbering and the same sides as the core's, no translation.
//     (A CalculiX model of the ring loaded on one wall, tests/python/test_compliance_db_fe.py,
//     tells which neighbour is which: reading the ring's contact wall as the mirror of the other
//     swaps the couplings of the teeth before and after the loaded one.)
// (4) Flank B through the mirror (mirror = 1). The tool obtains flank B from the body's mirror
//     symmetry: spur, the reflection y -> -y through tooth 0's centre plane; helical, the half
//     turn about tooth 0's radial centre line at mid-face (a reflection would turn the hand).
//     Both send tooth t to tooth -t and reverse the angular order, so flank B of load tooth t,
//     receiver t + d, is flank A of load tooth -t, receiver -t - d: offset -d, tooth set -t; the
//     half turn also sends the face coordinate z to -z (roll distances are radii: unchanged).
//     So a database-flank-B slice reads flank A's set with d -> -d, tooth set -t (cyclic: 0)
//     and, for a helical gear, face -> -face (receiver and load alike). With mirror = 0 flank B
//     has its own set, offsets in the same ccw sense, face as it is.
// Flanks of different sides never couple (the database has no cross-flank blocks).
struct DbFlank {
  int side = 1;        // +1 the database's flank A (ccw side of the tooth; ring: of the space), -1 B
  bool mirrored = false;   // read through the mirror: flank A's set, d -> -d, tooth set -t
  bool flip_face = false;  // and the face coordinate reversed (helical)
};

DbFlank db_flank(const FeView& m, int g, int flank) {
  const ComplianceDb& db = m.compliance[g];
  DbFlank r;
  r.side = flank;
  r.mirrored = r.side < 0 && db.mirror;
  r.flip_face = r.mirrored && db.helix_angle != 0;
  return r;
}

// Whether some slice on gear g reads its face reversed (the strip table then holds both).
bool may_flip_face(const FeView& m, int g) {
  return m.compliance[g].mirror && m.compliance[g].helix_angle != 0;
}

// Tooth index modulo z, and the offset d = t_i - t_j wrapped to -z/2..z/2.
int tooth_mod(int t, int z) { return ((t % z) + z) % z; }
int tooth_offset(int ti, int tj, int z) {
  int d = ti - tj;
  if (d < 0) d += z;
  if (d > z / 2) d -= z;
  return d;
}

// The database's tooth (ring: space) of the slice's tooth (ring: space) index, modulo z.
int db_tooth(const FeView& m, int g, int tooth) { return tooth_mod(tooth, int(m.compliance[g].teeth)); }

// Face position of a slice on gear g as the database reads it: from its mid-face along its
// axis, m, reversed when read through a helical mirror.
template <class T>
T face_position(const FeView& m, int g, const ContactSliceT<T>& s, const T& uz) {
  const T y = s.point.z() - uz - m.layout.axial_offset[g];
  return db_flank(m, g, s.flank).flip_face ? T(-y) : y;
}

template <class T>
FeSpot<T> fe_spot(const ComplianceDb& db, const T& roll, const T& face, const T& width) {
  FeSpot<T> p;
  p.roll = roll_spot(db, roll);
  p.lo = face - 0.5 * width;
  p.hi = face + 0.5 * width;
  face_range(db.face, val(p.lo), val(p.hi), p.face_lo, p.face_hi);
  return p;
}

// The database block between receiver tooth ti and load tooth tj (database teeth, modulo z, of
// db_tooth) on the slices' flanks, or -1 when they are not coupled.
int block_of(const FeView& m, int g, int flank_i, int ti, int flank_j, int tj) {
  const ComplianceDb& db = m.compliance[g];
  if (flank_i != flank_j) return -1;
  const int z = int(db.teeth);
  const DbFlank r = db_flank(m, g, flank_j);
  int d = tooth_offset(ti, tj, z);
  int t = tj;
  if (r.mirrored) {
    d = -d;
    t = tooth_mod(-tj, z);
  }
  if (std::abs(d) > std::min<int>(m.coupled_teeth, int(db.n_coupled))) return -1;
  const std::size_t set = db.cyclic ? 0 : std::size_t(t);
  const std::size_t f = (db.mirror || r.side > 0) ? 0 : 1;
  return int(db.block_index(set, f, d));
}

template <class T>
T fe_entry(const FeView& m, int g, const ContactSliceT<T>& si, const FeSpot<T>& pi,
           const ContactSliceT<T>& sj, const FeSpot<T>& pj) {
  const ComplianceDb& db = m.compliance[g];
  const int k = block_of(m, g, si.flank, db_tooth(m, g, si.tooth[g]), sj.flank,
                         db_tooth(m, g, sj.tooth[g]));
  if (k < 0) return T(0.0);
  const std::vector<double>& C = db.blocks[std::size_t(k)];
  const std::size_t nf = db.face.size(), ng = db.n_grid();
  const int reads = roll_reads(db);
  T sum = 0;
  for (int ai = 0; ai < reads; ++ai) {
    const T ra = pi.roll.w[ai];
    if (vanishes(ra)) continue;
    for (int mi = pi.face_lo; mi <= pi.face_hi; ++mi) {
      const T qa = ra * face_share(db.face, pi.lo, pi.hi, mi);
      if (vanishes(qa)) continue;
      const std::size_t row = (std::size_t(pi.roll.node + ai) * nf + mi) * ng;
      for (int bj = 0; bj < reads; ++bj) {
        const T rb = pj.roll.w[bj];
        if (vanishes(rb)) continue;
        for (int nj = pj.face_lo; nj <= pj.face_hi; ++nj) {
          const T qb = rb * face_share(db.face, pj.lo, pj.hi, nj);
          if (!vanishes(qb)) sum += qa * qb * C[row + std::size_t(pj.roll.node + bj) * nf + nj];
        }
      }
    }
  }
  return sum;
}

}  // namespace

template <class T>
T fe_pair_compliance(const FeView& m, const ContactSliceT<T>& si, const ContactSliceT<T>& sj,
                     const T uz[2]) {
  T c = 0;
  for (int g = 0; g < 2; ++g) {
    const ComplianceDb& db = m.compliance[g];
    const FeSpot<T> pi = fe_spot(db, si.roll[g], face_position(m, g, si, uz[g]), si.width);
    const FeSpot<T> pj = fe_spot(db, sj.roll[g], face_position(m, g, sj, uz[g]), sj.width);
    c += fe_entry(m, g, si, pi, sj, pj);
  }
  return c;
}

template double fe_pair_compliance(const FeView&, const ContactSlice&, const ContactSlice&,
                                   const double[2]);
template Dual fe_pair_compliance(const FeView&, const ContactSliceT<Dual>&,
                                 const ContactSliceT<Dual>&, const Dual[2]);

void fe_assemble_reference(const FeView& m, const ContactSlice* slices, const int* index, int n,
                           const double uz[2], Eigen::MatrixXd& C) {
  for (int a = 0; a < n; ++a)
    for (int b = 0; b <= a; ++b)
      C(a, b) = C(b, a) = fe_pair_compliance(m, slices[index[a]], slices[index[b]], uz);
}

// ---- FeDualAssembly ----

void FeDualAssembly::reserve(const FeView& m, int capacity) {
  const std::size_t c = std::size_t(std::max(capacity, 0));
  std::size_t per = 0;  // weights of one candidate over both gears: its roll nodes x face nodes
  for (int g = 0; g < 2; ++g)
    per += std::size_t(roll_reads(m.compliance[g])) * std::max<std::size_t>(1, m.compliance[g].face.size());
  weights_.reserve(c * per);
  for (auto& s : spots_) s.reserve(c);
}

void FeDualAssembly::assemble(const FeView& m, const ContactSliceT<Dual>* slices, const int* index, int n,
                              const Dual uz[2], Eigen::MatrixXd& C, Eigen::MatrixXd& dC) {
  weights_.clear();
  // each candidate's weights on each gear, in fe_entry's order (roll node, then face node),
  // leaving out the zero ones as fe_entry skips them
  for (int g = 0; g < 2; ++g) {
    const ComplianceDb& db = m.compliance[g];
    const std::size_t nf = db.face.size();
    const int reads = roll_reads(db);
    spots_[g].resize(std::size_t(n));
    for (int a = 0; a < n; ++a) {
      const ContactSliceT<Dual>& s = slices[index[a]];
      const FeSpot<Dual> p = fe_spot(db, s.roll[g], face_position(m, g, s, uz[g]), s.width);
      Spot& spot = spots_[g][std::size_t(a)];
      spot.first = int(weights_.size());
      spot.flank = s.flank;
      spot.tooth = db_tooth(m, g, s.tooth[g]);
      for (int ai = 0; ai < reads; ++ai) {
        const Dual ra = p.roll.w[ai];
        if (vanishes(ra)) continue;
        for (int mi = p.face_lo; mi <= p.face_hi; ++mi) {
          const Dual q = ra * face_share(db.face, p.lo, p.hi, mi);
          if (vanishes(q)) continue;
          weights_.push_back(Weight{int(std::size_t(p.roll.node + ai) * nf + std::size_t(mi)), q});
        }
      }
      spot.count = int(weights_.size()) - spot.first;
    }
  }
  for (int a = 0; a < n; ++a) {
    for (int b = 0; b <= a; ++b) {
      Dual c = 0;
      for (int g = 0; g < 2; ++g) {
        const Spot &pa = spots_[g][std::size_t(a)], &pb = spots_[g][std::size_t(b)];
        const int k = block_of(m, g, pa.flank, pa.tooth, pb.flank, pb.tooth);
        Dual sum = 0;
        if (k >= 0) {
          const std::vector<double>& block = m.compliance[g].blocks[std::size_t(k)];
          const std::size_t ng = m.compliance[g].n_grid();
          for (int i = pa.first; i < pa.first + pa.count; ++i) {
            const Dual qa = weights_[std::size_t(i)].w;
            const std::size_t row = std::size_t(weights_[std::size_t(i)].node) * ng;
            for (int j = pb.first; j < pb.first + pb.count; ++j)
              sum += qa * weights_[std::size_t(j)].w * block[row + std::size_t(weights_[std::size_t(j)].node)];
          }
        }
        c += sum;
      }
      C(a, b) = C(b, a) = c.v;
      dC(a, b) = dC(b, a) = c.d;
    }
  }
}

// ---- FeAssembly ----

void FeAssembly::reserve(const FeView& m, int capacity) {
  const std::size_t c = std::size_t(std::max(capacity, 0));
  // groups: the candidates of one tooth pair and flank, at most model.slices of them
  const std::size_t groups = std::max<std::size_t>(1, c / std::size_t(std::max(m.layout.slices, 1)));
  group_first_.reserve(c + 1);
  uniform_.reserve(2 * c);
  consecutive_.reserve(2 * c);
  for (int g = 0; g < 2; ++g) {
    Gear& G = gear_[g];
    const ComplianceDb& db = m.compliance[g];
    const std::size_t strips = std::size_t(m.layout.slices) * (may_flip_face(m, g) ? 2 : 1);
    const std::size_t nr = db.roll.size();
    span_at_.reserve(std::max(span_at_.capacity(), nr * nr));
    G.spots.resize(std::max(G.spots.size(), c));
    G.strips.reserve(strips);
    G.shares.reserve(strips * db.face.size());
    const std::size_t per_call = groups * (2 * std::size_t(db.n_coupled) + 1) * db.flank_sets();
    const std::size_t slots = db.cyclic ? db.block_count() : std::min(db.block_count(), 2 * per_call);
    if (G.blocks.size() < slots) G.blocks.resize(slots);
    const std::size_t K = m.face_shapes ? std::size_t(m.shapes) : 0;
    for (Block& B : G.blocks) {
      B.chunk.reserve(nr * nr);
      B.pool.reserve(nr * nr * strips * strips);
      if (K > 0) {
        B.proj.reserve(nr * nr);
        B.proj_pool.reserve(nr * nr * (3 * strips * K + 2 * K * K));
      }
    }
  }
}

void FeAssembly::invalidate() {
  for (Gear& G : gear_) {
    G.strips.clear();
    G.shares.clear();
    for (Block& B : G.blocks) B.index = -1;
    clear_chunks(G);
    G.direct = true;
  }
}

void FeAssembly::clear_chunks(Gear& G) {
  for (Block& B : G.blocks) {
    std::fill(B.chunk.begin(), B.chunk.end(), -1);
    B.pool.clear();
    std::fill(B.proj.begin(), B.proj.end(), -1);
    B.proj_pool.clear();
  }
}

std::size_t FeAssembly::cached_values() const {
  std::size_t n = 0;
  for (const Gear& G : gear_)
    for (const Block& B : G.blocks) n += B.pool.size();
  return n;
}

// The strip of face interval [lo, hi] on gear g, added if new (then every chunk of the gear is
// dropped and this call computes directly); -1 if the table is full (a face interval changed).
int FeAssembly::strip_of(const FeView& m, int g, double lo, double hi) {
  Gear& G = gear_[g];
  for (std::size_t s = 0; s < G.strips.size(); ++s)
    if (G.strips[s].lo == lo && G.strips[s].hi == hi) return int(s);
  if (int(G.strips.size()) >= m.layout.slices * (may_flip_face(m, g) ? 2 : 1)) return -1;
  const std::vector<double>& Z = m.compliance[g].face;
  Strip S;
  S.lo = lo;
  S.hi = hi;
  face_range(Z, lo, hi, S.face_lo, S.face_hi);
  S.share_at = int(G.shares.size());
  for (int k = S.face_lo; k <= S.face_hi; ++k) G.shares.push_back(face_share(Z, lo, hi, k));
  G.strips.push_back(S);
  clear_chunks(G);
  G.direct = true;
  return int(G.strips.size()) - 1;
}

// sum_m q_sm (sum_n q_s'n C_d[(a, m)][(b, n)]): the one function both paths use.
double FeAssembly::strip_value(const FeView& m, int g, int block, int a, int b, int si,
                               int sj) const {
  const ComplianceDb& db = m.compliance[g];
  const Gear& G = gear_[g];
  const Strip& Si = G.strips[std::size_t(si)];
  const Strip& Sj = G.strips[std::size_t(sj)];
  const std::size_t nf = db.face.size(), ng = db.n_grid();
  const double* C = db.blocks[std::size_t(block)].data();
  const double* qi = G.shares.data() + Si.share_at - Si.face_lo;
  const double* qj = G.shares.data() + Sj.share_at - Sj.face_lo;
  double sum = 0;
  for (int mi = Si.face_lo; mi <= Si.face_hi; ++mi) {
    if (qi[mi] == 0) continue;
    const double* row = C + (std::size_t(a) * nf + std::size_t(mi)) * ng + std::size_t(b) * nf;
    double inner = 0;
    for (int nj = Sj.face_lo; nj <= Sj.face_hi; ++nj)
      if (qj[nj] != 0) inner += qj[nj] * row[nj];
    sum += qi[mi] * inner;
  }
  return sum;
}

int FeAssembly::chunk_at(const FeView& m, int g, Block& B, int a, int b) {
  const int nr = int(m.compliance[g].roll.size());
  int& at = B.chunk[std::size_t(a) * std::size_t(nr) + std::size_t(b)];
  if (at < 0) {
    const int S = int(gear_[g].strips.size());
    at = int(B.pool.size());
    B.pool.resize(B.pool.size() + std::size_t(S) * std::size_t(S));
    for (int si = 0; si < S; ++si)
      for (int sj = 0; sj < S; ++sj)
        B.pool[std::size_t(at + si * S + sj)] = strip_value(m, g, B.index, a, b, si, sj);
  }
  return at;
}

// Chunk (a, b)'s projections, each column-major (the shapes over the strips: strip s is slice s,
// which project checks): V Phi, V^T Phi, Phi^T V Phi for two tooth pairs, and for a pair's own
// block W Phi, Phi^T W Phi with W the lower triangle of V mirrored, W[s][t] = V[max(s, t)][min(s, t)]:
// what assemble makes of it (it computes the entries of a receiver after the load and mirrors them;
// a real database's own-tooth block is not quite symmetric, its displacements read at a depth
// below the loaded surface).
int FeAssembly::projection_at(const FeView& m, int g, Block& B, int a, int b) {
  const int nr = int(m.compliance[g].roll.size());
  int& at = B.proj[std::size_t(a) * std::size_t(nr) + std::size_t(b)];
  if (at < 0) {
    const int v = chunk_at(m, g, B, a, b);
    const int S = int(gear_[g].strips.size()), K = m.shapes;
    constexpr int kMax = FaceBasis::kMaxShapes;
    at = int(B.proj_pool.size());
    B.proj_pool.resize(B.proj_pool.size() + std::size_t(3 * S * K + 2 * K * K));
    const double* V = B.pool.data() + v;
    const double* phi = m.face_shapes;
    double* VP = B.proj_pool.data() + at;
    double* VtP = VP + S * K;
    double* PVP = VtP + S * K;
    double* WP = PVP + K * K;
    double* PWP = WP + S * K;
    for (int k = 0; k < K; ++k)
      for (int s = 0; s < S; ++s) {
        double x = 0, y = 0, z = 0;
        for (int t = 0; t < S; ++t) {
          const double p = phi[t * kMax + k];
          x += V[s * S + t] * p;
          y += V[t * S + s] * p;
          z += (t <= s ? V[s * S + t] : V[t * S + s]) * p;
        }
        VP[k * S + s] = x;
        VtP[k * S + s] = y;
        WP[k * S + s] = z;
      }
    for (int l = 0; l < K; ++l)
      for (int k = 0; k < K; ++k) {
        double x = 0, z = 0;
        for (int s = 0; s < S; ++s) {
          x += phi[s * kMax + k] * VP[l * S + s];
          z += phi[s * kMax + k] * WP[l * S + s];
        }
        PVP[l * K + k] = x;
        PWP[l * K + k] = z;
      }
  }
  return at;
}

int FeAssembly::slot_of(const FeView& m, int g, const ContactSlice& si, const Spot& pi,
                        const ContactSlice& sj, const Spot& pj) {
  const int k = block_of(m, g, si.flank, pi.tooth, sj.flank, pj.tooth);
  if (k < 0) return -1;
  Gear& G = gear_[g];
  int free_slot = -1;
  for (std::size_t s = 0; s < G.blocks.size(); ++s) {
    if (G.blocks[s].index == k) {
      G.blocks[s].used = true;
      return int(s);
    }
    if (G.blocks[s].index < 0 && free_slot < 0) free_slot = int(s);
  }
  if (free_slot < 0) {
    free_slot = int(G.blocks.size());
    G.blocks.emplace_back();
  }
  Block& B = G.blocks[std::size_t(free_slot)];
  const std::size_t nr = m.compliance[g].roll.size();
  B.index = k;
  B.used = true;
  B.chunk.assign(nr * nr, -1);
  B.pool.clear();
  B.proj.assign(m.face_shapes ? nr * nr : 0, -1);
  B.proj_pool.clear();
  return free_slot;
}

// Groups: consecutive candidates of the same tooth pair and flank share their blocks.
GM_FE_STAGE void FeAssembly::group_candidates(const ContactSlice* slices, const int* index, int n) {
  group_first_.clear();
  for (int a = 0; a < n; ++a) {
    const ContactSlice& s = slices[index[a]];
    const ContactSlice* prev = a > 0 ? &slices[index[a - 1]] : nullptr;
    if (!prev || prev->tooth[0] != s.tooth[0] || prev->tooth[1] != s.tooth[1] ||
        prev->flank != s.flank)
      group_first_.push_back(a);
  }
}

// Each candidate's roll node and weight, face strip and database tooth on both gears; a face
// interval that changed (axial motion) makes new strips and this call direct.
GM_FE_STAGE void FeAssembly::locate_spots(const FeView& m, const ContactSlice* slices, const int* index,
                                          int n, const double uz[2]) {
  for (int g = 0; g < 2; ++g) {
    Gear& G = gear_[g];
    const ComplianceDb& db = m.compliance[g];
    if (int(G.spots.size()) < n) G.spots.resize(std::size_t(n));
    G.direct = false;
    for (Block& B : G.blocks) B.used = false;
    for (int pass = 0; pass < 2; ++pass) {
      bool full = false;
      for (int a = 0; a < n && !full; ++a) {
        const ContactSlice& s = slices[index[a]];
        Spot& p = G.spots[std::size_t(a)];
        const Spot* prev = a > 0 ? &G.spots[std::size_t(a) - 1] : nullptr;
        if (prev && s.roll[g] == slices[index[a - 1]].roll[g]) {  // an aligned spur pair's slices
          p.roll_node = prev->roll_node;
          std::copy(prev->roll_w, prev->roll_w + 3, p.roll_w);
        } else {
          const RollSpot<double> r = roll_spot(db, s.roll[g]);
          p.roll_node = r.node;
          std::copy(r.w, r.w + 3, p.roll_w);
        }
        const double face = face_position(m, g, s, uz[g]);
        // a tooth pair's slices usually follow the strips one by one: try the next one first
        const double lo = face - 0.5 * s.width, hi = face + 0.5 * s.width;
        const int next = prev ? prev->strip + 1 : 0;
        const bool hit = next < int(G.strips.size()) && G.strips[std::size_t(next)].lo == lo &&
                         G.strips[std::size_t(next)].hi == hi;
        p.strip = hit ? next : strip_of(m, g, lo, hi);
        p.tooth = db_tooth(m, g, s.tooth[g]);
        full = p.strip < 0;
      }
      if (!full) break;
      G.strips.clear();
      G.shares.clear();
      clear_chunks(G);
      G.direct = true;
    }
  }
}

// A group is uniform on gear g when its candidates share the roll nodes and weights there (an
// aligned spur pair): its entries then share the chunk values' positions and weights (four
// read linearly, nine quadratically). Its
// strips are consecutive when they follow the candidates one by one.
GM_FE_STAGE void FeAssembly::classify_groups(int ng) {
  uniform_.assign(std::size_t(2 * ng), 1);
  consecutive_.assign(std::size_t(2 * ng), 1);
  for (int g = 0; g < 2; ++g)
    for (int q = 0; q < ng; ++q) {
      const int a0 = group_first_[std::size_t(q)];
      const Spot& p0 = gear_[g].spots[std::size_t(a0)];
      for (int a = a0 + 1; a < group_first_[std::size_t(q) + 1]; ++a) {
        const Spot& p = gear_[g].spots[std::size_t(a)];
        if (p.roll_node != p0.roll_node || !std::equal(p.roll_w, p.roll_w + 3, p0.roll_w))
          uniform_[std::size_t(g * ng + q)] = 0;
        if (p.strip != p0.strip + a - a0) consecutive_[std::size_t(g * ng + q)] = 0;
      }
    }
}

namespace {

// col[k] (= or +=) sum_t w[t] v[t][base + k], k < len, over NT terms (0: nt of them), the terms
// summed in order. Eight, then two entries per pass in two-lane vectors (GCC's and Clang's vector
// extension; each term's pointer and weight read once per pass): each lane does one entry's
// operations in their order, so its bits are those of one entry at a time.
template <int NT>
inline void weighted_run(const double* w, const double* const* v, int base, int len, bool assign, double* col,
                         int nt = NT) {
  const int n = NT > 0 ? NT : nt;
  int k = 0;
#if defined(__GNUC__)
  typedef double Pair __attribute__((vector_size(16)));
  for (; k + 7 < len; k += 8) {
    Pair e[4] = {};
    for (int t = 0; t < n; ++t) {
      const double* x = v[t] + base + k;
      const double wt = w[t];
      for (int j = 0; j < 4; ++j) {
        Pair xj;
        std::memcpy(&xj, x + 2 * j, sizeof xj);
        e[j] += wt * xj;
      }
    }
    for (int j = 0; j < 4; ++j) {
      if (!assign) {
        Pair c;
        std::memcpy(&c, col + k + 2 * j, sizeof c);
        e[j] = c + e[j];
      }
      std::memcpy(col + k + 2 * j, &e[j], sizeof e[j]);
    }
  }
  for (; k + 1 < len; k += 2) {
    Pair e = {0, 0};
    for (int t = 0; t < n; ++t) {
      Pair x;
      std::memcpy(&x, v[t] + base + k, sizeof x);
      e += w[t] * x;
    }
    if (!assign) {
      Pair c;
      std::memcpy(&c, col + k, sizeof c);
      e = c + e;
    }
    std::memcpy(col + k, &e, sizeof e);
  }
#endif
  for (; k < len; ++k) {
    double e = 0;
    for (int t = 0; t < n; ++t) e += w[t] * v[t][base + k];
    col[k] = assign ? e : col[k] + e;
  }
}

}  // namespace

// Gear g's part of the entries of a group pair (columns a0..a1, rows b0..b1, upper triangle)
// for a uniform group pair from the cache: the same terms for every entry, in the
// general order of add_cached.
GM_FE_STAGE void FeAssembly::add_uniform(const FeView& m, int g, Block& B, const GroupPair& q,
                                         bool assign, Eigen::MatrixXd& C) {
  Gear& G = gear_[g];
  const int a0 = q.a0, a1 = q.a1, b0 = q.b0, b1 = q.b1;
  const int S = int(G.strips.size());
  const int reads = roll_reads(m.compliance[g]);
  const Spot& pa = G.spots[std::size_t(a0)];
  const Spot& pb = G.spots[std::size_t(b0)];
  double w[9];
  int at[9];
  const double* v[9];
  int nt = 0;
  for (int al = 0; al < reads; ++al) {
    const double ra = pa.roll_w[al];
    if (ra == 0) continue;
    for (int be = 0; be < reads; ++be) {
      const double rb = pb.roll_w[be];
      if (rb == 0) continue;
      w[nt] = ra * rb;
      at[nt++] = chunk_at(m, g, B, pa.roll_node + al, pb.roll_node + be);
    }
  }
  for (int t = 0; t < nt; ++t) v[t] = B.pool.data() + at[t];  // pool no longer grows
  const bool fast = q.b_consecutive[g];
  if (assign && !fast) zero_entries(q, C);
  if (fast) {
    // group b's strips are consecutive: each column segment C(b0.., a) reads a contiguous run
    // of every chunk (the same terms in the same order)
    const int s0 = G.spots[std::size_t(b0)].strip;
    for (int a = a0; a < a1; ++a) {
      const int base = G.spots[std::size_t(a)].strip * S + s0;
      const int len = std::min(b1, a + 1) - b0;
      double* col = &C(b0, a);
      if (nt == 9)
        weighted_run<9>(w, v, base, len, assign, col);
      else if (nt == 4)
        weighted_run<4>(w, v, base, len, assign, col);
      else
        weighted_run<0>(w, v, base, len, assign, col, nt);
    }
    return;
  }
  for (int a = a0; a < a1; ++a) {
    const int sa = G.spots[std::size_t(a)].strip * S;
    for (int b = b0; b < std::min(b1, a + 1); ++b) {
      const int at_ab = sa + G.spots[std::size_t(b)].strip;
      double e = 0;
      for (int t = 0; t < nt; ++t) e += w[t] * v[t][at_ab];
      C(b, a) += e;
    }
  }
}

// The same for a cached, non-uniform group pair (helical, tilted). The roll nodes the two
// groups' candidates touch span a few nodes each: every chunk of those node pairs is resolved
// first (computed when new; the pool may then grow, so pointers are taken only afterwards),
// then each entry is Reads^2 weighted values, summed in add_direct's order (a zero weight, where
// a candidate sits on a node, multiplies a finite value of a neighbouring chunk and adds 0).
template <int Reads>
GM_FE_STAGE void FeAssembly::add_cached(const FeView& m, int g, Block& B, const GroupPair& q,
                                        Eigen::MatrixXd& C) {
  Gear& G = gear_[g];
  const int S = int(G.strips.size());
  const int nrr = int(m.compliance[g].roll.size());
  int lo[2], hi[2];  // node spans of group a (0) and group b (1)
  for (int side = 0; side < 2; ++side) {
    const int c0 = side ? q.b0 : q.a0, c1 = side ? q.b1 : q.a1;
    lo[side] = nrr;
    hi[side] = -1;
    for (int c = c0; c < c1; ++c) {
      const Spot& p = G.spots[std::size_t(c)];
      lo[side] = std::min(lo[side], p.roll_node);
      hi[side] = std::max(hi[side], p.roll_node + Reads - 1);
    }
  }
  const int span_a = hi[0] - lo[0] + 1, span_b = hi[1] - lo[1] + 1;
  if (span_at_.size() < std::size_t(span_a * span_b)) span_at_.resize(std::size_t(span_a * span_b));
  int* at = span_at_.data();  // chunk offsets in B.pool, [node a - lo][node b - lo]
  for (int ia = 0; ia < span_a; ++ia)
    for (int ib = 0; ib < span_b; ++ib) {
      int& o = at[ia * span_b + ib];
      o = B.chunk[std::size_t(lo[0] + ia) * std::size_t(nrr) + std::size_t(lo[1] + ib)];
      if (o < 0) o = chunk_at(m, g, B, lo[0] + ia, lo[1] + ib);
    }
  const double* pool = B.pool.data();  // it no longer grows
  for (int a = q.a0; a < q.a1; ++a) {
    const Spot& pa = G.spots[std::size_t(a)];
    const int* va = at + (pa.roll_node - lo[0]) * span_b;
    const int row = pa.strip * S;
    for (int b = q.b0; b < std::min(q.b1, a + 1); ++b) {
      const Spot& pb = G.spots[std::size_t(b)];
      const int ib = pb.roll_node - lo[1];
      const int off = row + pb.strip;
      double e = 0;
      for (int al = 0; al < Reads; ++al)
        for (int be = 0; be < Reads; ++be)
          e += pa.roll_w[al] * pb.roll_w[be] * pool[va[al * span_b + ib + be] + off];
      C(b, a) += e;
    }
  }
}

// The same directly from the database (this call's face intervals are new).
GM_FE_STAGE void FeAssembly::add_direct(const FeView& m, int g, const Block& B, const GroupPair& q,
                                        Eigen::MatrixXd& C) const {
  const Gear& G = gear_[g];
  const int a0 = q.a0, a1 = q.a1, b0 = q.b0, b1 = q.b1;
  const int reads = roll_reads(m.compliance[g]);
  for (int a = a0; a < a1; ++a) {
    const Spot& pa = G.spots[std::size_t(a)];
    for (int b = b0; b < std::min(b1, a + 1); ++b) {
      const Spot& pb = G.spots[std::size_t(b)];
      double e = 0;
      for (int al = 0; al < reads; ++al) {
        const double ra = pa.roll_w[al];
        if (ra == 0) continue;
        for (int be = 0; be < reads; ++be) {
          const double rb = pb.roll_w[be];
          if (rb == 0) continue;
          e += ra * rb * strip_value(m, g, B.index, pa.roll_node + al, pb.roll_node + be,
                                     pa.strip, pb.strip);
        }
      }
      C(b, a) += e;
    }
  }
}

// The entries of a group pair (upper triangle) set to 0.
GM_FE_STAGE void FeAssembly::zero_entries(const GroupPair& q, Eigen::MatrixXd& C) {
  for (int a = q.a0; a < q.a1; ++a)
    for (int b = q.b0; b < std::min(q.b1, a + 1); ++b) C(b, a) = 0;
}

// Blocks of teeth that left the candidates: dropped (a cyclic database has few blocks, kept).
GM_FE_STAGE void FeAssembly::drop_unused_blocks(const FeView& m) {
  for (int g = 0; g < 2; ++g)
    for (Block& B : gear_[g].blocks)
      if (!m.compliance[g].cyclic && !B.used && B.index >= 0) {
        B.index = -1;
        B.pool.clear();
        B.proj_pool.clear();
      }
}

void FeAssembly::assemble(const FeView& m, const ContactSlice* slices, const int* index, int n,
                          const double uz[2], Eigen::MatrixXd& C) {
  prepare(m, slices, index, n, uz);
  fill(m, slices, index, n, C);
}

void FeAssembly::prepare(const FeView& m, const ContactSlice* slices, const int* index, int n,
                         const double uz[2]) {
  group_candidates(slices, index, n);
  const int ng = int(group_first_.size());
  locate_spots(m, slices, index, n, uz);
  group_first_.push_back(n);
  classify_groups(ng);
}

void FeAssembly::fill(const FeView& m, const ContactSlice* slices, const int* index, int, Eigen::MatrixXd& C) {
  const int ng = int(group_first_.size()) - 1;
  for (int ga = 0; ga < ng; ++ga) {
    for (int gb = 0; gb <= ga; ++gb) {
      GroupPair q;
      q.a0 = group_first_[std::size_t(ga)], q.a1 = group_first_[std::size_t(ga) + 1];
      q.b0 = group_first_[std::size_t(gb)], q.b1 = group_first_[std::size_t(gb) + 1];
      for (int g = 0; g < 2; ++g) {
        q.uniform[g] = uniform_[std::size_t(g * ng + ga)] && uniform_[std::size_t(g * ng + gb)];
        q.b_consecutive[g] = consecutive_[std::size_t(g * ng + gb)];
      }
      const int a0 = q.a0, a1 = q.a1, b0 = q.b0, b1 = q.b1;
      bool assigned = false;  // the entries hold a first gear's part (else they are zeroed)
      for (int g = 0; g < 2; ++g) {
        Gear& G = gear_[g];
        const int slot = slot_of(m, g, slices[index[a0]], G.spots[std::size_t(a0)],
                                 slices[index[b0]], G.spots[std::size_t(b0)]);
        if (slot < 0) continue;
        Block& B = G.blocks[std::size_t(slot)];
        if (!assigned && (G.direct || !q.uniform[g])) zero_entries(q, C);
        if (G.direct)
          add_direct(m, g, B, q, C);
        else if (q.uniform[g])
          add_uniform(m, g, B, q, !assigned, C);
        else if (roll_reads(m.compliance[g]) == 3)
          add_cached<3>(m, g, B, q, C);
        else if (roll_reads(m.compliance[g]) == 2)
          add_cached<2>(m, g, B, q, C);
        else
          add_cached<1>(m, g, B, q, C);
        assigned = true;
      }
      if (!assigned) zero_entries(q, C);
      for (int a = a0; a < a1; ++a)
        for (int b = b0; b < std::min(b1, a + 1); ++b) C(a, b) = C(b, a);
    }
  }
  drop_unused_blocks(m);
}

// Whether the prepared call can be projected: shapes, cached strips, cyclic databases, and every
// group a whole aligned spur face (S candidates on strips 0 .. S-1 in slice order, one roll spot)
// on both gears. (A database with a set per tooth drops a tooth's chunks when it leaves the mesh:
// their projections would be made again at every tooth, for more than they save.)
bool FeAssembly::projectable(const FeView& m, int n) const {
  const int S = m.layout.slices, ng = int(group_first_.size()) - 1;
  if (!m.face_shapes || m.shapes <= 0 || m.layout.tan_beta_b != 0 || ng < 1) return false;
  for (int g = 0; g < 2; ++g) {
    const Gear& G = gear_[g];
    if (G.direct || int(G.strips.size()) != S || !m.compliance[g].cyclic) return false;
    for (int q = 0; q < ng; ++q) {
      const int a0 = group_first_[std::size_t(q)];
      if (group_first_[std::size_t(q) + 1] - a0 != S || !uniform_[std::size_t(g * ng + q)] ||
          !consecutive_[std::size_t(g * ng + q)] || G.spots[std::size_t(a0)].strip != 0)
        return false;
    }
  }
  return n == ng * S;
}

bool FeAssembly::project(const FeView& m, const ContactSlice* slices, const int* index, int n, Eigen::MatrixXd& CP,
                         Eigen::MatrixXd& PCP, int& groups) {
  if (!projectable(m, n)) return false;
  for (int a = 0; a < n; ++a)  // strip s is slice s (the shapes are the slices')
    if (slices[index[a]].slice != gear_[0].spots[std::size_t(a)].strip) return false;
  const int S = m.layout.slices, K = m.shapes, ng = int(group_first_.size()) - 1;
  if (n > CP.rows() || ng * K > CP.cols() || ng * K > PCP.rows() || ng * K > PCP.cols()) return false;
  groups = ng;
  for (int ga = 0; ga < ng; ++ga) {
    for (int gb = 0; gb <= ga; ++gb) {
      const int a0 = group_first_[std::size_t(ga)], b0 = group_first_[std::size_t(gb)];
      // the terms of both gears: weight and chunk projection (block, offset); the offsets first,
      // as resolving one may grow its block's pool
      double w[18];
      Block* blk[18];
      int at[18];
      int nt = 0;
      for (int g = 0; g < 2; ++g) {
        Gear& G = gear_[g];
        const int slot = slot_of(m, g, slices[index[a0]], G.spots[std::size_t(a0)], slices[index[b0]],
                                 G.spots[std::size_t(b0)]);
        if (slot < 0) continue;
        Block& B = G.blocks[std::size_t(slot)];
        const int reads = roll_reads(m.compliance[g]);
        const Spot& pa = G.spots[std::size_t(a0)];
        const Spot& pb = G.spots[std::size_t(b0)];
        for (int al = 0; al < reads; ++al)
          for (int be = 0; be < reads; ++be) {
            if (pa.roll_w[al] == 0 || pb.roll_w[be] == 0) continue;
            w[nt] = pa.roll_w[al] * pb.roll_w[be];
            blk[nt] = &B;
            at[nt++] = projection_at(m, g, B, pa.roll_node + al, pb.roll_node + be);
          }
      }
      // a pair's own block: W of projection_at instead of V
      const double* VP[18];
      const double* VtP[18];
      const double* PVP[18];
      for (int t = 0; t < nt; ++t) {
        const double* base = blk[t]->proj_pool.data() + at[t];
        VP[t] = ga == gb ? base + 2 * S * K + K * K : base;
        VtP[t] = base + S * K;
        PVP[t] = ga == gb ? base + 3 * S * K + K * K : base + 2 * S * K;
      }
      // rows of group a, columns of group b: C_ab Phi = sum w V Phi; rows b, columns a: V^T Phi;
      // Phi^T C_ab Phi, and its transpose for (b, a)
      for (int k = 0; k < K; ++k) {
        double* col = &CP(a0, gb * K + k);
        if (nt > 0) weighted_run<0>(w, VP, k * S, S, true, col, nt);
        else std::fill(col, col + S, 0.0);
        if (ga == gb) continue;
        col = &CP(b0, ga * K + k);
        if (nt > 0) weighted_run<0>(w, VtP, k * S, S, true, col, nt);
        else std::fill(col, col + S, 0.0);
      }
      for (int l = 0; l < K; ++l) {
        double* col = &PCP(ga * K, gb * K + l);
        if (nt > 0) weighted_run<0>(w, PVP, l * K, K, true, col, nt);
        else std::fill(col, col + K, 0.0);
      }
      // symmetric in exact arithmetic: the block above from the one below (a group's own block
      // from its lower triangle)
      for (int k = 0; k < K; ++k)
        for (int l = 0; l < K; ++l)
          if (ga != gb || l > k) PCP(gb * K + l, ga * K + k) = PCP(ga * K + k, gb * K + l);
    }
  }
  drop_unused_blocks(m);
  return true;
}

}  // namespace gm
