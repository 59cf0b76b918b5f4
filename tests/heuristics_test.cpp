// Heuristics: fracture, plasticity and collisions, against their stated rules and the
// conservation laws they must keep.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "qbond/heuristics/contacts.hpp"
#include "qbond/heuristics/damping_zone.hpp"
#include "qbond/heuristics/formation.hpp"
#include "qbond/io/checkpoint.hpp"
#include "qbond/heuristics/fracture.hpp"
#include "qbond/io/scene.hpp"
#include "test_util.hpp"

namespace qbond {
namespace {

// A chain of n quanta along x (spacing a), the first anchored, the last pulled along +x at speed
// u; bond `weak` has half the stiffness of the others.
World pulled_chain(int n, double a, double k, double u, std::size_t weak) {
  World w;
  for (int q = 0; q < n; ++q) w.add_quanta(Vec3(q * a, 0, 0), Vec3::Zero(), 1e-3);
  for (int q = 0; q + 1 < n; ++q)
    w.add_bond(q, q + 1, {.stiffness = static_cast<std::size_t>(q) == weak ? k / 2 : k, .damping = 0.05});
  w.prescribe({0}, Motion{});
  Motion pull;
  pull.type = MotionType::translate;
  pull.velocity = Vec3(u, 0, 0);
  w.prescribe({static_cast<Index>(n - 1)}, pull);
  return w;
}

double strain_of(const World& w, std::size_t b) {
  const double r = (w.state.x[w.state.bonds.j[b]] - w.state.x[w.state.bonds.i[b]]).norm();
  return (r - w.state.bonds.rest[b]) / w.state.bonds.rest[b];
}

TEST(Break, ABarBreaksWhereTheStrainFirstPassesTheThreshold) {
  const double eps_max = 0.05;
  Simulation sim(pulled_chain(12, 0.01, 100, 0.01, 7), test::coupled(CoupledSolver::ldlt), 1e-3);
  sim.add_heuristic(make_heuristic(BreakRule{.max_strain = eps_max}));
  std::vector<BondEvent> events;
  for (int n = 0; n < 4000 && events.empty(); ++n) {
    // Before the break no bond was past the threshold at the end of a step.
    for (std::size_t b = 0; b < sim.world().num_bonds(); ++b) ASSERT_LE(strain_of(sim.world(), b), eps_max);
    ASSERT_EQ(sim.step().status, StepReport::Status::ok);
    events = sim.events();
  }
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].bond, 7u);  // the soft bond carries the same tension at twice the strain
  EXPECT_EQ(events[0].reason, BondEvent::Reason::strain);
  EXPECT_GT(events[0].strain, eps_max);
  EXPECT_FALSE(sim.world().state.bonds.alive[7]);
  EXPECT_EQ(sim.world().num_alive_bonds(), 10u);
  // The energy the break released is on the books: U = k/2 (ε L)² with k/2 the soft stiffness.
  const double U = 0.5 * 50 * std::pow(events[0].strain * 0.01, 2);
  EXPECT_NEAR(sim.world().state.energy.dissipated_heuristics, U, 1e-12);
}

TEST(Break, RandomBreakingDependsOnTheSeedOnly) {
  auto cracks = [](std::uint64_t seed) {
    World w = test::lattice(10, 4, 1, 200, 1e-3, 0.05, true);
    w.state.rng = Rng{seed};
    std::vector<Index> end;
    for (std::size_t i = 0; i < w.num_quanta(); ++i)
      if (w.state.x[i].x() > 0.085) end.push_back(static_cast<Index>(i));
    Motion pull;
    pull.type = MotionType::translate;
    pull.velocity = Vec3(0.05, 0, 0);
    w.prescribe(end, pull);
    Simulation sim(std::move(w), default_integrator(), 1e-3);
    sim.add_heuristic(make_heuristic(BreakRule{.max_strain = 0.02, .probability = 0.05}));
    std::vector<Index> broken;
    for (int n = 0; n < 400; ++n) {
      EXPECT_EQ(sim.step().status, StepReport::Status::ok);
      for (const BondEvent& e : sim.events()) broken.push_back(e.bond);
    }
    return broken;
  };
  const std::vector<Index> a = cracks(1), b = cracks(1), c = cracks(2);
  ASSERT_GT(a.size(), 5u);
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
}

