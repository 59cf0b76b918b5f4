// The step pipeline, the world's bookkeeping and kinematic motion.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <tuple>

#include "integrators/advance.hpp"  // the integrate stage's private path
#include "qbond/builders/samples.hpp"
#include "qbond/io/scene.hpp"
#include "test_util.hpp"

namespace qbond {
namespace {

// Records when it runs and what the projection looked like; optionally edits it.
class Recorder final : public Heuristic {
 public:
  Recorder(std::string name, std::vector<std::string>& log, bool zero_first) : name_(std::move(name)), log_(log), zero_first_(zero_first) {}
  std::string_view name() const override { return name_; }
  void apply(const Model&, State& state, Projection& p, const HeuristicContext& ctx) override {
    // Heuristics run after the projection and before it is applied: the state is still at t.
    EXPECT_EQ(state.time, ctx.step.t);
    log_.push_back(name_ + "@" + std::to_string(ctx.step.step));
    if (zero_first_) {
      p.dv[0].setZero();
      p.dx[0].setZero();
    }
  }

 private:
  std::string name_;
  std::vector<std::string>& log_;
  bool zero_first_;
};

TEST(Pipeline, HeuristicsRunInOrderBetweenProjectionAndApplication) {
  std::vector<std::string> log;
  Simulation sim(test::lattice(2, 2, 2, 100, 1e-3, 0, false, Vec3(0, 0, -9.81)), default_integrator(), 1e-3);
  sim.add_heuristic(std::make_unique<Recorder>("first", log, false));
  sim.add_heuristic(std::make_unique<Recorder>("second", log, true));
  const Vec3 x0 = sim.world().state.x[0], x1 = sim.world().state.x[1];
  for (int n = 0; n < 2; ++n) sim.step();
  EXPECT_EQ(log, (std::vector<std::string>{"first@0", "second@0", "first@1", "second@1"}));
  // The second heuristic's edit is what the step applied: quanta 0 never moved.
  EXPECT_EQ(sim.world().state.x[0], x0);
  EXPECT_NE(sim.world().state.x[1], x1);
}

// Whether two states' positions and velocities are the same bits.
void expect_same_motion(const State& s, const State& s0, const std::string& what) {
  ASSERT_EQ(s.x.size(), s0.x.size()) << what;
  EXPECT_EQ(std::memcmp(s.x.data(), s0.x.data(), s.x.size() * sizeof(Vec3)), 0) << what;
  EXPECT_EQ(std::memcmp(s.v.data(), s0.v.data(), s.v.size() * sizeof(Vec3)), 0) << what;
}

TEST(Pipeline, SameInputsSameBits) {
  auto run = [] {
    Scene s = builtin_scene("pendulum");
    Simulation sim(std::move(s.world), s.integrator, s.timestep);
    for (int n = 0; n < 300; ++n) sim.step();
    return sim.world().state;
  };
  const State a = run(), b = run();
  expect_same_motion(a, b, "");
  EXPECT_TRUE(a.energy == b.energy);  // field by field: the ledger has padding bytes
}

// Threads split loops and sums at fixed boundaries: any thread count gives the same bits. 16³
// quanta is large enough that every parallel loop and chunked sum really runs on several threads.
TEST(Pipeline, AnyThreadCountGivesTheSameBits) {
  const Scene scene = canonical_lattice(16);
  auto run = [&](IntegratorConfig c, int threads, bool broken) {
    c.threads = threads;
    World w = scene.world;
    test::perturb(w, 1e-4, 0.01);  // every bond stretched, so every term matters
    // Broken bonds: one thread then also walks a list of bonds, with gaps in it.
    for (std::size_t b = 5; broken && b < w.num_bonds(); b += 17) w.state.bonds.alive[b] = 0;
    Simulation sim(std::move(w), c, scene.timestep);
    for (int n = 0; n < 3; ++n) EXPECT_EQ(sim.step().status, StepReport::Status::ok);
    return sim.world().state;
  };
  IntegratorConfig sweep = test::config(IntegratorType::hybrid_implicit);
  sweep.iterations = 4;
  sweep.chebyshev_rho = 0.5;
  IntegratorConfig frozen = test::config(IntegratorType::hybrid_implicit);
  frozen.neighbours = NeighbourModel::frozen;
  IntegratorConfig jacobi = test::config(IntegratorType::hybrid_implicit);
  jacobi.neighbours = NeighbourModel::jacobi;
  jacobi.iterations = 3;
  IntegratorConfig em_cg = test::config(IntegratorType::energy_momentum);
  em_cg.tolerance = 1e-10;
  IntegratorConfig em_sweep = em_cg;
  em_sweep.solver = CoupledSolver::sweep;
  em_sweep.iterations = 2;
  IntegratorConfig bdf2 = test::config(IntegratorType::bdf2);
  for (const IntegratorConfig& c :
       {default_integrator(), sweep, frozen, jacobi, test::config(IntegratorType::rk4),
        test::config(IntegratorType::velocity_verlet), em_cg, em_sweep, bdf2}) {
    for (bool broken : {false, true}) {
      const State one = run(c, 1, broken);
      for (int threads : {2, 3}) {
        const State many = run(c, threads, broken);
        const std::string what = std::string(to_string(c.type)) + "/" + std::string(to_string(c.neighbours)) +
                                 "/" + std::string(to_string(c.solver)) + ", " + std::to_string(threads) +
                                 " threads" + (broken ? ", broken bonds" : "");
        expect_same_motion(many, one, what);
        EXPECT_TRUE(one.energy == many.energy) << what;
      }
    }
  }
}

// Without heuristics and the energy ledger, Simulation::step lets the integrator write the state
// the step applies (StepIntegrator::advance): the same bits as the steps that form dx and dv for the
// ledger and apply them, on any thread count, and the same report when a step blows up.
TEST(Pipeline, DirectStepsGiveTheSameBitsAndReportsAsStepsThroughDxDv) {
  Scene scene = canonical_lattice(16);
  World& w0 = scene.world;
  test::perturb(w0, 1e-4, 0.01);
  Motion spin;  // its velocity changes every step
  spin.type = MotionType::rotate;
  spin.axis = Vec3(0, 0, 1);
  spin.rate = 20;
  const Index last = static_cast<Index>(w0.num_quanta() - 1);
  w0.prescribe({last, last - 7, 2000}, spin);
  enum class Last { ok, too_fast, not_finite };
  auto run = [&](const IntegratorConfig& c, bool direct, int threads, Last last_step) {
    IntegratorConfig cfg = c;
    cfg.threads = threads;
    Simulation sim(w0, cfg, scene.timestep);
    sim.set_track_energy(!direct);
    for (int n = 0; n < 4; ++n) EXPECT_EQ(sim.step().status, StepReport::Status::ok);
    if (last_step == Last::too_fast) sim.limits().max_speed = 1e-3;
    if (last_step == Last::not_finite) sim.world().state.v[3000].y() = std::nan("");
    const StepReport r = sim.step();
    return std::pair{r, sim.world().state};
  };
  IntegratorConfig frozen = test::config(IntegratorType::hybrid_implicit), sweep = frozen, jacobi = frozen;
  frozen.neighbours = NeighbourModel::frozen;
  sweep.neighbours = NeighbourModel::sweep;
  jacobi.neighbours = NeighbourModel::jacobi;
  for (const IntegratorConfig& c : {test::config(IntegratorType::velocity_verlet), frozen, sweep, jacobi,
                                    default_integrator(), test::config(IntegratorType::rk4),
                                    test::config(IntegratorType::explicit_euler)})
    for (Last last_step : {Last::ok, Last::too_fast, Last::not_finite}) {
      const auto [r0, s0] = run(c, false, 1, last_step);
      EXPECT_EQ(r0.status == StepReport::Status::ok, last_step == Last::ok);
      for (int threads : {1, 2}) {
        const auto [r, s] = run(c, true, threads, last_step);
        const std::string what = std::string(to_string(c.type)) + "/" + std::string(to_string(c.neighbours)) +
                                 ", " + std::to_string(threads) + " threads, last step " +
                                 std::to_string(static_cast<int>(last_step));
        EXPECT_EQ(r.status, r0.status) << what;
        EXPECT_EQ(r.message, r0.message) << what;
        EXPECT_EQ(r.worst, r0.worst) << what;
        EXPECT_EQ(s.step, s0.step) << what;
        expect_same_motion(s, s0, what);
        EXPECT_TRUE(s.carry == s0.carry) << what;
      }
    }
}

// The integrate stage's private path, called directly: every integrator's advance() gives the
// state that project() and apply_checked give, bit for bit, with the same verdict and carry-over,
// over steps that use the carry-over; one that forms gravity gives it for an empty f_ext too
// (f_ext = m g exactly, as the gather stage forms it). Both verdicts fail together for a step
// too fast and for a non-finite velocity.
TEST(Pipeline, AdvanceInPlaceGivesTheBitsOfProjectAndApply) {
  World w0 = test::lattice(12, 10, 8, 1000, 1e-3, 0.01, false, Vec3(0.3, 0, -9.81));
  test::perturb(w0, 1e-4, 0.01);
  Motion spin;
  spin.type = MotionType::rotate;
  spin.axis = Vec3(0, 0, 1);
  spin.rate = 20;
  w0.prescribe({0, 5, 500}, spin);
  const Model& m = w0.model;
  const std::size_t n = w0.num_quanta();
  std::vector<Vec3> gravity(n);
  for (std::size_t i = 0; i < n; ++i) gravity[i] = m.mass[i] * m.gravity;
  const std::vector<Vec3> none;
  IntegratorConfig frozen = test::config(IntegratorType::hybrid_implicit), sweep = frozen, jacobi = frozen;
  frozen.neighbours = NeighbourModel::frozen;
  sweep.neighbours = NeighbourModel::sweep;
  jacobi.neighbours = NeighbourModel::jacobi;
  const IntegratorConfig configs[] = {test::config(IntegratorType::explicit_euler),
                                      test::config(IntegratorType::symplectic_euler),
                                      test::config(IntegratorType::velocity_verlet),
                                      test::config(IntegratorType::rk4),
                                      frozen,
                                      sweep,
                                      jacobi,
                                      default_integrator(),
                                      test::config(IntegratorType::energy_momentum),
                                      test::config(IntegratorType::bdf2)};
  auto same = [](const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3)) == 0;
  };
  for (const IntegratorConfig& c : configs)
    for (int threads : {1, 2}) {
      IntegratorConfig cfg = c;
      cfg.threads = threads;
      const std::string what = std::string(to_string(c.type)) + "/" + std::string(to_string(c.neighbours)) + ", " +
                               std::to_string(threads) + " threads";
      const auto in_place = make_step_integrator(cfg), in_place_gravity = make_step_integrator(cfg),
                 projected = make_step_integrator(cfg);
      const bool forms_gravity = in_place->forms_gravity();
      State s = w0.state, s_gravity = w0.state, s0 = w0.state;
      Adjacency adj;
      build_adjacency(m, s, adj);
      PrescribedAt prescribed;
      for (int step = 0; step < 3; ++step) {
        const StepContext ctx{.h = 1e-4, .t = step * 1e-4, .step = static_cast<std::uint64_t>(step)};
        Projection p, p_gravity, p0;
        Advanced a, a_gravity, a0;
        a.max_speed = a_gravity.max_speed = a0.max_speed = 1e5;
        in_place->advance(m, s, adj, gravity, ctx, p, a);
        in_place_gravity->advance(m, s_gravity, adj, forms_gravity ? none : gravity, ctx, p_gravity, a_gravity);
        projected->project(m, s0, adj, gravity, ctx, p0);
        apply_checked(m, s0, p0, ctx.t + ctx.h, threads, prescribed, a0);
        EXPECT_TRUE(a0.ok) << what;
        for (const auto& [to, carry, how] : {std::tuple{&a, &p, "f_ext"}, {&a_gravity, &p_gravity, "gravity"}}) {
          EXPECT_EQ(to->ok, a0.ok) << what << ", " << how;
          EXPECT_TRUE(same(to->x, a0.x)) << what << ", " << how << ", step " << step;
          EXPECT_TRUE(same(to->v, a0.v)) << what << ", " << how << ", step " << step;
          EXPECT_TRUE(carry->carry == p0.carry) << what << ", " << how << ", step " << step;
        }
        for (auto [state, to, carry] : {std::tuple{&s, &a, &p}, {&s_gravity, &a_gravity, &p_gravity}, {&s0, &a0, &p0}}) {
          state->x.swap(to->x);
          state->v.swap(to->v);
          state->carry.swap(carry->carry);
          state->time = ctx.t + ctx.h;
          state->step = ctx.step + 1;
        }
      }
      // The blow-up rule, from a state the step makes too fast or not finite (not for the Newton
      // integrators, whose default path is the same code, and which split a non-finite step down
      // to the smallest substep).
      if (c.type == IntegratorType::energy_momentum || c.type == IntegratorType::bdf2) continue;
      const StepContext ctx{.h = 1e-4, .t = 3e-4, .step = 3};
      for (bool finite : {true, false}) {
        State bad = s0;
        if (!finite) bad.v[123].y() = std::nan("");
        Projection p, p0;
        Advanced a, a0;
        a.max_speed = a0.max_speed = finite ? 1e-6 : 1e5;
        make_step_integrator(cfg)->advance(m, bad, adj, gravity, ctx, p, a);
        make_step_integrator(cfg)->project(m, bad, adj, gravity, ctx, p0);
        apply_checked(m, bad, p0, ctx.t + ctx.h, threads, prescribed, a0);
        EXPECT_FALSE(a.ok) << what << (finite ? ", too fast" : ", not finite");
        EXPECT_FALSE(a0.ok) << what << (finite ? ", too fast" : ", not finite");
        const Blowup b = find_blowup(m, a.x, a.v, a.max_speed, ctx, threads);
        const Blowup b0 = find_blowup(m, a0.x, a0.v, a0.max_speed, ctx, threads);
        EXPECT_TRUE(b.found) << what;
        EXPECT_EQ(b.who, b0.who) << what;
        EXPECT_EQ(b.message, b0.message) << what;
        EXPECT_EQ(b.message.find("non-finite") != std::string::npos, !finite) << b.message;
      }
    }
}

