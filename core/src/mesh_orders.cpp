// Mesh orders over whole mesh cycles (mesh_orders.hpp). The mesh angle u = z_1 |phi_1| runs 2 pi
// per mesh cycle; a cycle counts from the first boundary (a multiple of 2 pi) the trajectory
// crosses. Between two points the signals are taken linear in u and the Fourier integrals
//   A_k = (1/pi) int f cos(k u) du,  B_k = (1/pi) int f sin(k u) du
// over each cycle are integrated exactly; the amplitude and phase of order k are those of the
// mean of (A_k, B_k) over the window: f = mean + sum_k a_k cos(k u + psi_k), a_k = |(A_k, B_k)|,
// psi_k = atan2(-B_k, A_k).
#include "mesh_orders.hpp"

#include <algorithm>
#include <cmath>

namespace gm {
namespace {

constexpr double kPi = 3.14159265358979323846264338327950;
constexpr double kTwoPi = 2.0 * kPi;

void clear_sums(gm_mesh_orders& o) {
  for (auto& signal : o.sums)
    for (auto& order : signal) order[0] = order[1] = 0.0;
}

// cos(k u) and sin(k u) for k = 1 .. n from one cosine and sine (the angle-addition recurrence: two
// trigonometric calls per point instead of two per order).
void harmonics(double u, int n, double c[GM_MESH_ORDERS_MAX], double sn[GM_MESH_ORDERS_MAX]) {
  c[0] = std::cos(u);
  sn[0] = std::sin(u);
  for (int k = 1; k < n; ++k) {
    c[k] = c[k - 1] * c[0] - sn[k - 1] * sn[0];
    sn[k] = sn[k - 1] * c[0] + c[k - 1] * sn[0];
  }
}

// Add the piece [u0, u1] (u0 < u1, inside one cycle) to the open cycle: the integrals of
// (f0 + s (u - u0)) cos(k u) and sin(k u), s the slope, from their primitives
//   f sin(ku)/k + s cos(ku)/k^2  and  -f cos(ku)/k + s sin(ku)/k^2.
void add_piece(gm_mesh_orders& o, int n, double u0, double u1, const double f0[2], const double f1[2]) {
  double c0[GM_MESH_ORDERS_MAX], s0[GM_MESH_ORDERS_MAX], c1[GM_MESH_ORDERS_MAX], s1[GM_MESH_ORDERS_MAX];
  harmonics(u0, n, c0, s0);
  harmonics(u1, n, c1, s1);
  for (int sig = 0; sig < 2; ++sig) {
    const double slope = (f1[sig] - f0[sig]) / (u1 - u0);
    for (int k = 1; k <= n; ++k) {
      const double kk = k, a = f0[sig], b = f1[sig];
      const double cos_part = (b * s1[k - 1] - a * s0[k - 1]) / kk + slope * (c1[k - 1] - c0[k - 1]) / (kk * kk);
      const double sin_part = (a * c0[k - 1] - b * c1[k - 1]) / kk + slope * (s1[k - 1] - s0[k - 1]) / (kk * kk);
      o.sums[sig][k - 1][0] += cos_part / kPi;
      o.sums[sig][k - 1][1] += sin_part / kPi;
    }
  }
}

void close_cycle(gm_mesh_orders& o) {
  for (int sig = 0; sig < 2; ++sig)
    for (int k = 0; k < GM_MESH_ORDERS_MAX; ++k)
      for (int j = 0; j < 2; ++j) o.ring[o.ring_next][sig][k][j] = o.sums[sig][k][j];
  o.ring_next = (o.ring_next + 1) % GM_ORDER_CYCLES_MAX;
  o.ring_count = std::min(o.ring_count + 1, GM_ORDER_CYCLES_MAX);
  clear_sums(o);
}

}  // namespace

void orders_reset(gm_mesh_orders& o) {
  o = gm_mesh_orders{};
}

void orders_add(gm_mesh_orders& o, int z1, int n, const OrderPoint& a, const OrderPoint& b) {
  const double ta = z1 * a.phi1, tb = z1 * b.phi1;
  if (ta == tb) return;
  const int direction = tb > ta ? 1 : -1;
  if (o.direction != direction) {  // a reversal (or the first piece): the window starts anew
    orders_reset(o);
    o.direction = direction;
  }
  // u grows along the motion; the sine terms of a backward run change sign (u = -theta)
  double u0 = direction * ta, u1 = direction * tb;
  double f0[2] = {a.value[0], a.value[1]}, f1[2] = {b.value[0], b.value[1]};
  while (u0 < u1) {
    double boundary = kTwoPi * (std::floor(u0 / kTwoPi) + 1.0);
    if (!(boundary > u0)) boundary += kTwoPi;  // u0 on a boundary that the division rounded down
    const double end = std::min(u1, boundary);
    double f_end[2];
    for (int sig = 0; sig < 2; ++sig) f_end[sig] = f0[sig] + (f1[sig] - f0[sig]) * (end - u0) / (u1 - u0);
    if (o.open) add_piece(o, n, u0, end, f0, f_end);
    if (end == boundary) {  // a cycle ends here: closed if it began at a boundary, and a new one opens
      if (o.open) close_cycle(o);
      o.open = 1;
      o.open_from = boundary;
      clear_sums(o);
    }
    u0 = end;
    f0[0] = f_end[0];
    f0[1] = f_end[1];
  }
}

void orders_publish(gm_mesh_orders& o, int window, int orders) {
  const int n = std::min(std::max(window, 1), o.ring_count);
  o.cycles = n;
  o.orders = orders;
  for (int sig = 0; sig < 2; ++sig)
    for (int k = 0; k < GM_MESH_ORDERS_MAX; ++k) {
      double A = 0, B = 0;
      for (int i = 0; i < n && k < o.orders; ++i) {
        const int slot = (o.ring_next - 1 - i + 2 * GM_ORDER_CYCLES_MAX) % GM_ORDER_CYCLES_MAX;
        A += o.ring[slot][sig][k][0] / n;
        B += o.ring[slot][sig][k][1] / n;
      }
      const double amplitude = n ? std::hypot(A, B) : 0.0, phase = n ? std::atan2(-B, A) : 0.0;
      (sig == 0 ? o.te_amplitude : o.force_amplitude)[k] = amplitude;
      (sig == 0 ? o.te_phase : o.force_phase)[k] = phase;
    }
}

}  // namespace gm