// The stress criteria: one bond of tension T between quanta of volume V has n·σ·n = T r/(2V) at
// each end (stress.hpp), uniaxial, so its von Mises stress is the same number.
TEST(Break, StressCriteriaBreakAtTheVirialStress) {
  const double k = 100, L = 1, s0 = 0.1, V = 0.5;
  const double stress = k * s0 * (L + s0) / (2 * V);
  struct Case {
    BreakRule rule;
    bool breaks;
    BondEvent::Reason reason;
  };
  const Case cases[] = {{{.max_stress = 0.99 * stress}, true, BondEvent::Reason::stress},
                        {{.max_stress = 1.01 * stress}, false, {}},
                        {{.max_von_mises = 0.99 * stress}, true, BondEvent::Reason::von_mises},
                        {{.max_von_mises = 1.01 * stress}, false, {}}};
  for (const Case& c : cases) {
    World w = test::two_quanta(1, k, L, s0, 0);
    w.model.volume = {V, V};
    w.prescribe({0, 1}, Motion{});  // held, so the projected state is the initial one
    Simulation sim(std::move(w), default_integrator(), 1e-3);
    sim.add_heuristic(make_heuristic(c.rule));
    sim.step();
    ASSERT_EQ(sim.events().size(), c.breaks ? 1u : 0u);
    if (c.breaks) {
      EXPECT_EQ(sim.events()[0].reason, c.reason);
    }
  }
}

TEST(Plastic, RestLengthFollowsTheBilinearRule) {
  // Perfectly plastic: |r - L| stays at ε_y L₀. Hardening α: tangent α k, set (1-α)(ε - ε_y).
  const PlasticRule perfect{.yield_strain = 0.01};
  EXPECT_EQ(plastic_rest_length(perfect, 1.005, 1.0, 1.0), 1.0);  // elastic
  EXPECT_NEAR(plastic_rest_length(perfect, 1.05, 1.0, 1.0), 1.04, 1e-15);
  EXPECT_NEAR(plastic_rest_length(perfect, 0.95, 1.0, 1.0), 0.96, 1e-15);
  const PlasticRule hard{.yield_strain = 0.01, .hardening = 0.25};
  EXPECT_NEAR(plastic_rest_length(hard, 1.05, 1.0, 1.0) - 1.0, 0.75 * (0.05 - 0.01), 1e-15);
}

TEST(Plastic, ALoadedUnloadedBondKeepsThePermanentSetTheoryPredicts) {
  // One bond, anchored at 0, an overdamped mass at the other end loaded by F = 1.8 T_y, then
  // unloaded. With kinematic hardening c = α/(1-α) = 1, loading stops flowing at
  // e - c p = ε_y with e = F/(k L₀), so p = (F/(k L₀) - ε_y)/c; unloading is elastic (c p < ε_y).
  const double k = 100, L0 = 0.01, m = 1e-3, ey = 0.01, alpha = 0.5;
  const double F = 1.8 * k * ey * L0;
  World w;
  w.add_quanta(Vec3::Zero(), Vec3::Zero(), m);
  w.add_quanta(Vec3(L0, 0, 0), Vec3::Zero(), m);
  w.add_bond(0, 1, {.stiffness = k, .damping = 5 * std::sqrt(k * m)});
  w.prescribe({0}, Motion{});
  w.add_load({1}, Vec3(F, 0, 0));
  Simulation sim(std::move(w), test::coupled(CoupledSolver::ldlt), 1e-3);
  sim.add_heuristic(make_heuristic(PlasticRule{.yield_strain = ey, .hardening = alpha}));
  for (int n = 0; n < 5000; ++n) ASSERT_EQ(sim.step().status, StepReport::Status::ok);
  const double c = alpha / (1 - alpha);
  const double p = (F / (k * L0) - ey) / c;
  EXPECT_NEAR(sim.world().state.bonds.rest[0], L0 * (1 + p), 1e-9 * L0);
  sim.world().model.loads.clear();
  for (int n = 0; n < 5000; ++n) ASSERT_EQ(sim.step().status, StepReport::Status::ok);
  const World& done = sim.world();
  EXPECT_NEAR(done.state.bonds.rest[0], L0 * (1 + p), 1e-9 * L0);  // no reverse yielding
  EXPECT_NEAR(done.state.x[1].x(), L0 * (1 + p), 1e-9 * L0);  // at rest at its new length
  // The plastic work is what the books say: ∫ T dL = k L₀² (ε_y p + c p²/2) along the flow.
  const double work = k * L0 * L0 * (ey * p + 0.5 * c * p * p);
  EXPECT_NEAR(done.state.energy.dissipated_heuristics, work, 0.01 * work);
}

