// Multigrid-preconditioned CG for the coupled implicit step (solvers/multigrid.hpp,
// integrators/multigrid_step.hpp): the same solution as sparse LDLᵀ on every kind of body, a
// symmetric positive definite V-cycle, the hierarchy kept or rebuilt as bonds break and form, the
// same bits on any thread count, and iteration counts that do not grow with the body.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>

#include "integrators/backward_euler.hpp"
#include "integrators/multigrid_step.hpp"
#include "integrators/preconditioner_choice.hpp"
#include "qbond/builders/samples.hpp"
#include "qbond/io/checkpoint.hpp"
#include "qbond/io/scene.hpp"
#include "test_util.hpp"

namespace qbond {
namespace {

constexpr double kH = 1.0 / 60;

IntegratorConfig multigrid_config(double tolerance) {
  IntegratorConfig c;
  c.type = IntegratorType::coupled_implicit;
  c.solver = CoupledSolver::cg;
  c.preconditioner = Preconditioner::multigrid;
  c.tolerance = tolerance;
  c.restore_momentum = false;  // the comparison is with the linear system's own solution
  c.threads = 1;
  return c;
}

std::vector<Vec3> gravity_forces(const World& w) {
  std::vector<Vec3> f(w.num_quanta());
  for (std::size_t i = 0; i < f.size(); ++i) f[i] = w.model.mass[i] * w.model.gravity;
  return f;
}

// One step's Δv by `cfg`, and by sparse LDLᵀ; returns max |Δv − Δv_ldlt| / max |Δv_ldlt| over the
// free quanta, and the iterative solve's stats.
double mismatch_with_ldlt(const World& w, const IntegratorConfig& cfg, SolveStats* stats = nullptr) {
  Adjacency adj;
  build_adjacency(w.model, w.state, adj);
  const std::vector<Vec3> f = gravity_forces(w);
  IntegratorConfig ldlt = cfg;
  ldlt.solver = CoupledSolver::ldlt;
  Projection a, b;
  auto it = make_integrator(cfg);
  it->project(w.model, w.state, adj, f, {.h = kH}, a);
  if (stats) *stats = it->stats();
  make_integrator(ldlt)->project(w.model, w.state, adj, f, {.h = kH}, b);
  double err = 0, scale = 0;
  for (std::size_t i = 0; i < w.num_quanta(); ++i) {
    if (w.model.is_kinematic(static_cast<Index>(i))) continue;
    err = std::max(err, (a.dv[i] - b.dv[i]).norm());
    scale = std::max(scale, b.dv[i].norm());
  }
  return err / scale;
}

// A lattice in motion: positions and velocities perturbed, mixed laws and dampers, gravity.
World moving_lattice(int nx, int ny, int nz, bool anchored) {
  World w = test::lattice(nx, ny, nz, 1000, 1e-3, 0.01, anchored, Vec3(0, 0, -9.81));
  test::mix_bonds(w);
  test::perturb(w, 5e-4, 0.05);
  return w;
}

// CG stops at a relative residual of 1e-10; Δv then agrees with the direct solution to the
// residual times A's condition number as CG's error bound gives it (κ ≲ 1e3 here: h² k / m).
constexpr double kTol = 1e-10, kAgree = 1e-7;

TEST(Multigrid, MatchesLdltOnAnchoredLattices) {
  for (const auto& size : {std::array{10, 6, 5}, std::array{14, 9, 7}}) {
    SolveStats stats;
    EXPECT_LT(
        mismatch_with_ldlt(moving_lattice(size[0], size[1], size[2], true), multigrid_config(kTol), &stats),
        kAgree);
    EXPECT_LE(stats.residual, kTol);
    EXPECT_GT(stats.iterations, 0);
  }
}

TEST(Multigrid, MatchesLdltOnABodyWithNoAnchor) {
  World w = moving_lattice(9, 7, 6, false);
  for (std::size_t i = 0; i < w.num_quanta(); ++i)
    w.state.v[i] += Vec3(0, 0, 20).cross(w.state.x[i]);  // spinning
  EXPECT_LT(mismatch_with_ldlt(w, multigrid_config(kTol)), kAgree);
}

TEST(Multigrid, MatchesLdltOnTwoBodies) {
  World w = moving_lattice(8, 5, 5, true);
  CubicLattice second;
  second.size = {6, 6, 3};
  second.origin = Vec3(0.2, 0, 0);
  second.velocity = Vec3(-1, 0, 0.5);
  second.bond = {.law = Law::linear, .stiffness = 300, .damping = 0.02};
  add_cubic_lattice(w, second, 1);
  EXPECT_LT(mismatch_with_ldlt(w, multigrid_config(kTol)), kAgree);
}

TEST(Multigrid, MatchesLdltOnAVoxelisedMesh) {
  const Scene s = builtin_scene("mesh_drop");
  World w = s.world;
  test::perturb(w, 2e-4, 0.1);
  EXPECT_GT(w.num_quanta(), 1000u);
  EXPECT_LT(mismatch_with_ldlt(w, multigrid_config(kTol)), kAgree);
}

// The system of one step, as the coupled integrator builds it.
struct StepSystem {
  Adjacency adj;
  ImplicitSystem sys;
  Projection kin;
  void build(const World& w) {
    build_adjacency(w.model, w.state, adj);
    begin_implicit_step(w.model, w.state, adj, gravity_forces(w), {.h = kH}, false, 1, kin, sys);
  }
  // max |y − y_ldlt| / max |y_ldlt|.
  double mismatch(const World& w, const std::vector<Vec3>& y) {
    DirectSolver direct;
    std::vector<Vec3> ref;
    direct.solve(CoupledSolver::ldlt, w.model, w.state, sys, ref);
    double err = 0, scale = 0;
    for (std::size_t i = 0; i < y.size(); ++i) {
      err = std::max(err, (y[i] - ref[i]).norm());
      scale = std::max(scale, ref[i].norm());
    }
    return err / scale;
  }
};

TEST(Multigrid, DeepHierarchyMatchesLdlt) {
  World w = moving_lattice(10, 8, 8, true);
  StepSystem s;
  s.build(w);
  MultigridStep mg;
  mg.mg.coarsest = 12;  // coarsen as far as the body allows
  std::vector<Vec3> y;
  SolveStats stats;
  mg.solve(w.model, w.state, s.adj, s.sys, /*contacts=*/false, kH, kTol, 1000, 1, y, true, stats);
  EXPECT_GE(mg.mg.levels(), 3u);
  EXPECT_LT(s.mismatch(w, y), kAgree);
}

// The V-cycle is the preconditioner CG needs: symmetric, ⟨M r, s⟩ = ⟨r, M s⟩, and positive
// definite, ⟨M r, r⟩ > 0, up to the round-off of its passes.
TEST(Multigrid, CycleIsSymmetricPositiveDefinite) {
  World w = moving_lattice(12, 8, 6, true);
  StepSystem s;
  s.build(w);
  MultigridStep step;
  std::vector<Vec3> y;
  SolveStats stats;
  step.solve(w.model, w.state, s.adj, s.sys, /*contacts=*/false, kH, 1e-6, 1000, 1, y, true, stats);
  const std::size_t n = step.mg.unknowns()[0];
  Rng rng{3};
  std::vector<double> r(n), q(n), Mr(n), Mq(n);
  for (int trial = 0; trial < 4; ++trial) {
    for (std::size_t k = 0; k < n; ++k) {
      r[k] = 2 * rng.uniform() - 1;
      q[k] = 2 * rng.uniform() - 1;
    }
    step.mg.apply(r.data(), Mr.data(), 1);
    step.mg.apply(q.data(), Mq.data(), 1);
    double rMq = 0, qMr = 0, rMr = 0, scale = 0;
    for (std::size_t k = 0; k < n; ++k) {
      rMq += r[k] * Mq[k];
      qMr += q[k] * Mr[k];
      rMr += r[k] * Mr[k];
      scale += std::abs(r[k] * Mq[k]);
    }
    EXPECT_LT(std::abs(rMq - qMr), 1e-12 * scale);
    EXPECT_GT(rMr, 0);
  }
}

// Contacts come and go from solve to solve under a kept hierarchy: a sticking contact adds
// κ m (n nᵀ + 100 P) to its quanta's diagonal block (contact_solve.hpp: the normal spring and the
// sticking damper h² k_t P, k_t = 100 k; obstacle.hpp's default κ), far beyond the built blocks.
// Told so, the kept hierarchy's fine smoother takes the blocks that moved: the same solution, in
// fewer iterations, and without the update of the whole hierarchy that the stale one needs.
TEST(Multigrid, KeptHierarchySmoothsWithTheContactsDiagonal) {
  World w = builtin_scene("mesh_drop").world;
  StepSystem s;
  s.build(w);
  const std::vector<Mat3> plain = s.sys.diag;
  std::vector<Mat3> touching = plain;
  const double kappa = Obstacle{}.penalty;
  const Vec3 n = Vec3(0.3, 0, 1).normalized();  // a tilted ground under the lowest 3 cm
  const Mat3 nn = n * n.transpose();
  double lowest = INFINITY;
  for (std::size_t i = 0; i < w.num_quanta(); ++i) lowest = std::min(lowest, w.state.x[i].z());
  for (std::size_t i = 0; i < w.num_quanta(); ++i)
    if (!w.model.is_kinematic(static_cast<Index>(i)) && w.state.x[i].z() < lowest + 0.03)
      touching[i] += kappa * w.model.mass[i] * (nn + 100 * (Mat3::Identity() - nn));
  int iterations[2] = {};
  for (const bool contacts : {false, true}) {
    MultigridStep mg;
    std::vector<Vec3> y;
    SolveStats stats;
    s.sys.diag = plain;  // the hierarchy built without contacts
    mg.solve(w.model, w.state, s.adj, s.sys, /*contacts=*/false, kH, kTol, 1000, 1, y, true, stats);
    s.sys.diag = touching;
    mg.solve(w.model, w.state, s.adj, s.sys, contacts, kH, kTol, 1000, 1, y, true, stats);
    EXPECT_LE(stats.residual, kTol);
    EXPECT_LT(s.mismatch(w, y), kAgree);
    EXPECT_EQ(mg.builds, 1);
    iterations[contacts] = stats.iterations;
    if (!contacts) continue;
    EXPECT_EQ(mg.updates, 0);
    // The same contacts again: none moved, so they have settled, and the hierarchy is updated
    // beside them, once.
    for (int again = 0; again < 2; ++again) {
      mg.solve(w.model, w.state, s.adj, s.sys, contacts, kH, kTol, 1000, 1, y, true, stats);
      EXPECT_LT(s.mismatch(w, y), kAgree);
      EXPECT_EQ(mg.updates, 1);
    }
  }
  EXPECT_LT(iterations[true], iterations[false]);
}

TEST(Multigrid, HierarchyKeptThenRebuiltAsBondsBreakAndForm) {
  World w = moving_lattice(12, 6, 6, true);
  MultigridStep mg;
  std::vector<Vec3> y;
  SolveStats stats;
  auto solve = [&](double h) {
    StepSystem s;
    build_adjacency(w.model, w.state, s.adj);
    begin_implicit_step(w.model, w.state, s.adj, gravity_forces(w), {.h = h}, false, 1, s.kin, s.sys);
    mg.solve(w.model, w.state, s.adj, s.sys, /*contacts=*/false, h, kTol, 1000, 1, y, true, stats);
    return s.mismatch(w, y);
  };
  EXPECT_LT(solve(kH), kAgree);
  EXPECT_EQ(mg.builds, 1);
  // A few bonds break: the built hierarchy stays the preconditioner, and the solution is still the
  // direct solver's.
  for (Index b = 0; b < 10; ++b) w.break_bond(7 * b);
  EXPECT_LT(solve(kH), kAgree);
  EXPECT_EQ(mg.builds, 1);
  // A bond forms between quanta that had none.
  w.add_bond(1, static_cast<Index>(w.num_quanta() - 1),
             {.law = Law::linear, .stiffness = 500, .damping = 0.01});
  EXPECT_LT(solve(kH), kAgree);
  EXPECT_EQ(mg.builds, 1);
  EXPECT_EQ(mg.updates, 0);
  // Another step length: the operators are recomputed from the changed bonds on the built
  // aggregates.
  EXPECT_LT(solve(kH / 4), kAgree);
  EXPECT_EQ(mg.builds, 1);
  EXPECT_EQ(mg.updates, 1);
  // A fifth of the bonds break: the hierarchy is rebuilt.
  for (Index b = 0; b < w.num_bonds(); b += 5)
    if (w.state.bonds.alive[b]) w.break_bond(b);
  EXPECT_LT(solve(kH / 4), kAgree);
  EXPECT_EQ(mg.builds, 2);
  EXPECT_EQ(mg.updates, 1);
}

TEST(Multigrid, SameBitsOnOneAndTwoThreads) {
  Scene scene = canonical_lattice(17);  // 4 913 quanta: the passes run threaded
  IntegratorConfig c = multigrid_config(1e-6);
  c.restore_momentum = true;
  std::vector<State> end;
  for (int threads : {1, 2}) {
    c.threads = threads;
    Simulation sim(scene.world, c, kH);
    for (int k = 0; k < 3; ++k) sim.step();
    end.push_back(sim.world().state);
  }
  ASSERT_EQ(end[0].x.size(), end[1].x.size());
  EXPECT_EQ(std::memcmp(end[0].x.data(), end[1].x.data(), end[0].x.size() * sizeof(Vec3)), 0);
  EXPECT_EQ(std::memcmp(end[0].v.data(), end[1].v.data(), end[0].v.size() * sizeof(Vec3)), 0);
}

// At h = 1/60 s from rest, the canonical lattice's solve to 1e-6 takes about as many iterations
// at n = 20 as at n = 10 (block-Jacobi CG: 59 and 122).
TEST(Multigrid, IterationsDoNotGrowWithTheBody) {
  std::vector<int> iterations;
  for (int n : {10, 20}) {
    Scene scene = canonical_lattice(n);
    IntegratorConfig c = multigrid_config(1e-6);
    Simulation sim(scene.world, c, kH);
    sim.step();
    iterations.push_back(sim.integrator().stats().iterations);
    EXPECT_LE(sim.integrator().stats().residual, 1e-6);
  }
  EXPECT_LE(iterations[0], 12);
  EXPECT_LE(iterations[1], 12);
  EXPECT_LE(iterations[1], 1.5 * iterations[0]);
}

// The finest level's aggregates reach two bonds from their root: the first coarse level has about
// half the unknowns it has with one-bond aggregates (and a third of the blocks), and the solve
// about the same iterations, to the same residual.
TEST(Multigrid, TwoBondAggregatesCoarsenFasterAtTheSameIterations) {
  const World w = canonical_lattice(20).world;
  StepSystem s;
  s.build(w);
  std::vector<std::size_t> coarse;
  std::vector<int> iterations;
  for (int radius : {1, 2}) {
    MultigridStep mg;
    mg.mg.fine_aggregate_radius = radius;
    std::vector<Vec3> y;
    SolveStats stats;
    mg.solve(w.model, w.state, s.adj, s.sys, /*contacts=*/false, kH, 1e-6, 1000, 1, y, true, stats);
    EXPECT_LE(stats.residual, 1e-6);
    coarse.push_back(mg.mg.unknowns().at(1));
    iterations.push_back(stats.iterations);
  }
  EXPECT_LE(10 * coarse[1], 6 * coarse[0]) << coarse[0] << " vs " << coarse[1];
  EXPECT_LE(iterations[1], iterations[0] + 3) << iterations[0] << " vs " << iterations[1];
}

// `automatic`: block Jacobi on a step it converges on in few iterations; once a solve needs more
// than kMultigridAfter, multigrid from the next step on, to the same tolerance.
TEST(Multigrid, AutomaticTurnsToMultigridWhenBlockJacobiIsSlow) {
  Scene scene = canonical_lattice(20);
  IntegratorConfig c = multigrid_config(1e-6);
  c.preconditioner = Preconditioner::automatic;
  c.max_iterations = 0;
  c.warm_start = WarmStart::zero;  // each step's iterations from the same start
  {
    Simulation small(scene.world, c, 1e-5);  // h·sqrt(k/m) small: block Jacobi stays
    for (int s = 0; s < 3; ++s) {
      small.step();
      EXPECT_LE(small.integrator().stats().iterations, kMultigridAfter);
    }
  }
  Simulation sim(scene.world, c, 0.1);  // large steps: block Jacobi slow once the body moves
  bool slow = false;
  for (int s = 0; s < 6 && !slow; ++s) {
    sim.step();
    slow = sim.integrator().stats().iterations > kMultigridAfter;
  }
  ASSERT_TRUE(slow);
  sim.step();
  EXPECT_LE(sim.integrator().stats().iterations, 25);  // multigrid's
  EXPECT_LE(sim.integrator().stats().residual, 1e-6);
}

// mesh_drop with its ground held in the step at h = 1/60 s lands in one step on stiff contact
// springs. Under `automatic` that step's first solve is block Jacobi's (the falling steps before it
// took few iterations); it takes more than kMultigridAfter iterations, so the step's remaining
// active-set solves run multigrid: the step costs less than a quarter of block Jacobi's iterations.
TEST(Multigrid, AutomaticTurnsToMultigridWithinALandingStep) {
  std::ifstream f(std::string(QBOND_SOURCE_DIR) + "/scenes/mesh_drop.json");
  nlohmann::json j = nlohmann::json::parse(f);
  j["heuristics"][0]["method"] = "implicit";
  j["timestep"] = kH;
  j.erase("output");
  const Scene s = parse_scene(j.dump(), "mesh_drop", {.dir = std::string(QBOND_SOURCE_DIR) + "/scenes"});
  ASSERT_GE(s.world.num_quanta(), kMultigridQuanta);
  IntegratorConfig c = s.integrator;
  c.threads = 1;
  ASSERT_EQ(c.preconditioner, Preconditioner::automatic);
  IntegratorConfig jacobi = c;
  jacobi.preconditioner = Preconditioner::block_jacobi;
  Simulation a(s.world, c, kH), b(s.world, jacobi, kH);
  bool landed = false;
  for (int step = 0; step < 8 && !landed; ++step) {
    ASSERT_EQ(a.step().status, StepReport::Status::ok);
    ASSERT_EQ(b.step().status, StepReport::Status::ok);
    landed = b.integrator().stats().iterations > 4 * kMultigridAfter;
    if (landed) {
      EXPECT_LT(4 * a.integrator().stats().iterations, b.integrator().stats().iterations) << step;
    }
  }
  EXPECT_TRUE(landed);
}

// `automatic`'s choice from each step's iterations: to multigrid after a slow block-Jacobi step;
// a multigrid step of few iterations, or dearer than block Jacobi's last, tries block Jacobi,
// which stays while it is cheaper; a settled body whose block-Jacobi steps cost more tries again
// at doubling intervals, not every other step; a new body starts from block Jacobi.
TEST(Multigrid, AutomaticChoosesByCostWithoutAlternating) {
  constexpr std::size_t kQuanta = kMultigridQuanta;
  PreconditionerChoice choice;
  ASSERT_FALSE(choice.multigrid(kQuanta));
  choice.after_jacobi(kMultigridAfter);
  ASSERT_FALSE(choice.multigrid(kQuanta));
  choice.after_jacobi(kMultigridAfter + 1);
  ASSERT_TRUE(choice.multigrid(kQuanta));
  choice.after_multigrid(kJacobiTryBelow + 1);  // multigrid pays: kept
  ASSERT_TRUE(choice.multigrid(kQuanta));

  // Settled: multigrid takes 2 iterations, block Jacobi 50 (more than 2 · kMultigridIterationCost).
  const int settled_jacobi = 2 * kMultigridIterationCost + 30;
  int tries = 0;
  std::vector<int> tried_at;
  for (int steps = 0; steps < 200; ++steps) {
    if (choice.multigrid(kQuanta)) {
      choice.after_multigrid(2);
    } else {
      ++tries;
      tried_at.push_back(steps);
      choice.after_jacobi(settled_jacobi);
      ASSERT_TRUE(choice.multigrid(kQuanta)) << "a dearer block-Jacobi try keeps multigrid";
    }
  }
  // Waits 2, 4, ..., kJacobiTryWaitMost multigrid steps between tries, then kJacobiTryWaitMost.
  EXPECT_LE(tries, 8) << "tries in 200 settled steps";
  for (std::size_t k = 1; k < tried_at.size(); ++k)
    EXPECT_GT(tried_at[k] - tried_at[k - 1], static_cast<int>(std::min<std::size_t>(2u << (k - 1), kJacobiTryWaitMost)))
        << "try " << k;

  // Small steps: block Jacobi now as cheap as multigrid's one iteration: it stays while it is.
  while (choice.multigrid(kQuanta)) choice.after_multigrid(1);
  choice.after_jacobi(kMultigridIterationCost);
  EXPECT_FALSE(choice.multigrid(kQuanta));
  choice.after_jacobi(kMultigridIterationCost + 1);
  EXPECT_TRUE(choice.multigrid(kQuanta));
  // A hierarchy that fits the system badly: a multigrid step dearer than block Jacobi's last
  // tries block Jacobi, which stays while it is the cheaper.
  PreconditionerChoice bad;
  ASSERT_FALSE(bad.multigrid(kQuanta));
  bad.after_jacobi(150);
  ASSERT_TRUE(bad.multigrid(kQuanta));
  bad.after_multigrid(14);  // 140 block-Jacobi iterations' worth: kept
  ASSERT_TRUE(bad.multigrid(kQuanta));
  bad.after_multigrid(100);
  ASSERT_FALSE(bad.multigrid(kQuanta));
  bad.after_jacobi(200);
  EXPECT_FALSE(bad.multigrid(kQuanta));
  bad.after_jacobi(100 * kMultigridIterationCost);
  EXPECT_FALSE(bad.multigrid(kQuanta));
  bad.after_jacobi(100 * kMultigridIterationCost + 1);
  EXPECT_TRUE(bad.multigrid(kQuanta));

  // Another body, or a small one: block Jacobi.
  EXPECT_FALSE(choice.multigrid(kQuanta + 1));
  choice.after_jacobi(10 * kMultigridAfter);
  EXPECT_TRUE(choice.multigrid(kQuanta + 1));
  EXPECT_FALSE(choice.multigrid(kQuanta - 1));
  choice.after_jacobi(10 * kMultigridAfter);
  EXPECT_FALSE(choice.multigrid(kQuanta - 1));
}

// On a body of fewer than kMultigridQuanta quanta `automatic` keeps block Jacobi even where its
// solves are slow: the same bits as `block_jacobi`.
TEST(Multigrid, AutomaticKeepsBlockJacobiOnSmallBodies) {
  const World w = test::lattice(60, 4, 4, 1000, 1e-3, 0.01, true, Vec3(0, 0, -9.81));  // a slender beam
  ASSERT_LT(w.num_quanta(), kMultigridQuanta);
  IntegratorConfig c = multigrid_config(1e-6);
  c.preconditioner = Preconditioner::automatic;
  c.warm_start = WarmStart::zero;  // each step's iterations from the same start
  IntegratorConfig jacobi = c;
  jacobi.preconditioner = Preconditioner::block_jacobi;
  Simulation a(w, c, 0.5), b(w, jacobi, 0.5);
  int most = 0;
  for (int s = 0; s < 6; ++s) {
    a.step();
    b.step();
    most = std::max(most, a.integrator().stats().iterations);
  }
  EXPECT_GT(most, kMultigridAfter);
  EXPECT_EQ(a.world().state.x, b.world().state.x);
  EXPECT_EQ(a.world().state.v, b.world().state.v);
}

// A run resumed from a checkpoint builds its hierarchy from the system of its first step (the
// hierarchy is not in the checkpoint); the uninterrupted run drops its own where it writes the
// checkpoint (Simulation::forget_history), so it builds the same one there and the two go on with
// the same bits: with `multigrid`, and with `automatic`, whose choice starts again from block
// Jacobi in both.
TEST(Multigrid, AResumedRunContinuesBitForBit) {
  const World start = canonical_lattice(13).world;  // at least kMultigridQuanta: automatic may turn
  constexpr int kSteps = 12;
  struct Case {
    Preconditioner preconditioner;
    double h;
    int resume_at;  // automatic: once it has turned to multigrid (from its 3rd step)
    double tolerance;  // automatic: tight enough for block Jacobi to be slow
  };
  for (const Case& k : {Case{Preconditioner::multigrid, kH, 6, 1e-6}, Case{Preconditioner::automatic, 0.5, 5, 1e-8}}) {
    IntegratorConfig c = multigrid_config(k.tolerance);
    c.preconditioner = k.preconditioner;
    c.restore_momentum = true;
    std::vector<int> iterations;
    auto run = [&](const std::string* from, int steps, std::string* checkpoint) {
      World w = start;
      if (from) w.state = deserialize_state(*from);
      Simulation sim(std::move(w), c, k.h);
      for (int s = 0; s < steps; ++s) {
        sim.step();
        EXPECT_LE(sim.integrator().stats().residual, k.tolerance);
        iterations.push_back(sim.integrator().stats().iterations);
        if (checkpoint && s + 1 == k.resume_at) {
          *checkpoint = serialize_state(sim.world().state);
          sim.forget_history();  // as the runner does where it writes a checkpoint
        }
      }
      return sim.world().state;
    };
    std::string checkpoint;
    const State whole = run(nullptr, kSteps, &checkpoint);
    const State resumed = run(&checkpoint, kSteps - k.resume_at, nullptr);
    SCOPED_TRACE(std::string(to_string(k.preconditioner)));
    ASSERT_EQ(resumed.step, whole.step);
    EXPECT_EQ(resumed.x, whole.x);
    EXPECT_EQ(resumed.v, whole.v);
    // Iterative multigrid solves after the resume (few iterations, not a direct solve on one level).
    const auto after = std::vector<int>(iterations.begin() + kSteps, iterations.end());
    EXPECT_GE(*std::max_element(after.begin(), after.end()), 2);
    EXPECT_LE(*std::min_element(after.begin(), after.end()), 25);
    if (k.preconditioner == Preconditioner::automatic) {  // block Jacobi was slow: multigrid came in
      EXPECT_GT(*std::max_element(iterations.begin(), iterations.begin() + kSteps), kMultigridAfter);
    }
  }
}

TEST(Multigrid, SceneKey) {
  auto scene = [](const std::string& integrator) {
    return parse_scene(R"({"timestep": 1e-3, "steps": 1, "integrator": )" + integrator +
                       R"(, "materials": {"m": {"law": "linear", "stiffness": 100}},
                           "bodies": [{"name": "b", "type": "lattice", "cell": "cubic", "size": [2, 2, 2], "spacing": 0.01,
                                       "quanta_mass": 1e-3, "material": "m"}]})");
  };
  EXPECT_EQ(scene(R"({"preconditioner": "multigrid"})").integrator.preconditioner, Preconditioner::multigrid);
  EXPECT_EQ(scene(R"({"preconditioner": "block_jacobi"})").integrator.preconditioner,
            Preconditioner::block_jacobi);
  EXPECT_EQ(scene(R"({"preconditioner": "automatic"})").integrator.preconditioner, Preconditioner::automatic);
  EXPECT_EQ(scene(R"({"preconditioner": "multigrid"})").resolved["integrator"]["preconditioner"],
            "multigrid");
  EXPECT_THROW(scene(R"({"preconditioner": "ilu"})"), SceneError);
  for (const auto& p : preconditioners()) EXPECT_EQ(parse_preconditioner(p.key), p.value);
}


// The system changes within a run without a topology change or another step length (an impact,
// a stiffening): the kept hierarchy's solve is cut off at a few times its first iterations, the
// hierarchy's values are refreshed, and the solve still reaches the direct solver's solution.
TEST(Multigrid, StaleHierarchyRefreshedWithinTheStep) {
  World w = moving_lattice(12, 6, 6, true);
  MultigridStep mg;
  std::vector<Vec3> y;
  SolveStats stats;
  auto solve = [&] {
    StepSystem s;
    build_adjacency(w.model, w.state, s.adj);
    begin_implicit_step(w.model, w.state, s.adj, gravity_forces(w), {.h = kH}, false, 1, s.kin, s.sys);
    mg.solve(w.model, w.state, s.adj, s.sys, /*contacts=*/false, kH, kTol, 100000, 1, y, true, stats);
    return s.mismatch(w, y);
  };
  EXPECT_LT(solve(), kAgree);
  const int first = stats.iterations;
  EXPECT_EQ(mg.builds, 1);
  // The bonds of one half of the body become 1e4 times stiffer: the hierarchy's coarse operators
  // no longer match the system.
  Bonds& bonds = w.state.edit_bonds();
  for (std::size_t b = 0; b < bonds.size(); ++b)
    if (w.state.x[bonds.i[b]].x() < w.state.x[0].x() + 0.05) bonds.strength[b] *= 1e4;
  EXPECT_LT(solve(), kAgree);
  EXPECT_LE(stats.residual, kTol);
  EXPECT_EQ(mg.builds, 1);
  EXPECT_EQ(mg.updates, 1) << "iterations " << stats.iterations << ", first solve " << first;
  // Cut off at 4 × first + 20, then the refreshed hierarchy's own iterations.
  EXPECT_LE(stats.iterations, 2 * (4 * first + 20)) << "first solve " << first;
}

}  // namespace
}  // namespace qbond