// A world with no bond (a gas with no container) large enough to step on several threads: the
// bond partition's parts then have no runs, and the frozen step starts and solves their rows
// after the bond pass, the applied state of a step advanced in place included (Verlet alike).
TEST(Pipeline, DirectStepsWithoutBondsGiveTheSameBitsAsStepsThroughDxDv) {
  World w0;
  w0.model.gravity = Vec3(0, 0, -9.81);
  for (int q = 0; q < 5000; ++q)
    w0.add_quanta(Vec3(0.01 * (q % 17), 0.01 * (q / 17 % 13), 0.01 * (q / 221)),
                  Vec3(std::sin(q), std::cos(3.0 * q), 0.1), 1e-3);
  IntegratorConfig frozen = test::config(IntegratorType::hybrid_implicit);
  frozen.neighbours = NeighbourModel::frozen;
  for (const IntegratorConfig& c : {frozen, test::config(IntegratorType::velocity_verlet)}) {
    auto run = [&](bool direct, int threads) {
      IntegratorConfig cfg = c;
      cfg.threads = threads;
      Simulation sim(w0, cfg, 1e-3);
      sim.set_track_energy(!direct);
      for (int n = 0; n < 3; ++n) EXPECT_EQ(sim.step().status, StepReport::Status::ok);
      return sim.world().state;
    };
    const State s0 = run(false, 1);
    for (int threads : {1, 2, 3}) {
      const State s = run(true, threads);
      const std::string what = std::string(to_string(c.type)) + ", " + std::to_string(threads) + " threads";
      expect_same_motion(s, s0, what);
    }
  }
}