TEST(Plastic, PastTheDuctilityLimitTheBondBreaks) {
  Simulation sim(pulled_chain(2, 0.01, 100, 0.01, 99), test::coupled(CoupledSolver::ldlt), 1e-3);
  sim.add_heuristic(make_heuristic(PlasticRule{.yield_strain = 0.01, .max_plastic_strain = 0.1}));
  for (int n = 0; n < 200 && sim.events().empty(); ++n) sim.step();
  ASSERT_EQ(sim.events().size(), 1u);
  EXPECT_EQ(sim.events()[0].reason, BondEvent::Reason::ductility);
  // Broken when its plastic strain passed 0.1: at a total strain of about 0.11.
  const double stretch = sim.world().state.x[1].x() / 0.01 - 1;
  EXPECT_NEAR(stretch, 0.11, 0.002);
}

Obstacle ground(double restitution, double friction) {
  Obstacle g;
  g.material = {restitution, friction};
  return g;
}

// A 4×4×4 cube falling at 10 m/s onto the ground. At h = 1 ms a step moves it one spacing: no
// quanta may end a step below the ground and the cube comes to rest on it. The contact acts on the
// projection after the solve, so the layers above the stopped one learn of the impact only a step
// later: at this step they land on it and the cube is crushed, and the contact's position edit
// stores energy in the crushed bonds (docs/heuristics.md, "Limits"). At h = 0.1 ms (0.1 spacing
// per step) the impact only takes energy away and the cube lands whole.
void drop_cube(double h, double seconds, bool small_step) {
  World w = test::lattice(4, 4, 4, 1e4, 1e-3, 5, false, Vec3(0, 0, -9.81));
  for (std::size_t i = 0; i < w.num_quanta(); ++i) {
    w.state.x[i].z() += 0.05;
    w.state.v[i] = Vec3(0, 0, -10);
  }
  const double e0 = energies(w.model, w.state).total();
  Simulation sim(std::move(w), default_integrator(), h);
  sim.add_heuristic(make_obstacle_heuristic({ground(0.2, 0.5)}));
  const int steps = static_cast<int>(seconds / h);
  for (int n = 0; n < steps; ++n) {
    ASSERT_EQ(sim.step().status, StepReport::Status::ok);
    for (const Vec3& x : sim.world().state.x) ASSERT_GE(x.z(), -1e-12) << "h " << h << ", step " << n;
    if (small_step) {
      ASSERT_LE(energies(sim.world().model, sim.world().state).total(), e0) << "step " << n;
    }
  }
  EXPECT_LT(max_speed(sim.world().model, sim.world().state).first, 0.01) << "h " << h;
  double top = -INFINITY;
  for (const Vec3& x : sim.world().state.x) top = std::max(top, x.z());
  if (small_step) {
    EXPECT_NEAR(top, 0.03, 0.001);  // on its bottom face, 3 spacings tall
  }
}

TEST(Obstacles, ACubeDroppedAt10MetresPerSecondComesToRestOnTheGround) {
  drop_cube(1e-3, 1.5, false);
  drop_cube(1e-4, 1.2, true);
}

TEST(Obstacles, AFastQuantaCannotPassThroughAThinBoxOrASphere) {
  for (Obstacle::Shape shape : {Obstacle::Shape::box, Obstacle::Shape::sphere}) {
    Obstacle o;
    o.shape = shape;
    o.center = Vec3(0.5, 0, 0);
    o.half_extents = Vec3(0.001, 1, 1);  // a 2 mm wall
    o.radius = 0.01;
    World w;
    w.add_quanta(Vec3(0, 0, 0), Vec3(100, 0, 0), 1);  // 1 m per step at h = 0.01
    Simulation sim(std::move(w), default_integrator(), 0.01);
    sim.add_heuristic(make_obstacle_heuristic({o}));
    for (int n = 0; n < 5; ++n) sim.step();
    EXPECT_LE(sim.world().state.x[0].x(), 0.5) << int(shape);
    Vec3 nrm;
    EXPECT_GE(o.distance(sim.world().state.x[0], nrm), -1e-12) << int(shape);
  }
}

TEST(Obstacles, FrictionStopsASlidingQuantaAtTheCoulombDistance) {
  // Sliding on the ground at v₀ with friction μ under gravity: it stops after v₀²/(2 μ g) (to
  // first order in h, the velocity each step loses is μ g h).
  const double v0 = 1, mu = 0.5, g = 9.81, h = 1e-4;
  World w;
  w.model.gravity = Vec3(0, 0, -g);
  w.add_quanta(Vec3::Zero(), Vec3(v0, 0, 0), 1);
  Simulation sim(std::move(w), default_integrator(), h);
  sim.add_heuristic(make_obstacle_heuristic({ground(0, mu)}));
  for (int n = 0; n < 4000; ++n) sim.step();
  EXPECT_EQ(sim.world().state.v[0].x(), 0.0);
  EXPECT_NEAR(sim.world().state.x[0].x(), v0 * v0 / (2 * mu * g), 2 * v0 * h);
}

