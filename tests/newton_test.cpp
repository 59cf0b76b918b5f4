// The Newton-solved integrators (src/integrators/newton.hpp): energy_momentum conserves energy and both
// momenta at any step and its ledger closes with damping; polished, both conservative schemes
// keep angular momentum to round-off; a split step is its substeps taken as steps, with the same
// bits for any thread count; implicit_midpoint conserves a quadratic energy exactly; all three
// are second order; their Newton blocks match finite differences; bdf2 resumes from a checkpoint
// bit for bit.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstring>
#include <limits>

#include "integrators/newton.hpp"
#include "core/parallel.hpp"
#include "qbond/io/checkpoint.hpp"
#include "test_util.hpp"

namespace qbond {
namespace {

IntegratorConfig newton(IntegratorType t, CoupledSolver s = CoupledSolver::ldlt, double tol = 1e-12) {
  IntegratorConfig c;
  c.type = t;
  c.solver = s;
  c.tolerance = tol;
  c.newton_iterations = 50;
  return c;
}

// The paper's four-quanta experiment as scenes/four_quanta.json builds it (Figs. 6–7): a regular
// tetrahedron of 1 kg quanta, every pair bonded (k = 100 N/m, rest length the side, 1 m).
World four_quanta(double damping = 0) {
  World w;
  const Vec3 x[4] = {{0, 0, 0}, {1, 0, 0}, {0.5, 0.8660254037844386, 0}, {0.5, 0.28867513459481287, 0.816496580927726}};
  const Vec3 v[4] = {{1, 0, 0}, {-1, 0.5, 0}, {0, -1, 0.5}, {0, 0.5, -0.5}};
  for (int i = 0; i < 4; ++i) w.add_quanta(x[i], v[i], 1.0);
  for (Index i = 0; i < 4; ++i)
    for (Index j = i + 1; j < 4; ++j) w.add_bond(i, j, {.stiffness = 100.0, .damping = damping});
  return w;
}

// A free 3×3×3 lattice (face diagonals, k = 1000 N/m, 1 g quanta), every quanta nudged.
World small_lattice(double damping = 0) {
  World w = test::lattice(3, 3, 3, 1000, 1e-3, damping, false);
  test::perturb(w, 1e-4, 0.05);
  return w;
}


struct Drift {
  double energy = 0, momentum = 0, angular = 0;  // largest relative changes over the run
  double residual = 0;                           // largest Newton residual of a step
  int split = 0, substeps = 0, unconverged = 0;  // steps split, substeps taken, solves not converged
};

// Runs `steps` steps and records the largest relative drift of E, P and L (relative to E(0) and
// to the momenta's natural scales Σ m |v| and Σ m |x − c| |v|).
Drift run(World w, const IntegratorConfig& cfg, double h, int steps) {
  Simulation sim(std::move(w), cfg, h);
  const Model& m = sim.world().model;
  const State& s = sim.world().state;
  const double E0 = energies(m, s).total();
  const Vec3 P0 = linear_momentum(m, s), L0 = angular_momentum(m, s);
  double pscale = 0, lscale = 0;
  for (std::size_t i = 0; i < m.num_quanta(); ++i) {
    pscale += m.mass[i] * s.v[i].norm();
    lscale += m.mass[i] * s.x[i].norm() * s.v[i].norm();
  }
  Drift d;
  for (int n = 0; n < steps; ++n) {
    EXPECT_EQ(sim.step().status, StepReport::Status::ok);
    d.energy = std::max(d.energy, std::abs(energies(m, s).total() - E0) / E0);
    d.momentum = std::max(d.momentum, (linear_momentum(m, s) - P0).norm() / pscale);
    d.angular = std::max(d.angular, (angular_momentum(m, s) - L0).norm() / lscale);
    const SolveStats& st = sim.integrator().stats();
    d.residual = std::max(d.residual, st.residual);
    d.split += st.substeps > 0;
    d.substeps += st.substeps;
    d.unconverged += st.unconverged;
  }
  return d;
}

// Undamped, the discrete gradient's step satisfies E₁ = E₀ exactly when R = 0, and each step
// changes E by at most R·Δx: at Newton tolerance 1e-12 (relative to the residual's terms) and
// 2000 steps, 1e-8 of E leaves four decades for the accumulation. Momenta: bond forces cancel
// in pairs and are parallel to the midpoint lever arm, so P and L change only by round-off and
// by Σ x_mid × R, at most the tolerance (relative to the residual's terms, of the momentum's
// scale) per step: steps × 1e-12 of their scales.
struct ConservationCase {
  const char* name;
  bool lattice;
  double homega;
  CoupledSolver solver;
};
class EnergyMomentumConserves : public testing::TestWithParam<ConservationCase> {};

TEST_P(EnergyMomentumConserves, EnergyAndBothMomentaAtAnyStep) {
  const ConservationCase c = GetParam();
  World w = c.lattice ? small_lattice() : four_quanta();
  const double h = c.homega / max_angular_frequency(w.model, w.state);
  const int steps = c.lattice ? 1000 : 2000;
  IntegratorConfig cfg = newton(IntegratorType::energy_momentum, c.solver);
  if (c.solver == CoupledSolver::sweep) cfg.iterations = 20;
  const Drift d = run(std::move(w), cfg, h, steps);
  RecordProperty("energy_drift", std::to_string(d.energy));
  RecordProperty("angular_drift", std::to_string(d.angular));
  RecordProperty("split_steps", std::to_string(d.split));
  RecordProperty("substeps", std::to_string(d.substeps));
  // Steps whose Newton iteration does not converge are split into substeps (four quanta at
  // hω = 100: bonds turn by radians per step); every solve then converges.
  EXPECT_EQ(d.unconverged, 0);
  EXPECT_LT(d.residual, 1e-12);
  EXPECT_LT(d.energy, 1e-8);
  EXPECT_LT(d.momentum, steps * 1e-12);
  EXPECT_LT(d.angular, steps * 1e-12);
}

INSTANTIATE_TEST_SUITE_P(
    Newton, EnergyMomentumConserves,
    testing::Values(ConservationCase{"four_quanta_10_ldlt", false, 10, CoupledSolver::ldlt},
                    ConservationCase{"four_quanta_10_dense", false, 10, CoupledSolver::dense},
                    ConservationCase{"four_quanta_100_ldlt", false, 100, CoupledSolver::ldlt},
                    ConservationCase{"lattice_10_ldlt", true, 10, CoupledSolver::ldlt},
                    ConservationCase{"lattice_100_ldlt", true, 100, CoupledSolver::ldlt},
                    ConservationCase{"lattice_10_cg", true, 10, CoupledSolver::cg},
                    ConservationCase{"lattice_100_cg", true, 100, CoupledSolver::cg},
                    ConservationCase{"lattice_10_sweep", true, 10, CoupledSolver::sweep}),
    [](const auto& info) { return std::string(info.param.name); });

// A free tetrahedron (no anchor, no gravity) spinning about an axis through its centre of mass
// while its bonds vibrate.
World spinning_tetrahedron() {
  World w = four_quanta();
  Vec3 c = Vec3::Zero();
  for (const Vec3& x : w.state.x) c += x / 4;
  const Vec3 spin(0.3, -0.4, 1.0);  // [rad/s]
  for (std::size_t i = 0; i < 4; ++i) {
    w.state.x[i] -= c;
    w.state.v[i] = 0.3 * w.state.v[i] + spin.cross(w.state.x[i]);
  }
  return w;
}

// newton_polish: both conservative schemes keep angular momentum exactly for the exact solution
// of their step, and an accepted step changes it by Σ x_mid × R. Polished, R is at the round-off
// of its evaluation and L changes per step by round-off, about ε of its scale Σ m |x| |v|
// (at most 2ε per step, of one sign, on the experiment's lattice at hω = 100): steps × 2ε
// bounds the drift. Stopped at the tolerance (1e-12 relative to R's terms: no polishing) the
// drift over these 400 steps is tens of times that bound (energy_momentum at hω = 20, bonds
// turning by up to 1.35 rad per step; implicit_midpoint at hω = 5, up to 0.32 rad), so the
// bound tells polished steps from unpolished ones. (implicit_midpoint at
// hω = 10 gains energy without bound on this system, the blow-up check stopping it within 400
// steps: docs/integrators.md.) Linear momentum to the same bound.
struct PolishCase {
  IntegratorType type;
  double homega;
};
class NewtonPolish : public testing::TestWithParam<PolishCase> {};
TEST_P(NewtonPolish, KeepsAngularMomentumToRoundOff) {
  const PolishCase c = GetParam();
  World w = spinning_tetrahedron();
  const double h = c.homega / max_angular_frequency(w.model, w.state);
  const int steps = 400;
  IntegratorConfig cfg = newton(c.type);
  cfg.newton_polish = true;
  Simulation sim(std::move(w), cfg, h);
  const Model& m = sim.world().model;
  const State& s = sim.world().state;
  const Vec3 P0 = linear_momentum(m, s), L0 = angular_momentum(m, s);
  double pscale = 0, lscale = 0;
  for (std::size_t i = 0; i < m.num_quanta(); ++i) {
    pscale += m.mass[i] * s.v[i].norm();
    lscale += m.mass[i] * s.x[i].norm() * s.v[i].norm();
  }
  double dP = 0, dL = 0, turn = 0;
  int polished = 0;
  for (int n = 0; n < steps; ++n) {
    const std::vector<Vec3> x0 = s.x;
    ASSERT_EQ(sim.step().status, StepReport::Status::ok);
    ASSERT_EQ(sim.integrator().stats().unconverged, 0);
    polished += sim.integrator().stats().polish_iterations > 0;
    dP = std::max(dP, (linear_momentum(m, s) - P0).norm() / pscale);
    dL = std::max(dL, (angular_momentum(m, s) - L0).norm() / lscale);
    const Vec3 d0 = x0[1] - x0[0], d1 = s.x[1] - s.x[0];
    turn = std::max(turn, std::atan2(d0.cross(d1).norm(), d0.dot(d1)));
  }
  RecordProperty("angular_drift", std::to_string(dL));
  RecordProperty("largest_turn_rad", std::to_string(turn));
  EXPECT_GT(turn, 0.25);  // bonds turn a lot per step: the modified iteration converges linearly
  EXPECT_GT(polished, steps / 2);
  const double bound = steps * 2 * std::numeric_limits<double>::epsilon();
  EXPECT_LT(dL, bound);
  EXPECT_LT(dP, bound);
}
INSTANTIATE_TEST_SUITE_P(Newton, NewtonPolish,
                         testing::Values(PolishCase{IntegratorType::energy_momentum, 20},
                                         PolishCase{IntegratorType::implicit_midpoint, 5}),
                         [](const auto& info) { return std::string(to_string(info.param.type)); });

// The substepping fallback (newton.cpp, NewtonIntegrator::advance): a step whose Newton
// iteration does not converge is solved as two halves, each from the state the one before
// reached. Such a split step must be exactly the two half steps taken as steps of their own: the
// same substep length, the second half from the first's end state, the composite dx, dv. Four
// quanta at hω = 100 (bonds turning by 80°–180° per step) split; the first step split into two
// halves that each converged whole is taken again as two steps of h/2 from the state before it.
// Both solves start from y = 0 and are polished to round-off, so they agree to the round-off of
// the composition (x + (x₂ − x) against x₂; the substep length (t + h/2) − t against h/2):
// 1e-12 of the state's scale. Both momenta are kept over the split step (the composition keeps
// what each substep keeps). For implicit_midpoint this is its only test of a split step; its
// energy is not kept on this system (docs/integrators.md: the midpoint force along the
// midpoint chord, which is far shorter than the bond when it turns by radians), so the
// blow-up check is lifted.
class NewtonSplit : public testing::TestWithParam<IntegratorType> {};
TEST_P(NewtonSplit, SplitStepEqualsItsTwoHalfSteps) {
  IntegratorConfig cfg = newton(GetParam());
  cfg.newton_polish = true;
  World w = four_quanta();
  const double h = 100 / max_angular_frequency(w.model, w.state);
  Simulation sim(std::move(w), cfg, h);
  sim.limits().energy_growth = 1e12;
  World before;
  int n = 0;
  for (; n < 300; ++n) {
    before = sim.world();
    ASSERT_EQ(sim.step().status, StepReport::Status::ok);
    ASSERT_EQ(sim.integrator().stats().unconverged, 0);
    if (sim.integrator().stats().substeps == 2) break;
  }
  ASSERT_LT(n, 300) << "no step split into two halves";
  RecordProperty("split_step", std::to_string(n));
  const State& split = sim.world().state;

  Simulation halves(before, cfg, 0.5 * h);
  halves.limits().energy_growth = 1e12;
  for (int k = 0; k < 2; ++k) {
    ASSERT_EQ(halves.step().status, StepReport::Status::ok);
    EXPECT_EQ(halves.integrator().stats().substeps, 0);  // each half converges whole
  }
  const State& two = halves.world().state;
  EXPECT_EQ(split.time, two.time);
  double xscale = 0, vscale = 0, dx = 0, dv = 0;
  for (std::size_t i = 0; i < split.x.size(); ++i) {
    xscale = std::max({xscale, before.state.x[i].norm(), split.x[i].norm()});
    vscale = std::max({vscale, before.state.v[i].norm(), split.v[i].norm()});
    dx = std::max(dx, (split.x[i] - two.x[i]).norm());
    dv = std::max(dv, (split.v[i] - two.v[i]).norm());
  }
  RecordProperty("x_difference", std::to_string(dx / xscale));
  RecordProperty("v_difference", std::to_string(dv / vscale));
  EXPECT_LT(dx, 1e-12 * xscale);
  EXPECT_LT(dv, 1e-12 * vscale);
  // The split step moved the system (it is not a trivial comparison) and kept both momenta.
  const Model& m = sim.world().model;
  double pscale = 0, lscale = 0;
  for (std::size_t i = 0; i < m.num_quanta(); ++i) {
    pscale += m.mass[i] * before.state.v[i].norm();
    lscale += m.mass[i] * before.state.x[i].norm() * before.state.v[i].norm();
    EXPECT_GT((split.x[i] - before.state.x[i]).norm(), 0.1);
  }
  EXPECT_LT((linear_momentum(m, split) - linear_momentum(m, before.state)).norm(), 1e-13 * pscale);
  EXPECT_LT((angular_momentum(m, split) - angular_momentum(m, before.state)).norm(), 1e-13 * lscale);
}
INSTANTIATE_TEST_SUITE_P(Newton, NewtonSplit,
                         testing::Values(IntegratorType::energy_momentum, IntegratorType::implicit_midpoint),
                         [](const auto& info) { return std::string(to_string(info.param)); });

// Split steps are deterministic for any thread count (Pipeline.AnyThreadCountGivesTheSameBits
// does not split a step). parallel_for runs on one thread below kParallelMin (4096) items, so
// one four-quanta system would compare one thread with itself: 1024 copies of it, side by side
// 3 m apart (4096 quanta, 6144 bonds), make every per-quanta and per-bond pass and every
// deterministic_sum run on both threads. The copies differ by the round-off of their positions;
// at hω = 100 the whole system's Newton iteration fails where one copy's does (its third step)
// and the step splits, with the substep solves, the polish and the substep ledger on 2 threads.
TEST(NewtonSplit, AnyThreadCountGivesTheSameBits) {
  World many;
  const World one = four_quanta();
  for (int c = 0; c < 1024; ++c) {
    const Vec3 offset(3.0 * (c % 32), 3.0 * (c / 32), 0.0);
    const Index first = static_cast<Index>(many.num_quanta());
    for (std::size_t i = 0; i < one.num_quanta(); ++i)
      many.add_quanta(one.state.x[i] + offset, one.state.v[i], 1.0);
    for (std::size_t b = 0; b < one.num_bonds(); ++b)
      many.add_bond(first + one.state.bonds.i[b], first + one.state.bonds.j[b], {.stiffness = 100.0});
  }
  ASSERT_GE(many.num_quanta(), kParallelMin);
  // ω_max of disjoint copies is one copy's (and the dense eigenproblem of 12288 unknowns is slow).
  const double h = 100 / max_angular_frequency(one.model, one.state);
  auto run = [&](int threads, int& split) {
    IntegratorConfig cfg = newton(IntegratorType::energy_momentum);
    cfg.newton_polish = true;
    cfg.threads = threads;
    Simulation sim(many, cfg, h);
    split = 0;
    for (int n = 0; n < 3; ++n) {
      EXPECT_EQ(sim.step().status, StepReport::Status::ok);
      split += sim.integrator().stats().substeps > 0;
    }
    return sim.world().state;
  };
  int split1 = 0, split2 = 0;
  const State a = run(1, split1), b = run(2, split2);
  EXPECT_GT(split1, 0);
  EXPECT_EQ(split1, split2);
  ASSERT_EQ(a.x.size(), b.x.size());
  EXPECT_EQ(std::memcmp(a.x.data(), b.x.data(), a.x.size() * sizeof(Vec3)), 0);
  EXPECT_EQ(std::memcmp(a.v.data(), b.v.data(), a.v.size() * sizeof(Vec3)), 0);
  EXPECT_TRUE(a.energy == b.energy);
}

// Backward Euler at the same steps loses most of the energy: what energy_momentum fixes.
TEST(EnergyMomentum, BackwardEulerLosesTheEnergyItKeeps) {
  World w = four_quanta();
  const double h = 10 / max_angular_frequency(w.model, w.state);
  const Drift be = run(four_quanta(), test::coupled(CoupledSolver::ldlt), h, 200);
  EXPECT_GT(be.energy, 0.1);
}

// With dampers (axial and isotropic), gravity, a load and a moving anchor, the ledger charges
// the dampers at the midpoint velocity along the midpoint bond and the anchor with the discrete
// gradient — exactly what the integrator applied — so its numerical remainder is round-off.
// (Along a curved prescribed path the chord Δx_k differs from h (v + Δv/2) by O(h³), and a
// damper on such a quanta is charged with that difference: see docs/integrators.md.)
TEST(EnergyMomentum, LedgerClosesWithDampingLoadsAndAnchors) {
  for (DampingModel dm : {DampingModel::axial, DampingModel::isotropic}) {
    World w = test::lattice(4, 2, 2, 1000, 1e-3, 0.05, false, Vec3(0, 0, -9.81));
    for (double& D : w.state.bonds.damping) D = 0.05;
    for (auto& model : w.state.bonds.damping_model) model = dm;
    std::vector<Index> start, end;
    for (std::size_t i = 0; i < w.num_quanta(); ++i) {
      if (w.state.x[i].x() == 0.0) start.push_back(static_cast<Index>(i));
      if (w.state.x[i].x() > 0.025) end.push_back(static_cast<Index>(i));
    }
    Motion pull;  // a translation: the chord of the path is h times the midpoint velocity
    pull.type = MotionType::translate;
    pull.velocity = Vec3(-0.01, 0.005, 0.002);
    w.prescribe(start, pull);
    w.add_load(end, Vec3(0.0, 0.02, 0.01));
    const double h = 10 / max_angular_frequency(w.model, w.state);
    Simulation sim(std::move(w), newton(IntegratorType::energy_momentum), h);
    for (int n = 0; n < 500; ++n) ASSERT_EQ(sim.step().status, StepReport::Status::ok);
    const EnergyBudget b = energy_budget(sim.world().model, sim.world().state);
    const double scale = std::abs(b.work_anchors) + std::abs(b.work_loads) + b.dissipated_damping +
                         std::abs(b.now.total()) + std::abs(b.initial_total);
    EXPECT_GT(b.dissipated_damping, 1e-3 * scale);
    EXPECT_GT(std::abs(b.work_anchors), 1e-3 * scale);
    EXPECT_LT(std::abs(b.dissipated_numerical), 1e-9 * scale)
        << to_string(dm) << ": anchors " << b.work_anchors << " loads " << b.work_loads << " damping "
        << b.dissipated_damping;
    // The kinematic quanta sit on their prescribed path.
    const Motion& mo = sim.world().model.motions[0];
    for (std::size_t k = 0; k < mo.quanta.size(); ++k) {
      Vec3 x, v;
      mo.at(k, sim.world().state.time, x, v);
      EXPECT_EQ(sim.world().state.x[mo.quanta[k]], x);
    }
  }
}

// Steps split into substeps (four quanta at hω = 100, bonds turning by radians per step): the
// ledger charges the anchor's and the dampers' work summed over the substeps, as the integrator
// applied it (SubstepLedger); the whole-step estimate from the composite dx, dv would not be.
TEST(EnergyMomentum, LedgerClosesOverSubsteps) {
  for (DampingModel dm : {DampingModel::axial, DampingModel::isotropic}) {
    World w = four_quanta(0.2);
    for (auto& model : w.state.bonds.damping_model) model = dm;
    Motion pull;
    pull.type = MotionType::translate;
    pull.velocity = Vec3(0.3, -0.2, 0.1);
    w.prescribe({0}, pull);
    const double h = 100 / max_angular_frequency(w.model, w.state);
    Simulation sim(std::move(w), newton(IntegratorType::energy_momentum), h);
    int split = 0;
    for (int n = 0; n < 300; ++n) {
      ASSERT_EQ(sim.step().status, StepReport::Status::ok);
      split += sim.integrator().stats().substeps > 0;
      ASSERT_EQ(sim.integrator().stats().unconverged, 0);
    }
    const EnergyBudget b = energy_budget(sim.world().model, sim.world().state);
    const double scale = std::abs(b.work_anchors) + b.dissipated_damping + std::abs(b.now.total()) +
                         std::abs(b.initial_total);
    RecordProperty(std::string("split_steps_") + std::string(to_string(dm)), std::to_string(split));
    EXPECT_GT(split, 0) << to_string(dm);
    EXPECT_GT(b.dissipated_damping, 1e-3 * scale);
    EXPECT_GT(std::abs(b.work_anchors), 1e-3 * scale);
    EXPECT_LT(std::abs(b.dissipated_numerical), 1e-9 * scale)
        << to_string(dm) << ": anchors " << b.work_anchors << " damping " << b.dissipated_damping;
  }
}

// Free damped four quanta: energy only falls, by exactly the damping work.
TEST(EnergyMomentum, DampedEnergyLossEqualsDampingWork) {
  World w = four_quanta(0.5);
  const double h = 10 / max_angular_frequency(w.model, w.state);
  Simulation sim(std::move(w), newton(IntegratorType::energy_momentum), h);
  const Vec3 L0 = angular_momentum(sim.world().model, sim.world().state);
  for (int n = 0; n < 300; ++n) ASSERT_EQ(sim.step().status, StepReport::Status::ok);
  const EnergyBudget b = energy_budget(sim.world().model, sim.world().state);
  EXPECT_GT(b.dissipated_damping, 0.1 * b.initial_total);
  EXPECT_LT(std::abs(b.dissipated_numerical), 1e-10 * b.initial_total);
  // Axial dampers act along the midpoint bond too: angular momentum is kept.
  EXPECT_LT((angular_momentum(sim.world().model, sim.world().state) - L0).norm(), 1e-10 * L0.norm());
}

// A chain moving along its axis with the linear law has a quadratic energy, which the implicit
// midpoint rule conserves exactly (it conserves every quadratic invariant); the system is
// linear, so Newton converges in one step to round-off.
TEST(ImplicitMidpoint, ConservesQuadraticEnergyOfAxialChain) {
  for (double homega : {1.0, 10.0, 100.0}) {
    World w;
    Chain ch;
    ch.count = 12;
    ch.end = Vec3(0.11, 0, 0);
    ch.bond = {.stiffness = 1000.0};
    add_chain(w, ch);
    for (std::size_t i = 0; i < w.num_quanta(); ++i) w.state.v[i] = Vec3(0.1 * std::sin(1.0 + 3.0 * i), 0, 0);
    const double h = homega / max_angular_frequency(w.model, w.state);
    const Drift d = run(std::move(w), newton(IntegratorType::implicit_midpoint, CoupledSolver::ldlt, 1e-13), h, 1000);
    // Round-off: each step's solve carries ε κ(A) ≈ 1e-16 (1 + (hω/2)²) relative error, ~2.5e-13
    // at hω = 100, and 1000 steps accumulate it.
    EXPECT_LT(d.energy, 1e-10) << "hω = " << homega;
  }
}

// Two quanta on a linear bond (relative motion harmonic, ω = 1) against the exact solution.
double two_quanta_error(const IntegratorConfig& cfg, double h, double T) {
  const double m = 1.0, k = 0.5, L = 1.0, s0 = 0.1, w0 = 0.05;
  Simulation sim(test::two_quanta(m, k, L, s0, w0), cfg, h);
  const auto steps = static_cast<int>(std::lround(T / h));
  for (int i = 0; i < steps; ++i) sim.step();
  const double omega = std::sqrt(2 * k / m), t = steps * h;
  const double s = s0 * std::cos(omega * t) + (w0 / omega) * std::sin(omega * t);
  const Vec3 exact(0.5 * (L + s0) + 0.5 * (L + s), 0, 0);
  return (sim.world().state.x[1] - exact).norm();
}

class NewtonOrder : public testing::TestWithParam<IntegratorType> {};
TEST_P(NewtonOrder, IsSecondOrder) {
  const IntegratorConfig cfg = newton(GetParam(), CoupledSolver::ldlt, 1e-13);
  const double T = 10, h0 = 0.05;
  const double e1 = two_quanta_error(cfg, h0, T), e2 = two_quanta_error(cfg, h0 / 2, T),
               e3 = two_quanta_error(cfg, h0 / 4, T);
  const double p1 = std::log2(e1 / e2), p2 = std::log2(e2 / e3);
  RecordProperty("observed_order", std::to_string(p2));
  EXPECT_NEAR(p1, 2, 0.25) << e1 << " " << e2;
  EXPECT_NEAR(p2, 2, 0.25) << e2 << " " << e3;
}
INSTANTIATE_TEST_SUITE_P(Newton, NewtonOrder,
                         testing::Values(IntegratorType::energy_momentum, IntegratorType::implicit_midpoint,
                                         IntegratorType::bdf2),
                         [](const auto& info) { return std::string(to_string(info.param)); });

// The discrete gradient per law: T̄ (r1 − r0) = U(r1) − U(r0) to round-off for any Δr (down to
// 1e-12 of the length, where the quotient itself would have lost every digit), T̄ → T as Δr → 0,
// and ∂T̄/∂r1 against a central difference.
TEST(MeanTension, IsTheExactEnergyQuotientForEveryLaw) {
  const double L = 1.0;
  for (Law law : {Law::linear, Law::inverse}) {
    const double strength = law == Law::linear ? 100.0 : 5.0;
    const LawArgs a{.strength = strength, .shape = {0.05, 0}};
    for (double r0 : {0.9, 0.98, 1.0, 1.03, 1.2}) {
      for (double dr : {0.3, -0.1, 1e-3, 1e-6, -1e-9, 1e-12}) {
        const double r1 = r0 + dr;
        const MeanTension mt = mean_tension(law, r0, r1, L, a);
        const double dU = evaluate_law(law, r1, L, a).U - evaluate_law(law, r0, L, a).U;
        const double U = std::abs(evaluate_law(law, r0, L, a).U) + std::abs(mt.T * dr);
        EXPECT_NEAR(mt.T * (r1 - r0), dU, 1e-14 * std::max(U, 1e-300) + 1e-15 * strength * std::abs(dr))
            << to_string(law) << " r0 " << r0 << " dr " << dr;
        if (std::abs(dr) <= 1e-6) {
          EXPECT_NEAR(mt.T, evaluate_law(law, 0.5 * (r0 + r1), L, a).T, 1e-6 * strength);
        }
        const double step = 1e-6;
        const double fd = (mean_tension(law, r0, r1 + step, L, a).T -
                           mean_tension(law, r0, r1 - step, L, a).T) / (2 * step);
        EXPECT_NEAR(mt.dT1, fd, 1e-5 * std::abs(evaluate_law(law, r0, L, a).dT) + 1e-6 * strength)
            << to_string(law) << " r0 " << r0 << " dr " << dr;
      }
    }
  }
}

// The Newton block against central differences of the residual R(y). The modified block is
// exact (to the difference's O(ε²)) for the midpoint, bdf2 and backward-Euler tangents in any
// configuration (no damping, bonds in tension so no clamp bites), and for the discrete gradient
// when no bond turns over the step (collinear motion), where the part newton.hpp leaves out
// vanishes — with axial dampers. The exact blocks (exact Newton, sparse LU) match in every configuration:
// turning bonds, compressed bonds (rest length 1.3: the inverse law's softening, T' < 0 where
// |r − L| > ε, and compressed linear bonds' T/r < 0 make the tangent indefinite), axial and
// isotropic dampers, an anchor moving with prescribed velocity. Tolerance: the central
// difference's truncation O(ε² R''') ~ 1e-12 and its round-off ~1e-16 |R|/ε ~ 1e-10 of the
// largest entry, well under 1e-7.
struct JacobianCase {
  const char* name;
  NewtonScheme scheme;
  Law law;
  bool collinear;
  double damping;
  bool exact = false;
  DampingModel damping_model = DampingModel::axial;
};
class NewtonJacobian : public testing::TestWithParam<JacobianCase> {};

TEST_P(NewtonJacobian, MatchesFiniteDifferences) {
  const JacobianCase c = GetParam();
  World w;
  const double inverse_eps = 0.2;
  const BondSpec spec{.law = c.law, .stiffness = c.law == Law::linear ? 50.0 : 2.0, .damping = c.damping,
                      .damping_model = c.damping_model, .rest_length = c.exact ? 1.3 : 0.9,
                      .shape = c.law == Law::inverse ? LawShape{inverse_eps, 0} : LawShape{}};
  if (c.collinear) {
    for (int i = 0; i < 4; ++i) w.add_quanta(Vec3(1.0 * i, 0, 0), Vec3(0.3 * std::sin(2.0 * i), 0, 0), 1.0 + 0.5 * i);
    for (Index i = 0; i + 1 < 4; ++i) w.add_bond(i, i + 1, spec);
  } else {
    const Vec3 x[4] = {{0, 0, 0}, {1, 0.1, 0}, {0.4, 0.95, 0.05}, {0.5, 0.3, 0.9}};
    for (int i = 0; i < 4; ++i) w.add_quanta(x[i], Vec3(0.2 * std::sin(1.0 + i), 0.1 * i, -0.3 * std::cos(i)), 1.0 + 0.5 * i);
    for (Index i = 0; i < 4; ++i)
      for (Index j = i + 1; j < 4; ++j) w.add_bond(i, j, spec);
  }
  Motion slide;
  slide.type = MotionType::translate;
  slide.velocity = Vec3(0.05, 0, 0);
  w.prescribe({0}, slide);
  Adjacency adj;
  build_adjacency(w.model, w.state, adj);
  const std::size_t n = w.num_quanta();
  const double h = 0.05;
  Projection kin;
  kin.resize(n);
  project_kinematic(w.model, w.state, {h, 0.0, 0}, kin);
  std::vector<Vec3> x_prev(n), v_prev(n);  // bdf2's previous state: a step back, slightly different
  for (std::size_t i = 0; i < n; ++i) {
    x_prev[i] = w.state.x[i] - h * w.state.v[i] + Vec3(0.001, -0.002, 0.0) * (c.collinear ? 0.0 : 1.0);
    v_prev[i] = w.state.v[i] * 0.97;
  }
  if (c.collinear)
    for (Vec3& x : x_prev) x.y() = x.z() = 0;
  NewtonStep st;
  setup_newton_step(c.scheme, w.model, w.state, kin, h, &x_prev, &v_prev, st);
  st.exact = c.exact;
  std::vector<Vec3> y(n);
  for (std::size_t i = 0; i < n; ++i) y[i] = w.model.is_kinematic(static_cast<Index>(i)) ? kin.dv[i]
                                                 : Vec3(0.05 * std::cos(3.0 * i), 0, 0) * (c.collinear ? 1.0 : 2.0);
  const std::vector<Vec3> f_ext(n, Vec3(0, 0, -1.0));
  std::vector<Vec3> force, R;
  std::vector<double> scale;
  ImplicitSystem sys;
  newton_bonds(w.model, w.state, st, y, 1, force, &sys);
  assemble_blocks(w.model, w.state.bonds, adj, 1, false, sys);
  int compressed = 0, softening = 0;  // with `exact`, bonds the clamp would change
  for (std::size_t b = 0; b < w.num_bonds(); ++b) {
    const double r = (w.state.x[w.state.bonds.j[b]] - w.state.x[w.state.bonds.i[b]]).norm();
    if (!c.exact) {
      ASSERT_GT(r, 0.9);  // every bond stretched: no clamp
    }
    compressed += r < spec.rest_length;
    softening += std::abs(r - spec.rest_length) > inverse_eps;
  }
  if (c.exact) {
    ASSERT_EQ(sys.exact.size(), w.num_bonds());
    EXPECT_GT(compressed, 0);
    if (c.law == Law::inverse) {
      EXPECT_GT(softening, 0);
    }
  } else {
    ASSERT_TRUE(sys.exact.empty());
  }
  std::vector<Eigen::Index> dof;
  std::vector<Eigen::Triplet<double>> trip;
  Eigen::SparseMatrix<double> A;
  Eigen::VectorXd b;
  sys.rhs.assign(n, Vec3::Zero());
  assemble_system(w.model, w.state, sys, dof, trip, A, b);
  const Eigen::MatrixXd J(A);
  Eigen::MatrixXd fd = Eigen::MatrixXd::Zero(J.rows(), J.cols());
  auto residual = [&](const std::vector<Vec3>& yy) {
    newton_bonds(w.model, w.state, st, yy, 1, force, nullptr);
    newton_residual(w.model, w.state.bonds, adj, st, f_ext, force, yy, 1, R, scale);
    return R;
  };
  const double eps = 1e-6;
  for (std::size_t q = 0; q < n; ++q) {
    if (dof[q] < 0) continue;
    for (int k = 0; k < 3; ++k) {
      std::vector<Vec3> yp = y, ym = y;
      yp[q][k] += eps;
      ym[q][k] -= eps;
      const std::vector<Vec3> Rp = residual(yp), Rm = residual(ym);
      for (std::size_t i = 0; i < n; ++i)
        if (dof[i] >= 0) fd.block<3, 1>(dof[i], dof[q] + k) = (Rp[i] - Rm[i]) / (2 * eps);
    }
  }
  const double err = (J - fd).cwiseAbs().maxCoeff(), size = J.cwiseAbs().maxCoeff();
  RecordProperty("relative_error", std::to_string(err / size));
  EXPECT_LT(err, 1e-7 * size) << "\nJ =\n" << J << "\nfd =\n" << fd;
}

INSTANTIATE_TEST_SUITE_P(
    Newton, NewtonJacobian,
    testing::Values(JacobianCase{"midpoint_linear", NewtonScheme::implicit_midpoint, Law::linear, false, 0},
                    JacobianCase{"midpoint_inverse", NewtonScheme::implicit_midpoint, Law::inverse, false, 0},
                    JacobianCase{"bdf2_linear", NewtonScheme::bdf2, Law::linear, false, 0},
                    JacobianCase{"backward_euler_inverse", NewtonScheme::backward_euler, Law::inverse, false, 0},
                    JacobianCase{"midpoint_damped_collinear", NewtonScheme::implicit_midpoint, Law::linear, true, 0.7},
                    JacobianCase{"bdf2_damped_collinear", NewtonScheme::bdf2, Law::inverse, true, 0.7},
                    JacobianCase{"energy_momentum_linear_collinear", NewtonScheme::energy_momentum, Law::linear, true, 0},
                    JacobianCase{"energy_momentum_inverse_collinear", NewtonScheme::energy_momentum, Law::inverse,
                                 true, 0},
                    JacobianCase{"energy_momentum_damped_collinear", NewtonScheme::energy_momentum, Law::inverse,
                                 true, 0.7},
                    JacobianCase{"exact_energy_momentum_linear", NewtonScheme::energy_momentum, Law::linear, false, 0,
                                 true},
                    JacobianCase{"exact_energy_momentum_inverse", NewtonScheme::energy_momentum, Law::inverse, false,
                                 0, true},
                    JacobianCase{"exact_energy_momentum_axial", NewtonScheme::energy_momentum, Law::inverse, false, 0.7,
                                 true},
                    JacobianCase{"exact_energy_momentum_isotropic", NewtonScheme::energy_momentum, Law::linear, false,
                                 0.7, true, DampingModel::isotropic},
                    JacobianCase{"exact_midpoint_axial", NewtonScheme::implicit_midpoint, Law::inverse, false, 0.7,
                                 true},
                    JacobianCase{"exact_bdf2_axial", NewtonScheme::bdf2, Law::linear, false, 0.7, true},
                    JacobianCase{"exact_backward_euler_isotropic", NewtonScheme::backward_euler, Law::inverse, false,
                                 0.7, true, DampingModel::isotropic}),
    [](const auto& info) { return std::string(info.param.name); });

// BDF2's previous state travels in State::carry (Bdf2History): a run resumed from a checkpoint continues bit for
// bit, and a changed timestep restarts it with a backward-Euler step instead of using a history
// taken with another h.
TEST(Bdf2, ResumesFromACheckpointBitForBit) {
  const IntegratorConfig cfg = newton(IntegratorType::bdf2, CoupledSolver::cg, 1e-10);
  Simulation a(small_lattice(0.01), cfg, 1e-3);
  for (int n = 0; n < 20; ++n) a.step();
  World resumed = small_lattice(0.01);
  resumed.state = deserialize_state(serialize_state(a.world().state));
  Simulation b(std::move(resumed), cfg, 1e-3);
  for (int n = 0; n < 20; ++n) {
    a.step();
    b.step();
  }
  test::expect_same_bits(a.world().state, b.world().state);
  const State& sa = a.world().state;
  ASSERT_TRUE(std::holds_alternative<Bdf2History>(sa.carry));

  // Without the history (another integrator's carry-over, or none) the step is backward Euler.
  World c = a.world();
  c.state.carry = std::monostate{};
  const Projection fresh = test::project_once(c, cfg, 1e-3);
  const Projection with_history = test::project_once(a.world(), cfg, 1e-3);
  const Projection other_h = test::project_once(a.world(), cfg, 2e-3);
  World d = a.world();
  d.state.carry = std::monostate{};
  const Projection be_other_h = test::project_once(d, cfg, 2e-3);
  EXPECT_NE(with_history.dx, fresh.dx);  // the history is used when it fits
  EXPECT_EQ(other_h.dx, be_other_h.dx);  // and ignored after a timestep change
}

TEST(Newton, OptionsAreChecked) {
  IntegratorConfig c = newton(IntegratorType::energy_momentum);
  c.newton_iterations = 0;
  EXPECT_THROW(make_integrator(c), std::invalid_argument);
  c = newton(IntegratorType::bdf2);
  c.warm_start = WarmStart::previous;
  EXPECT_THROW(make_integrator(c), std::invalid_argument);
  c = test::coupled(CoupledSolver::sweep);
  EXPECT_THROW(make_integrator(c), std::invalid_argument);

  for (auto t : {IntegratorType::energy_momentum, IntegratorType::implicit_midpoint, IntegratorType::bdf2})
    EXPECT_EQ(parse_integrator_type(to_string(t)), t);
  EXPECT_EQ(parse_coupled_solver("sweep"), CoupledSolver::sweep);
}

}  // namespace
}  // namespace qbond
