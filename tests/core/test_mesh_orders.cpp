// The mesh orders' Fourier integration (mesh_orders.cpp) against the closed form of a sampled
// signal: a sum of cosines f(u) = c + sum_k a_k cos(k u + psi_k), sampled N times per mesh cycle
// and joined linearly in u (as the integrator's stage points are), has at order k the
// coefficient a_k sinc^2(k du / 2), du = 2 pi / N, with the phase psi_k kept (the transfer
// function of linear interpolation; no aliasing while the orders stay below N / 2).
#include <gtest/gtest.h>

#include <cmath>

#include "mesh_orders.hpp"

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kTeeth = 19;           // z1: u = z1 phi1
constexpr int kPerCycle = 64;        // samples per mesh cycle
constexpr int kSignalOrders = 9;     // orders in the signal, one more than any test reads

double amplitude(int k) { return 1e-6 / k; }
double phase(int k) { return 0.3 * k - 1.0; }
double signal(double u, double scale) {
  double f = 4e-6;
  for (int k = 1; k <= kSignalOrders; ++k) f += scale * amplitude(k) * std::cos(k * u + phase(k));
  return f;
}

// Run `cycles` mesh cycles forward from u0 (a point off the cycle boundaries), both signals the
// test signal (the force's scaled by 1e6), and publish `orders` orders over `window` cycles.
gm_mesh_orders run(int orders, int window, int cycles, double u0 = 0.37) {
  gm_mesh_orders o{};
  gm::orders_reset(o);
  const double du = 2 * kPi / kPerCycle;
  auto point = [](double u) { return gm::OrderPoint{u / kTeeth, {signal(u, 1.0), signal(u, 1e6)}}; };
  // the start point, then the samples on the grid u = j du after it (a boundary every kPerCycle)
  gm::OrderPoint a = point(u0);
  const int first = static_cast<int>(std::floor(u0 / du)) + 1;
  for (int j = first; j <= first + cycles * kPerCycle; ++j) {
    const gm::OrderPoint b = point(j * du);
    gm::orders_add(o, kTeeth, orders, a, b);
    a = b;
  }
  gm::orders_publish(o, window, orders);
  return o;
}

double sinc2(double x) { return std::pow(std::sin(x) / x, 2); }

TEST(MeshOrders, EqualTheClosedFormOfTheSampledSignal) {
  const int orders = 8;
  const gm_mesh_orders o = run(orders, 4, 6);
  EXPECT_EQ(o.cycles, 4);
  EXPECT_EQ(o.orders, orders);
  const double du = 2 * kPi / kPerCycle;
  for (int k = 1; k <= orders; ++k) {
    const double expected = amplitude(k) * sinc2(k * du / 2);
    EXPECT_NEAR(o.te_amplitude[k - 1], expected, 1e-12 * amplitude(1)) << k;
    EXPECT_NEAR(o.force_amplitude[k - 1], 1e6 * expected, 1e-6 * amplitude(1)) << k;
    EXPECT_NEAR(std::remainder(o.te_phase[k - 1] - phase(k), 2 * kPi), 0.0, 1e-9) << k;
  }
  for (int k = orders; k < GM_MESH_ORDERS_MAX; ++k) {  // past dynamics.mesh_orders: none
    EXPECT_EQ(o.te_amplitude[k], 0.0) << k + 1;
    EXPECT_EQ(o.force_phase[k], 0.0) << k + 1;
  }
}

TEST(MeshOrders, MoreOrdersLeaveTheFirstOnesBitForBit) {
  const gm_mesh_orders three = run(3, 4, 6), twelve = run(GM_MESH_ORDERS_MAX, 4, 6);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(three.te_amplitude[k], twelve.te_amplitude[k]) << k + 1;
    EXPECT_EQ(three.te_phase[k], twelve.te_phase[k]) << k + 1;
    EXPECT_EQ(three.force_amplitude[k], twelve.force_amplitude[k]) << k + 1;
  }
  const double du = 2 * kPi / kPerCycle;  // the orders past 3: the signal's last, and none past it
  EXPECT_NEAR(twelve.te_amplitude[kSignalOrders - 1], amplitude(kSignalOrders) * sinc2(kSignalOrders * du / 2),
              1e-12 * amplitude(1));
  EXPECT_LT(twelve.te_amplitude[GM_MESH_ORDERS_MAX - 1], 1e-12 * amplitude(1));
}

TEST(MeshOrders, AnOpenCycleCountsOnlyWhenItCloses) {
  // 2.5 cycles from 0.37: the first partial cycle is skipped, one whole cycle closes
  gm_mesh_orders o = run(3, 4, 2);
  EXPECT_EQ(o.cycles, 1);
  o = run(3, 4, 0);
  EXPECT_EQ(o.cycles, 0);
  EXPECT_EQ(o.te_amplitude[0], 0.0);
}

}  // namespace
