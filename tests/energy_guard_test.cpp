// No energy gain for the default integrator: its linearised backward-Euler step, where bonds turn
// far in one step, would end with more energy than it started with plus the external work; the
// step is then retaken in substeps, each split again while it would create energy
// (Simulation::retake_gaining_step, docs/integrators.md "No energy gain"). And a run of any
// integrator that gains energy says so (Simulation::energy_gain, BlowupLimits::energy_gain).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <numbers>

#include "qbond/analysis/analysis.hpp"
#include "qbond/io/scene.hpp"
#include "qbond/simulation/simulation.hpp"
#include "test_util.hpp"

namespace qbond {
namespace {

namespace fs = std::filesystem;
const fs::path kScenes = fs::path(__FILE__).parent_path().parent_path() / "scenes";

// E − (E(0) + loads' and anchors' work) after each step, the largest over the run [J], and the
// scale it is compared with: the largest of E(0)'s kinetic + bond energy and the gravity work.
struct Gain {
  double largest = -HUGE_VAL;  // largest E(t) − E(0) − W
  double step = -HUGE_VAL;     // largest gain of one step over its own start plus its work
  double scale = 0;
  int substeps = 0;            // substeps the integrator took, over the run
  Vec3 momentum = Vec3::Zero();
};

Gain run(Simulation& sim, int steps) {
  Gain g;
  const EnergyBudget b0 = energy_budget(sim.world().model, sim.world().state);
  g.scale = b0.now.kinetic + b0.now.bonds;
  for (int k = 0; k < steps; ++k) {
    const EnergyBudget before = energy_budget(sim.world().model, sim.world().state);
    const StepReport r = sim.step();
    EXPECT_EQ(r.status, StepReport::Status::ok) << r.message;
    const EnergyBudget b = energy_budget(sim.world().model, sim.world().state);
    const double work = b.work_loads + b.work_anchors;
    g.largest = std::max(g.largest, b.now.total() - b.initial_total - work);
    g.step = std::max(g.step, b.now.total() - before.now.total() - (work - before.work_loads - before.work_anchors));
    g.scale = std::max(g.scale, std::abs(b.now.gravity - b0.now.gravity));
    g.substeps += sim.integrator().stats().substeps;
  }
  g.momentum = linear_momentum(sim.world().model, sim.world().state);
  return g;
}

Simulation from_scene(const char* file, double h) {
  Scene s = load_scene(kScenes / file);
  return Simulation(std::move(s.world), s.integrator, h);
}

// The solve's tolerance (CG at relative residual 1e-6) bounds what a converged step may appear
// to gain; the gains the guard removes are of the order of the energy itself.
constexpr double kSlack = 1e-8;

TEST(EnergyGuard, FourQuantaNeverGainAtLargeSteps) {
  for (double h : {0.1, 1.0, 5.0}) {
    Simulation sim = from_scene("four_quanta.json", h);
    const Gain g = run(sim, 200);
    EXPECT_LE(g.largest, kSlack * g.scale) << "h = " << h;
    EXPECT_LE(g.step, kSlack * g.scale) << "h = " << h;
    EXPECT_LT(g.momentum.norm(), 1e-9) << "h = " << h;  // it starts at rest as a whole
    if (h == 5.0) {
      EXPECT_GT(g.substeps, 0);  // the guard acted
    }
  }
}

TEST(EnergyGuard, WithoutTheLedgerTheLinearisedStepGains) {
  // What the guard prevents: the bare step (no energy ledger, hence no guard) at h = 5 s takes
  // the four quanta from 2 J to tens of joules in one step.
  Simulation sim = from_scene("four_quanta.json", 5.0);
  sim.set_track_energy(false);
  const double e0 = energies(sim.world().model, sim.world().state).total();
  sim.step();
  EXPECT_GT(energies(sim.world().model, sim.world().state).total(), 10 * e0);
}

TEST(EnergyGuard, GalileanInvariant) {
  // The same four quanta carried at 3 m/s: the same motion relative to the moving frame (the
  // guard's decisions depend on energy changes, which a uniform velocity does not alter when the
  // momentum does not change).
  const double h = 5.0;
  Simulation a = from_scene("four_quanta.json", h), b = from_scene("four_quanta.json", h);
  const Vec3 V(3, -1, 2);
  for (Vec3& v : b.world().state.v) v += V;
  for (int k = 0; k < 20; ++k) {
    a.step();
    b.step();
  }
  const double t = a.world().state.time;
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_LT((b.world().state.x[i] - V * t - a.world().state.x[i]).norm(), 1e-9 * V.norm() * t);
    EXPECT_LT((b.world().state.v[i] - V - a.world().state.v[i]).norm(), 1e-9 * V.norm());
  }
}

TEST(EnergyGuard, SpinningFreeLatticeOneTurnPerFrame) {
  // A free 4×4×4 lattice spinning at one turn per frame (h = 1/60 s, 120π rad/s).
  World w = test::lattice(4, 4, 4, 1000, 1e-3, 0.01, false);
  Vec3 c = Vec3::Zero();
  for (const Vec3& x : w.state.x) c += x;
  c /= static_cast<double>(w.state.x.size());
  const Vec3 omega(0, 0, 2 * std::numbers::pi * 60);
  for (std::size_t i = 0; i < w.state.x.size(); ++i) w.state.v[i] = omega.cross(w.state.x[i] - c);
  Simulation sim(std::move(w), default_integrator(), 1.0 / 60);
  const Gain g = run(sim, 30);
  EXPECT_GT(g.substeps, 0);  // the guard acted
  EXPECT_LE(g.largest, kSlack * g.scale);
  EXPECT_LE(g.step, kSlack * g.scale);
  EXPECT_LT(g.momentum.norm(), 1e-9);
}

TEST(EnergyGuard, PendulumAtFrameSteps) {
  Simulation sim = from_scene("pendulum.json", 1.0 / 60);
  const Gain g = run(sim, 180);
  EXPECT_LE(g.largest, kSlack * g.scale);
  EXPECT_LE(g.step, kSlack * g.scale);
}

TEST(EnergyGain, HybridSweepOnThePendulumIsReported) {
  // One sweep a step on the pendulum at 1/60 s pumps energy: the Simulation reports it, and with
  // stop_on_energy_gain the step that exceeds the limit fails.
  Scene s = load_scene(kScenes / "pendulum.json");
  IntegratorConfig cfg = s.integrator;
  cfg.type = IntegratorType::hybrid_implicit;
  cfg.neighbours = NeighbourModel::sweep;
  Simulation sim(std::move(s.world), cfg, 1.0 / 60);
  for (int k = 0; k < 180 && !sim.energy_gain().exceeded; ++k) sim.step();
  ASSERT_TRUE(sim.energy_gain().exceeded);
  EXPECT_GT(sim.energy_gain().relative, sim.limits().energy_gain);

  Scene s2 = load_scene(kScenes / "pendulum.json");
  Simulation stop(std::move(s2.world), cfg, 1.0 / 60);
  stop.limits().stop_on_energy_gain = true;
  StepReport r;
  for (int k = 0; k < 180 && r.status == StepReport::Status::ok; ++k) r = stop.step();
  EXPECT_EQ(r.status, StepReport::Status::blowup);
  EXPECT_NE(r.message.find("energy gained"), std::string::npos) << r.message;
}

TEST(EnergyGain, DefaultPendulumIsNotReported) {
  Simulation sim = from_scene("pendulum.json", 1.0 / 60);
  for (int k = 0; k < 180; ++k) sim.step();
  EXPECT_FALSE(sim.energy_gain().exceeded);
  EXPECT_LE(sim.energy_gain().largest, 0.0 + 1e-9);
}

}  // namespace
}  // namespace qbond