TEST(Contacts, TwoCollidingBodiesConserveLinearMomentum) {
  World w = test::lattice(3, 3, 3, 1000, 1e-3, 0.05, false);
  const std::size_t n1 = w.num_quanta();
  CubicLattice other;
  other.size = {3, 3, 3};
  other.spacing = 0.01;
  other.quanta_mass = 2e-3;
  other.bond = {.stiffness = 1000, .damping = 0.05};
  add_cubic_lattice(w, other, w.add_body("b"));
  for (std::size_t i = 0; i < w.num_quanta(); ++i) {
    if (i >= n1) w.state.x[i] += Vec3(0.035, 0.005, 0);
    w.state.v[i] = Vec3(i < n1 ? 1.0 : -0.5, 0, 0);
  }
  const Vec3 p0 = linear_momentum(w.model, w.state);
  Simulation sim(std::move(w), default_integrator(), 1e-4);
  sim.add_heuristic(make_heuristic(QuantaContactRule{.radius = 0.004, .material = {0.5, 0.3}}));
  for (int n = 0; n < 400; ++n) ASSERT_EQ(sim.step().status, StepReport::Status::ok);
  const World& done = sim.world();
  const Vec3 p1 = linear_momentum(done.model, done.state);
  double scale = 0;  // Σ m |v|: the momenta that cancel in p0
  for (std::size_t i = 0; i < done.num_quanta(); ++i) scale += done.model.mass[i] * (i < n1 ? 1.0 : 0.5);
  EXPECT_LE((p1 - p0).norm(), 1e-14 * scale);
  // They met and bounced: the first body now moves slower than it came, or backwards.
  Vec3 v1 = Vec3::Zero();
  for (std::size_t i = 0; i < n1; ++i) v1 += done.state.v[i];
  EXPECT_LT(v1.x() / static_cast<double>(n1), 0.5);
}

// Smallest distance between two quanta that share no bond.
double closest_unbonded(const World& w) {
  double best = INFINITY;
  std::vector<std::vector<Index>> nb(w.num_quanta());
  for (std::size_t b = 0; b < w.num_bonds(); ++b) {
    nb[w.state.bonds.i[b]].push_back(w.state.bonds.j[b]);
    nb[w.state.bonds.j[b]].push_back(w.state.bonds.i[b]);
  }
  for (std::size_t i = 0; i < w.num_quanta(); ++i)
    for (std::size_t j = i + 1; j < w.num_quanta(); ++j) {
      if (std::find(nb[i].begin(), nb[i].end(), j) != nb[i].end()) continue;
      best = std::min(best, (w.state.x[i] - w.state.x[j]).norm());
    }
  return best;
}

TEST(Contacts, ADroppedSheetFoldsOnItselfWithoutPassingThroughItself) {
  // A soft sheet standing on its edge falls over onto the ground and crumples: its layers meet,
  // and no two unbonded quanta ever come closer than the contact allows.
  World w;
  w.model.gravity = Vec3(0, 0, -9.81);
  SquareLattice sheet;
  sheet.size = {16, 16};
  sheet.spacing = 0.01;
  sheet.quanta_mass = 1e-3;
  sheet.diagonals = true;
  sheet.bending = true;
  sheet.bond = {.stiffness = 50, .damping = 0.01};
  const auto ids = add_square_lattice(w, sheet);
  // Stand it in the x-z plane, tilted, 1 cm above the ground.
  for (Index i : ids) {
    const Vec3 p = w.state.x[i];
    w.state.x[i] = Vec3(p.x(), 0.3 * p.y(), p.y() + 0.01);
  }
  const double R = 0.0045;
  Simulation sim(std::move(w), default_integrator(), 1e-3);
  sim.add_heuristic(make_obstacle_heuristic({ground(0, 0.5)}));
  sim.add_heuristic(make_heuristic(QuantaContactRule{.radius = R, .material = {0, 0.3}}));
  double closest = INFINITY;
  for (int n = 0; n < 1500; ++n) {
    ASSERT_EQ(sim.step().status, StepReport::Status::ok);
    if (n % 50 == 49) closest = std::min(closest, closest_unbonded(sim.world()));
  }
  // The sheet lies crumpled on the ground: its top is far below its standing height.
  double top = -INFINITY;
  for (const Vec3& x : sim.world().state.x) top = std::max(top, x.z());
  EXPECT_LT(top, 0.08);
  EXPECT_GE(closest, 1.5 * R);  // layers touched (contacts active) but never passed through
}

