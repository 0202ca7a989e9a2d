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

// int over [u0, u1] of (f0 + s (u - u0)) cos(k u) and sin(k u) du, s the slope.
void linear_fourier(double u0, double u1, double f0, double f1, int k, double* c, double* sn) {
  const double s = u1 > u0 ? (f1 - f0) / (u1 - u0) : 0.0;
  const auto primitive = [&](double u, double* pc, double* ps) {
    const double kk = k, ck = std::cos(k * u), sk = std::sin(k * u);
    const double f = f0 + s * (u - u0);
    *pc = f * sk / kk + s * ck / (kk * kk);   // d/du: f cos(ku)
    *ps = -f * ck / kk + s * sk / (kk * kk);  // d/du: f sin(ku)
  };
  double c0, s0, c1, s1;
  primitive(u0, &c0, &s0);
  primitive(u1, &c1, &s1);
  *c = c1 - c0;
  *sn = s1 - s0;
}

void clear_sums(gm_mesh_orders& o) {
  for (auto& signal : o.sums)
    for (auto& order : signal) order[0] = order[1] = 0.0;
}

// Add the piece [u0, u1] (u0 < u1, inside one cycle) to the open cycle.
void add_piece(gm_mesh_orders& o, double u0, double u1, const double f0[2], const double f1[2]) {
  for (int sig = 0; sig < 2; ++sig)
    for (int k = 1; k <= GM_MESH_ORDERS; ++k) {
      double c, sn;
      linear_fourier(u0, u1, f0[sig], f1[sig], k, &c, &sn);
      o.sums[sig][k - 1][0] += c / kPi;
      o.sums[sig][k - 1][1] += sn / kPi;
    }
}

void close_cycle(gm_mesh_orders& o) {
  for (int sig = 0; sig < 2; ++sig)
    for (int k = 0; k < GM_MESH_ORDERS; ++k)
      for (int j = 0; j < 2; ++j) o.ring[o.ring_next][sig][k][j] = o.sums[sig][k][j];
  o.ring_next = (o.ring_next + 1) % GM_ORDER_CYCLES_MAX;
  o.ring_count = std::min(o.ring_count + 1, GM_ORDER_CYCLES_MAX);
  clear_sums(o);
}

}  // namespace

void orders_reset(gm_mesh_orders& o) {
  o = gm_mesh_orders{};
}

void orders_add(gm_mesh_orders& o, int z1, const OrderPoint& a, const OrderPoint& b) {
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
    double fe[2];
    for (int sig = 0; sig < 2; ++sig) fe[sig] = f0[sig] + (f1[sig] - f0[sig]) * (end - u0) / (u1 - u0);
    if (o.open) add_piece(o, u0, end, f0, fe);
    if (end == boundary) {  // a cycle ends here: closed if it began at a boundary, and a new one opens
      if (o.open) close_cycle(o);
      o.open = 1;
      o.open_from = boundary;
      clear_sums(o);
    }
    u0 = end;
    f0[0] = fe[0];
    f0[1] = fe[1];
  }
}

void orders_publish(gm_mesh_orders& o, int window) {
  const int n = std::min(std::max(window, 1), o.ring_count);
  o.cycles = n;
  for (int sig = 0; sig < 2; ++sig)
    for (int k = 0; k < GM_MESH_ORDERS; ++k) {
      double A = 0, B = 0;
      for (int i = 0; i < n; ++i) {
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
