// Level 5 (FE): the coupled compliance C = C^1 + C^2 between candidate slices from the gears'
// compliance databases (docs/physics.md §5, paper 2.2-2.3), as a straightforward reference and as the
// cached assembly the evaluation uses.
//
// C^g[i][j] for slices i (receiver) and j (load) on teeth t_i, t_j of gear g, offset
// d = t_i - t_j (wrapped to -z/2..z/2; 0 beyond model.coupled_teeth), from the database block
// C_d of tooth set t_j and the database flank that carries the slices' flank (no coupling
// between flank A and flank B). Conventions (derived in fe_compliance.cpp): both gears' body
// frames have z along the housing's z, tooth indices increase counter-clockwise as the
// database's do, and the face coordinate z - c_z - axial_offset has the database's sign; the
// pair's flank A is the database's flank A on every gear: the ccw side of a tooth, on a ring
// (whose core and database both count spaces) the ccw wall of a space. A database flank B read
// through the mirror (mirror = 1) uses flank A's
// set with d -> -d, tooth set -t and, for a helical gear, the face coordinate reversed:
//
//   C^g[i][j] = sum_{a,m} sum_{b,n} r_ia q_im r_jb q_jn C_d[(a, m)][(b, n)]
//
// Roll (on gear g's flank): r_ia are the weights of the slice's roll distance on the grid nodes a
// (clamped at the grid ends): the shape functions of the quadratic element (three nodes) it lies
// in when the database is a quadratic mesh's flank nodes, as compliance_tool's are, else the
// linear interpolation weights between two nodes (fe_compliance.cpp, roll_spot). Face (along gear g's axis from its
// mid-face): q_im = |slice_i n strip_m| / w_i, the share of slice i's width inside node m's
// tributary strip (strips end half-way between nodes; the end strips are unbounded). SCALING:
// a database column is the response to a unit POINT load at a node, which the core reads as the
// node's lumped share of a line load over its strip. A slice force F_j is a uniform line load
// F_j / w_j over the slice width, so node n receives F_j q_jn; the receiver displacement is the
// width average of the nodal displacements (weights q_im). The result is symmetric when C_d is
// (Maxwell-Betti) and reproduces a per-unit-width compliance c'/w exactly when the database is
// diagonal in face with C = c'/Delta_face and the slices coincide with the strips; with slices
// narrower than the strips a face-diagonal database cannot resolve them (a real FE database is
// smooth across the face, where this is a width average of a smooth kernel).
//
// DYNAMIC ASSEMBLY (FeAssembly). A slice's face interval is fixed while the axial pose (u_z,
// the axial offsets) is, so the face sums are cached: per database block C_d in use and per pair
// of roll nodes (a, b) a "chunk" S x S of strip values
//   V_ab[s][s'] = sum_m q_sm (sum_n q_s'n C_d[(a, m)][(b, n)])
// over the S slice strips; an entry is then sum_{alpha, beta} r_alpha r_beta V over the roll
// nodes of each slice (nine values per gear read quadratically, four linearly). Chunks are
// computed when first needed; the blocks of teeth that left the candidate set are dropped after
// the call; the strips (and with them every chunk) are rebuilt when a face interval changes, and
// that call computes the strip values directly with the same function, so the cached and the
// direct results are the same bits whatever the history (FMU get/set state stays bit for bit).
//
// PROJECTED ASSEMBLY (FeAssembly::project, the reduced face basis of face_basis.hpp). With the
// model's fixed face shapes Phi (S x K over the slices, face_shapes.hpp) each chunk also keeps
// V Phi, V^T Phi (S x K) and Phi^T V Phi (K x K), and the same of the chunk as a tooth pair's own
// block is assembled (its lower triangle mirrored: fe_compliance.cpp, projection_at); where every
// tooth pair of the call is an aligned spur pair's whole face (its S slices on strips 0 .. S-1,
// one roll spot per gear), the reduced matrices C Phi and Phi^T C Phi are then the same weighted
// sums of these (S K or K^2 values per chunk and term instead of S^2), without C.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "gearmesh/internal/compliance_db.hpp"
#include "detection.hpp"
#include "dual.hpp"

