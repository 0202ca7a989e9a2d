// The load distribution across the face of the last evaluation (gm_data_load_distribution) and
// the slices' positions (gm_model_slice_positions); docs/model.md, "Load across the face".
#include <algorithm>
#include <cstring>

#include "model.hpp"

namespace {

// One loaded tooth pair while the record is read.
struct PairSum {
  int pair, flank;
  double force, weighted_position, approach;
};

constexpr int kMaxPairSums = 64;  // loaded tooth pairs one evaluation can report

}  // namespace

int gm_data_load_distribution(const gm_model* m, const gm_data* d, int max_pairs, gm_pair_load* pairs,
                              double* line_load) {
  if (!m || !d || max_pairs < 0) return 0;
  const int slices = m->params.slices;
  if (pairs) std::memset(pairs, 0, sizeof(gm_pair_load) * std::size_t(max_pairs));
  if (line_load) std::fill(line_load, line_load + std::size_t(max_pairs) * std::size_t(slices), 0.0);
  // a tooth pair's slices are consecutive in the record (detection emits them so)
  PairSum sums[kMaxPairSums];
  int n = 0;
  double total = 0;
  for (int i = 0; i < d->loaded_count; ++i) {
    const gm_data::LoadedSlice& s = d->loaded[std::size_t(i)];
    if (n == 0 || sums[n - 1].pair != s.pair) {
      if (n == kMaxPairSums) break;
      sums[n++] = PairSum{s.pair, s.flank > 0 ? 1 : 2, 0.0, 0.0, s.approach};
    }
    PairSum& p = sums[n - 1];
    p.force += s.force;
    p.weighted_position += s.force * s.path_position;
    p.approach = std::max(p.approach, s.approach);
    total += s.force;
  }
  // by flank, then by the position on the path of contact
  std::sort(sums, sums + n, [](const PairSum& a, const PairSum& b) {
    if (a.flank != b.flank) return a.flank < b.flank;
    return a.weighted_position / a.force < b.weighted_position / b.force;
  });
  for (int k = 0; k < n && k < max_pairs; ++k) {
    const PairSum& p = sums[k];
    if (pairs) pairs[k] = gm_pair_load{p.force, p.force / total, p.weighted_position / p.force, p.approach, p.flank};
    if (!line_load) continue;
    double* row = line_load + std::size_t(k) * std::size_t(slices);
    for (int i = 0; i < d->loaded_count; ++i) {
      const gm_data::LoadedSlice& s = d->loaded[std::size_t(i)];
      if (s.pair != p.pair) continue;
      for (int j = s.slice; j < s.slice + s.run && j < slices; ++j) row[j] = s.force / s.width;
    }
  }
  return n;
}

void gm_model_slice_positions(const gm_model* m, double* z) {
  if (!m || !z) return;
  const gm::MeshLayout& L = m->layout;
  // the axial overlap of the two faces with the gears at their nominal poses (detection's frame)
  const double lo = std::max(L.axial_offset[0] - 0.5 * L.face_width[0], L.axial_offset[1] - 0.5 * L.face_width[1]);
  const double hi = std::min(L.axial_offset[0] + 0.5 * L.face_width[0], L.axial_offset[1] + 0.5 * L.face_width[1]);
  const double width = std::max(hi - lo, 0.0) / L.slices;
  for (int j = 0; j < L.slices; ++j) z[j] = lo + (j + 0.5) * width;
}
