// A whole gm_evaluate allocates nothing once warm: every stiffness level 0-5, plain and
// quasi-static, with the user tables (stiffness table at level 1, TE table at every level), over
// a sweep of steps that crosses mesh events (pairs entering and leaving) after one warm-up call.
// Its own executable because it replaces the global operator new and delete (every form:
// plain, array, nothrow, aligned; sized and unsized deletes), which must not leak into the main
// core test binary.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <string>
#include <vector>

#include "fe_synthetic.hpp"
#include "gearmesh/gearmesh.h"
#include "test_support.hpp"

namespace {
std::atomic<bool> g_count{false};
std::atomic<long> g_news{0};

void* counted_alloc(std::size_t size) {
  if (g_count.load(std::memory_order_relaxed)) g_news.fetch_add(1, std::memory_order_relaxed);
  return std::malloc(size ? size : 1);
}
void* counted_aligned(std::size_t size, std::align_val_t al) {
  if (g_count.load(std::memory_order_relaxed)) g_news.fetch_add(1, std::memory_order_relaxed);
  const std::size_t a = std::max(static_cast<std::size_t>(al), sizeof(void*));
  const std::size_t n = (size + a - 1) / a * a;
  return std::aligned_alloc(a, n ? n : a);
}
}  // namespace

void* operator new(std::size_t size) {
  if (void* p = counted_alloc(size)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) {
  if (void* p = counted_alloc(size)) return p;
  throw std::bad_alloc();
}
void* operator new(std::size_t size, const std::nothrow_t&) noexcept { return counted_alloc(size); }
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept { return counted_alloc(size); }
void* operator new(std::size_t size, std::align_val_t al) {
  if (void* p = counted_aligned(size, al)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size, std::align_val_t al) {
  if (void* p = counted_aligned(size, al)) return p;
  throw std::bad_alloc();
}
void* operator new(std::size_t size, std::align_val_t al, const std::nothrow_t&) noexcept {
  return counted_aligned(size, al);
}
void* operator new[](std::size_t size, std::align_val_t al, const std::nothrow_t&) noexcept {
  return counted_aligned(size, al);
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept { std::free(p); }

namespace {

using namespace gm_test;

// Gear 1's pitch of a z1 gear sampled by a sine of 1 um (TE table), and a stiffness table over
// gear 1's roll angle (deg, N/(mm um)).
std::string te_table(int z1) {
  std::string s = "gearmesh-te-table 1\n";
  char buf[80];
  for (int k = 0; k < 24; ++k) {
    std::snprintf(buf, sizeof buf, "%.17g %.17g\n", 360.0 / z1 * k / 24,
                  std::sin(2 * kPi * k / 24));
    s += buf;
  }
  return s;
}
const char* const kStiffnessTable = "gearmesh-stiffness-table 1\n17 12\n23 15.5\n29 12\n";

// Allocations of the process while f runs.
template <class F>
long allocations(F&& f) {
  g_news = 0;
  g_count = true;
  f();
  g_count = false;
  return g_news.load();
}

// Through volatile pointers: a new-expression whose result is unused may be elided.
TEST(NoAlloc, TheCounterSeesEveryForm) {
  struct alignas(64) Wide {
    double x[8];
  };
  int* volatile i = nullptr;
  double* volatile a = nullptr;
  std::vector<double>* volatile v = nullptr;
  Wide* volatile w = nullptr;
  EXPECT_EQ(allocations([&] { i = new int(1); }), 1);
  delete i;
  EXPECT_EQ(allocations([&] { a = new double[7]; }), 1);
  delete[] a;
  EXPECT_EQ(allocations([&] { i = new (std::nothrow) int(2); }), 1);
  delete i;
  EXPECT_EQ(allocations([&] { v = new std::vector<double>(9); }), 2);  // the vector, its data
  delete v;
  EXPECT_EQ(allocations([&] { w = new Wide(); }), 1);
  delete w;
  EXPECT_EQ(allocations([&] { w = new Wide[3]; }), 1);
  delete[] w;
}

struct Case {
  int level;
  int quasi_static;
};

class Evaluate : public ::testing::TestWithParam<Case> {};

TEST_P(Evaluate, AllocatesNothingOnceWarm) {
  const Case c = GetParam();
  gm_model_params p = paper();
  p.slices = 5;
  p.quasi_static = c.quasi_static;
  p.stiffness_level = c.level;
  const std::string tag = "l" + std::to_string(c.level) + "q" + std::to_string(c.quasi_static);
  const std::string te_path = write_temp("no_alloc_" + tag + "_te.txt", te_table(p.gear[0].teeth));
  const std::string k_path = write_temp("no_alloc_" + tag + "_k.txt", kStiffnessTable);
  p.te_table = te_path.c_str();
  if (c.level == GM_STIFFNESS_USER_VARIABLE) p.stiffness_table = k_path.c_str();
  std::string db_path[2];
  if (c.level == GM_STIFFNESS_FE) {
    for (int g = 0; g < 2; ++g) {
      std::string msg;
      const gm::ComplianceDb db = smooth_db(p, g, SmoothDbShape{}, msg);
      ASSERT_TRUE(msg.empty()) << msg;
      db_path[g] = write_db("no_alloc_" + tag + "_g" + std::to_string(g + 1) + ".gcdb", db);
    }
    p.compliance[0] = db_path[0].c_str();
    p.compliance[1] = db_path[1].c_str();
  }
  Instance in(p);
  const double pitch = 2 * kPi / p.gear[0].teeth;
  gm_kinematics k{};
  k.load_torque = 150;
  k.omega[0] = 10;
  k.omega[1] = -10 * in.rb(0) / in.rb(1);
  const auto pose = [&](int s) {
    k.phi[0] = 1.5 * pitch * s / 60;
    k.phi[1] = (4e-6 - in.rb(0) * k.phi[0]) / in.rb(1);
    k.u[1][2] = s >= 40 ? 20e-6 : 0;  // an axial motion: level 5's face strips change
  };
  gm_result r{};
  pose(0);
  ASSERT_EQ(gm_evaluate(in.m, in.d, &k, &r), GM_OK) << gm_data_message(in.d);  // warm-up
  for (int s = 1; s <= 60; ++s) {
    pose(s);
    gm_status st = GM_OK;
    const long n = allocations([&] { st = gm_evaluate(in.m, in.d, &k, &r); });
    ASSERT_EQ(st, GM_OK) << gm_data_message(in.d);
    ASSERT_GT(r.normal_force, 0) << "step " << s;
    ASSERT_EQ(n, 0) << "level " << c.level << (c.quasi_static ? " quasi-static" : "")
                    << ": step " << s << " allocated " << n << " times";
  }
}

INSTANTIATE_TEST_SUITE_P(
    EveryLevel, Evaluate,
    ::testing::Values(Case{0, 0}, Case{1, 0}, Case{2, 0}, Case{3, 0}, Case{4, 0}, Case{5, 0},
                      Case{0, 1}, Case{1, 1}, Case{2, 1}, Case{3, 1}, Case{4, 1}, Case{5, 1}),
    [](const ::testing::TestParamInfo<Case>& i) {
      return "level" + std::to_string(i.param.level) + (i.param.quasi_static ? "_quasi" : "_plain");
    });

}  // namespace