namespace gm {

// What the FE level reads of the model (model.hpp's fe_view(m) makes it): the two gears'
// compliance databases, the detection layout (mesh sign, slices, axial offsets),
// model.coupled_teeth and the reduced face basis's fixed shapes (face_shapes.hpp).
struct FeView {
  const ComplianceDb* compliance;  // [2], gear 1 and gear 2
  const MeshLayout& layout;
  int coupled_teeth;
  const double* face_shapes = nullptr;  // per slice FaceBasis::kMaxShapes values; null: none
  int shapes = 0;                       // K of them used
};

// Reference: C^1 + C^2 between receiver si and load sj, straight from the databases (every
// interpolation weight and face share recomputed), over double or dual numbers (the roll, face
// position and width carry the derivative). uz: the gears' axial displacements, m.
template <class T>
T fe_pair_compliance(const FeView& m, const ContactSliceT<T>& si, const ContactSliceT<T>& sj,
                     const T uz[2]);

// The whole matrix by the reference, for candidates index[0..n) (C's top-left n x n).
void fe_assemble_reference(const FeView& m, const ContactSlice* slices, const int* index, int n,
                           const double uz[2], Eigen::MatrixXd& C);

class FeAssembly {
 public:
  // Size every buffer for a model whose evaluations have at most `capacity` candidates
  // (gm_data_create), so that assemble allocates nothing: the face strips and their shares, the
  // per-candidate spots and groups, and for each block slot the chunk index and a pool that
  // holds every chunk (n_roll^2 S^2 values, S the strips). Slots: every block of a cyclic
  // database, else at most twice the blocks one call can use (the previous call's are dropped
  // at its end), and never more than the database has, so the cache holds at most the
  // database's size times (S/n_face)^2. Beyond these bounds assemble still works, allocating.
  void reserve(const FeView& m, int capacity);
  // Forget every cached value (model or data reset, FMU state restored); results do not
  // depend on it, only the time of the next call does.
  void invalidate();
  // C's top-left n x n for candidates index[0..n); C must be at least n x n.
  void assemble(const FeView& m, const ContactSlice* slices, const int* index, int n,
                const double uz[2], Eigen::MatrixXd& C);
  // The same in two stages: prepare (each candidate's spots, the groups), then either fill (C as
  // assemble makes it) or project, or project and then, where the reduced solve is refused, fill.
  void prepare(const FeView& m, const ContactSlice* slices, const int* index, int n, const double uz[2]);
  void fill(const FeView& m, const ContactSlice* slices, const int* index, int n, Eigen::MatrixXd& C);
  // C Phi into CP (n x groups K: column q K + k is group q's shape k on its slices) and
  // Phi^T C Phi into PCP (groups K square), groups the tooth pairs in the candidates' order;
  // false (nothing written) unless every group is a whole aligned spur face on cached strips
  // (the header's PROJECTED ASSEMBLY) and m has shapes.
  bool project(const FeView& m, const ContactSlice* slices, const int* index, int n, Eigen::MatrixXd& CP,
               Eigen::MatrixXd& PCP, int& groups);
  // Whether the last assemble used cached strip values for gear g (false: computed directly).
  bool cached(int g) const { return !gear_[g].direct; }
  // Cached strip values held, over both gears (memory: 8 bytes each).
  std::size_t cached_values() const;

