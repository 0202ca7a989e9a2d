// Repeated slices merged into one wider slice (levels 0-4; docs/model.md, "Tooth coupling at level 4", Cost).
//
// An aligned spur pair without lead modifications gives every slice of a tooth pair the same
// contact: only the face position z differs. At levels 0-4 a slice's law is linear in its width
// (a compliance per unit face width, and a Hertz law of the line load F / L), so k such slices
// carry what one slice k times as wide carries at the mean z: the same forces summed, moments
// (their arms differ only along the axis, and sum to the mean's), line load, energy, damping and
// friction. Merged before the laws are built, the rest of the pass sees fewer slices. Level 5
// keeps every slice: its compliance database couples the face strips one by one.
//
// Candidates repeat when every value but z is the same (values alone, so that the derivative's
// dual detection merges exactly the slices the evaluation merges); over dual numbers the merged
// slice carries the mean of their derivatives, which is the outputs' exact first-order change
// because they are sums over slices at equal values.
#pragma once

#include "detection.hpp"
#include "dual.hpp"

namespace gm {
namespace slice_merge_detail {

// acc holds the mean of `count` slices' values equal to x's: the derivative part is averaged.
inline void fold(double&, double, int) {}
inline void fold(Dual& acc, const Dual& x, int count) { acc.d += (x.d - acc.d) / count; }

template <class T>
bool same(const T& a, const T& b) {
  return val(a) == val(b);
}

// Whether b repeats a at another face position (a's width: that of one slice of its run).
template <class T>
bool repeats(const ContactSliceT<T>& a, const T& a_width, const ContactSliceT<T>& b) {
  if (a.flank != b.flank || a.kind != b.kind || a.pair != b.pair || a.tooth[0] != b.tooth[0] ||
      a.tooth[1] != b.tooth[1] || b.slice != a.slice + a.run)  // the next slice of a's run
    return false;
  if (!same(a.approach, b.approach) || !same(a_width, b.width) || !same(a.roll[0], b.roll[0]) ||
      !same(a.roll[1], b.roll[1]) || !same(a.approach_rate, b.approach_rate) ||
      !same(a.sliding_velocity, b.sliding_velocity) || !same(a.te_gain, b.te_gain) ||
      !same(a.path_position, b.path_position) || !same(a.corner_slope, b.corner_slope))
    return false;
  for (int k = 0; k < 3; ++k)
    if (!same(a.tangent[k], b.tangent[k]) || !same(a.normal[k], b.normal[k])) return false;
  return same(a.point.x(), b.point.x()) && same(a.point.y(), b.point.y());
}

// Fold slice x into acc, which then stands for `count` slices.
template <class T>
void merge_into(ContactSliceT<T>& acc, const ContactSliceT<T>& x, int count) {
  acc.point.z() += (x.point.z() - acc.point.z()) / count;  // the mean face position
  fold(acc.approach, x.approach, count);
  fold(acc.roll[0], x.roll[0], count);
  fold(acc.roll[1], x.roll[1], count);
  fold(acc.approach_rate, x.approach_rate, count);
  fold(acc.sliding_velocity, x.sliding_velocity, count);
  fold(acc.te_gain, x.te_gain, count);
  fold(acc.path_position, x.path_position, count);
  fold(acc.corner_slope, x.corner_slope, count);
  for (int k = 0; k < 3; ++k) {
    fold(acc.tangent[k], x.tangent[k], count);
    fold(acc.normal[k], x.normal[k], count);
  }
  fold(acc.point.x(), x.point.x(), count);
  fold(acc.point.y(), x.point.y(), count);
  acc.width += x.width;  // the widths add, and the slices it stands for
  acc.run += x.run;
}

}  // namespace slice_merge_detail

// Merge runs of repeated slices in place; returns the new count (the order is kept).
template <class T>
int merge_repeated_slices(ContactSliceT<T>* slices, int n) {
  int out = 0, count = 0;
  T width = 0;  // one slice's width in the current run
  for (int i = 0; i < n; ++i) {
    if (out > 0 && slice_merge_detail::repeats(slices[out - 1], width, slices[i])) {
      slice_merge_detail::merge_into(slices[out - 1], slices[i], ++count);
      continue;
    }
    if (out != i) slices[out] = slices[i];
    width = slices[out].width;
    ++out;
    count = 1;
  }
  return out;
}

}  // namespace gm
