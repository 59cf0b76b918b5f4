// A world of fewer than kParallelMin quanta steps on the calling thread alone: no pass of its
// step, the bond passes included (bond_pass_threads), starts OpenMP's threads, which would
// otherwise spin between steps on the other cores for a few microseconds of shared work. A
// larger world does start them, which shows that the count below sees them.
//
// Counts the process's threads in /proc/self/task (Linux). Its own executable, one test: OpenMP
// keeps its threads once started, so the process must not have stepped a large world before.
#include <gtest/gtest.h>

#include <filesystem>

#include "core/parallel.hpp"
#include "qbond/heuristics/fracture.hpp"
#include "qbond/builders/samples.hpp"
#include "qbond/simulation/simulation.hpp"

namespace qbond {
namespace {

std::size_t process_threads() {
  std::size_t n = 0;
  for ([[maybe_unused]] const auto& task : std::filesystem::directory_iterator("/proc/self/task")) ++n;
  return n;
}

// A few steps of the canonical lattice on two threads as `qbond run` takes them (energy ledger
// on) under a break rule: the step's quanta passes, its bond passes (integrator, ledger, rule).
void step_canonical(int n, IntegratorType type) {
  Scene scene = canonical_lattice(n);
  scene.integrator.type = type;
  scene.integrator.threads = 2;
  Simulation sim(std::move(scene.world), scene.integrator, scene.timestep);
  sim.add_heuristic(make_heuristic(BreakRule{.max_strain = 0.5}));
  for (int k = 0; k < 3; ++k) ASSERT_EQ(sim.step().status, StepReport::Status::ok);
}

TEST(Threads, ASmallWorldStartsNoThreadAndALargeOneDoes) {
  const std::size_t before = process_threads();  // 1, or a sanitizer's own
  // 10³: 1 000 quanta, 7 560 bonds, enough for the bond sums to split into chunks.
  ASSERT_LT(canonical_lattice(10).world.num_quanta(), kParallelMin);
  for (IntegratorType type : {IntegratorType::coupled_implicit, IntegratorType::velocity_verlet,
                              IntegratorType::hybrid_implicit, IntegratorType::energy_momentum})
    step_canonical(10, type);
  EXPECT_EQ(process_threads(), before);
  step_canonical(16, IntegratorType::velocity_verlet);  // 4 096 quanta
  EXPECT_GT(process_threads(), before);
}

}  // namespace
}  // namespace qbond