// A step of the frozen hybrid, Verlet or the coupled step advanced in place forms gravity itself
// (StepIntegrator::forms_gravity) only when gravity is the only external force: with a load or a
// queued force it takes Simulation's array, and gives the bits of a step through dx and dv, which
// always does.
TEST(Pipeline, DirectStepsTakeLoadsAndQueuedForces) {
  Scene scene = canonical_lattice(6);
  IntegratorConfig frozen = test::config(IntegratorType::hybrid_implicit);
  frozen.neighbours = NeighbourModel::frozen;
  for (const IntegratorConfig& c :
       {frozen, test::config(IntegratorType::velocity_verlet), default_integrator()}) {
    auto run = [&](bool direct, bool load, bool force) {
      World w = scene.world;
      if (load) w.model.loads.push_back({{200, 201, 215}, Vec3(0.3, -0.2, 1.0)});
      Simulation sim(w, c, scene.timestep);
      sim.set_track_energy(!direct);
      for (int n = 0; n < 3; ++n) {
        if (force) sim.add_force(100, Vec3(0.5, 0.1, -0.4));
        EXPECT_EQ(sim.step().status, StepReport::Status::ok);
      }
      return sim.world().state;
    };
    const State plain = run(true, false, false);
    for (const auto& [load, force] :
         {std::pair{true, false}, std::pair{false, true}, std::pair{true, true}}) {
      const State s0 = run(false, load, force), s = run(true, load, force);
      const std::string what =
          std::string(to_string(c.type)) + (load ? " load" : "") + (force ? " force" : "");
      expect_same_motion(s, s0, what);
      EXPECT_NE(std::memcmp(s.v.data(), plain.v.data(), s.v.size() * sizeof(Vec3)), 0) << what;
    }
  }
}

