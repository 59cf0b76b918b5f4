// Contact inside the implicit step (obstacles with method "implicit", contact_solve.hpp): no
// tunnelling, resting contact, Coulomb friction on an incline, restitution, and the ledger's
// contact columns, at frame-sized steps.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "qbond/analysis/analysis.hpp"
#include "qbond/io/scene.hpp"
#include "qbond/simulation/simulation.hpp"
#include "test_util.hpp"

namespace qbond {
namespace {

constexpr double kG = 9.81;
constexpr double kRadius = 0.005;  // the quanta's radius: the obstacles' margin [m]

Obstacle solved_ground(double restitution = 0, double mu_k = 0, double mu_s = -1) {
  Obstacle g;
  g.margin = kRadius;
  g.method = ContactMethod::implicit;
  g.material = {.restitution = restitution, .friction = mu_k, .static_friction = mu_s};
  return g;
}

// What the ledger's checks read on every step: the dissipation (never negative), the numerical
// residual, and the largest kinetic or gravity energy seen (the weight's height above the ground,
// or the gravity energy released since the start on an incline).
struct LedgerWatch {
  double largest = 0, worst_numerical = 0, least_dissipated = 0, gravity0 = NAN, numerical = 0, damping = 0;
  void see(const World& w) {
    const EnergyBudget b = energy_budget(w.model, w.state);
    if (std::isnan(gravity0)) gravity0 = b.now.gravity;
    double above = 0;
    for (std::size_t i = 0; i < w.num_quanta(); ++i) above += w.model.mass[i] * kG * w.state.x[i].z();
    largest = std::max({largest, b.now.kinetic, above, std::abs(b.now.gravity - gravity0)});
    numerical = b.dissipated_numerical;
    damping = b.numerical_damping;
    worst_numerical = std::max(worst_numerical, std::abs(numerical));
    least_dissipated = std::min(least_dissipated, b.dissipated_damping + b.dissipated_contact);
  }
};

TEST(SolvedContact, AQuantaMovingTwoRadiiAStepDoesNotPassThePlane) {
  // 2 radii a step, and 50, straight at the ground from just above it, at h = 1/60 s: the path's
  // entry into the plane becomes a contact before the step is solved. The spring then leaves it
  // at most its approach v h over the penalty κ inside the surface.
  const double h = 1.0 / 60;
  for (double radii : {2.0, 50.0}) {
    World w;
    const double v = radii * kRadius / h;
    w.add_quanta(Vec3(0, 0, kRadius + 0.3 * v * h), Vec3(0, 0, -v), 1e-3);
    w.model.obstacles = {solved_ground()};
    Simulation sim(std::move(w), default_integrator(), h);
    for (int n = 0; n < 30; ++n) {
      ASSERT_EQ(sim.step().status, StepReport::Status::ok);
      EXPECT_GE(sim.world().state.x[0].z() - kRadius, -v * h / solved_ground().penalty - 1e-12)
          << radii << " radii a step, step " << n;
    }
    // Stopped (restitution 0): at most the spring's push-back, the depth v h / κ in a step, is left.
    EXPECT_LE(std::abs(sim.world().state.v[0].z()), v / solved_ground().penalty * (1 + 1e-9)) << radii;
  }
}

// A 4×4×4 block (1 cm spacing, k = 1e4 N/m) standing on the solved ground from rest at h = 1/60 s.
TEST(SolvedContact, ABlockRestsOnTheGroundAtFrameSizedSteps) {
  const double h = 1.0 / 60;
  World w = test::lattice(4, 4, 4, 1e4, 1e-3, 5, false, Vec3(0, 0, -kG));
  for (Vec3& x : w.state.x) x.z() += kRadius;
  w.model.obstacles = {solved_ground(0, 0.5)};
  Simulation sim(std::move(w), default_integrator(), h);
  LedgerWatch ledger;
  for (int n = 0; n < 60; ++n) {  // settling: 1 s
    ASSERT_EQ(sim.step().status, StepReport::Status::ok);
    ledger.see(sim.world());
  }
  for (int n = 0; n < 600; ++n) {  // 10 s at rest
    ASSERT_EQ(sim.step().status, StepReport::Status::ok);
    ledger.see(sim.world());
    const World& now = sim.world();
    for (std::size_t i = 0; i < now.num_quanta(); ++i)
      if (now.state.x[i].z() < 0.5 * 0.01) {
        ASSERT_NEAR(now.state.x[i].z(), kRadius, 0.01 * kRadius) << "step " << n;
      }
    const double ke = energies(now.model, now.state).kinetic;
    ASSERT_LT(ke, 1e-9 * ledger.largest) << "step " << n;
  }
  EXPECT_GE(ledger.least_dissipated, 0.0);
  EXPECT_LE(ledger.worst_numerical, 0.01 * ledger.largest);
}

// A 3×3×3 block on the ground with gravity tilted by θ (the ground as an incline), μ_s = 0.5,
// μ_k = 0.4, at h = 1/60 s: below tan θ = μ_s it stays put; above it it slides with the
// acceleration g (sin θ − μ_k cos θ).
double incline_run(double theta, double seconds, double& accel, LedgerWatch& ledger) {
  const double h = 1.0 / 60;
  const Vec3 g(kG * std::sin(theta), 0, -kG * std::cos(theta));
  World w = test::lattice(3, 3, 3, 1e4, 1e-3, 5, false, g);
  for (Vec3& x : w.state.x) x.z() += kRadius - 0.25 * kG * h * h / 1000;
  w.model.obstacles = {solved_ground(0, 0.4, 0.5)};
  Simulation sim(std::move(w), default_integrator(), h);
  auto mean_vx = [&] {
    double p = 0, m = 0;
    const World& now = sim.world();
    for (std::size_t i = 0; i < now.num_quanta(); ++i) {
      p += now.model.mass[i] * now.state.v[i].x();
      m += now.model.mass[i];
    }
    return p / m;
  };
  const double x0 = sim.world().state.x[0].x();
  const int steps = static_cast<int>(std::lround(seconds / h));
  double v_half = 0;
  for (int n = 0; n < steps; ++n) {
    EXPECT_EQ(sim.step().status, StepReport::Status::ok);
    if (n + 1 == steps / 2) v_half = mean_vx();
    ledger.see(sim.world());
  }
  accel = (mean_vx() - v_half) / (h * (steps - steps / 2));
  return sim.world().state.x[0].x() - x0;
}

TEST(SolvedContact, ABlockSticksOnAnInclineBelowStaticFriction) {
  const double theta = std::atan(0.3);  // tan θ = 0.3 < μ_k = 0.4 < μ_s = 0.5
  double accel = 0;
  LedgerWatch ledger;
  const double moved = incline_run(theta, 5.0, accel, ledger);
  EXPECT_LT(std::abs(moved), 1e-3);
  EXPECT_GE(ledger.least_dissipated, 0.0);
  EXPECT_LE(ledger.worst_numerical, 0.01 * ledger.largest);
}

TEST(SolvedContact, ABlockSlidesDownAnInclineWithKineticFriction) {
  const double theta = std::atan(0.7);  // tan θ = 0.7 > μ_s = 0.5
  double accel = 0;
  LedgerWatch ledger;
  incline_run(theta, 1.0, accel, ledger);
  const double expected = kG * (std::sin(theta) - 0.4 * std::cos(theta));
  EXPECT_NEAR(accel, expected, 0.02 * expected);
  EXPECT_GE(ledger.least_dissipated, 0.0);
  // Backward Euler charges gravity's work at the end-of-step velocity: on a body accelerating at
  // a it loses ½ M g sin θ a h² a step (1.6% of the energy released over 60 steps), which
  // `numerical_damping` holds; the contacts leave nothing more to `numerical`.
  const double h = 1.0 / 60, mass = 27e-3;
  const double euler = 60 * 0.5 * mass * kG * std::sin(theta) * expected * h * h;
  EXPECT_NEAR(ledger.damping, euler, 0.01 * ledger.largest);
  EXPECT_LE(ledger.worst_numerical, 0.01 * ledger.largest);
}

// Apex heights of a quanta dropped on the solved ground with restitution e, above the height at
// which it touches: from the first state after each bounce, z + v_z² / (2 g) (its flight is exact).
std::vector<double> apexes(double h, double e, double drop, int count) {
  World w;
  w.model.gravity = Vec3(0, 0, -kG);
  w.add_quanta(Vec3(0, 0, kRadius + drop), Vec3::Zero(), 1e-3);
  w.model.obstacles = {solved_ground(e)};
  Simulation sim(std::move(w), default_integrator(), h);
  std::vector<double> out;
  double last_vz = 0;
  while (static_cast<int>(out.size()) < count && sim.world().state.time < 10) {
    sim.step();
    const double vz = sim.world().state.v[0].z(), z = sim.world().state.x[0].z();
    if (last_vz <= 0 && vz > 0) out.push_back(z - kRadius + vz * vz / (2 * kG));
    last_vz = vz;
  }
  return out;
}

TEST(SolvedContact, BouncesKeepTheRestitutionsSquareOfTheirHeight) {
  // A lone quanta's flight and bounce are exact at any step: the apexes follow e² for three
  // bounces, up to where the contact spring holds the bounce's end within the step, h v / κ of a
  // 1 m fall's speed, 0.06 mm at h = 1/60 s (0.4% of the third apex, 1.6 cm).
  const double e = 0.5, drop = 1.0;
  for (double h : {1e-3, 1.0 / 60}) {
    const std::vector<double> apex = apexes(h, e, drop, 3);
    ASSERT_EQ(apex.size(), 3u);
    double before = drop;
    for (double a : apex) {
      EXPECT_NEAR(a / before, e * e, 0.01 * e * e) << "h " << h << " apex " << a;
      before = a;
    }
  }
}

TEST(SolvedContact, AnImpactLeavesWithTheRestitutionTimesItsApproachAtFrameSizedSteps) {
  // At h = 1/60 s a lone quanta meets the ground within a step. Its flight is exact (free fall and
  // the impact step's flight before and after the bounce): it reaches the ground at
  // v_c = √(2 g H), leaves at e v_c, and ends the step where and as fast as that bounce takes it.
  // The impact takes (1 − e²) ½ m v_c², charged to the contact, and nothing is left to `numerical`.
  const double h = 1.0 / 60, e = 0.5, drop = 0.6, m = 1e-3;
  World w;
  w.model.gravity = Vec3(0, 0, -kG);
  w.add_quanta(Vec3(0, 0, kRadius + drop), Vec3::Zero(), m);
  w.model.obstacles = {solved_ground(e)};
  Simulation sim(std::move(w), default_integrator(), h);
  double v_in = 0, gap = 0;
  for (int n = 0; n < 200; ++n) {
    v_in = -sim.world().state.v[0].z();
    gap = sim.world().state.x[0].z() - kRadius;
    sim.step();
    if (sim.world().state.v[0].z() > 0) break;
  }
  const double vc = std::sqrt(2 * kG * drop);
  const double t = 2 * gap / (v_in + std::sqrt(v_in * v_in + 2 * kG * gap)), tau = h - t;
  EXPECT_NEAR(v_in + kG * t, vc, 1e-9 * vc);  // the flight before was exact
  EXPECT_NEAR(sim.world().state.v[0].z(), e * vc - kG * tau, 1e-9 * vc);
  // Where the bounce ends, within the contact spring's hold of the step's motion, h v_c / κ.
  EXPECT_NEAR(sim.world().state.x[0].z() - kRadius, e * vc * tau - 0.5 * kG * tau * tau, h * vc / solved_ground().penalty);
  const EnergyBudget b = energy_budget(sim.world().model, sim.world().state);
  const double lost = 0.5 * m * vc * vc * (1 - e * e);
  EXPECT_NEAR(b.dissipated_contact, lost, m * kG * h * vc / solved_ground().penalty);
  EXPECT_NEAR(b.dissipated_numerical, 0, 1e-12 * m * kG * drop);
  EXPECT_EQ(b.numerical_damping, 0.0);  // a quanta without bonds flies and bounces exactly
}

std::string scene_with(const std::string& obstacle, const std::string& integrator = "coupled_implicit") {
  return R"({"timestep": 0.01, "steps": 1, "integrator": {"type": ")" + integrator + R"("},
    "bodies": [{"name": "q", "type": "quanta", "positions": [[0, 0, 1]], "mass": 0.001}],
    "heuristics": [)" +
         obstacle + "]}";
}

TEST(SolvedContact, SceneObstaclesWithMethodImplicitJoinTheModel) {
  const Scene s = parse_scene(scene_with(R"({"type": "ground", "margin": 0.005, "method": "implicit",
      "friction": 0.4, "static_friction": 0.5, "restitution": 0.5, "penalty": 500},
      {"type": "ground", "height": -1})"));
  ASSERT_EQ(s.world.model.obstacles.size(), 1u);
  const Obstacle& o = s.world.model.obstacles[0];
  EXPECT_EQ(o.method, ContactMethod::implicit);
  EXPECT_EQ(o.material.friction, 0.4);
  EXPECT_EQ(o.material.static_coefficient(), 0.5);
  EXPECT_EQ(o.material.restitution, 0.5);
  EXPECT_EQ(o.penalty, 500);
  ASSERT_EQ(s.heuristics.size(), 1u);  // the projection one stays a rule, numbered from 0
  EXPECT_EQ(std::get<Obstacle>(s.heuristics[0]).record, 0);
  auto refused = [](const std::string& text, const std::string& says) {
    try {
      parse_scene(text);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const std::exception& e) {
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
    }
  };
  refused(scene_with(R"({"type": "ground", "method": "implicit"})", "velocity_verlet"), "coupled_implicit");
  refused(scene_with(R"({"type": "ground", "method": "implicit", "friction": 0.5, "static_friction": 0.4})"),
          "must be >= friction");
  refused(scene_with(R"({"type": "ground", "penalty": 10})"), "method");
  refused(scene_with(R"({"type": "ground", "method": "solve"})"), "method");
}

}  // namespace
}  // namespace qbond
