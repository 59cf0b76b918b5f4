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
// ledger's `numerical_damping` must equal Σ (½ m Δv² + ½ k Δx²), summed here from the trajectory
// (the ledger forms it from the solve's Δv and the bond's stiffness), its `numerical` — the
// remainder — must vanish, and its `work` and `dissipated` must equal the first two sums.
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
    EXPECT_NEAR(b.numerical_damping, numerical, tol) << "h ω = " << hw;
    EXPECT_NEAR(b.dissipated_numerical, 0, tol) << "h ω = " << hw;
    EXPECT_GT(numerical, 1e3 * tol) << "the integrator's own loss must be measurable for the check to mean anything";
    // Control: had the ledger charged the damper at the step's start velocity, its remainder
    // would be numerical + (damping − damping_at_start), far outside the tolerance.
    EXPECT_GT(std::abs(damping - damping_at_start), 1e3 * tol) << "h ω = " << hw;
  }
}

// The exact damped oscillator (no load, no gravity) loses E(0) − E(T) to its damper. RK4's ledger
// charges the damper at the step's mean velocity v̄ = (v₀ + v₁)/2, so the column is a quadrature
// of ∫ c v² dt along a fourth-order trajectory. With v̄ = v(t + h/2) + h² v''/8 + O(h⁴) and the
// composite midpoint rule's error, Σ h c v̄² = ∫ c v² dt + h² c [(v a)/6 |₀ᵀ − ¼ ∫ a² dt] + O(h⁴)
// (a = v'): the test predicts the column's error from the exact solution alone and finds it, to
// the next order, at three step sizes. A damper charged at the start velocity (the control) is
// off by a first-order term instead, which the same check rejects.
TEST(LedgerIndependent, Rk4DissipationMatchesTheExactOscillatorToItsOrder) {
  Oscillator o;
  o.F = 0, o.g = 0;
  const double w0 = std::sqrt(o.k / o.m), zeta = o.c / (2 * std::sqrt(o.k * o.m));
  const double alpha = zeta * w0, wd = w0 * std::sqrt(1 - zeta * zeta), T = 2.0;
  // u = e^(−αt) (A cos ω_d t + B sin ω_d t), and its derivatives in the same form.
  const double A = o.u0, B = (o.v0 + alpha * o.u0) / wd;
  const double C = B * wd - alpha * A, D = -A * wd - alpha * B;     // v
  const double E = D * wd - alpha * C, G = -C * wd - alpha * D;     // a
  auto form = [&](double p, double q, double t) { return std::exp(-alpha * t) * (p * std::cos(wd * t) + q * std::sin(wd * t)); };
  const double uT = form(A, B, T), vT = form(C, D, T), aT = form(E, G, T), a0 = form(E, G, 0);
  ASSERT_NEAR(form(C, D, 0), o.v0, 1e-12);
  const double exact = 0.5 * o.m * o.v0 * o.v0 + 0.5 * o.k * o.u0 * o.u0 - (0.5 * o.m * vT * vT + 0.5 * o.k * uT * uT);
  ASSERT_GT(exact, 0.0);
  // ∫ a² dt by Simpson's rule on 20 000 intervals (error ~1e-14 of it).
  double a2 = 0;
  const int K = 20000;
  for (int k = 0; k <= K; ++k) {
    const double a = form(E, G, T * k / K);
    a2 += (k == 0 || k == K ? 1 : k % 2 ? 4 : 2) * a * a;
  }
  a2 *= T / K / 3;
  const double coeff = o.c * ((vT * aT - o.v0 * a0) / 6 - a2 / 4);  // the error is coeff h² + O(h⁴)

  for (const int steps : {200, 400, 800}) {
    const double h = T / steps;
    const Trajectory t = run(o, test::config(IntegratorType::rk4), h, steps);
    // RK4's global error: O((h ω₀)⁴) per unit of ω₀ T, of the amplitude.
    EXPECT_NEAR(t.x.back() - o.L, uT, 0.01 * std::pow(h * w0, 4) * w0 * T * o.u0) << "the trajectory follows the exact solution";
    const double predicted = coeff * h * h;
    const double error = t.budget.dissipated_damping - exact;
    double at_start = 0;
    for (int n = 0; n < steps; ++n) at_start += h * o.c * t.v[static_cast<std::size_t>(n)] * t.v[static_cast<std::size_t>(n)];
    // The next order, h⁴ terms, against h²: (h ω₀)² ≤ 0.025 here, so within 5 % of the prediction.
    EXPECT_NEAR(error, predicted, 0.05 * std::abs(predicted)) << steps << " steps";
    EXPECT_GT(std::abs(at_start - exact - predicted), 0.3 * std::abs(predicted)) << "the control must fail: " << steps << " steps";
    std::printf("RK4, %d steps: ledger dissipation − exact (%.6g J) = %.4g J, predicted %.4g J; start-velocity control off by %.4g J\n",
                steps, exact, error, predicted, at_start - exact);
  }
}

}  // namespace
}  // namespace qbond