// The coupled step's other reads of the external forces, formed for gravity alone in a direct
// step: the initial guess from them (WarmStart::external) and the momentum a free body must gain.
TEST(Pipeline, DirectCoupledStepsFormGravityForTheGuessAndTheMomentum) {
  const World w0 = test::lattice(5, 4, 3, 1000, 1e-3, 0.01, false, Vec3(0.5, 0, -9.81));
  IntegratorConfig c = default_integrator();
  c.warm_start = WarmStart::external;
  c.restore_momentum = true;
  auto run = [&](bool direct) {
    Simulation sim(w0, c, 1e-3);
    sim.set_track_energy(!direct);
    for (int n = 0; n < 3; ++n) EXPECT_EQ(sim.step().status, StepReport::Status::ok);
    return sim.world().state;
  };
  expect_same_motion(run(true), run(false), "coupled, external guess, momentum restored");
}

// A heuristic that edits the bonds every step, as fracture and plasticity do: breaks the first
// alive bond, doubles its rest length and stamps its time (energy neutral: a broken bond has none).
class BondEditor : public Heuristic {
 public:
  std::string_view name() const override { return "bond_editor"; }
  int edits = 0;
  void apply(const Model&, State& s, Projection&, const HeuristicContext& ctx) override {
    ++edits;
    for (std::size_t b = 0; b < s.bonds.alive.size(); ++b)
      if (s.bonds.alive[b]) {
        s.break_bond(static_cast<Index>(b));
        s.bonds.rest[b] *= 2;
        s.bonds.time[b] = ctx.step.t;
        return;
      }
  }
};

