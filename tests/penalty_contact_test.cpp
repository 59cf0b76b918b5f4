// Penalty contact of the explicit integrators (method "penalty", penalty_contact.hpp): restitution
// from the spring's unloading stiffness, momentum kept between quanta, Coulomb friction on an
// incline, the creep that stands for sticking, no passing through a plane, and the ledger's contact
// columns.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "integrators/penalty_contact.hpp"
#include "qbond/analysis/analysis.hpp"
#include "qbond/io/scene.hpp"
#include "qbond/simulation/simulation.hpp"
#include "test_util.hpp"

namespace qbond {
namespace {

constexpr double kG = 9.81;
constexpr double kRadius = 0.005;  // the quanta's radius: the obstacles' margin [m]

Obstacle penalty_ground(double restitution, double mu = 0, double kappa = kPenaltyForceDefault) {
  Obstacle g;
  g.margin = kRadius;
  g.method = ContactMethod::penalty;
  g.penalty = kappa;
  g.material = {.restitution = restitution, .friction = mu};
  return g;
}

IntegratorConfig explicit_integrator(IntegratorType type) {
  IntegratorConfig c;
  c.type = type;
  return c;
}

// The ledger's checks on every step: dissipation never negative, and the numerical residual against
// the largest kinetic or gravity energy seen.
struct LedgerWatch {
  double largest = 0, worst_numerical = 0, least_dissipated = 0, gravity0 = NAN;
  void see(const World& w) {
    const EnergyBudget b = energy_budget(w.model, w.state);
    if (std::isnan(gravity0)) gravity0 = b.now.gravity;
    largest = std::max({largest, b.now.kinetic, std::abs(b.now.gravity - gravity0)});
    worst_numerical = std::max(worst_numerical, std::abs(b.dissipated_numerical));
    least_dissipated = std::min(least_dissipated, b.dissipated_contact);
  }
};

// A lone quanta arriving at the ground at speed v (no gravity), with the contact starting at the
// fraction `phase` of a step: the speed it leaves with over v.
double rebound(IntegratorType type, double e, double kappa, double phase, LedgerWatch& ledger) {
  const double h = 1e-4, v = 1.0;
  World w;
  w.add_quanta(Vec3(0, 0, kRadius + (1 - phase) * v * h + 2 * v * h), Vec3(0, 0, -v), 1e-3);
  w.model.obstacles = {penalty_ground(e, 0, kappa)};
  Simulation sim(std::move(w), explicit_integrator(type), h);
  auto left = [&] { return sim.world().state.v[0].z() >= 0 && sim.world().state.x[0].z() > kRadius; };
  for (int n = 0; n < 2000 && !left(); ++n) {
    EXPECT_EQ(sim.step().status, StepReport::Status::ok);
    ledger.see(sim.world());
  }
  return sim.world().state.v[0].z() / v;
}

TEST(PenaltyContact, AQuantaLeavesWithTheRestitutionTimesItsApproach) {
  // In time the spring–dashpot gives back e of the approach speed (penalty_restitution: e itself
  // unless the damping e needs is more than the step takes). The step resolves the contact to
  // first order in ω h = √κ: the error stays within √κ / 2 and shrinks at least twofold when κ
  // shrinks sixteenfold. The ledger's contact balance is charged only when positive: the
  // integrator's energy error on the stiff spring, up and down again over a contact, is left in
  // `numerical`, up to (ω h)² = κ of the impact's energy for the second-order integrators and ω h =
  // √κ for symplectic Euler, plus κ / 2 from entering and leaving within a step.
  for (IntegratorType type : {IntegratorType::velocity_verlet, IntegratorType::symplectic_euler, IntegratorType::rk4})
    for (double e : {1.0, 0.5, 0.0}) {
      double worst[2] = {0, 0};
      const double kappas[2] = {0.1, 0.1 / 16};
      for (int k = 0; k < 2; ++k)
        for (double phase : {0.0, 0.3, 0.7}) {
          const double kappa = kappas[k];
          LedgerWatch ledger;
          const double out = rebound(type, e, kappa, phase, ledger);
          const double expected = penalty_restitution(e, kappa);
          worst[k] = std::max(worst[k], std::abs(out - expected));
          EXPECT_LE(std::abs(out - expected), 0.5 * std::sqrt(kappa))
              << to_string(type) << " e " << e << " κ " << kappa << " phase " << phase;
          EXPECT_GE(ledger.least_dissipated, 0.0) << to_string(type);
          const double residual =
              type == IntegratorType::symplectic_euler ? std::sqrt(kappa) + 0.5 * kappa : 1.5 * kappa;
          EXPECT_LE(ledger.worst_numerical, residual * ledger.largest)
              << to_string(type) << " e " << e << " κ " << kappa << " phase " << phase;
        }
      if (e < 1) {
        EXPECT_LT(worst[1], 0.5 * worst[0]) << to_string(type) << " e " << e;
      }
    }
}

TEST(PenaltyContact, TheLeastRestitutionIsWhatTheMostDampingTheStepTakesReaches) {
  // ζ ≤ 1/(2 √κ): 5 at the default κ, √2.5 at κ = 0.1; the closed form's restitution there.
  EXPECT_NEAR(penalty_restitution(0, kPenaltyForceDefault), 0.0093, 5e-5);
  EXPECT_NEAR(penalty_restitution(0, 0.1), 0.070, 5e-4);
  // Above that, the restitution asked for.
  for (double e : {0.05, 0.3, 0.9, 1.0}) EXPECT_NEAR(penalty_restitution(e, kPenaltyForceDefault), e, 1e-12) << e;
}

TEST(PenaltyContact, TwoQuantaKeepTheirMomentumAndPartWithTheRestitution) {
  const double h = 1e-4, e = 0.5, R = kRadius;
  World w;
  w.add_quanta(Vec3(0, 0, 0), Vec3(0.7, 0.2, 0), 1e-3);
  w.add_quanta(Vec3(2 * R + 0.004, 0.001, 0), Vec3(-0.3, 0, 0.1), 3e-3);
  w.model.quanta_contact = {.radius = R, .material = {.restitution = e, .friction = 0.3}};
  w.model.quanta_contact.method = ContactMethod::penalty;
  w.model.quanta_contact.penalty = kPenaltyForceDefault;
  const Vec3 p0 = 1e-3 * w.state.v[0] + 3e-3 * w.state.v[1];
  Simulation sim(std::move(w), explicit_integrator(IntegratorType::velocity_verlet), h);
  LedgerWatch ledger;
  bool touched = false;
  for (int n = 0; n < 400; ++n) {
    ASSERT_EQ(sim.step().status, StepReport::Status::ok);
    ledger.see(sim.world());
    const State& s = sim.world().state;
    touched = touched || (s.x[1] - s.x[0]).norm() < 2 * R;
    const Vec3 p = 1e-3 * s.v[0] + 3e-3 * s.v[1];
    ASSERT_LE((p - p0).norm(), 1e-15) << "step " << n;
  }
  EXPECT_TRUE(touched);
  const State& s = sim.world().state;
  EXPECT_GT((s.x[1] - s.x[0]).norm(), 2 * R);
  EXPECT_GE(ledger.least_dissipated, 0.0);
  EXPECT_GT(sim.world().state.energy.dissipated_contact, 0.0);
}

// A 3×3×3 block (1 cm spacing, k = 1e4 N/m, D = 0.2 N s/m) on the ground with gravity tilted by θ,
// μ_k = 0.4, at h = kInclineStep, for `seconds`: how far its centre of mass moved along the incline
// over the second half (the first settles its bounce on the contact springs), and its acceleration
// there.
constexpr double kInclineStep = 5e-5;
double incline_run(double theta, double seconds, double& accel, LedgerWatch& ledger) {
  const double h = kInclineStep;
  const Vec3 g(kG * std::sin(theta), 0, -kG * std::cos(theta));
  World w = test::lattice(3, 3, 3, 1e4, 1e-3, 0.2, false, g);
  for (Vec3& x : w.state.x) x.z() += kRadius;
  w.model.obstacles = {penalty_ground(0, 0.4)};
  Simulation sim(std::move(w), explicit_integrator(IntegratorType::velocity_verlet), h);
  // The centre of mass's x and vx.
  auto mean_x = [&] {
    double x = 0, p = 0, m = 0;
    const World& now = sim.world();
    for (std::size_t i = 0; i < now.num_quanta(); ++i) {
      x += now.model.mass[i] * now.state.x[i].x();
      p += now.model.mass[i] * now.state.v[i].x();
      m += now.model.mass[i];
    }
    return std::pair{x / m, p / m};
  };
  const int steps = static_cast<int>(std::lround(seconds / h));
  std::pair<double, double> half;
  for (int n = 0; n < steps; ++n) {
    EXPECT_EQ(sim.step().status, StepReport::Status::ok);
    if (n + 1 == steps / 2) half = mean_x();
    if (n % 10 == 0) ledger.see(sim.world());
  }
  const auto [x1, v1] = mean_x();
  accel = (v1 - half.second) / (h * (steps - steps / 2));
  return x1 - half.first;
}

TEST(PenaltyContact, ABlockSlidesDownAnInclineWithKineticFriction) {
  const double theta = std::atan(0.7);
  double accel = 0;
  LedgerWatch ledger;
  incline_run(theta, 1.0, accel, ledger);
  const double expected = kG * (std::sin(theta) - 0.4 * std::cos(theta));
  EXPECT_NEAR(accel, expected, 0.02 * expected);
  EXPECT_GE(ledger.least_dissipated, 0.0);
  EXPECT_LE(ledger.worst_numerical, 0.01 * ledger.largest);
}

TEST(PenaltyContact, ABlockWellBelowItsFrictionAngleCreepsAtTheDampersSpeed) {
  // A penalty force has no memory of where a contact stuck: the friction damper c_t = m / h on each
  // of the 9 quanta touching the ground carries the block's weight component M g sin θ at the speed
  // (M / 9 m) g sin θ h, while no contact reaches μ_k f_n (tan θ = 0.15, well below μ_k = 0.4).
  const double theta = std::atan(0.15), h = kInclineStep, seconds = 2.0;
  double accel = 0;
  LedgerWatch ledger;
  const double moved = incline_run(theta, seconds, accel, ledger);
  const double creep = 3 * kG * std::sin(theta) * h;
  EXPECT_NEAR(moved, creep * seconds / 2, 1e-3 * creep * seconds / 2);
  EXPECT_NEAR(accel, 0, 1e-3);
  EXPECT_GE(ledger.least_dissipated, 0.0);
}

TEST(PenaltyContact, AQuantaMovingTwoRadiiAStepDoesNotPassThePlane) {
  // The ground is a half space: however deep a step takes the quanta, its spring pushes it back.
  const double h = 1e-4, v = 2 * kRadius / h;
  World w;
  w.add_quanta(Vec3(0, 0, kRadius + 0.3 * v * h), Vec3(0, 0, -v), 1e-3);
  w.model.obstacles = {penalty_ground(0.5)};
  Simulation sim(std::move(w), explicit_integrator(IntegratorType::velocity_verlet), h);
  for (int n = 0; n < 200; ++n) ASSERT_EQ(sim.step().status, StepReport::Status::ok);
  EXPECT_GT(sim.world().state.x[0].z(), kRadius);
  EXPECT_GT(sim.world().state.v[0].z(), 0.0);
}

TEST(PenaltyContact, ResultsDoNotDependOnTheThreadCount) {
  auto run = [](int threads) {
    World w = test::lattice(4, 4, 4, 1e4, 1e-3, 0.2, false, Vec3(0, 0, -kG));
    for (Vec3& x : w.state.x) x.z() += kRadius + 0.002;
    w.model.obstacles = {penalty_ground(0.3, 0.4)};
    w.model.quanta_contact = {.radius = 0.0045, .material = {.restitution = 0.2, .friction = 0.3}};
    w.model.quanta_contact.method = ContactMethod::penalty;
    w.model.quanta_contact.penalty = kPenaltyForceDefault;
    IntegratorConfig c = explicit_integrator(IntegratorType::velocity_verlet);
    c.threads = threads;
    Simulation sim(std::move(w), c, kInclineStep);
    for (int n = 0; n < 300; ++n) sim.step();
    return sim.world().state;
  };
  const State one = run(1), two = run(2);
  EXPECT_EQ(one.x, two.x);
  EXPECT_EQ(one.v, two.v);
  EXPECT_EQ(one.energy.dissipated_contact, two.energy.dissipated_contact);
}

std::string scene_with(const std::string& obstacle, const std::string& integrator = "velocity_verlet") {
  return R"({"timestep": 0.0001, "steps": 1, "integrator": {"type": ")" + integrator + R"("},
    "bodies": [{"name": "q", "type": "quanta", "positions": [[0, 0, 1], [0, 0, 2]], "mass": 0.001}],
    "heuristics": [)" +
         obstacle + "]}";
}

TEST(PenaltyContact, SceneContactsWithMethodPenaltyJoinTheModel) {
  const Scene s = parse_scene(scene_with(R"({"type": "ground", "margin": 0.005, "method": "penalty",
      "friction": 0.4, "restitution": 0.5}, {"type": "contact", "radius": 0.1, "method": "penalty", "penalty": 0.5})"));
  ASSERT_EQ(s.world.model.obstacles.size(), 1u);
  EXPECT_EQ(s.world.model.obstacles[0].method, ContactMethod::penalty);
  EXPECT_EQ(s.world.model.obstacles[0].penalty, kPenaltyForceDefault);
  EXPECT_EQ(s.world.model.quanta_contact.method, ContactMethod::penalty);
  EXPECT_EQ(s.world.model.quanta_contact.penalty, 0.5);
  EXPECT_TRUE(s.heuristics.empty());
}

TEST(PenaltyContact, ScenesThatMisuseItAreRefusedWithTheKeyNamed) {
  auto refused = [](const std::string& text, const std::string& says) {
    try {
      parse_scene(text);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const SceneError& e) {
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
    }
  };
  refused(scene_with(R"({"type": "ground", "method": "penalty", "penalty": 2})"), "heuristics[0].penalty");
  refused(scene_with(R"({"type": "ground", "method": "penalty", "friction": 0.3, "static_friction": 0.5})"),
          "heuristics[0].static_friction");
  refused(scene_with(R"({"type": "ground", "method": "penalty"})", "coupled_implicit"), "use \"implicit\"");
  refused(scene_with(R"({"type": "ground", "method": "penalty"})", "hybrid_implicit"), "heuristics[0].method");
  refused(scene_with(R"({"type": "ground", "method": "implicit"})"), "use \"penalty\"");
  refused(scene_with(R"({"type": "ground", "method": "penalty"}, {"type": "contact", "radius": 0.1, "method": "implicit"})",
                     "rk4"),
          "heuristics[1].method");
}

TEST(PenaltyContact, AnIntegratorThatCannotHoldThemIsRefused) {
  World w;
  w.add_quanta(Vec3(0, 0, 1), Vec3::Zero(), 1e-3);
  w.model.obstacles = {penalty_ground(0)};
  EXPECT_THROW(Simulation(w, default_integrator(), 1e-3), std::invalid_argument);
  Simulation sim(w, explicit_integrator(IntegratorType::velocity_verlet), 1e-3);
  EXPECT_THROW(sim.set_integrator(default_integrator()), std::invalid_argument);
}

}  // namespace
}  // namespace qbond