TEST(Heuristics, SceneKeysBuildTheRules) {
  const Scene s = parse_scene(R"({
    "timestep": 0.001, "steps": 10,
    "bodies": [{"name": "bar", "type": "lattice", "cell": "cubic", "size": [4, 2, 2], "spacing": 0.01,
                "quanta_mass": 0.001, "material": "m"}],
    "materials": {"m": {"stiffness": 100}},
    "heuristics": [{"type": "break", "max_strain": 0.1, "probability": 0.5, "select": {"box": [[0, -1, -1], [0.015, 1, 1]]}},
                   {"type": "plastic", "yield_strain": 0.01, "hardening": 0.2},
                   {"type": "ground", "height": -0.1, "restitution": 0.3, "friction": 0.4},
                   {"type": "box", "center": [0, 0, -1], "size": [1, 1, 0.1], "rotation": {"axis": [0, 0, 1], "angle": 0.3}},
                   {"type": "contact", "radius": 0.004}]})",
                              "h.json");
  ASSERT_EQ(s.heuristics.size(), 5u);
  const auto& br = std::get<BreakRule>(s.heuristics[0]);
  EXPECT_EQ(br.max_strain, 0.1);
  EXPECT_EQ(br.probability, 0.5);
  ASSERT_EQ(br.quanta.size(), s.world.num_quanta());
  std::size_t selected = 0;
  for (auto q : br.quanta) selected += q;
  EXPECT_GT(selected, 0u);
  EXPECT_LT(selected, s.world.num_quanta());
  EXPECT_EQ(std::get<PlasticRule>(s.heuristics[1]).hardening, 0.2);
  EXPECT_EQ(std::get<Obstacle>(s.heuristics[2]).center.z(), -0.1);
  EXPECT_EQ(std::get<Obstacle>(s.heuristics[3]).half_extents, Vec3(0.5, 0.5, 0.05));
  EXPECT_EQ(std::get<QuantaContactRule>(s.heuristics[4]).radius, 0.004);
}

// Three free quanta on the x axis: 0 and 1 of body 0 at distance d01, 2 of body 1 approaching 1.
World approaching(double d01, double gap, double speed) {
  World w;
  w.add_body("one");
  const Index b1 = w.add_body("other");
  w.add_quanta(Vec3(0, 0, 0), Vec3::Zero(), 1e-3);
  w.add_quanta(Vec3(d01, 0, 0), Vec3::Zero(), 1e-3);
  w.add_quanta(Vec3(d01 + gap, 0, 0), Vec3(-speed, 0, 0), 1e-3, b1);
  return w;
}

TEST(Form, QuantaWithinTheCaptureRadiusBondAtTheirDistance) {
  const double h = 1e-3, speed = 1.0, capture = 0.012;
  Simulation sim(approaching(0.03, 0.02, speed), default_integrator(), h);
  sim.add_heuristic(make_heuristic(FormRule{.capture_radius = capture, .bond = {.stiffness = 50}}));
  std::vector<BondEvent> formed;
  double distance_before = 0;
  for (int n = 0; n < 12 && formed.empty(); ++n) {
    const World& w = sim.world();
    distance_before = (w.state.x[2] - w.state.x[1]).norm();
    sim.step();
    for (const BondEvent& e : sim.events()) formed.push_back(e);
  }
  ASSERT_EQ(formed.size(), 1u);  // 0 and 1 are 0.03 apart: never within 0.012
  const BondEvent& e = formed[0];
  EXPECT_EQ(e.kind, BondEvent::Kind::formed);
  EXPECT_EQ(e.reason, BondEvent::Reason::capture);
  EXPECT_EQ(std::min(e.i, e.j), 1u);
  EXPECT_EQ(std::max(e.i, e.j), 2u);
  const World& w = sim.world();
  const double r = (w.state.x[2] - w.state.x[1]).norm();
  EXPECT_LT(r, capture);
  EXPECT_GE(distance_before, capture - h * speed);  // it formed in the first step that came within
  EXPECT_DOUBLE_EQ(w.state.bonds.rest[e.bond], r);        // rest length: the distance at formation
  EXPECT_EQ(w.state.bonds.first_formed, 0u);  // a bond formed during the run
  EXPECT_EQ(w.num_bonds(), 1u);
}