// Explicit Euler (h sqrt(k/m) = 5) and velocity Verlet (0.8, past its stability limit on this
// lattice) gain energy every step; with keep_last_good the step that trips the runaway check is
// undone, so the world holds exactly the state before it: the ledger; the bonds, which the copy
// leaves out when no heuristic can edit them and holds when one does; and positions, velocities
// and Verlet's carry-over, which the copy always leaves out (the step had already swapped in its
// own: the rollback swaps them back).
TEST(Pipeline, EnergyRunawayIsRolledBackToTheLastGoodState) {
  for (const auto& [type, edits] : {std::pair{IntegratorType::explicit_euler, false}, {IntegratorType::explicit_euler, true},
                                   {IntegratorType::velocity_verlet, false}, {IntegratorType::velocity_verlet, true}}) {
    SCOPED_TRACE(std::string(to_string(type)) + (edits ? ", a heuristic edits bonds" : ""));
    World w = test::lattice(3, 3, 3, 1000, 1e-3, 0.0, false);
    test::perturb(w, 1e-4, 0.0);
    // Verlet at h = 0.005 runs away in its first step, before it carries anything; at 8e-4 in
    // its third.
    const bool verlet = type == IntegratorType::velocity_verlet;
    Simulation sim(std::move(w), test::config(type), verlet ? 0.0008 : 0.005);
    auto editor = std::make_unique<BondEditor>();
    const BondEditor* editor_seen = editor.get();
    if (edits) sim.add_heuristic(std::move(editor));
    sim.limits().energy_growth = 2.0;
    sim.set_keep_last_good(true);
    bool ran_away = false;
    for (int n = 0; n < 10000 && !ran_away; ++n) {
      const State before = sim.world().state;
      const StepReport r = sim.step();
      if (r.status == StepReport::Status::ok) continue;
      ran_away = true;
      EXPECT_NE(r.message.find("energy runaway"), std::string::npos) << r.message;
      const State& after = sim.world().state;
      EXPECT_EQ(after.step, before.step);
      EXPECT_EQ(after.time, before.time);
      EXPECT_EQ(after.energy.dissipated_damping, before.energy.dissipated_damping);
      EXPECT_EQ(after.topology_version(), before.topology_version());
      EXPECT_TRUE(after.bonds == before.bonds) << edits;
      EXPECT_EQ(std::holds_alternative<VerletForces>(after.carry), verlet);
      EXPECT_EQ(std::holds_alternative<std::monostate>(after.carry), !verlet);
      EXPECT_TRUE(after.carry == before.carry);
      if (edits) {
        EXPECT_EQ(editor_seen->edits, n + 1);  // the step that ran away broke a bond too
      }
      for (std::size_t i = 0; i < after.x.size(); ++i) {
        EXPECT_EQ(after.x[i], before.x[i]);
        EXPECT_EQ(after.v[i], before.v[i]);
      }
      // The world steps on from the restored state: the bonds it kept are the state's own.
      EXPECT_EQ(sim.adjacency().version, after.topology_version());
      EXPECT_EQ(sim.step().status, StepReport::Status::blowup);
    }
    EXPECT_TRUE(ran_away) << "h sqrt(k/m) = 5 (0.8 for Verlet) should run away";
  }
}

