// Gases: the gas builder, elastic quanta–quanta and wall collisions, container obstacles and the
// wall impulse that measures pressure (docs/gases.md).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "qbond/analysis/analysis.hpp"
#include "qbond/io/checkpoint.hpp"
#include "qbond/heuristics/contacts.hpp"
#include "qbond/builders/gas.hpp"
#include "qbond/builders/samples.hpp"
#include "qbond/io/scene.hpp"
#include "qbond/simulation/simulation.hpp"

namespace qbond {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();

double kinetic(const World& w) {
  double e = 0;
  for (std::size_t i = 0; i < w.num_quanta(); ++i) e += 0.5 * w.model.mass[i] * w.state.v[i].squaredNorm();
  return e;
}

Gas small_gas(Gas::Speeds speeds, std::size_t count = 201) {
  Gas g;
  g.size = Vec3(0.05, 0.05, 0.05);
  g.count = count;
  g.min_distance = 0.004;
  g.quanta_mass = 2e-3;
  g.kT = 3e-3;
  g.speeds = speeds;
  g.seed = 5;
  return g;
}

// A 5 cm gas (centres in [0.002, 0.052]) in a container whose walls are `radius` from the centres.
struct Boxed {
  World world;
  Obstacle box;
  double radius = 0.002;
};
Boxed boxed_gas(Gas::Speeds speeds) {
  Boxed b;
  const Gas g = small_gas(speeds);
  add_gas(b.world, g, b.world.add_body("gas"));
  for (Vec3& x : b.world.state.x) x += Vec3::Constant(b.radius);
  b.box.shape = Obstacle::Shape::box;
  b.box.inside = true;
  b.box.center = 0.5 * g.size + Vec3::Constant(b.radius);
  b.box.half_extents = 0.5 * g.size + Vec3::Constant(b.radius);
  b.box.margin = b.radius;
  b.box.material.restitution = 1;
  b.box.record = 0;
  return b;
}

Simulation gas_simulation(const Boxed& b, double h) {
  Simulation sim(b.world, default_integrator(), h);
  sim.add_heuristic(make_obstacle_heuristic({b.box}));
  QuantaContactRule r;
  r.radius = b.radius;
  r.material.restitution = 1;
  sim.add_heuristic(make_heuristic(r));
  return sim;
}

TEST(Gas, BuilderGivesZeroMomentumAndTheRequestedTemperature) {
  for (Gas::Speeds sp : {Gas::Speeds::maxwell, Gas::Speeds::equal}) {
    for (std::size_t n : {200, 201}) {  // equal speeds: pairs, and a triangle for an odd count
      const Gas g = small_gas(sp, n);
      World w;
      const std::vector<Index> ids = add_gas(w, g);
      ASSERT_EQ(ids.size(), n);
      // Each velocity is O(v_rms); summing n of them rounds at about n eps v_rms.
      const double v_rms = std::sqrt(3 * g.kT / g.quanta_mass);
      EXPECT_LT(linear_momentum(w.model, w.state).norm(), 10 * n * kEps * g.quanta_mass * v_rms);
      EXPECT_NEAR(kinetic_temperature(w.model, w.state, ids), g.kT, 10 * n * kEps * g.kT);
      EXPECT_EQ(w.num_bonds(), 0u);
      for (std::size_t i = 0; i < n; ++i) {
        EXPECT_TRUE((w.state.x[i].array() >= 0).all() && (w.state.x[i].array() <= g.size.array()).all());
        for (std::size_t j = 0; j < i; ++j) EXPECT_GE((w.state.x[i] - w.state.x[j]).norm(), g.min_distance);
        if (sp == Gas::Speeds::equal) {
          EXPECT_NEAR(w.state.v[i].norm(), v_rms, 10 * kEps * v_rms);
        }
      }
    }
  }
}

TEST(Gas, MaxwellSpeedsAreNotAllEqual) {
  // The Maxwell–Boltzmann builder's speeds spread: for MB the standard deviation of the speed is
  // sqrt(3π/8 - 1) = 0.42 of its mean; with 201 samples the estimate's own standard error is
  // about 0.42/sqrt(2 × 201) ≈ 0.02, so 0.1 is five of them (equal speeds would give 0).
  World w;
  add_gas(w, small_gas(Gas::Speeds::maxwell));
  double s = 0, s2 = 0;
  for (const Vec3& v : w.state.v) {
    s += v.norm();
    s2 += v.squaredNorm();
  }
  const double n = static_cast<double>(w.num_quanta()), mean = s / n, sd = std::sqrt(s2 / n - mean * mean);
  const double pi = 3.14159265358979323846;
  EXPECT_NEAR(sd / mean, std::sqrt(3 * pi / 8 - 1), 0.1);
}

TEST(Gas, DeterministicForASeed) {
  const Gas g = small_gas(Gas::Speeds::maxwell);
  World a, b, c;
  add_gas(a, g);
  add_gas(b, g);
  Gas other = g;
  other.seed = 6;
  add_gas(c, other);
  EXPECT_EQ(serialize_state(a.state), serialize_state(b.state));
  EXPECT_NE(serialize_state(a.state), serialize_state(c.state));
}

TEST(Gas, RefusesWhatCannotBeBuilt) {
  Gas g = small_gas(Gas::Speeds::maxwell);
  World w;
  g.count = 1;
  EXPECT_THROW(add_gas(w, g), std::invalid_argument);
  g = small_gas(Gas::Speeds::maxwell, 100000);  // cannot fit 4 mm apart in 5 cm
  EXPECT_THROW(add_gas(w, g), std::invalid_argument);
}

TEST(Contacts, HeadOnElasticCollisionExchangesVelocities) {
  // Equal masses, restitution 1: the velocities swap; nothing else moves them.
  World w;
  w.add_quanta(Vec3(0, 0, 0), Vec3(1, 0, 0), 1e-3);
  w.add_quanta(Vec3(0.01, 0, 0), Vec3(-1, 0, 0), 1e-3);
  Simulation sim(std::move(w), default_integrator(), 1e-4);
  QuantaContactRule r;
  r.radius = 0.002;
  r.material.restitution = 1;
  sim.add_heuristic(make_heuristic(r));
  for (int n = 0; n < 100; ++n) ASSERT_EQ(sim.step().status, StepReport::Status::ok);
  const State& s = sim.world().state;
  EXPECT_NEAR(s.v[0].x(), -1, 1e-14);
  EXPECT_NEAR(s.v[1].x(), 1, 1e-14);
  EXPECT_EQ(s.v[0].y(), 0);
  EXPECT_EQ(s.v[1].z(), 0);
  // They met and parted: at least 2 radii apart, moving away.
  EXPECT_GE(s.x[1].x() - s.x[0].x(), 2 * r.radius);
}

TEST(Contacts, ContainerKeepsQuantaInsideAndRecordsTheImpulseAsMomentumChange) {
  const Boxed b = boxed_gas(Gas::Speeds::equal);
  Simulation sim = gas_simulation(b, 1e-4);
  const Vec3 p0 = linear_momentum(sim.world().model, sim.world().state);
  for (int n = 0; n < 2000; ++n) ASSERT_EQ(sim.step().status, StepReport::Status::ok);
  const World& w = sim.world();
  ASSERT_EQ(w.state.obstacle_impulse.size(), 1u);
  const ObstacleImpulse& J = w.state.obstacle_impulse[0];
  // Quanta–quanta impulses cancel in pairs: the momentum changes only by what the walls gave.
  // Each wall hit reverses a momentum of O(m v_rms); the sums round at eps per term.
  const double scale = 2e-3 * std::sqrt(3 * 3e-3 / 2e-3);
  EXPECT_GT(J.normal, 100 * scale);  // the walls were hit, many times
  EXPECT_LT((linear_momentum(w.model, w.state) - p0 - J.total).norm(), 1e-12 * J.normal + 1e3 * kEps * scale);
  // Every hit pushes toward the free side: the normal impulse is the sum of |m Δv|.
  EXPECT_GE(J.normal, J.total.norm());
  // Inside the box shrunk by the margin (rounding: eps of the coordinates).
  const Vec3 lo = b.box.center - b.box.half_extents + Vec3::Constant(b.box.margin);
  const Vec3 hi = b.box.center + b.box.half_extents - Vec3::Constant(b.box.margin);
  for (const Vec3& x : w.state.x) {
    EXPECT_TRUE((x.array() >= lo.array() - 1e-15).all()) << x.transpose();
    EXPECT_TRUE((x.array() <= hi.array() + 1e-15).all()) << x.transpose();
  }
}

TEST(Contacts, ElasticGasKeepsItsKineticEnergy) {
  // Restitution 1 everywhere and no forces: each contact reverses a normal velocity exactly, so the
  // kinetic energy changes only by rounding (eps per contact, ~10^4 contacts here), even when a
  // quanta meets the wall and another quanta in the same step.
  const Boxed b = boxed_gas(Gas::Speeds::maxwell);
  Simulation sim = gas_simulation(b, 1e-4);
  const double e0 = kinetic(sim.world());
  for (int n = 0; n < 3000; ++n) ASSERT_EQ(sim.step().status, StepReport::Status::ok);
  EXPECT_NEAR(kinetic(sim.world()) / e0, 1, 1e-11);
  EXPECT_LT(std::abs(sim.world().state.energy.dissipated_heuristics), 1e-11 * e0);
}

TEST(Contacts, ContainerSphereKeepsQuantaInside) {
  World w;
  Rng rng{3};
  for (int k = 0; k < 50; ++k)
    w.add_quanta(Vec3(0.01 * (rng.uniform() - 0.5), 0.01 * (rng.uniform() - 0.5), 0.01 * (rng.uniform() - 0.5)),
                 Vec3(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5) * 4, 1e-3);
  Obstacle o;
  o.shape = Obstacle::Shape::sphere;
  o.inside = true;
  o.radius = 0.02;
  o.margin = 0.001;
  o.material.restitution = 1;
  Simulation sim(std::move(w), default_integrator(), 1e-4);
  sim.add_heuristic(make_obstacle_heuristic({o}));
  const double e0 = kinetic(sim.world());
  for (int n = 0; n < 1000; ++n) ASSERT_EQ(sim.step().status, StepReport::Status::ok);
  for (const Vec3& x : sim.world().state.x) EXPECT_LE(x.norm(), o.radius - o.margin + 1e-15);
  EXPECT_NEAR(kinetic(sim.world()) / e0, 1, 1e-12);
}

TEST(Gas, SceneRunsTheSameBitsOnAnyThreadCount) {
  auto run = [](int threads) {
    Scene s = builtin_scene("gas_and_block");
    s.integrator.threads = threads;
    Simulation sim(std::move(s.world), s.integrator, s.timestep);
    for (const HeuristicSpec& h : s.heuristics) sim.add_heuristic(make_heuristic(h));
    for (int n = 0; n < 300; ++n) EXPECT_EQ(sim.step().status, StepReport::Status::ok);
    return serialize_state(sim.world().state);
  };
  const std::string one = run(1);
  EXPECT_EQ(one, run(2));
  EXPECT_EQ(one, run(3));
}

TEST(Gas, SceneKeysAreChecked) {
  const char* base = R"({"timestep": 1e-4, "steps": 1, "bodies": [{"name": "g", "type": "gas", "size": [0.1, 0.1, 0.1],
    "count": 10, "quanta_mass": 0.001, "kT": 0.001 %s}], "heuristics": [{"type": "box", "inside": true,
    "center": [0.05, 0.05, 0.05], "size": [0.1, 0.1, 0.1], "margin": %s}]})";
  auto scene = [&](const char* extra, const char* margin) {
    char buf[1024];
    std::snprintf(buf, sizeof buf, base, extra, margin);
    return std::string(buf);
  };
  const Scene s = parse_scene(scene("", "0.001"));
  EXPECT_EQ(s.world.num_quanta(), 10u);
  EXPECT_EQ(s.world.state.obstacle_impulse.size(), 1u);
  EXPECT_NEAR(kinetic_temperature(s.world.model, s.world.state, std::vector<Index>{0, 1, 2, 3, 4, 5, 6, 7, 8, 9}), 0.001,
              1e-15);
  auto error = [&](const std::string& text) {
    try {
      parse_scene(text);
    } catch (const SceneError& e) {
      return e.path;
    }
    return std::string("(none)");
  };
  EXPECT_EQ(error(scene(", \"speeds\": \"fast\"", "0.001")), "bodies[0].speeds");
  EXPECT_EQ(error(scene(", \"min_distance\": -1", "0.001")), "bodies[0].min_distance");
  EXPECT_EQ(error(scene("", "0.06")), "heuristics[0].margin");
}

}  // namespace
}  // namespace qbond