TEST(Form, PairRulesAndBondCountsLimitWhoBonds) {
  // Five quanta in a tight row; body 0: quanta 0-2, body 1: quanta 3-4, all within the radius.
  auto bonds_made = [](FormRule rule) {
    World w;
    w.add_body("b0");
    const Index b1 = w.add_body("b1");
    for (int q = 0; q < 5; ++q) w.add_quanta(Vec3(0.001 * q, 0, 0), Vec3::Zero(), 1e-3, q < 3 ? 0 : b1);
    Simulation sim(std::move(w), default_integrator(), 1e-3);
    rule.capture_radius = 0.0105;
    rule.bond.stiffness = 10;
    sim.add_heuristic(make_heuristic(rule));
    sim.step();
    std::vector<std::pair<Index, Index>> pairs;
    for (const BondEvent& e : sim.events()) pairs.emplace_back(e.i, e.j);
    return pairs;
  };
  EXPECT_EQ(bonds_made({}).size(), 10u);  // every pair
  for (const auto& [i, j] : bonds_made({.pairs = FormPairs::same_body})) {
    EXPECT_EQ(i < 3, j < 3);
  }
  EXPECT_EQ(bonds_made({.pairs = FormPairs::same_body}).size(), 3u + 1u);
  for (const auto& [i, j] : bonds_made({.pairs = FormPairs::other_body})) {
    EXPECT_NE(i < 3, j < 3);
  }
  EXPECT_EQ(bonds_made({.pairs = FormPairs::other_body}).size(), 6u);
  // At most one bond each: a matching, made in order (0-1, then 2-3).
  const auto matched = bonds_made({.max_bonds = 1});
  EXPECT_EQ(matched, (std::vector<std::pair<Index, Index>>{{0, 1}, {2, 3}}));
  // Only selected quanta bond.
  EXPECT_EQ(bonds_made({.quanta = {1, 1, 0, 0, 0}}).size(), 1u);
}

// A bond that breaks is not made again within min_age, and its slot is reused after.
TEST(Form, BrokenPairsWaitMinAgeAndSlotsAreReused) {
  World w;
  w.add_quanta(Vec3(0, 0, 0), Vec3::Zero(), 1e-3);
  w.add_quanta(Vec3(0.005, 0, 0), Vec3::Zero(), 1e-3);
  Simulation sim(std::move(w), default_integrator(), 1e-3);
  sim.add_heuristic(make_heuristic(FormRule{.capture_radius = 0.01, .min_age = 0.0045, .bond = {.stiffness = 10}}));
  sim.step();
  ASSERT_EQ(sim.world().num_bonds(), 1u);
  sim.world().break_bond(0);  // at t = 1 ms
  int rebond_step = -1;
  for (int n = 1; n < 10 && rebond_step < 0; ++n) {
    sim.step();
    if (!sim.events().empty()) rebond_step = n;
  }
  // Broken at t = 1 ms; the step starting at t bonds once t > 1 ms + 4.5 ms: the one from 6 ms.
  EXPECT_EQ(rebond_step, 6);
  EXPECT_EQ(sim.world().num_bonds(), 1u);  // the broken slot, reused
  EXPECT_TRUE(sim.world().state.bonds.alive[0]);
}

// A formed bond lives in the state alone: a world built without it takes it back with a saved
// state, and the model the rule's shape was interned in is all it needs.
TEST(Form, AFormedBondTravelsWithTheState) {
  Simulation sim(approaching(0.03, 0.001, 0.0), default_integrator(), 1e-3);
  sim.add_heuristic(make_heuristic(FormRule{.capture_radius = 0.002, .bond = {.stiffness = 10}}));
  const Model model = sim.world().model;
  sim.step();
  ASSERT_EQ(sim.world().num_bonds(), 1u);
  EXPECT_TRUE(sim.world().model == model);
  World fresh = approaching(0.03, 0.001, 0.0);
  EXPECT_EQ(fresh.num_bonds(), 0u);
  fresh.state = deserialize_state(serialize_state(sim.world().state));
  ASSERT_EQ(fresh.num_bonds(), 1u);
  EXPECT_EQ(fresh.state.bonds.i[0], sim.world().state.bonds.i[0]);
  EXPECT_EQ(fresh.state.bonds.strength[0], 10.0);
  EXPECT_EQ(fresh.state.bonds.first_formed, 0u);
}

