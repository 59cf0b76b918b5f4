// Energy restoration (IntegratorConfig::restore_energy, src/integrators/energy_restore.hpp): the velocity
// correction changes the kinetic energy by what is asked and keeps each free component's momenta;
// on a dissipative integrator it closes the energy budget.
#include <gtest/gtest.h>

#include <cmath>

#include "integrators/energy_restore.hpp"
#include "qbond/analysis/analysis.hpp"
#include "test_util.hpp"

namespace qbond {
namespace {

TEST(EnergyRestore, CorrectionChangesKineticEnergyAndKeepsMomenta) {
  // Two free components (a tumbling, vibrating block and a chain) and one anchored block.
  World w = test::lattice(3, 3, 2, 1e3, 0.01, 0, false);
  World chain = test::lattice(4, 1, 1, 1e3, 0.02, 0, false);
  for (std::size_t i = 0; i < chain.num_quanta(); ++i) w.add_quanta(chain.state.x[i] + Vec3(0, 0.2, 0), Vec3::Zero(), 0.02, 1);
  for (std::size_t b = 0; b < chain.num_bonds(); ++b)
    w.add_bond(chain.state.bonds.i[b] + 18, chain.state.bonds.j[b] + 18, {.law = Law::linear, .stiffness = 1e3});
  test::perturb(w, 1e-3, 0.3);
  for (std::size_t i = 0; i < w.num_quanta(); ++i) w.state.v[i] += Vec3(0.1, -0.2, 0.05) + Vec3(0, 0, 2).cross(w.state.x[i]);
  Adjacency adj;
  build_adjacency(w.model, w.state, adj);
  const double k0 = energies(w.model, w.state).kinetic;
  auto momenta = [&](Index first, Index last, Vec3& p, Vec3& l) {
    p.setZero(), l.setZero();
    for (Index i = first; i < last; ++i) {
      p += w.model.mass[i] * w.state.v[i];
      l += w.model.mass[i] * w.state.x[i].cross(w.state.v[i]);
    }
  };
  Vec3 p0, l0, p1, l1, q0, m0, q1, m1;
  momenta(0, 18, p0, l0);
  momenta(18, 22, q0, m0);
  for (const double dk : {0.3 * k0, -0.2 * k0}) {
    const double before = energies(w.model, w.state).kinetic;
    const double lambda = scale_internal_velocities(w.model, adj, w.state, dk * (before / k0));
    EXPECT_NE(lambda, 1.0);
    EXPECT_NEAR(energies(w.model, w.state).kinetic - before, dk * (before / k0), 1e-12 * before);
  }
  momenta(0, 18, p1, l1);
  momenta(18, 22, q1, m1);
  EXPECT_LT((p1 - p0).norm(), 1e-13 * p0.norm() * 10);
  EXPECT_LT((l1 - l0).norm(), 1e-12 * l0.norm() * 10);
  EXPECT_LT((q1 - q0).norm(), 1e-13 * q0.norm() * 10);
  EXPECT_LT((m1 - m0).norm(), 1e-12 * m0.norm() * 10);
}

// Backward Euler (coupled, LDLT) on a vibrating free block at h ω_max ≈ 10 loses most of its
// energy; with restore_energy the total stays at E(0) to round-off and linear momentum is kept.
TEST(EnergyRestore, ClosesTheBudgetOfBackwardEuler) {
  World w = test::lattice(3, 3, 3, 1e3, 0.01, 0, false);
  test::perturb(w, 2e-4, 0.05);
  const double h = 10 / std::sqrt(2 * 18 * 1e3 / 0.01);  // ω_max² ≲ 2 Σk/m (Gershgorin)
  for (const bool restore : {false, true}) {
    IntegratorConfig cfg = test::coupled(CoupledSolver::ldlt);
    cfg.restore_energy = restore;
    Simulation sim(w, cfg, h);
    const double e0 = energies(sim.world().model, sim.world().state).total();
    const Vec3 p0 = linear_momentum(sim.world().model, sim.world().state);
    for (int k = 0; k < 500; ++k) ASSERT_EQ(sim.step().status, StepReport::Status::ok);
    const double e1 = energies(sim.world().model, sim.world().state).total();
    const Vec3 p1 = linear_momentum(sim.world().model, sim.world().state);
    if (restore) {
      EXPECT_NEAR(e1 / e0, 1.0, 1e-9);
      EXPECT_LT((p1 - p0).norm(), 1e-12);
      EXPECT_NEAR(energy_budget(sim.world().model, sim.world().state).dissipated_numerical, 0, 1e-9 * e0);
    } else {
      EXPECT_LT(e1 / e0, 0.5);  // what there is to restore
    }
  }
}

}  // namespace
}  // namespace qbond
