// Quanta–quanta contact inside the implicit step ("contact" with method "implicit",
// contact_solve.hpp): the pair spring against its backward-Euler and continuous solutions, its
// block against finite differences of the penalty force, and stacking, a trampoline and a gap at
// frame-sized steps with the ledger's contact columns.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>

#include "integrators/backward_euler.hpp"
#include "integrators/contact_solve.hpp"
#include "qbond/analysis/analysis.hpp"
#include "qbond/io/scene.hpp"
#include "qbond/simulation/simulation.hpp"
#include "test_util.hpp"

namespace qbond {
namespace {

constexpr double kRadius = 0.005;

QuantaContactRule solved_contact(double penalty = 1000, double mu = 0, double e = 0) {
  QuantaContactRule r;
  r.radius = kRadius;
  r.method = ContactMethod::implicit;
  r.penalty = penalty;
  r.material = {.restitution = e, .friction = mu};
  return r;
}

// Two free quanta (masses 1 and 2 g) touching at rest, pressed together by equal and opposite
// loads F along their line, no gravity: the pair spring k = κ μ / h² holds them. Returns the gap
// |x_j − x_i| − 2R after each step.
constexpr double kMu = 1e-3 * 2e-3 / 3e-3;  // their reduced mass
std::vector<double> pressed(double h, double penalty, double F, CoupledSolver solver, int steps) {
  World w;
  w.add_quanta(Vec3(0, 0, 0), Vec3::Zero(), 1e-3);
  w.add_quanta(Vec3(2 * kRadius, 0, 0), Vec3::Zero(), 2e-3);
  w.model.loads = {{{0}, Vec3(F, 0, 0)}, {{1}, Vec3(-F, 0, 0)}};
  w.model.quanta_contact = solved_contact(penalty);
  IntegratorConfig c = default_integrator();
  c.solver = solver;
  c.tolerance = 1e-14;
  Simulation sim(std::move(w), c, h);
  std::vector<double> out;
  for (int n = 0; n < steps; ++n) {
    const StepReport rep = sim.step();
    EXPECT_EQ(rep.status, StepReport::Status::ok) << rep.message;
    const State& s = sim.world().state;
    // Momentum stays zero: the pair's forces are equal and opposite.
    EXPECT_NEAR((1e-3 * s.v[0] + 2e-3 * s.v[1]).norm(), 0.0, 1e-15);
    out.push_back(s.x[1].x() - s.x[0].x() - 2 * kRadius);
  }
  return out;
}

TEST(SolvedQuantaContact, APressedPairFollowsTheBackwardEulerSpring) {
  // Along the line of centres the gap is linear in the positions, so each step is backward Euler
  // of μ g'' = −F − k g exactly: w' = (μ w − h F − h k g) / (μ + h² k), g' = g + h w'; it comes
  // to rest at g = −F/k.
  const double h = 1.0 / 60;
  for (double penalty : {0.05, 1000.0})
    for (CoupledSolver solver : {CoupledSolver::cg, CoupledSolver::ldlt}) {
      const double k = penalty * kMu / (h * h), F = 1e-4 * k * kRadius;
      const std::vector<double> g = pressed(h, penalty, F, solver, 300);
      double gap = 0, v = 0;
      for (std::size_t n = 0; n < g.size(); ++n) {
        v = (kMu * v - h * F - h * k * gap) / (kMu + h * h * k);
        gap += h * v;
        EXPECT_NEAR(g[n], gap, 1e-9 * F / k) << "κ " << penalty << " step " << n;
      }
      if (penalty > 1) {  // the soft one still rings
        EXPECT_NEAR(g.back(), -F / k, 1e-9 * F / k);
      }
    }
}

TEST(SolvedQuantaContact, ThePairSpringConvergesToTheContinuousOneAsTheStepShrinks) {
  // At a fixed physical stiffness k (κ = k h² / μ) the gap follows μ g'' = −F − k g, whose first
  // deepest point is −2F/k at t = π/ω; backward Euler's damping makes its error O(h).
  const double k = 50, F = 1e-4 * k * kRadius, omega = std::sqrt(k / kMu), pi = 3.14159265358979;
  std::vector<double> error;
  for (int per : {40, 80, 160, 320}) {
    const double h = 2 * pi / omega / per;
    const std::vector<double> g = pressed(h, k * h * h / kMu, F, CoupledSolver::ldlt, per / 2 + 2);
    const double deepest = *std::min_element(g.begin(), g.end());
    error.push_back(std::abs(deepest + 2 * F / k) / (2 * F / k));
  }
  for (std::size_t n = 1; n < error.size(); ++n) EXPECT_NEAR(error[n - 1] / error[n], 2.0, 0.25) << n;
  EXPECT_LT(error.back(), 0.02);
}

TEST(SolvedQuantaContact, ThePairBlockIsTheFiniteDifferenceOfThePenaltyForce) {
  // Two overlapping quanta on a skew line: the step's residual R(y) = M y − h F(x + h (v + y)),
  // F the nonlinear penalty force k (2R − |d|) d/|d| on j (and −F on i), has the Jacobian
  // M + h² k (±) [n nᵀ + (φ/|d|)(I − n nᵀ)] at y = 0 (v = 0, d = x_j − x_i): the system's
  // contact block is its normal part, and drops the tangential φ/|d| term (negative for an
  // overlap, φ < 0) as bonds' clamped stiffness drops theirs.
  World w;
  const Vec3 d = Vec3(0.6, -0.3, 0.7).normalized() * (2 * kRadius - 4e-4);
  w.add_quanta(Vec3(0.1, 0.2, 0.3), Vec3::Zero(), 1e-3);
  w.add_quanta(Vec3(0.1, 0.2, 0.3) + d, Vec3::Zero(), 3e-3);
  w.model.quanta_contact = solved_contact(1000);
  const Model& m = w.model;
  const double h = 1.0 / 60, mu = 1e-3 * 3e-3 / 4e-3, k = 1000 * mu / (h * h);
  Adjacency adj;
  build_adjacency(m, w.state, adj);
  const std::vector<Vec3> f_ext(2, Vec3::Zero());
  ImplicitSystem sys;
  Projection out;
  begin_implicit_step(m, w.state, adj, f_ext, StepContext{h, 0, 0}, false, 1, out, sys);
  ContactSolve contact;
  ASSERT_TRUE(contact.begin(m, w.state, adj, f_ext, h, h, 1, sys));
  ASSERT_EQ(sys.couplings.size(), 1u);
  auto residual = [&](const std::vector<Vec3>& y) {
    const Vec3 dd = w.state.x[1] + h * y[1] - w.state.x[0] - h * y[0];
    const Vec3 F = k * (2 * kRadius - dd.norm()) * dd.normalized();
    return std::vector<Vec3>{m.mass[0] * y[0] + h * F, m.mass[1] * y[1] - h * F};
  };
  // b = −R(0): the spring's force at the start.
  const std::vector<Vec3> r0 = residual({Vec3::Zero(), Vec3::Zero()});
  for (int q = 0; q < 2; ++q) EXPECT_LT((sys.rhs[q] + r0[q]).norm(), 1e-12 * sys.rhs[q].norm());
  const Vec3 n = d.normalized();
  const double phi = d.norm() - 2 * kRadius;
  const double eps = 1e-9;
  for (int q = 0; q < 2; ++q)
    for (int c = 0; c < 3; ++c) {
      std::vector<Vec3> e(2, Vec3::Zero());
      e[q][c] = 1;
      std::vector<Vec3> Ae;
      apply_system(m, w.state.bonds, sys, e, 1, Ae);
      std::vector<Vec3> plus = e, minus = e;
      plus[q][c] = eps;
      minus[q][c] = -eps;
      const std::vector<Vec3> rp = residual(plus), rm = residual(minus);
      for (int p = 0; p < 2; ++p) {
        const Vec3 fd = (rp[p] - rm[p]) / (2 * eps);
        // The dropped term: h² k φ/|d| (I − n nᵀ) e_c, with the sign of the block (p == q) or −.
        const Vec3 geometric = (p == q ? 1.0 : -1.0) * h * h * k * phi / d.norm() * (e[q] - n * n.dot(e[q]));
        EXPECT_NEAR((Ae[p] - (fd - geometric)).norm(), 0.0, 1e-6 * h * h * k) << q << c << p;
        EXPECT_NEAR(n.dot(Ae[p] - fd), 0.0, 1e-6 * h * h * k) << q << c << p;
      }
    }
}

// What the ledger checks read on every row: the dissipation (never negative), the integrator's
// whole loss (`numerical_damping` + `numerical`), the remainder `numerical` alone, and the largest
// kinetic or gravity energy (above z = 0, or released since the start). `before_contact`: the
// largest |loss| on the rows before any contact held energy or took some; `least_numerical`: the
// loss's least value (negative: energy the books did not account for).
struct Ledger {
  double largest = 0, worst_numerical = 0, least_dissipated = 0, gravity0 = NAN;
  double before_contact = 0, least_numerical = 0, worst_remainder = 0;
  bool touched = false;
  void see(const World& w) {
    const EnergyBudget b = energy_budget(w.model, w.state);
    if (std::isnan(gravity0)) gravity0 = b.now.gravity;
    largest = std::max({largest, b.now.kinetic, std::abs(b.now.gravity), std::abs(b.now.gravity - gravity0)});
    if (!w.state.energy.initialised) return;  // before the first step: the books are not open
    const double loss = b.integrator_loss();
    worst_numerical = std::max(worst_numerical, std::abs(loss));
    least_numerical = std::min(least_numerical, loss);
    worst_remainder = std::max(worst_remainder, std::abs(b.dissipated_numerical));
    touched = touched || b.contact_stored > 0 || b.dissipated_contact > 0;
    if (!touched) before_contact = std::max(before_contact, std::abs(loss));
    least_dissipated =
        std::min({least_dissipated, b.dissipated_contact, b.dissipated_damping + b.dissipated_contact});
  }
};

// Steps sim `steps` times, each step ok, the ledger seeing the start and every step's end.
void step_watched(Simulation& sim, std::uint64_t steps, Ledger& ledger) {
  ledger.see(sim.world());
  for (std::uint64_t n = 0; n < steps; ++n) {
    ASSERT_EQ(sim.step().status, StepReport::Status::ok) << n;
    ledger.see(sim.world());
  }
}

// A body's centre of mass.
Vec3 mean_position(const World& w, Index body) {
  Vec3 x = Vec3::Zero();
  double m = 0;
  for (std::size_t i = 0; i < w.num_quanta(); ++i)
    if (w.model.body[i] == body) {
      x += w.model.mass[i] * w.state.x[i];
      m += w.model.mass[i];
    }
  return x / m;
}

double mean_z(const World& w, Index body) { return mean_position(w, body).z(); }

Index body_named(const World& w, const std::string& name) {
  const auto it = std::find(w.model.body_names.begin(), w.model.body_names.end(), name);
  EXPECT_NE(it, w.model.body_names.end()) << name;
  return static_cast<Index>(it - w.model.body_names.begin());
}

// Runs a resting scene: `settle` seconds, then 10 s in which each probed body's mean height stays
// within 1% of a radius of where it settled and the kinetic energy below 1e-6 of the gravity
// energy released; the ledger holds on every step, `numerical` within 1% of the largest energy.
// `impact`: the integrator's whole loss is held to backward
// Euler's own loss (`own_numerical`, and the steps of free fall of the body `falling`) plus 1% of
// the largest energy until the first contact, and after it never below minus that (the books never
// show energy the step created): what backward Euler takes from the vibration an impact excites is
// a loss of its own (TheTrampolinesStateAndImpactLossConvergeAsTheStepShrinks).
void expect_rests(const std::string& file, const std::vector<std::string>& bodies, double settle,
                  double own_numerical = 0, const std::string& falling = "", bool impact = false) {
  Scene s = load_scene(std::string(QBOND_SOURCE_DIR) + "/scenes/" + file);
  ASSERT_EQ(s.timestep, 1.0 / 60);
  Simulation sim(std::move(s.world), s.integrator, s.timestep);
  Ledger ledger;
  ledger.see(sim.world());
  const int settle_steps = static_cast<int>(std::lround(settle / s.timestep));
  // A body's steps of free fall: backward Euler's own loss, ½ M g² h² each (gravity's work at the
  // end velocity), is `numerical`'s too.
  const Index fall = falling.empty() ? 0 : body_named(sim.world(), falling);
  auto momentum_z = [&] {
    double p = 0, m = 0;
    const World& w = sim.world();
    for (std::size_t i = 0; i < w.num_quanta(); ++i)
      if (w.model.body[i] == fall) {
        p += w.model.mass[i] * w.state.v[i].z();
        m += w.model.mass[i];
      }
    return std::pair{p, m};
  };
  const double g = 9.81, h = s.timestep;
  for (int n = 0; n < settle_steps; ++n) {
    const double p0 = momentum_z().first;
    ASSERT_EQ(sim.step().status, StepReport::Status::ok) << n;
    ledger.see(sim.world());
    const auto [p1, M] = momentum_z();
    if (!falling.empty() && std::abs(p1 - p0 + M * g * h) < 1e-9 * M * g * h)
      own_numerical += 0.5 * M * g * g * h * h;
  }
  std::vector<Index> ids;
  std::vector<double> rest;
  for (const std::string& b : bodies) {
    ids.push_back(body_named(sim.world(), b));
    rest.push_back(mean_z(sim.world(), ids.back()));
  }
  const double released = ledger.gravity0 - energy_budget(sim.world().model, sim.world().state).now.gravity;
  ASSERT_GT(released, 0);
  double worst_ke = 0, worst_drift = 0;
  for (int n = 0; n < 600; ++n) {
    ASSERT_EQ(sim.step().status, StepReport::Status::ok) << n;
    ledger.see(sim.world());
    for (std::size_t k = 0; k < ids.size(); ++k)
      worst_drift = std::max(worst_drift, std::abs(mean_z(sim.world(), ids[k]) - rest[k]));
    worst_ke = std::max(worst_ke, energies(sim.world().model, sim.world().state).kinetic);
  }
  EXPECT_LT(worst_drift, 0.01 * kRadius) << file;
  EXPECT_LT(worst_ke, 1e-6 * released) << file;
  EXPECT_GE(ledger.least_dissipated, 0.0) << file;
  // With backward Euler's own loss in `numerical_damping`, what is left is within 1% outright,
  // through an impact too.
  EXPECT_LE(ledger.worst_remainder, 0.01 * ledger.largest) << file;
  if (!impact) {
    EXPECT_LE(ledger.worst_numerical, own_numerical + 0.01 * ledger.largest) << file;
    return;
  }
  EXPECT_TRUE(ledger.touched) << file;
  EXPECT_LE(ledger.before_contact, own_numerical + 0.01 * ledger.largest) << file;
  EXPECT_GE(ledger.least_numerical, -(own_numerical + 0.01 * ledger.largest)) << file;
}

TEST(SolvedQuantaContact, AStackOfThreeBlocksRestsAtFrameSizedSteps) {
  expect_rests("stack.json", {"bottom", "middle", "top"}, 2.0);
}

TEST(SolvedQuantaContact, ABlockRestsOnATrampolineAtFrameSizedSteps) {
  // The flat sheet sagging under its own weight at h = 1/60 s loses energy to backward Euler
  // whatever the contact does: that run alone bounds `numerical`'s part that is not the contact's.
  std::ifstream f(std::string(QBOND_SOURCE_DIR) + "/scenes/trampoline.json");
  nlohmann::json j = nlohmann::json::parse(f);
  j["bodies"].erase(1);
  j["heuristics"].erase(1);
  j.erase("output");
  Scene alone = parse_scene(j.dump());
  Simulation sheet(std::move(alone.world), alone.integrator, alone.timestep);
  double own = 0;
  for (int n = 0; n < 840; ++n) {
    ASSERT_EQ(sheet.step().status, StepReport::Status::ok);
    own = std::max(own, std::abs(energy_budget(sheet.world().model, sheet.world().state).integrator_loss()));
  }
  expect_rests("trampoline.json", {"block", "sheet"}, 4.0, own, "block", /*impact=*/true);
}

// The scene j at h = 1/per_second for `duration` s, without outputs.
Scene scene_at(nlohmann::json j, int per_second, double duration) {
  j["timestep"] = 1.0 / per_second;
  j["duration"] = duration;
  j.erase("output");
  return parse_scene(j.dump());
}

TEST(SolvedQuantaContact, TheTrampolinesStateAndImpactLossConvergeAsTheStepShrinks) {
  // The block dropped 20 cm, at h = 1/60, 1/120, 1/240, 1/480 s, after 4 s (at rest at every h):
  // the block's and the sheet's mean heights, whose difference between successive steps shrinks
  // (the penalty's depth F h² / (κ μ) with them), and the integrator's loss (`numerical_damping`
  // + `numerical`), which shrinks as h does. The
  // impact excites the bodies' vibration, whose modes faster than 1/h backward Euler damps in a
  // step (its loss ½ Δvᵀ M Δv + ½ Δxᵀ K Δx a step is the energy of such a mode): the finer the
  // step, the fewer modes it damps so. Never below zero (a loss: no step created energy).
  // Without friction: a stuck contact's rest state depends on its history (static friction
  // holds any tangential load below μ_s f_n), so with it the state need not converge.
  std::ifstream f(std::string(QBOND_SOURCE_DIR) + "/scenes/trampoline.json");
  nlohmann::json j0 = nlohmann::json::parse(f);
  j0["heuristics"][0].erase("friction");
  j0["heuristics"][1].erase("friction");
  std::vector<double> block, sheet, numerical;
  for (int per_second : {60, 120, 240, 480}) {
    Scene s = scene_at(j0, per_second, 4.0);
    Simulation sim(std::move(s.world), s.integrator, s.timestep);
    for (std::uint64_t n = 0; n < s.steps; ++n) ASSERT_EQ(sim.step().status, StepReport::Status::ok);
    block.push_back(mean_z(sim.world(), body_named(sim.world(), "block")));
    sheet.push_back(mean_z(sim.world(), body_named(sim.world(), "sheet")));
    numerical.push_back(energy_budget(sim.world().model, sim.world().state).integrator_loss());
  }
  for (std::size_t n = 2; n < block.size(); ++n) {
    EXPECT_LT(std::abs(block[n] - block[n - 1]), std::abs(block[n - 1] - block[n - 2])) << n;
    EXPECT_LT(std::abs(sheet[n] - sheet[n - 1]), std::abs(sheet[n - 1] - sheet[n - 2])) << n;
  }
  for (std::size_t n = 1; n < numerical.size(); ++n) EXPECT_LT(numerical[n], numerical[n - 1]) << n;
  EXPECT_GT(numerical.back(), 0.0);
  EXPECT_LT(std::abs(block[3] - block[2]), 0.01 * kRadius);
}

TEST(SolvedQuantaContact, TheTrampolineWithFrictionConvergesAsTheStepShrinks) {
  // The scene with its pair friction 0.5 but the block dropped over the sheet's middle, its quanta
  // over the hollows between the sheet's (as shipped it lands on their tops, where friction holds
  // it perched as long as the steps damp the impact's vibration: docs/heuristics.md), at
  // h = 1/60 ... 1/480 s, after 4 s: the block's mean height changes less from one h to the next
  // than from the one before, and the block stays on the sheet's axis (symmetric: round-off
  // amplified by its stuck contacts moves it < 0.004 radii). At 1/120 s the impact's active set
  // used to cycle (a stick contact pulled once released) until the block passed into the sheet:
  // the ledger's `numerical` stays within 1%. Solved by LDLᵀ: the active-set rules are the same
  // whatever the solver, CG takes 300–1000 iterations a step here, and the direct solve leaves
  // CG's tolerance out of the heights compared.
  std::ifstream f(std::string(QBOND_SOURCE_DIR) + "/scenes/trampoline.json");
  nlohmann::json j0 = nlohmann::json::parse(f);
  ASSERT_EQ(j0["bodies"][1]["name"], "block");
  j0["bodies"][1]["origin"] = {-0.015, -0.015, 0.31};
  j0["integrator"] = {{"type", "coupled_implicit"}, {"solver", "ldlt"}};
  std::vector<double> height;
  for (int per_second : {60, 120, 240, 480}) {
    Scene s = scene_at(j0, per_second, 4.0);
    Simulation sim(std::move(s.world), s.integrator, s.timestep);
    Ledger ledger;
    ASSERT_NO_FATAL_FAILURE(step_watched(sim, s.steps, ledger)) << per_second;
    EXPECT_GE(ledger.least_dissipated, 0.0) << per_second;
    EXPECT_LE(ledger.worst_remainder, 0.01 * ledger.largest) << per_second;
    const Index block = body_named(sim.world(), "block");
    const Vec3 c = mean_position(sim.world(), block);
    EXPECT_LT(std::hypot(c.x(), c.y()), 0.01 * kRadius) << per_second;
    height.push_back(c.z());
  }
  for (std::size_t n = 2; n < height.size(); ++n)
    EXPECT_LT(std::abs(height[n] - height[n - 1]), std::abs(height[n - 1] - height[n - 2])) << n;
}

TEST(SolvedQuantaContact, TheTrampolineWithFrictionCreatesNoEnergyAtAnyFrameSizedStep) {
  // The scene as shipped, friction included, at h = 1/60 and 1/120 s through its impact: no step
  // ends with more energy (kinetic, bonds', gravity's, the contact springs') than the start held
  // plus the work done on it. At 1/120 s the landing step's linearisation alone would create
  // 0.26 J, more than its contacts' energies could explain: the energy guard retakes it in halves.
  std::ifstream f(std::string(QBOND_SOURCE_DIR) + "/scenes/trampoline.json");
  const nlohmann::json j0 = nlohmann::json::parse(f);
  for (int per_second : {60, 120}) {
    Scene s = scene_at(j0, per_second, 0.5);
    Simulation sim(std::move(s.world), s.integrator, s.timestep);
    double worst = -1;
    for (std::uint64_t n = 0; n < s.steps; ++n) {
      ASSERT_EQ(sim.step().status, StepReport::Status::ok);
      const EnergyBudget b = energy_budget(sim.world().model, sim.world().state);
      const double gain = b.now.total() + b.contact_stored - b.initial_total - b.work_loads - b.work_anchors;
      worst = std::max(worst, gain / b.initial_total);
    }
    // The guard's tolerance, 1e-9 of a step's energies, summed over the steps.
    EXPECT_LT(worst, 1e-9 * static_cast<double>(s.steps)) << per_second;
  }
}

TEST(SolvedQuantaContact, TheMeshDropsLedgerClosesAtFrameSizedSteps) {
  // mesh_drop as shipped (its ground in the step with friction 0.5, h = 1/60 s) but voxelised at
  // 1 cm: the bodies land from 10 cm at 1 m/s and more, and the ledger holds on every step:
  // `dissipated` never negative, `numerical` within 1% of the largest energy; they end at rest.
  // With the ground's margin half the spacing, as shipped, and with a quarter: there the active
  // set of the landing step cycles (contacts released and entered again), and a quanta must not
  // end it inside the ground with no spring holding it.
  std::ifstream f(std::string(QBOND_SOURCE_DIR) + "/scenes/mesh_drop.json");
  const nlohmann::json j0 = nlohmann::json::parse(f);
  ASSERT_EQ(j0["heuristics"][0]["method"], "implicit");
  ASSERT_EQ(j0["heuristics"][0]["margin"], 0.5 * j0["bodies"][0]["spacing"].get<double>());
  for (double margin : {0.005, 0.0025}) {
    SCOPED_TRACE(margin);
    nlohmann::json j = j0;
    for (nlohmann::json& b : j["bodies"]) b["spacing"] = 0.01;
    j["heuristics"][0]["margin"] = margin;
    j.erase("output");
    Scene s = parse_scene(j.dump(), "mesh_drop", {.dir = std::string(QBOND_SOURCE_DIR) + "/scenes"});
    ASSERT_EQ(s.timestep, 1.0 / 60);
    Simulation sim(std::move(s.world), s.integrator, s.timestep);
    Ledger ledger;
    ASSERT_NO_FATAL_FAILURE(step_watched(sim, s.steps, ledger));
    EXPECT_TRUE(ledger.touched);
    EXPECT_GE(ledger.least_dissipated, 0.0);
    EXPECT_LE(ledger.worst_remainder, 0.01 * ledger.largest);
    EXPECT_LT(energies(sim.world().model, sim.world().state).kinetic, 1e-6 * ledger.largest);
  }
}

TEST(SolvedQuantaContact, TheMeshDropsRestHeightsConvergeAsTheStepShrinks) {
  // mesh_drop's torus and blob voxelised at 1 cm (a small size) with the ground in the step,
  // without friction (as the trampoline's, above), after 1.5 s at h = 1/60 ... 1/480 s: each body's
  // mean height, resting on the ground, changes less from one h to the next than from the one
  // before (the penalty's depth F h² / (κ m) shrinks with h²), and the last change is far below
  // a radius.
  std::ifstream f(std::string(QBOND_SOURCE_DIR) + "/scenes/mesh_drop.json");
  nlohmann::json j0 = nlohmann::json::parse(f);
  j0["heuristics"][0]["method"] = "implicit";
  j0["heuristics"][0].erase("friction");
  for (nlohmann::json& b : j0["bodies"]) b["spacing"] = 0.01;
  j0["duration"] = 1.5;
  j0.erase("output");
  std::vector<double> torus, blob;
  for (int per_second : {60, 120, 240, 480}) {
    nlohmann::json j = j0;
    j["timestep"] = 1.0 / per_second;
    Scene s = parse_scene(j.dump(), "mesh_drop", {.dir = std::string(QBOND_SOURCE_DIR) + "/scenes"});
    Simulation sim(std::move(s.world), s.integrator, s.timestep);
    for (std::uint64_t n = 0; n < s.steps; ++n) ASSERT_EQ(sim.step().status, StepReport::Status::ok);
    torus.push_back(mean_z(sim.world(), body_named(sim.world(), "torus")));
    blob.push_back(mean_z(sim.world(), body_named(sim.world(), "blob")));
  }
  for (std::size_t n = 2; n < torus.size(); ++n) {
    EXPECT_LT(std::abs(torus[n] - torus[n - 1]), std::abs(torus[n - 1] - torus[n - 2])) << n;
    EXPECT_LT(std::abs(blob[n] - blob[n - 1]), std::abs(blob[n - 1] - blob[n - 2])) << n;
  }
  EXPECT_LT(std::abs(torus[3] - torus[2]), 0.01 * kRadius);
  EXPECT_LT(std::abs(blob[3] - blob[2]), 0.01 * kRadius);
}

TEST(SolvedQuantaContact, ABodyDoesNotTunnelThroughAGapNarrowerThanItself) {
  // The block meets one-layer ledges (centres at z = 0.1) at 38 mm a step, nearly four times
  // their thickness: no quanta of it ever passes below the ledges' layer (its middle column may sag
  // into the gap, between them), its mean height stays above their top, and it comes to rest.
  Scene s = load_scene(std::string(QBOND_SOURCE_DIR) + "/scenes/gap.json");
  Simulation sim(std::move(s.world), s.integrator, s.timestep);
  const Index block = body_named(sim.world(), "block");
  const double ledge = 0.1;
  double fastest = 0, flight = 0;
  Ledger ledger;
  ledger.see(sim.world());
  const double g = 9.81, h = s.timestep;
  auto mean_vz = [&] {
    double p = 0, m = 0;
    const World& w = sim.world();
    for (std::size_t i = 0; i < w.num_quanta(); ++i)
      if (w.model.body[i] == block) {
        p += w.model.mass[i] * w.state.v[i].z();
        m += w.model.mass[i];
      }
    return std::pair{p / m, m};
  };
  for (std::uint64_t n = 0; n < s.steps; ++n) {
    const World& w = sim.world();
    const double vz0 = mean_vz().first;
    for (std::size_t i = 0; i < w.num_quanta(); ++i)
      if (w.model.body[i] == block) fastest = std::max(fastest, std::abs(w.state.v[i].z()) * s.timestep);
    ASSERT_EQ(sim.step().status, StepReport::Status::ok) << n;
    ledger.see(sim.world());
    // A step of free fall: backward Euler's own loss, ½ M g² h² (gravity's work at the end velocity).
    const auto [vz1, M] = mean_vz();
    if (std::abs(vz1 - vz0 + g * h) < 1e-9) flight += 0.5 * M * g * g * h * h;
    for (std::size_t i = 0; i < w.num_quanta(); ++i)
      if (w.model.body[i] == block) {
        ASSERT_GT(w.state.x[i].z(), ledge - kRadius) << "step " << n << " quanta " << i;
      }
    ASSERT_GT(mean_z(w, block), ledge + kRadius) << "step " << n;
  }
  EXPECT_GT(fastest, 3.5 * 2 * kRadius);  // over three and a half times the ledges' thickness a step
  EXPECT_LT(energies(sim.world().model, sim.world().state).kinetic, 1e-6 * ledger.largest);
  EXPECT_GE(ledger.least_dissipated, 0.0);
  // The integrator's loss peaks at backward Euler's loss in flight, the contacts add at most 1%
  // to it, and it ends within 1%: the impact's charge holds the kinetic energy the ledger saw.
  // Backward Euler's part in closed form, `numerical_damping`, leaves `numerical` within 1%
  // throughout.
  EXPECT_GT(flight, 0);
  EXPECT_LE(ledger.worst_numerical, flight + 0.01 * ledger.largest);
  EXPECT_LE(std::abs(energy_budget(sim.world().model, sim.world().state).integrator_loss()), 0.01 * ledger.largest);
  EXPECT_LE(ledger.worst_remainder, 0.01 * ledger.largest);
}

// Two free quanta (1 and 2 g, no gravity) touching along x at the overlap F_n/k where the normal
// spring holds the equal and opposite loads ∓F_n x̂ that press them, with tangential loads ±F_t ŷ
// shearing them (F_t on j, −F_t on i), μ_k = 0.4, μ_s = 0.5. Returns j's velocity relative to i
// along y after each step and the relative displacement along y over the run.
std::pair<std::vector<double>, double> sheared(double Fn, double Ft, int steps) {
  const double h = 1.0 / 60, k = 1000 * kMu / (h * h);
  World w;
  w.add_quanta(Vec3(0, 0, 0), Vec3::Zero(), 1e-3);
  w.add_quanta(Vec3(2 * kRadius - Fn / k, 0, 0), Vec3::Zero(), 2e-3);
  w.model.loads = {{{0}, Vec3(Fn, -Ft, 0)}, {{1}, Vec3(-Fn, Ft, 0)}};
  w.model.quanta_contact = solved_contact(1000, 0.4);
  w.model.quanta_contact.material.static_friction = 0.5;
  IntegratorConfig c = default_integrator();
  c.solver = CoupledSolver::ldlt;
  Simulation sim(std::move(w), c, h);
  std::vector<double> wy;
  for (int n = 0; n < steps; ++n) {
    EXPECT_EQ(sim.step().status, StepReport::Status::ok);
    const State& s = sim.world().state;
    wy.push_back(s.v[1].y() - s.v[0].y());
  }
  const State& s = sim.world().state;
  return {wy, s.x[1].y() - s.x[0].y()};
}

TEST(SolvedQuantaContact, APairSlidesUnderCoulombsForceAndSticksBelowIt) {
  const double h = 1.0 / 60, Fn = 0.01, k = 1000 * kMu / (h * h);
  // tan = F_t/F_n = 0.6 > μ_s: in one step from rest the pair's relative velocity along the
  // surface is h (F_t − μ_k F_n)/μ (backward Euler of a constant force is exact), to the
  // settling tolerance 1e-3 of the friction force.
  const double Ft = 0.006;
  const double slid = sheared(Fn, Ft, 1).first[0];
  EXPECT_NEAR(slid, h * (Ft - 0.4 * Fn) / kMu, 1e-3 * h * 0.4 * Fn / kMu);
  // tan = 0.3 < μ_s: it sticks; the stick spring k_t = 100 k anchored at each step's start lets
  // it creep at most F_t / k_t a step, plus what the pressing load adds along the surface as the
  // line of centres turns by the creep δ, F_n δ / (2R − F_n/k).
  const double held = 0.3 * Fn, kt = 100 * k;
  const auto [wy, moved] = sheared(Fn, held, 120);
  const double turned = Fn * moved / (2 * kRadius - Fn / k);
  EXPECT_GT(moved, 0);
  EXPECT_LE(moved, 120 * (held + turned) / kt * (1 + 1e-9));
  EXPECT_LE(std::abs(wy.back()), (held + turned) / (kt * h) * (1 + 1e-9));
}

TEST(SolvedQuantaContact, FrictionTakesEnergyFromAnObliqueImpactAndPutsNoneIn) {
  // A 3×3×3 block thrown at 0.3 m/s sideways, dropped 20 cm onto an anchored one-layer slab
  // (k = 1e4 N/m), pair friction μ = 0.5, h = 1/60 s: it meets the slab at 2 m/s, 3.3 cm a step.
  // Every step the energy it holds, kinetic + gravity + bonds + the contact springs', does not
  // grow (the friction's damper and the normal springs only take energy out; tolerance: the
  // solver's relative residual on the largest energy); no quanta of the block passes the slab's
  // layer, `dissipated` never decreases, and the friction stops its sideways motion at the
  // impact (it moves less than a tenth of what a frictionless block does after landing).
  auto run = [](double mu, double& travelled) {
    const std::string text = R"({"timestep": 0.016666666666666666, "duration": 1.0, "gravity": [0, 0, -9.81],
      "materials": {"rubber": {"law": "linear", "stiffness": 10000, "damping": 5}},
      "bodies": [
        {"name": "slab", "type": "lattice", "cell": "cubic", "neighbors": "face_diagonal", "size": [15, 7, 1],
         "spacing": 0.01, "quanta_mass": 0.001, "material": "rubber", "origin": [-0.07, -0.03, 0.1]},
        {"name": "block", "type": "lattice", "cell": "cubic", "neighbors": "face_diagonal", "size": [3, 3, 3],
         "spacing": 0.01, "quanta_mass": 0.001, "material": "rubber", "origin": [-0.05, -0.01, 0.31],
         "velocity": [0.3, 0, 0]}],
      "anchors": [{"select": {"body": "slab"}}],
      "heuristics": [{"type": "contact", "radius": 0.005, "method": "implicit", "friction": MU}]})";
    std::string t = text;
    t.replace(t.find("MU"), 2, std::to_string(mu));
    Scene s = parse_scene(t);
    Simulation sim(std::move(s.world), s.integrator, s.timestep);
    const Index block = body_named(sim.world(), "block");
    auto held = [&] {
      const EnergyBudget b = energy_budget(sim.world().model, sim.world().state);
      return std::pair{b.now.total() + b.contact_stored, b};
    };
    double largest = 0, worst_gain = -1, last_dissipated = 0;
    double x_landed = NAN;
    auto [e0, b0] = held();
    largest = std::abs(b0.now.gravity);
    for (std::uint64_t n = 0; n < s.steps; ++n) {
      EXPECT_EQ(sim.step().status, StepReport::Status::ok) << n;
      const auto [e1, b1] = held();
      worst_gain = std::max(worst_gain, e1 - e0);
      e0 = e1;
      EXPECT_GE(b1.dissipated_contact, last_dissipated - 1e-15) << n;
      last_dissipated = b1.dissipated_contact;
      const World& w = sim.world();
      double x = 0;
      for (std::size_t i = 0; i < w.num_quanta(); ++i)
        if (w.model.body[i] == block) {
          EXPECT_GT(w.state.x[i].z(), 0.1) << "step " << n << " quanta " << i;
          x += w.state.x[i].x() / 27;
        }
      if (std::isnan(x_landed) && b1.contact_stored > 0) x_landed = x;
      travelled = x - x_landed;
    }
    EXPECT_LE(worst_gain, 1e-9 * largest) << "μ " << mu;
    EXPECT_GT(last_dissipated, 0.1 * largest) << "μ " << mu;
  };
  double with = 0, without = 0;
  run(0.5, with);
  run(0.0, without);
  EXPECT_LT(std::abs(with), 0.1 * std::abs(without));
}

