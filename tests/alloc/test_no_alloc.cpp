// A whole gm_evaluate allocates nothing once warm: every stiffness level 0-5, plain and
// quasi-static, with the user tables (stiffness table at level 1, TE table at every level), over
// a sweep of steps that crosses mesh events (pairs entering and leaving) after one warm-up call.
// Its own executable because it replaces the C allocator (malloc, calloc, realloc, free,
// aligned_alloc, posix_memalign, memalign, valloc, pvalloc: glibc's, forwarded to its
// __libc_* entry points) and the global operator new and delete (every form: plain, array,
// nothrow, aligned; sized and unsized deletes; they allocate through the C functions), which must
// not leak into the main core test binary. Counting the C functions is what sees Eigen, whose
// dynamic matrices allocate with malloc, not with operator new. Symbols defined in the executable
// take the place of libc's for every shared library too (libstdc++'s operator new, Eigen's
// aligned_malloc), so every allocation of the process is counted once. glibc only; the test is
// not built with the sanitizers, which replace the allocator themselves (tests/CMakeLists.txt).
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <malloc.h>
#include <new>
#include <string>
#include <vector>

#include "fe_synthetic.hpp"
#include "gearmesh/gearmesh.h"
#include "test_support.hpp"

#if !defined(__GLIBC__)
#error "test_no_alloc.cpp counts allocations through glibc's __libc_malloc family"
#endif

extern "C" {
void* __libc_malloc(std::size_t size);
void* __libc_calloc(std::size_t count, std::size_t size);
void* __libc_realloc(void* p, std::size_t size);
void __libc_free(void* p);
void* __libc_memalign(std::size_t alignment, std::size_t size);
void* __libc_valloc(std::size_t size);
void* __libc_pvalloc(std::size_t size);
}

namespace {
std::atomic<bool> g_count{false};
std::atomic<long> g_allocs{0};  // malloc, calloc, any realloc, the aligned forms (and so new)
std::atomic<long> g_frees{0};   // free of a non-null pointer (and so delete)

void count_alloc() {
  if (g_count.load(std::memory_order_relaxed)) g_allocs.fetch_add(1, std::memory_order_relaxed);
}
void count_free(const void* p) {
  if (p && g_count.load(std::memory_order_relaxed)) g_frees.fetch_add(1, std::memory_order_relaxed);
}
bool power_of_two(std::size_t a) { return a != 0 && (a & (a - 1)) == 0; }
}  // namespace

extern "C" {
void* malloc(std::size_t size) noexcept {
  count_alloc();
  return __libc_malloc(size);
}
void* calloc(std::size_t count, std::size_t size) noexcept {
  count_alloc();
  return __libc_calloc(count, size);
}
void* realloc(void* p, std::size_t size) noexcept {
  count_alloc();
  return __libc_realloc(p, size);
}
void free(void* p) noexcept {
  count_free(p);
  __libc_free(p);
}
void* aligned_alloc(std::size_t alignment, std::size_t size) noexcept {
  count_alloc();
  return __libc_memalign(alignment, size);
}
void* memalign(std::size_t alignment, std::size_t size) noexcept {
  count_alloc();
  return __libc_memalign(alignment, size);
}
int posix_memalign(void** out, std::size_t alignment, std::size_t size) noexcept {
  count_alloc();
  if (alignment % sizeof(void*) != 0 || !power_of_two(alignment)) return EINVAL;
  void* p = __libc_memalign(alignment, size);
  if (!p) return ENOMEM;
  *out = p;
  return 0;
}
void* valloc(std::size_t size) noexcept {
  count_alloc();
  return __libc_valloc(size);
}
void* pvalloc(std::size_t size) noexcept {
  count_alloc();
  return __libc_pvalloc(size);
}
}

namespace {
// operator new and delete through the counted C functions (counted there, once).
void* new_plain(std::size_t size) { return std::malloc(size ? size : 1); }
void* new_aligned(std::size_t size, std::align_val_t al) {
  const std::size_t a = std::max(static_cast<std::size_t>(al), sizeof(void*));
  const std::size_t n = (size + a - 1) / a * a;
  return aligned_alloc(a, n ? n : a);
}
}  // namespace

