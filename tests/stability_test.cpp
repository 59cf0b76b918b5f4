// The paper's central claim: implicit integration stays stable on stiff lattices at steps where
// explicit integration blows up.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
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

TEST(Stability, BlowupKeepsTheLastGoodState) {
  // Explicit Euler at h ω = 100: the step that would go non-finite or too fast is refused.
  Simulation sim(test::lattice(3, 3, 3, 1000, 1e-3, 0.0, false), test::config(IntegratorType::explicit_euler), 0.1);
  test::perturb(sim.world(), 1e-4, 0.0);
  sim.limits().energy_growth = 1e300;  // leave it to the projection check
  StepReport r;
  for (int n = 0; n < 10000 && r.status == StepReport::Status::ok; ++n) r = sim.step();
  ASSERT_EQ(r.status, StepReport::Status::blowup);
  for (const Vec3& v : sim.world().state.v) EXPECT_TRUE(v.allFinite());
  EXPECT_NE(r.message.find("quanta"), std::string::npos);
}

// The projection check on its own: a free quanta faster than the limit, or a position or velocity
// that would go non-finite, stops the step and leaves the world as it was; a prescribed quanta
// may move faster than the limit.
TEST(Stability, ProjectionCheckStopsTooFastAndNonFiniteSteps) {
  auto world = [](Vec3 x_free, Vec3 v_free) {
    World w;
    w.add_quanta(x_free, v_free, 1.0);
    const Index k = w.add_quanta(Vec3(1, 0, 0), Vec3::Zero(), 1.0);
    Motion fast;
    fast.type = MotionType::translate;
    fast.velocity = Vec3(5, 0, 0);
    w.prescribe({k}, fast);
    return w;
  };
  auto first_step = [](World w) {
    Simulation sim(w, test::config(IntegratorType::symplectic_euler), 0.01);
    sim.limits().max_speed = 2;
    sim.limits().energy_growth = 1e300;  // leave it to the projection check
    const StepReport r = sim.step();
    if (r.status != StepReport::Status::ok) {
      EXPECT_EQ(std::memcmp(sim.world().state.x.data(), w.state.x.data(), 2 * sizeof(Vec3)), 0);
      EXPECT_EQ(sim.world().state.step, 0u);
    }
    return r;
  };
  EXPECT_EQ(first_step(world(Vec3::Zero(), Vec3(1.9, 0, 0))).status, StepReport::Status::ok);
  const StepReport fast = first_step(world(Vec3::Zero(), Vec3(0, 2.1, 0)));
  EXPECT_EQ(fast.status, StepReport::Status::blowup);
  EXPECT_EQ(fast.worst, 0u);
  const StepReport nan = first_step(world(Vec3(0, std::nan(""), 0), Vec3::Zero()));
  EXPECT_EQ(nan.status, StepReport::Status::blowup);
  EXPECT_NE(nan.message.find("non-finite"), std::string::npos) << nan.message;
}

// The projection check is a reduction over chunks of quanta: any thread count names the same
// quanta (the fastest free one, the first of equals) at the same step. 20³ quanta, so the chunks
// really run on several threads.
TEST(Stability, BlowupReportIsTheSameOnAnyThreadCount) {
  auto first_blowup = [](int threads) {
    IntegratorConfig c = test::config(IntegratorType::explicit_euler);
    c.threads = threads;
    Simulation sim(test::lattice(20, 20, 20, 1000, 1e-3, 0.0, false), c, 0.02);
    test::perturb(sim.world(), 1e-4, 0.0);
    sim.limits().energy_growth = 1e300;  // leave it to the projection check
    StepReport r;
    for (int n = 0; n < 1000 && r.status == StepReport::Status::ok; ++n) r = sim.step();
    return r;
  };
  const StepReport one = first_blowup(1);
  ASSERT_EQ(one.status, StepReport::Status::blowup);
  for (int threads : {2, 3}) {
    const StepReport many = first_blowup(threads);
    EXPECT_EQ(many.message, one.message) << threads << " threads";
    EXPECT_EQ(many.worst, one.worst) << threads << " threads";
  }
}

TEST(Stability, FirstExplicitStepFromRestIsNotABlowup) {
  // Gravity gives velocity before it moves anything: the first step stores kinetic energy while
  // gravity has done no work yet. That is not a runaway.
  for (auto t : {IntegratorType::explicit_euler, IntegratorType::symplectic_euler}) {
    Simulation sim(test::lattice(3, 3, 3, 1000, 1e-3, 0.01, true, Vec3(0, 0, -9.81)), test::config(t), 1e-5);
    for (int n = 0; n < 100; ++n) ASSERT_EQ(sim.step().status, StepReport::Status::ok) << to_string(t) << " step " << n;
  }
}

}  // namespace
}  // namespace qbond