TEST(SolvedQuantaContact, SceneContactWithMethodImplicitJoinsTheModel) {
  const std::string base = R"({"timestep": 0.01, "steps": 1, "integrator": {"type": "INTEGRATOR"},
    "bodies": [{"name": "q", "type": "quanta", "positions": [[0, 0, 1], [0, 0, 2]], "mass": 0.001}],
    "heuristics": [CONTACT]})";
  auto scene = [&](const std::string& contact, const std::string& integrator = "coupled_implicit") {
    std::string t = base;
    t.replace(t.find("INTEGRATOR"), 10, integrator);
    t.replace(t.find("CONTACT"), 7, contact);
    return t;
  };
  const Scene s =
      parse_scene(scene(R"({"type": "contact", "radius": 0.1, "method": "implicit", "friction": 0.3,
      "static_friction": 0.4, "restitution": 0.5, "penalty": 200, "same_body": false})"));
  EXPECT_TRUE(s.heuristics.empty());
  const QuantaContactRule& r = s.world.model.quanta_contact;
  EXPECT_EQ(r.radius, 0.1);
  EXPECT_EQ(r.penalty, 200);
  EXPECT_EQ(r.material.static_coefficient(), 0.4);
  EXPECT_FALSE(r.same_body);
  EXPECT_TRUE(s.world.model.solves_contact());
  auto refused = [](const std::string& text, const std::string& says) {
    try {
      parse_scene(text);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const std::exception& e) {
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
    }
  };
  refused(scene(R"({"type": "contact", "radius": 0.1, "method": "implicit"})", "velocity_verlet"),
          "coupled_implicit");
  refused(scene(R"({"type": "contact", "radius": 0.1, "penalty": 10})"), "method");
  refused(scene(R"({"type": "contact", "radius": 0.1, "method": "implicit", "iterations": 3})"),
          "projection");
}

}  // namespace
}  // namespace qbond
