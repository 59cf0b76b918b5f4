// The adaptive timestep (adaptive.hpp): the embedded error estimate against the exact local error,
// and the controller on a system that blows up at a fixed step.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>

#include "qbond/integrators/adaptive.hpp"
#include "qbond/analysis/analysis.hpp"
#include "qbond/builders/samples.hpp"
#include "qbond/io/checkpoint.hpp"
#include "qbond/io/files.hpp"
#include "qbond/simulation/runner.hpp"
#include "test_util.hpp"

namespace qbond {
namespace {

// Backward Euler's local position error is (h²/2)|a| to leading order, and the estimate
// h|Δv|/2 → (h²/2)|a| as h → 0: their ratio tends to 1 (off by O(hω)).
TEST(Adaptive, EstimateMatchesBackwardEulersLocalError) {
  const double m = 1, k = 100, L = 1, s0 = 0.01;  // relative ω = √(2k/m)
  const double w = std::sqrt(2 * k / m);
  for (const double h : {1e-3, 1e-4}) {
    World world = test::two_quanta(m, k, L, s0, 0);
    const Projection p = test::project_once(world, test::coupled(CoupledSolver::ldlt), h);
    // Exact: the stretch s(t) = s0 cos ωt, each quanta moving ∓ s/2.
    const double exact_dx1 = 0.5 * s0 * (std::cos(w * h) - 1);
    const double err = std::abs(p.dx[1].x() - exact_dx1);
    const double est = step_error(world.model, world.state, p, h);
    EXPECT_NEAR(est / err, 1.0, 3 * w * h) << "h = " << h;
  }
}

// Velocity Verlet on the pendulum at 3× its stability limit blows up at the fixed step; the
// controller finishes the same second, keeps the energy drift under its tolerance, and lands
// exactly on the end time.
TEST(Adaptive, FinishesWhatTheFixedStepBlowsUp) {
  World w = test::lattice(4, 3, 3, 5e4, 0.2, 0.5, true, Vec3(0, 0, -9.81));
  test::perturb(w, 1e-4, 0.05);
  IntegratorConfig cfg = test::config(IntegratorType::velocity_verlet);
  const double h = 3e-3, t_end = 1.0;  // ω_max ≈ 2·√(2 Σk/m) ≈ 2700/s: stable below ~7e-4 s
  {
    Simulation fixed(w, cfg, h);
    bool blew_up = false;
    for (double t = 0; t < t_end && !blew_up; t += h) blew_up = fixed.step().status != StepReport::Status::ok;
    EXPECT_TRUE(blew_up);
  }
  AdaptiveConfig a;
  a.enabled = true;
  a.error = 1e-5;
  a.energy = 1e-2;
  a.horizon = t_end;
  Simulation sim(w, cfg, h);
  int steps = 0, rejected = 0;
  double smallest = h, largest = 0;
  while (sim.world().state.time < t_end) {
    const AdaptiveReport r = adaptive_step(sim, a, t_end);
    ASSERT_EQ(r.step.status, StepReport::Status::ok) << r.step.message;
    EXPECT_LE(r.error, a.error);
    ++steps, rejected += r.rejected;
    smallest = std::min(smallest, r.h), largest = std::max(largest, r.h);
  }
  EXPECT_EQ(sim.world().state.time, t_end);
  EXPECT_GT(rejected, 0);
  EXPECT_LT(smallest, h / 3);  // it had to go below the stability limit
  const EnergyBudget b = energy_budget(sim.world().model, sim.world().state);
  const double scale = std::max(std::abs(b.initial_total), b.now.kinetic + b.now.bonds);
  EXPECT_LE(std::abs(b.dissipated_numerical), a.energy * scale);
  std::printf("adaptive Verlet: %d steps (%d rejected), h in [%.3g, %.3g] s, numerical energy %.3g of %.3g J\n", steps,
              rejected, smallest, largest, b.dissipated_numerical, scale);
}

// A step the controller undoes after it applied leaves no trace: the carry-over (Verlet's forces,
// BDF2's history, CG's guesses) comes back with the state, so the accepted retry is the step a run
// from the state before takes with the retried length, bit for bit, carry-over included.
TEST(Adaptive, UndoneStepsRestoreTheCarryOver) {
  World w = test::lattice(4, 3, 3, 5e4, 0.2, 0.5, true, Vec3(0, 0, -9.81));
  test::perturb(w, 1e-4, 0.05);
  for (const auto& [name, cfg] : test::carrying_integrators()) {
    AdaptiveConfig a;
    a.enabled = true;
    a.error = HUGE_VAL;  // no rejection before a step applies: every one is an undo
    a.energy = 1e-4;
    Simulation sim(w, cfg, 3e-3);
    int undone = 0;
    for (int k = 0; k < 40; ++k) {
      const World before = sim.world();
      const AdaptiveReport r = adaptive_step(sim, a, 1.0);
      ASSERT_EQ(r.step.status, StepReport::Status::ok) << name << ": " << r.step.message;
      if (r.rejected == 0) continue;
      ++undone;
      Simulation replay(before, cfg, r.h);
      replay.step();
      test::expect_same_bits(replay.world().state, sim.world().state);
      EXPECT_TRUE(replay.world().state.carry == sim.world().state.carry) << name << ", step " << k;
      EXPECT_FALSE(std::holds_alternative<std::monostate>(sim.world().state.carry)) << name;
    }
    EXPECT_GT(undone, 0) << name;
  }
}

// An adaptive run stopped and resumed from its checkpoint goes on as if it had never stopped:
// the controller's next step and last step travel in the checkpoint, so the rows after the stop
// (their timestep column included) and the end state are those of the uninterrupted run.
TEST(Adaptive, ResumedRunsContinueBitForBit) {
  namespace fs = std::filesystem;
  const fs::path root = fs::temp_directory_path() / ("qbond_adaptive_resume_" + std::to_string(::getpid()));
  fs::remove_all(root);
  auto run = [&](const std::string& name, const std::function<bool()>& stop) {
    Scene scene = builtin_scene("adaptive_pendulum");
    RunSettings rs = settings_of(scene);
    rs.out_dir = root / name;
    rs.every = 7;
    rs.vtk = false;
    Runner r(std::move(scene), rs);
    return r.run(stop);
  };
  ASSERT_EQ(run("whole", {}).status, RunStatus::completed);
  int calls = 0;
  ASSERT_EQ(run("halves", [&] { return ++calls == 333; }).status, RunStatus::stopped);
  Runner resumed = Runner::resume(root / "halves" / "checkpoint.qbc");
  EXPECT_EQ(resumed.settings().out_dir, root / "halves");
  ASSERT_EQ(resumed.run().status, RunStatus::completed);
  const Checkpoint a = load_checkpoint(root / "whole" / "checkpoint.qbc");
  const Checkpoint b = load_checkpoint(root / "halves" / "checkpoint.qbc");
  EXPECT_EQ(serialize_state(a.state), serialize_state(b.state));
  EXPECT_EQ(nlohmann::json::parse(a.metadata)["adaptive"], nlohmann::json::parse(b.metadata)["adaptive"]);
  EXPECT_EQ(read_file(root / "whole" / "diagnostics.csv"), read_file(root / "halves" / "diagnostics.csv"));
  EXPECT_GT(a.state.step, 333u);
}

}  // namespace
}  // namespace qbond
