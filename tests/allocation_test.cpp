// "No allocation inside a step" (the fast path, docs/performance.md): once a simulation has made its first
// steps (buffers grown), further steps of the fast integrators allocate nothing.
//
// Counts every malloc family call of the process by interposing malloc, calloc, realloc and
// aligned_alloc/posix_memalign (operator new and Eigen's aligned allocator both end there),
// forwarding to glibc's own entry points. Its own executable: the interposition is
// process-wide. Under AddressSanitizer (which interposes malloc itself) the test is skipped.
#include <gtest/gtest.h>

#include <atomic>
#include <cstddef>

#include "test_util.hpp"

#if defined(__has_feature)  // clang says it so
#if __has_feature(address_sanitizer)
#define QBOND_ASAN 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__) || defined(QBOND_ASAN)
#define QBOND_COUNTS_ALLOCATIONS 0
#else
#define QBOND_COUNTS_ALLOCATIONS 1
#endif

namespace {
std::atomic<long> g_allocations{0};
}  // namespace

#if QBOND_COUNTS_ALLOCATIONS
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);

void* malloc(std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_malloc(n);
}
void* calloc(std::size_t k, std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_calloc(k, n);
}
void* realloc(void* p, std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_realloc(p, n);
}
void* aligned_alloc(std::size_t a, std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_memalign(a, n);
}
int posix_memalign(void** out, std::size_t a, std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  *out = __libc_memalign(a, n);
  return *out ? 0 : 12;  // ENOMEM
}
}
#endif

namespace qbond {
namespace {

struct Case {
  const char* name;
  IntegratorConfig config;
};

std::vector<Case> fast_integrators() {
  IntegratorConfig frozen, sweep, verlet, symplectic, coupled;
  frozen.type = sweep.type = IntegratorType::hybrid_implicit;
  frozen.neighbours = NeighbourModel::frozen;
  sweep.neighbours = NeighbourModel::sweep;
  verlet.type = IntegratorType::velocity_verlet;
  symplectic.type = IntegratorType::symplectic_euler;
  coupled = default_integrator();
  return {{"hybrid_frozen", frozen}, {"hybrid_sweep", sweep}, {"velocity_verlet", verlet},
          {"symplectic_euler", symplectic}, {"default", coupled}};
}

TEST(Allocation, TheCounterSeesAllocations) {
  if (!QBOND_COUNTS_ALLOCATIONS) GTEST_SKIP() << "AddressSanitizer interposes malloc itself";
  const long before = g_allocations.load();
  std::vector<double> v(1000);
  Eigen::VectorXd e(1000);
  EXPECT_GE(g_allocations.load() - before, 2);
}

TEST(Allocation, StepsAfterTheFirstAllocateNothing) {
  if (!QBOND_COUNTS_ALLOCATIONS) GTEST_SKIP() << "AddressSanitizer interposes malloc itself";
  for (const Case& c : fast_integrators())
    for (int threads : {1, 2})
      for (bool ledger : {true, false}) {  // without it the steps advance in place (advance.hpp)
        IntegratorConfig cfg = c.config;
        cfg.threads = threads;
        // Large enough that the passes run in parallel (kParallelMin).
        Simulation sim(test::lattice(24, 16, 12, 1000, 1e-3, 0.01, true, Vec3(0, 0, -9.81)), cfg, 1e-4);
        sim.set_track_energy(ledger);
        for (int k = 0; k < 3; ++k) ASSERT_EQ(sim.step().status, StepReport::Status::ok);
        const long before = g_allocations.load();
        for (int k = 0; k < 10; ++k) ASSERT_EQ(sim.step().status, StepReport::Status::ok);
        EXPECT_EQ(g_allocations.load() - before, 0)
            << c.name << ", " << threads << " thread(s)" << (ledger ? "" : ", no ledger");
      }
}

}  // namespace
}  // namespace qbond