// Welding: a block moving into an anchored one welds to it on contact and then hangs from it;
// formation changes no momentum.
TEST(Form, WeldedBlocksHoldTogetherAndKeepMomentum) {
  World w;
  w.add_body("upper");
  CubicLattice top;
  top.size = {3, 3, 3};
  top.bond = {.stiffness = 200, .damping = 0.05};
  const auto upper = add_cubic_lattice(w, top);
  CubicLattice low = top;
  low.origin = Vec3(0, 0, -0.03);
  low.velocity = Vec3(0, 0, 0.2);
  const Index b1 = w.add_body("lower");
  const auto lower = add_cubic_lattice(w, low, b1);
  const Vec3 p0 = linear_momentum(w.model, w.state);
  Simulation sim(std::move(w), default_integrator(), 1e-3);
  sim.add_heuristic(make_heuristic(FormRule{.capture_radius = 0.0105, .pairs = FormPairs::other_body,
                                         .bond = {.stiffness = 200, .damping = 0.05}}));
  std::size_t welds = 0;
  for (int n = 0; n < 200; ++n) {
    sim.step();
    welds += sim.events().size();
  }
  EXPECT_GE(welds, 9u);  // the 3x3 facing quanta at least
  EXPECT_NEAR((linear_momentum(sim.world().model, sim.world().state) - p0).norm(), 0, 1e-15);
  // Now anchor the top and let gravity pull: the lower block hangs on the weld.
  World& ww = sim.world();
  std::vector<Index> top_face;
  for (Index i : upper)
    if (ww.state.x[i].z() > 0.015) top_face.push_back(i);
  ww.prescribe(top_face, Motion{});
  ww.model.gravity = Vec3(0, 0, -9.81);
  for (int n = 0; n < 1000; ++n) sim.step();
  double lowest = 0;
  for (Index i : lower) lowest = std::min(lowest, ww.state.x[i].z());
  EXPECT_GT(lowest, -0.06);  // still hanging (a free fall of 1 s would be ~5 m)
}

// ---- damping_zone -----------------------------------------------------------------------------

// With no force, a step leaves v as it was, so the zone alone acts: after N steps v = v0 f^N with
// f = e^{−rate h}, the position has advanced by h v0 (1 − f^N)/(1 − f) (each step moves at the
// velocity it began with), and the ledger holds ½ m v0² (1 − f^{2N}), the kinetic energy lost.
TEST(DampingZone, AFreeQuantaInsideSlowsByTheExactExponentialAndTheLedgerHoldsWhatItLost) {
  const double m = 0.5, v0 = 2, rate = 5, h = 1e-3;
  const int N = 200;
  World w;
  w.add_quanta(Vec3::Zero(), Vec3(v0, 0, 0), m);
  Simulation sim(std::move(w), test::config(IntegratorType::symplectic_euler), h);
  sim.add_heuristic(
      make_heuristic(DampingZone{.center = Vec3::Zero(), .size = Vec3(10, 10, 10), .rate = rate}));
  for (int n = 0; n < N; ++n) ASSERT_EQ(sim.step().status, StepReport::Status::ok);
  const double f = std::exp(-rate * h), fN = std::pow(f, N);
  const State& s = sim.world().state;
  EXPECT_NEAR(s.v[0].x(), v0 * fN, 1e-13 * v0);
  EXPECT_EQ(s.v[0].y(), 0.0);
  EXPECT_NEAR(s.x[0].x(), h * v0 * (1 - fN) / (1 - f), 1e-13);
  EXPECT_NEAR(s.energy.dissipated_heuristics, 0.5 * m * v0 * v0 * (1 - fN * fN), 1e-13);
}

// Quanta outside the box, outside the selection, or kinematic move exactly as without the zone.
TEST(DampingZone, QuantaOutsideTheBoxUnselectedOrKinematicAreUntouched) {
  auto world = [] {
    World w;
    w.add_quanta(Vec3(0, 0, 0), Vec3(1, 0, 0), 1e-3);    // inside, selected: damped
    w.add_quanta(Vec3(5, 0, 0), Vec3(1, 0, 0), 1e-3);    // outside the box
    w.add_quanta(Vec3(0, 0.2, 0), Vec3(1, 0, 0), 1e-3);  // inside, not selected
    w.add_quanta(Vec3(0, -0.2, 0), Vec3::Zero(), 1e-3);  // inside, kinematic
    Motion slide;
    slide.type = MotionType::translate;
    slide.velocity = Vec3(1, 0, 0);
    w.prescribe({3}, slide);
    return w;
  };
  Simulation damped(world(), test::coupled(CoupledSolver::ldlt), 1e-3);
  Simulation free(world(), test::coupled(CoupledSolver::ldlt), 1e-3);
  damped.add_heuristic(make_heuristic(
      DampingZone{.center = Vec3::Zero(), .size = Vec3(2, 2, 2), .rate = 100, .quanta = {1, 1, 0, 1}}));
  for (int n = 0; n < 100; ++n) {
    ASSERT_EQ(damped.step().status, StepReport::Status::ok);
    ASSERT_EQ(free.step().status, StepReport::Status::ok);
  }
  const State &d = damped.world().state, &f = free.world().state;
  EXPECT_LT(d.v[0].x(), 0.5 * f.v[0].x());
  for (Index i : {1u, 2u, 3u}) {
    EXPECT_EQ(d.x[i], f.x[i]) << i;
    EXPECT_EQ(d.v[i], f.v[i]) << i;
  }
}

