// The paper's central claim: implicit integration stays stable on stiff lattices at steps where
// explicit integration blows up. 10 000 steps of each integrator: labelled 'long' (seconds in
// Release, minutes under the sanitizers, whose run leaves them out; tests/CMakeLists.txt).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "test_util.hpp"

namespace qbond {
namespace {

using test::coupled;
using test::hybrid;

struct RunResult {
  bool blew_up = false;
  std::string message;
  double max_ratio = 0;  // max over steps of (kinetic + bond energy) / |gravity work so far|
  double final_energy = 0;
};

// A 5×3×3 cantilever (k = 1000 N/m, m = 1 g: sqrt(k/m) = 1000 /s) sagging from rest under gravity.
// The energy it can hold is bounded by the gravity work done on it; the ratio measures overshoot.
RunResult run_cantilever(const IntegratorConfig& cfg, double h_sqrt_k_over_m, int steps) {
  Simulation sim(test::lattice(5, 3, 3, 1000, 1e-3, 0.0, true, Vec3(0, 0, -9.81)), cfg, h_sqrt_k_over_m / 1000);
  sim.limits().energy_growth = 1e6;
  RunResult r;
  for (int n = 0; n < steps; ++n) {
    const StepReport rep = sim.step();
    if (rep.status != StepReport::Status::ok) {
      r.blew_up = true;
      r.message = rep.message;
      return r;
    }
    const Energies e = energies(sim.world().model, sim.world().state);
    const double work = std::abs(e.gravity - sim.world().state.energy.initial_gravity);
    if (work > 0) r.max_ratio = std::max(r.max_ratio, (e.kinetic + e.bonds) / work);
  }
  const Energies e = energies(sim.world().model, sim.world().state);
  r.final_energy = e.kinetic + e.bonds;
  return r;
}

class StiffLattice : public testing::TestWithParam<double> {};

TEST_P(StiffLattice, ImplicitIntegratorsStayBoundedFor10000Steps) {
  const double hw = GetParam();
  // Reference: the exact static sag energy, reached by the direct coupled solver.
  const RunResult ref = run_cantilever(coupled(CoupledSolver::ldlt), hw, 10000);
  ASSERT_FALSE(ref.blew_up) << ref.message;
  // Backward Euler never gains energy: the stored energy stays below the work gravity did.
  EXPECT_LT(ref.max_ratio, 1.0);
  struct Case {
    std::string name;
    IntegratorConfig cfg;
  };
  std::vector<Case> cases = {{"frozen", hybrid(NeighbourModel::frozen)},
                             {"coupled_cg", coupled(CoupledSolver::cg, 1e-6)}};
  for (int it : {1, 2, 4}) cases.push_back({"sweep" + std::to_string(it), hybrid(NeighbourModel::sweep, it)});
  for (const Case& c : cases) {
    const RunResult r = run_cantilever(c.cfg, hw, 10000);
    EXPECT_FALSE(r.blew_up) << c.name << ": " << r.message;
    EXPECT_LT(r.max_ratio, 1.0) << c.name;
    // All settle to the same static sag (frozen and sweeps converge to it too).
    EXPECT_NEAR(r.final_energy, ref.final_energy, 1e-6 * ref.final_energy) << c.name;
    RecordProperty(c.name + "_max_energy_ratio", std::to_string(r.max_ratio));
  }
  // Sweeps started from the external-force prediction overshoot: report how much vs sweeps.
  for (int it : {1, 2, 4, 8}) {
    IntegratorConfig cfg = hybrid(NeighbourModel::sweep, it);
    cfg.warm_start = WarmStart::external;
    const RunResult r = run_cantilever(cfg, hw, 10000);
    EXPECT_FALSE(r.blew_up) << "sweep from external start, " << it << " sweeps: " << r.message;
    std::printf("h·sqrt(k/m) = %g, sweep from dv = h f_ext/m, %d sweep(s): largest energy / gravity work %.3g\n", hw,
                it, r.max_ratio);
    RecordProperty("sweep_external_" + std::to_string(it) + "_max_energy_ratio", std::to_string(r.max_ratio));
  }
}

TEST_P(StiffLattice, ExplicitEulerBlowsUpAndIsDetected) {
  const RunResult r = run_cantilever(test::config(IntegratorType::explicit_euler), GetParam(), 10000);
  EXPECT_TRUE(r.blew_up);
  EXPECT_NE(r.message.find("blow-up at step"), std::string::npos) << r.message;
}

INSTANTIATE_TEST_SUITE_P(Stability, StiffLattice, testing::Values(10.0, 100.0),
                         [](const auto& info) { return "h_omega_" + std::to_string(static_cast<int>(info.param)); });

}  // namespace
}  // namespace qbond
