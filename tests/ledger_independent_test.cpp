// The energy ledger's columns against the same quantities computed another way. The ledger's
// `numerical` is the remainder work − dissipated − ΔE, so the budget's identity holds by
// construction; these tests compute each side independently — from the recorded trajectory and
// the integrator's own energy identity, or from the exact solution of a damped oscillator — and
// show, with a control computation, that a wrong column would fail them.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "test_util.hpp"

namespace qbond {
namespace {

// One free quanta on a damped linear spring to an anchored one, moving along the spring (x) only:
// a linear system, m ẍ = F + m g − k (x − L) − c ẋ.
struct Oscillator {
  double m = 0.2, k = 50, c = 0.3, L = 1, F = 0.4, g = -2, u0 = 0.05, v0 = 0.3;
};

World oscillator_world(const Oscillator& o) {
  World w;
  w.add_quanta(Vec3::Zero(), Vec3::Zero(), 0.0);  // mass 0: anchored
  w.add_quanta(Vec3(o.L + o.u0, 0, 0), Vec3(o.v0, 0, 0), o.m);
  w.add_bond(0, 1, BondSpec{.law = Law::linear, .stiffness = o.k, .damping = o.c, .rest_length = o.L});
  w.model.gravity = Vec3(o.g, 0, 0);
  if (o.F != 0) w.add_load({1}, Vec3(o.F, 0, 0));
  return w;
}

struct Trajectory {
  std::vector<double> x, v;  // the free quanta's, at steps 0..n
  EnergyBudget budget;       // the ledger at the end
};

Trajectory run(const Oscillator& o, const IntegratorConfig& cfg, double h, int steps) {
  Simulation sim(oscillator_world(o), cfg, h);
  Trajectory t;
  auto record = [&] {
    const State& s = sim.world().state;
    t.x.push_back(s.x[1].x());
    t.v.push_back(s.v[1].x());
    EXPECT_EQ(s.x[1].y(), 0.0);
    EXPECT_EQ(s.v[1].z(), 0.0);
  };
  record();
  for (int n = 0; n < steps; ++n) {
    sim.step();
    record();
  }
  t.budget = energy_budget(sim.world().model, sim.world().state);
  return t;
}

// Backward Euler on a linear system satisfies, step by step and exactly,
//   E₁ − E₀ = F Δx − h c v₁² − ½ m Δv² − ½ k Δx²
// (from m Δv = h (F + m g − k s₁ − c v₁) times v₁, with E including gravity's potential −m g x):
// the loads' work, the damper's dissipation charged at v₁, and the integrator's own loss. So the
// ledger's `numerical` — the remainder — must equal Σ (½ m Δv² + ½ k Δx²), which the ledger never
// computes, and its `work` and `dissipated` must equal the first two sums.
TEST(LedgerIndependent, BackwardEulerColumnsMatchItsEnergyIdentity) {
  const Oscillator o;
  const double omega = std::sqrt(o.k / o.m);
  for (const double hw : {0.05, 0.5, 5.0}) {
    IntegratorConfig cfg = test::coupled(CoupledSolver::ldlt);
    cfg.restore_momentum = false;
    const double h = hw / omega;
    const Trajectory t = run(o, cfg, h, 400);
    auto energy = [&](std::size_t n) {
      const double s = t.x[n] - o.L;
      return 0.5 * o.m * t.v[n] * t.v[n] + 0.5 * o.k * s * s - o.m * o.g * t.x[n];
    };
    const std::size_t N = t.x.size() - 1;
    const double work = o.F * (t.x[N] - t.x[0]);
    double damping = 0, numerical = 0, damping_at_start = 0;
    for (std::size_t n = 0; n < N; ++n) {
      const double dv = t.v[n + 1] - t.v[n], dx = t.x[n + 1] - t.x[n];
      damping += h * o.c * t.v[n + 1] * t.v[n + 1];
      damping_at_start += h * o.c * t.v[n] * t.v[n];  // control: a damper charged at the wrong velocity
      numerical += 0.5 * o.m * dv * dv + 0.5 * o.k * dx * dx;
    }
    const EnergyBudget& b = t.budget;
    // Round-off: each of 400 steps adds terms of relative error ~1e-16 of the energy scale.
    const double scale = std::abs(work) + damping + numerical + std::abs(energy(0));
    const double tol = 1e-11 * scale;
    EXPECT_NEAR(b.now.total() - b.initial_total, energy(N) - energy(0), tol) << "h ω = " << hw;
    EXPECT_NEAR(b.work_loads, work, tol) << "h ω = " << hw;
    EXPECT_NEAR(b.dissipated_damping, damping, tol) << "h ω = " << hw;
    EXPECT_NEAR(b.dissipated_numerical, numerical, tol) << "h ω = " << hw;
    EXPECT_GT(numerical, 1e3 * tol) << "the integrator's own loss must be measurable for the check to mean anything";
    // Control: had the ledger charged the damper at the step's start velocity, its remainder
    // would be numerical + (damping − damping_at_start), far outside the tolerance.
    EXPECT_GT(std::abs(damping - damping_at_start), 1e3 * tol) << "h ω = " << hw;
  }
}

// The exact damped oscillator (no load, no gravity) loses E(0) − E(T) to its damper. RK4's ledger
// charges the damper at the step's mid velocity (v₀ + v₁)/2, a second-order quadrature of
// ∫ c v² dt along a fourth-order trajectory: the dissipation column converges to the exact loss
// at order 2. A damper charged at the start velocity would converge at order 1 (the control).
TEST(LedgerIndependent, Rk4DissipationConvergesToTheExactOscillatorsLoss) {
  Oscillator o;
  o.F = 0, o.g = 0;
  const double w0 = std::sqrt(o.k / o.m), zeta = o.c / (2 * std::sqrt(o.k * o.m));
  const double wd = w0 * std::sqrt(1 - zeta * zeta), T = 2.0;
  // u(t) = e^(−ζω₀t) (u₀ cos ω_d t + (v₀ + ζω₀u₀)/ω_d sin ω_d t), the exact solution.
  const double a = o.u0, bcoef = (o.v0 + zeta * w0 * o.u0) / wd;
  const double u = std::exp(-zeta * w0 * T) * (a * std::cos(wd * T) + bcoef * std::sin(wd * T));
  const double v = std::exp(-zeta * w0 * T) * ((bcoef * wd - zeta * w0 * a) * std::cos(wd * T) -
                                               (a * wd + zeta * w0 * bcoef) * std::sin(wd * T));
  const double exact = 0.5 * o.m * o.v0 * o.v0 + 0.5 * o.k * o.u0 * o.u0 - (0.5 * o.m * v * v + 0.5 * o.k * u * u);
  ASSERT_GT(exact, 0.0);

  std::vector<double> err, err_start;
  for (const int steps : {200, 400, 800}) {
    const double h = T / steps;
    const Trajectory t = run(o, test::config(IntegratorType::rk4), h, steps);
    EXPECT_NEAR(t.x.back() - o.L, u, 1e-3 * o.u0) << "the trajectory itself follows the exact solution";
    err.push_back(std::abs(t.budget.dissipated_damping - exact));
    double at_start = 0;
    for (int n = 0; n < steps; ++n) at_start += h * o.c * t.v[static_cast<std::size_t>(n)] * t.v[static_cast<std::size_t>(n)];
    err_start.push_back(std::abs(at_start - exact));
  }
  for (std::size_t k = 0; k + 1 < err.size(); ++k) {
    // Order 2: halving h divides the error by 4 (3 to 5 allows the next term of the expansion).
    EXPECT_GT(err[k] / err[k + 1], 3.0) << err[k] << " then " << err[k + 1];
    EXPECT_LT(err[k] / err[k + 1], 5.0) << err[k] << " then " << err[k + 1];
    // The control converges at order 1: the same check rejects it.
    EXPECT_LT(err_start[k] / err_start[k + 1], 2.5) << err_start[k] << " then " << err_start[k + 1];
  }
  EXPECT_LT(err.back(), 1e-4 * exact);
  std::printf("RK4 damper dissipation vs exact %.6g J: errors %.3g, %.3g, %.3g J (start-velocity control %.3g, %.3g, %.3g J)\n",
              exact, err[0], err[1], err[2], err_start[0], err_start[1], err_start[2]);
}

}  // namespace
}  // namespace qbond