// The use the rule is for: a pulse travelling along a free chain would run back and forth for
// ever; with a damping zone over the chain's last third it is absorbed. Undamped symplectic Euler
// keeps the energy to O(h), so what the chain loses is what the ledger says the zone took.
TEST(DampingZone, AZoneAtTheEndOfAChainAbsorbsAPulseAndTheLedgerAccountsForIt) {
  const int n = 120;
  const double a = 0.01, m = 1e-3, k = 100, h = 1e-4;
  World w;
  double E0 = 0;
  for (int q = 0; q < n; ++q) {
    const double s = (q - 10) / 3.0;  // a smooth pulse of velocities around quanta 10
    const Vec3 v(0.1 * std::exp(-s * s), 0, 0);
    w.add_quanta(Vec3(q * a, 0, 0), v, m);
    E0 += 0.5 * m * v.squaredNorm();
  }
  for (int q = 0; q + 1 < n; ++q) w.add_bond(q, q + 1, {.stiffness = k});
  Simulation sim(std::move(w), test::config(IntegratorType::symplectic_euler), h);
  // The zone's edge reflects little when the rate is well below the pulse's frequency (~400 /s).
  sim.add_heuristic(
      make_heuristic(DampingZone{.center = Vec3(1.0, 0, 0), .size = Vec3(0.4, 1, 1), .rate = 40}));
  // Sound speed a √(k/m) ≈ 3.2 m/s: 1.5 s carries both halves of the pulse into the zone and
  // through it and back more than once.
  for (int step = 0; step < 15000; ++step) ASSERT_EQ(sim.step().status, StepReport::Status::ok);
  const State& s = sim.world().state;
  double left = 0;  // kinetic and elastic energy still in the chain
  for (int q = 0; q < n; ++q) left += 0.5 * m * s.v[q].squaredNorm();
  for (int q = 0; q + 1 < n; ++q) {
    const double stretch = (s.x[q + 1] - s.x[q]).norm() - a;
    left += 0.5 * k * stretch * stretch;
  }
  EXPECT_LT(left, 0.02 * E0);
  EXPECT_NEAR(s.energy.dissipated_heuristics + left, E0, 0.01 * E0);
}

TEST(DampingZone, TheSceneTypeReadsItsKeysAndNamesTheEntryInItsErrors) {
  auto scene = [](const std::string& zone) {
    return parse_scene(R"({"timestep": 0.001, "steps": 1,
      "bodies": [{"name": "bar", "type": "lattice", "cell": "cubic", "size": [4, 2, 2], "spacing": 0.01,
                  "quanta_mass": 0.001, "material": "m"}],
      "materials": {"m": {"stiffness": 100}},
      "heuristics": [{"type": "break", "max_strain": 0.1}, )" +
                           zone + "]}",
                       "zone.json");
  };
  const Scene s = scene(R"({"type": "damping_zone", "center": [0, 0, 0], "size": [0.02, 1, 1], "rate": 30,
                            "select": {"box": [[0, -1, -1], [0.015, 1, 1]]}})");
  ASSERT_EQ(s.heuristics.size(), 2u);
  const auto& z = std::get<DampingZone>(s.heuristics[1]);
  EXPECT_EQ(z.size, Vec3(0.02, 1, 1));
  EXPECT_EQ(z.rate, 30.0);
  ASSERT_EQ(z.quanta.size(), s.world.num_quanta());
  auto error = [&](const std::string& zone) {
    try {
      scene(zone);
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error(R"({"type": "damping_zone", "center": [0, 0, 0], "size": [1, 0, 1], "rate": 1})")
                .find("heuristics[1].size: every edge must be > 0"),
            std::string::npos);
  EXPECT_NE(error(R"({"type": "damping_zone", "center": [0, 0, 0], "size": [1, 1, 1], "rate": -1})")
                .find("heuristics[1].rate"),
            std::string::npos);
  EXPECT_NE(error(R"({"type": "damping_zone", "center": [0, 0, 0], "size": [1, 1, 1]})")
                .find("heuristics[1].rate: required key missing"),
            std::string::npos);
  EXPECT_NE(
      error(R"({"type": "damping_zone", "center": [0, 0, 0], "size": [1, 1, 1], "rate": 1, "speed": 2})")
          .find("heuristics[1].speed: unknown key"),
      std::string::npos);
  EXPECT_THROW(make_heuristic(DampingZone{.size = Vec3(1, 1, 1), .rate = 0}), std::invalid_argument);
}

}  // namespace
}  // namespace qbond