TEST(Pipeline, UserForceActsForOneStepOnly) {
  World w;
  w.add_quanta(Vec3::Zero(), Vec3::Zero(), 2.0);
  Simulation sim(std::move(w), default_integrator(), 0.1);
  sim.add_force(0, Vec3(4, 0, 0));
  sim.step();
  EXPECT_NEAR(sim.world().state.v[0].x(), 0.1 * 4 / 2.0, 1e-15);
  sim.step();
  EXPECT_NEAR(sim.world().state.v[0].x(), 0.2, 1e-15);
}

TEST(Pipeline, LoadIsSpreadEvenlyAndGravityActsOnFreeQuanta) {
  World w;
  for (int i = 0; i < 4; ++i) w.add_quanta(Vec3(i, 0, 0), Vec3::Zero(), 0.5);
  w.model.gravity = Vec3(0, 0, -10);
  w.add_load({0, 1}, Vec3(2, 0, 0));  // 1 N on each of the two
  Simulation sim(std::move(w), test::coupled(CoupledSolver::ldlt), 0.01);
  sim.step();
  const auto& v = sim.world().state.v;
  EXPECT_NEAR(v[0].x(), 0.01 * 1.0 / 0.5, 1e-15);
  EXPECT_NEAR(v[1].x(), 0.02, 1e-15);
  EXPECT_EQ(v[2].x(), 0.0);
  for (const Vec3& vi : v) EXPECT_NEAR(vi.z(), -0.1, 1e-15);
}

