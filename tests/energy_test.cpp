// Energy: velocity Verlet's bounded error, the energy ledger's accounts, and the sign of the
// implicit integrators' numerical dissipation.
#include <gtest/gtest.h>

#include <cmath>

#include "test_util.hpp"

namespace qbond {
namespace {

using test::coupled;
using test::hybrid;

// The paper's four bonded quanta (Figs. 6–7): a square with both diagonals, set moving.
World four_quanta(double damping) {
  World w;
  const double a = 1.0;
  w.add_quanta(Vec3(0, 0, 0), Vec3(0.3, 0.1, 0), 1.0);
  w.add_quanta(Vec3(a, 0, 0), Vec3(-0.2, 0.2, 0.1), 1.0);
  w.add_quanta(Vec3(a, a, 0), Vec3(0, -0.3, 0), 1.0);
  w.add_quanta(Vec3(0, a, 0), Vec3(0.1, 0, -0.1), 1.0);
  const BondSpec s{.law = Law::linear, .stiffness = 10.0, .damping = damping};
  for (auto [i, j] : {std::pair{0, 1}, {1, 2}, {2, 3}, {3, 0}, {0, 2}, {1, 3}}) w.add_bond(i, j, s);
  return w;
}

TEST(VelocityVerlet, EnergyErrorBoundedWithoutDriftOver100000Steps) {
  const double h = 0.01;  // ω_max ≈ sqrt(4k/m) ≈ 6.3: h ω ≈ 0.06
  Simulation sim(four_quanta(0.0), test::config(IntegratorType::velocity_verlet), h);
  const double e0 = energies(sim.world().model, sim.world().state).total();
  const int steps = 100000, decile = steps / 10;
  double first = 0, last = 0, worst = 0;
  for (int n = 0; n < steps; ++n) {
    sim.step();
    const double err = std::abs(energies(sim.world().model, sim.world().state).total() - e0) / e0;
    worst = std::max(worst, err);
    if (n < decile) first = std::max(first, err);
    if (n >= steps - decile) last = std::max(last, err);
  }
  RecordProperty("max_relative_energy_error", std::to_string(worst));
  // Second order: the error oscillates with amplitude O((h ω)²) ≈ 4e-3 and does not grow.
  EXPECT_LT(worst, 4e-3);
  EXPECT_LT(last, 1.5 * first) << "energy error drifts: first decile " << first << ", last " << last;
}

// With an accurate explicit integrator the integrator's own dissipation is negligible, so the
// ledger's loads, anchors and damping accounts must close the budget on their own.
TEST(EnergyLedger, AccountsCloseTheBudgetWithRk4) {
  World w = test::lattice(4, 2, 2, 200, 1e-3, 0.02, false, Vec3(0, 0, -9.81));
  std::vector<Index> end, start;
  for (std::size_t i = 0; i < w.num_quanta(); ++i) {
    if (w.state.x[i].x() == 0.0) start.push_back(static_cast<Index>(i));
    if (w.state.x[i].x() > 0.025) end.push_back(static_cast<Index>(i));
  }
  Motion twist;
  twist.type = MotionType::rotate;
  twist.axis = Vec3::UnitX();
  twist.center = Vec3(0, 0.005, 0.005);
  twist.rate = 2.0;
  w.prescribe(start, twist);
  w.add_load(end, Vec3(0.0, 0.02, 0.01));
  Simulation sim(std::move(w), test::config(IntegratorType::rk4), 2e-5);
  for (int n = 0; n < 5000; ++n) sim.step();
  const EnergyBudget b = energy_budget(sim.world().model, sim.world().state);
  const double scale = std::abs(b.work_anchors) + std::abs(b.work_loads) + b.dissipated_damping;
  EXPECT_GT(std::abs(b.work_anchors), 0.0);
  EXPECT_GT(std::abs(b.work_loads), 0.0);
  EXPECT_GT(b.dissipated_damping, 0.0);
  EXPECT_LT(std::abs(b.dissipated_numerical), 1e-3 * scale)
      << "anchors " << b.work_anchors << " loads " << b.work_loads << " damping " << b.dissipated_damping;
}

// A 1D chain moving along its axis is a linear system. Backward Euler (coupled, direct solver)
// satisfies E₁ - E₀ = -h v₁ᵀC v₁ - ½|Δv|²_M - ½|Δx|²_K, so after charging the dampers at v₁ the
// integrator's loss is ≥ 0 every step, all of it in `numerical_damping` (the remainder is
// round-off); the frozen hybrid only removes energy too, all of it in `numerical`.
TEST(EnergyLedger, NumericalDissipationNeverNegativeOnAxialChain) {
  for (double hw : {0.5, 5.0, 50.0}) {
    for (const auto& [name, cfg] : {std::pair{"frozen", hybrid(NeighbourModel::frozen)},
                                    std::pair{"coupled_dense", coupled(CoupledSolver::dense)},
                                    std::pair{"coupled_ldlt", coupled(CoupledSolver::ldlt)}}) {
      World w;
      Chain c;
      c.count = 12;
      c.end = Vec3(0.11, 0, 0);
      c.quanta_mass = 1e-3;
      c.bond = {.law = Law::linear, .stiffness = 1000.0, .damping = 0.005};
      add_chain(w, c);
      Rng rng{11};
      for (auto& v : w.state.v) v = Vec3(0.5 + 0.2 * rng.uniform(), 0, 0);
      for (std::size_t i = 1; i + 1 < w.num_quanta(); ++i) w.state.x[i].x() += 1e-4 * (rng.uniform() - 0.5);
      Simulation sim(std::move(w), cfg, hw / std::sqrt(1000.0 / 1e-3));
      double prev = 0, worst = 0;
      const double e0 = energies(sim.world().model, sim.world().state).total();
      for (int n = 0; n < 2000; ++n) {
        sim.step();
        const EnergyBudget b = energy_budget(sim.world().model, sim.world().state);
        const double num = b.integrator_loss();
        worst = std::min(worst, num - prev);
        prev = num;
        if (cfg.type == IntegratorType::coupled_implicit)
          ASSERT_LE(std::abs(b.dissipated_numerical), 1e-12 * e0) << name << " h ω = " << hw << " step " << n;
        else
          ASSERT_EQ(b.numerical_damping, 0.0) << name;
      }
      EXPECT_GE(worst, -1e-13 * e0) << name << " h ω = " << hw;
    }
  }
}

}  // namespace
}  // namespace qbond