void* operator new(std::size_t size) {
  if (void* p = new_plain(size)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) {
  if (void* p = new_plain(size)) return p;
  throw std::bad_alloc();
}
void* operator new(std::size_t size, const std::nothrow_t&) noexcept { return new_plain(size); }
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept { return new_plain(size); }
void* operator new(std::size_t size, std::align_val_t al) {
  if (void* p = new_aligned(size, al)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size, std::align_val_t al) {
  if (void* p = new_aligned(size, al)) return p;
  throw std::bad_alloc();
}
void* operator new(std::size_t size, std::align_val_t al, const std::nothrow_t&) noexcept {
  return new_aligned(size, al);
}
void* operator new[](std::size_t size, std::align_val_t al, const std::nothrow_t&) noexcept {
  return new_aligned(size, al);
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

struct Counts {
  long allocs;  // malloc, calloc, realloc, the aligned forms; new through them
  long frees;   // free of a pointer; delete through it
};

// Allocations and frees of the process while f runs.
template <class F>
Counts counted(F&& f) {
  g_allocs = 0;
  g_frees = 0;
  g_count = true;
  f();
  g_count = false;
  return {g_allocs.load(), g_frees.load()};
}
template <class F>
long allocations(F&& f) {
  return counted(f).allocs;
}
template <class F>
long frees(F&& f) {
  return counted(f).frees;
}

// Through volatile pointers: an allocation whose result is unused may be elided.
TEST(NoAlloc, TheCounterSeesEveryForm) {
  struct alignas(64) Wide {
    double x[8];
  };
  int* volatile i = nullptr;
  double* volatile a = nullptr;
  std::vector<double>* volatile v = nullptr;
  Wide* volatile w = nullptr;
  EXPECT_EQ(allocations([&] { i = new int(1); }), 1);
  EXPECT_EQ(frees([&] { delete i; }), 1);
  EXPECT_EQ(allocations([&] { a = new double[7]; }), 1);
  EXPECT_EQ(frees([&] { delete[] a; }), 1);
  EXPECT_EQ(allocations([&] { i = new (std::nothrow) int(2); }), 1);
  delete i;
  EXPECT_EQ(allocations([&] { v = new std::vector<double>(9); }), 2);  // the vector, its data
  EXPECT_EQ(frees([&] { delete v; }), 2);
  EXPECT_EQ(allocations([&] { w = new Wide(); }), 1);
  delete w;
  EXPECT_EQ(allocations([&] { w = new Wide[3]; }), 1);
  delete[] w;
  // the C functions, which operator new never sees
  void* volatile p = nullptr;
  void* q = nullptr;
  EXPECT_EQ(allocations([&] { p = std::malloc(24); }), 1);
  EXPECT_EQ(allocations([&] { p = std::realloc(p, 4096); }), 1);
  const Counts freed = counted([&] { std::free(p); });
  EXPECT_EQ(freed.allocs, 0);
  EXPECT_EQ(freed.frees, 1);
  EXPECT_EQ(frees([&] { std::free(nullptr); }), 0);
  EXPECT_EQ(allocations([&] { p = std::calloc(3, 8); }), 1);
  std::free(p);
  EXPECT_EQ(allocations([&] { p = std::aligned_alloc(64, 128); }), 1);
  std::free(p);
  EXPECT_EQ(allocations([&] { EXPECT_EQ(posix_memalign(&q, 64, 100), 0); }), 1);
  p = q;
  std::free(p);
  EXPECT_EQ(allocations([&] { p = memalign(128, 8); }), 1);
  std::free(p);
  // inside libc: strdup allocates with the replaced malloc
  char* volatile c = nullptr;
  EXPECT_EQ(allocations([&] { c = strdup("gear"); }), 1);
  std::free(c);
  // Eigen's dynamic matrices allocate with malloc (aligned_malloc), not operator new
  Eigen::VectorXd* volatile e = nullptr;
  EXPECT_EQ(allocations([&] { e = new Eigen::VectorXd(100); }), 2);  // the object, its data
  EXPECT_EQ(frees([&] { delete e; }), 2);
  Eigen::VectorXd x = Eigen::VectorXd::Ones(50);
  double volatile sum = 0;
  const Counts temporary = counted([&] {
    const Eigen::VectorXd y = x * 2;
    sum = y.sum();
  });
  EXPECT_EQ(temporary.allocs, 1);
  EXPECT_EQ(temporary.frees, 1);
  EXPECT_EQ(sum, 100);
}

struct Case {
  int level;
  int quasi_static;
  int face_shapes = 3;  // level 5: solver.face_shapes (the default 3: the reduced face basis; 0: every slice)
};

class Evaluate : public ::testing::TestWithParam<Case> {};

TEST_P(Evaluate, AllocatesNothingOnceWarm) {
  const Case c = GetParam();
  gm_model_params p = paper();
  p.slices = 5;
  p.quasi_static = c.quasi_static;
  p.stiffness_level = c.level;
  p.solver_face_shapes = c.face_shapes;
  const std::string tag =
      "l" + std::to_string(c.level) + "q" + std::to_string(c.quasi_static) + "s" + std::to_string(c.face_shapes);
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
    const Counts n = counted([&] { st = gm_evaluate(in.m, in.d, &k, &r); });
    ASSERT_EQ(st, GM_OK) << gm_data_message(in.d);
    ASSERT_GT(r.normal_force, 0) << "step " << s;
    const std::string where = "level " + std::to_string(c.level) + (c.quasi_static ? " quasi-static" : "") +
                              ": step " + std::to_string(s);
    ASSERT_EQ(n.allocs, 0) << where << " allocated " << n.allocs << " times";
    ASSERT_EQ(n.frees, 0) << where << " freed " << n.frees << " times";
  }
}

INSTANTIATE_TEST_SUITE_P(
    EveryLevel, Evaluate,
    ::testing::Values(Case{0, 0}, Case{1, 0}, Case{2, 0}, Case{3, 0}, Case{4, 0}, Case{5, 0},
                      Case{0, 1}, Case{1, 1}, Case{2, 1}, Case{3, 1}, Case{4, 1}, Case{5, 1}, Case{5, 0, 0},
                      Case{5, 1, 0}, Case{5, 0, 4}),
    [](const ::testing::TestParamInfo<Case>& i) {
      return "level" + std::to_string(i.param.level) + (i.param.quasi_static ? "_quasi" : "_plain") +
             (i.param.face_shapes != 3 ? "_face_shapes" + std::to_string(i.param.face_shapes) : "");
    });

}  // namespace