TEST(Kinematics, PrescribedMotionsAreFollowedExactly) {
  World w;
  const Index fixed = w.add_quanta(Vec3(0, 0, 0), Vec3(5, 5, 5), 1.0);
  const Index slide = w.add_quanta(Vec3(1, 0, 0), Vec3::Zero(), 1.0);
  const Index spin = w.add_quanta(Vec3(2, 1, 0), Vec3::Zero(), 1.0);
  const Index free = w.add_quanta(Vec3(1, 1, 0), Vec3::Zero(), 1.0);
  for (Index k : {fixed, slide, spin}) w.add_bond(free, k, {.law = Law::linear, .stiffness = 10, .damping = 0.1});
  w.prescribe({fixed}, Motion{});
  Motion m;
  m.type = MotionType::translate;
  m.velocity = Vec3(0, 0.5, 0);
  w.prescribe({slide}, m);
  Motion r;
  r.type = MotionType::rotate;
  r.axis = Vec3(0, 0, 2);  // normalised on entry
  r.center = Vec3(2, 0, 0);
  r.rate = 0.25;
  w.prescribe({spin}, r);
  EXPECT_EQ(w.state.v[fixed], Vec3::Zero());
  for (IntegratorConfig cfg : {default_integrator(), test::config(IntegratorType::rk4), test::hybrid(NeighbourModel::frozen)}) {
    Simulation sim(w, cfg, 0.01);
    for (int n = 0; n < 400; ++n) sim.step();
    const State& s = sim.world().state;
    const double t = s.time;
    EXPECT_NEAR(t, 4.0, 1e-12);
    EXPECT_EQ(s.x[fixed], Vec3(0, 0, 0));
    EXPECT_LE((s.x[slide] - Vec3(1, 0.5 * t, 0)).norm(), 1e-14);
    const double a = 0.25 * t;
    EXPECT_LE((s.x[spin] - Vec3(2 - std::sin(a), std::cos(a), 0)).norm(), 1e-14);
    EXPECT_LE((s.v[spin] - 0.25 * Vec3(-std::cos(a), -std::sin(a), 0)).norm(), 1e-14);
    EXPECT_EQ(sim.world().model.inv_mass[spin], 0.0);
  }
}

// Prescribing quanta during a run frees them from the integrators' view of the free quanta: the
// run goes on as one built from that world would (the same bits), with no energy-guard splitting
// (momentum restored on the block as if it were still free would create energy every step).
TEST(Kinematics, QuantaPrescribedDuringARunStepAsInARunBuiltWithThem) {
  Simulation sim(test::lattice(3, 3, 6, 200, 1e-3, 0.05, false, Vec3(0, 0, -9.81)), default_integrator(), 1e-3);
  for (int n = 0; n < 50; ++n) sim.step();
  std::vector<Index> top;
  const World& w = sim.world();
  for (Index i = 0; i < w.num_quanta(); ++i)
    if (w.state.x[i].x() < w.state.x[0].x() + 1e-9) top.push_back(i);
  sim.world().prescribe(top, Motion{});
  Simulation fresh(sim.world(), default_integrator(), 1e-3);
  for (int n = 0; n < 100; ++n) {
    sim.step();
    fresh.step();
    ASSERT_EQ(sim.integrator().stats().substeps, 0) << "step " << n;
  }
  const State &a = sim.world().state, &b = fresh.world().state;
  EXPECT_EQ(std::memcmp(a.x.data(), b.x.data(), a.x.size() * sizeof(Vec3)), 0);
  EXPECT_EQ(std::memcmp(a.v.data(), b.v.data(), a.v.size() * sizeof(Vec3)), 0);
}