 private:
  struct Strip {
    double lo = 0, hi = 0;        // face interval on the gear, m
    int face_lo = 0, face_hi = 0; // face nodes whose strips it touches
    int share_at = 0;             // its shares q_m in `shares`, from face_lo
  };
  struct Block {
    int index = -1;               // database block, -1: slot free
    bool used = false;            // used by this call
    std::vector<int> chunk;       // n_roll^2 offsets into pool (-1: not computed)
    std::vector<double> pool;     // chunks of strips.size()^2 values
    std::vector<int> proj;        // n_roll^2 offsets into proj_pool (-1: not computed)
    std::vector<double> proj_pool;  // per chunk V Phi, V^T Phi, Phi^T V Phi, W Phi, Phi^T W Phi
                                    // (projection_at)
  };
  struct Spot {
    int roll_node = 0;                // first of its roll nodes (fe_compliance.cpp, roll_reads)
    double roll_w[3] = {1, 0, 0};     // their weights
    int strip = 0;
    int tooth = 0;                // the database's tooth (modulo z) of the slice's flank
  };
  struct Gear {
    std::vector<Strip> strips;
    std::vector<double> shares;
    std::vector<Block> blocks;
    std::vector<Spot> spots;      // per candidate of the call
    bool direct = true;           // this call computes strip values directly
  };
  int strip_of(const FeView& m, int g, double lo, double hi);
  void clear_chunks(Gear& G);
  int slot_of(const FeView& m, int g, const ContactSlice& si, const Spot& pi,
              const ContactSlice& sj, const Spot& pj);
  // offset of chunk (a, b) in B.pool, computed if new (the pool may grow: no pointers kept)
  int chunk_at(const FeView& m, int g, Block& B, int a, int b);
  double strip_value(const FeView& m, int g, int block, int a, int b, int si, int sj) const;
  // offset of chunk (a, b)'s projections in B.proj_pool, computed if new
  int projection_at(const FeView& m, int g, Block& B, int a, int b);
  bool projectable(const FeView& m, int n) const;
  // the stages of assemble (fe_compliance.cpp)
  void group_candidates(const ContactSlice* slices, const int* index, int n);
  void locate_spots(const FeView& m, const ContactSlice* slices, const int* index, int n,
                    const double uz[2]);
  void classify_groups(int ng);
  // two groups' candidates a0..a1 and b0..b1 (b's group not after a's) and, per gear, whether
  // both are uniform and whether b's strips are consecutive
  struct GroupPair {
    int a0 = 0, a1 = 0, b0 = 0, b1 = 0;
    bool uniform[2] = {false, false}, b_consecutive[2] = {false, false};
  };
  // assign: the entries are set (zeroed first when the terms are not the four-chunk run), not
  // added to
  void add_uniform(const FeView& m, int g, Block& B, const GroupPair& q, bool assign,
                   Eigen::MatrixXd& C);
  static void zero_entries(const GroupPair& q, Eigen::MatrixXd& C);
  template <int Reads>
  void add_cached(const FeView& m, int g, Block& B, const GroupPair& q, Eigen::MatrixXd& C);
  void add_direct(const FeView& m, int g, const Block& B, const GroupPair& q, Eigen::MatrixXd& C) const;
  void drop_unused_blocks(const FeView& m);

  Gear gear_[2];
  std::vector<int> group_first_;  // groups (consecutive candidates of one tooth pair and
                                  // flank) -> first candidate, and n after the last
  std::vector<char> uniform_;     // (gear, group) -> its candidates share roll node and weight
  std::vector<char> consecutive_; // (gear, group) -> its candidates' strips are consecutive
  std::vector<int> span_at_;      // add_cached: chunk offsets over the node pairs two groups span
};

// The derivative's assembly: C and dC between candidates index[0..n) over dual numbers, each
// entry bit for bit what fe_pair_compliance<Dual> gives (the same products summed in the same
// order), but every candidate's interpolation weights found once per call instead of once per
// entry (gm_directional_derivative at level 5 spent most of its time there).
class FeDualAssembly {
 public:
  // Size the buffers for at most `capacity` candidates (gm_data_create): assemble then
  // allocates nothing.
  void reserve(const FeView& m, int capacity);
  // C's and dC's top-left n x n (values and derivatives); both must be at least n x n.
  void assemble(const FeView& m, const ContactSliceT<Dual>* slices, const int* index, int n,
                const Dual uz[2], Eigen::MatrixXd& C, Eigen::MatrixXd& dC);

 private:
  struct Weight {
    int node = 0;  // grid node of the database: roll node * n_face + face node
    Dual w;        // its weight: roll weight times face share
  };
  struct Spot {
    int first = 0, count = 0;  // its weights in weights_
    int flank = 0, tooth = 0;  // the slice's flank and the database's tooth (modulo z)
  };
  std::vector<Weight> weights_;
  std::vector<Spot> spots_[2];  // per gear, per candidate of the call
};

}  // namespace gm