TEST(World, AdjacencyFollowsTheAliveBonds) {
  World w = test::lattice(3, 2, 2, 1, 1, 0, false);
  Adjacency adj;
  build_adjacency(w.model, w.state, adj);
  ASSERT_EQ(adj.offset.size(), w.num_quanta() + 1);
  EXPECT_EQ(adj.offset.back(), 2 * w.num_bonds());
  for (std::size_t i = 0; i < w.num_quanta(); ++i)
    for (Index e = adj.offset[i]; e < adj.offset[i + 1]; ++e) {
      const Index b = adj.bond[e];
      EXPECT_TRUE(w.state.bonds.i[b] == i || w.state.bonds.j[b] == i);
      EXPECT_EQ(adj.other[e], w.state.bonds.i[b] == i ? w.state.bonds.j[b] : w.state.bonds.i[b]);
    }
  const auto version = w.state.topology_version();
  w.break_bond(0);
  EXPECT_GT(w.state.topology_version(), version);
  build_adjacency(w.model, w.state, adj);
  EXPECT_EQ(adj.offset.back(), 2 * (w.num_bonds() - 1));
  EXPECT_EQ(w.num_alive_bonds(), w.num_bonds() - 1);
  for (Index b : adj.bond) EXPECT_NE(b, 0u);
}

TEST(World, BrokenBondLeavesTheSolverAtOnce) {
  // Two quanta pulled apart by a stretched bond; once broken, nothing pulls them.
  World w = test::two_quanta(1, 100, 1, 0.2, 0);
  w.break_bond(0);
  Simulation sim(std::move(w), default_integrator(), 0.01);
  sim.step();
  EXPECT_EQ(sim.world().state.v[0], Vec3::Zero());
  EXPECT_EQ(sim.world().state.v[1], Vec3::Zero());
}

TEST(Builders, CanonicalLatticeHasTheWorkloadsBondCount) {
  // n³ quanta; nearest 3n²(n-1) and face diagonals 6n(n-1)² bonds (552 240 at n = 40).
  for (int n : {2, 3, 5}) {
    const Scene s = canonical_lattice(n);
    EXPECT_EQ(s.world.num_quanta(), static_cast<std::size_t>(n * n * n));
    EXPECT_EQ(s.world.num_bonds(), static_cast<std::size_t>(3 * n * n * (n - 1) + 6 * n * (n - 1) * (n - 1)));
    std::size_t anchored = 0;
    for (double im : s.world.model.inv_mass) anchored += im == 0.0;
    EXPECT_EQ(anchored, static_cast<std::size_t>(n * n));
  }
  World w;
  CubicLattice lat;
  lat.size = {3, 3, 3};
  lat.shells = Shells::body_diagonal;
  add_cubic_lattice(w, lat);
  EXPECT_EQ(w.num_bonds(), 3u * 9 * 2 + 6u * 3 * 4 + 4u * 8);
  lat.size = {0, 1, 1};
  EXPECT_THROW(add_cubic_lattice(w, lat), std::invalid_argument);
}

TEST(Samples, EveryBuiltInSceneRunsWithoutBlowup) {
  ASSERT_GE(builtin_scenes().size(), 8u);
  for (const BuiltinScene& s : builtin_scenes()) {
    Scene scene = builtin_scene(s.name);
    EXPECT_EQ(scene.name, s.name);
    Simulation sim(std::move(scene.world), scene.integrator, scene.timestep);
    sim.limits() = scene.limits;
    for (const HeuristicSpec& h : scene.heuristics) sim.add_heuristic(make_heuristic(h));
    // 50 steps, or a fifth of a second at frame-sized steps: through mesh_drop's landing, whose
    // settling steps each take a few solves of its contacts.
    const int steps = std::min(50, static_cast<int>(std::ceil(0.2 / scene.timestep)));
    for (int n = 0; n < steps; ++n) {
      // Scenes with an adaptive section need it (adaptive_pendulum blows up at its fixed step).
      const StepReport r = scene.adaptive.enabled ? adaptive_step(sim, scene.adaptive, scene.adaptive.horizon).step : sim.step();
      ASSERT_EQ(r.status, StepReport::Status::ok) << s.name;
    }
  }
  EXPECT_NO_THROW(builtin_scene(kDefaultScene));
  EXPECT_THROW(builtin_scene("nope"), std::invalid_argument);
}

}  // namespace
}  // namespace qbond
