// Bond topology lives in the State: bonds that break, form (into new slots and into reused broken
// ones) and flow plastically during a run come back whole from a rollback (a copy of the State)
// and from a checkpoint, and the Model stays what the scene built.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include "qbond/io/checkpoint.hpp"
#include "qbond/io/scene.hpp"
#include "qbond/simulation/simulation.hpp"

namespace qbond {
namespace {

namespace fs = std::filesystem;

// A small liquid blob thrown at the ground: bonds past 20% strain break, quanta within 1.1
// spacings bond (reusing broken slots), and bonds flow past 1% strain and break past 10%.
constexpr const char* kScene = R"({
  "name": "splash", "timestep": 0.0002, "steps": 200, "gravity": [0, 0, -9.81], "seed": 3,
  "materials": {"water": {"law": "linear", "stiffness": 20.0, "damping": 0.002},
                "glue": {"law": "morse", "D0": 1e-4, "alpha": 400, "damping": 0.001}},
  "bodies": [{"name": "blob", "type": "lattice", "cell": "cubic", "neighbors": "nearest",
              "size": [4, 4, 4], "spacing": 0.005, "total_mass": 0.008, "material": "water",
              "origin": [-0.0075, -0.0075, 0.0005], "velocity": [0.3, 0, -1.5]}],
  "heuristics": [
    {"type": "plastic", "yield_strain": 0.01, "hardening": 0.2, "max_plastic_strain": 0.1},
    {"type": "liquid", "spacing": 0.005, "max_strain": 0.2, "capture_radius": 0.0055, "material": "water"},
    {"type": "form", "capture_radius": 0.0045, "max_bonds": 2, "material": "glue"},
    {"type": "ground", "height": 0, "restitution": 0.0, "friction": 0.05}
  ]
})";

Scene splash() { return parse_scene(kScene, "splash"); }

Simulation simulation_of(const Scene& scene, World world) {
  Simulation sim(std::move(world), scene.integrator, scene.timestep);
  for (const HeuristicSpec& h : scene.heuristics) sim.add_heuristic(make_heuristic(h));
  return sim;
}

// What the topology edits of a run were, from its events and its state.
struct Edits {
  int broken = 0, appended = 0, reused = 0;
};

// Steps `sim` n times, counting its topology edits.
void run(Simulation& sim, int n, Edits& edits) {
  for (int k = 0; k < n; ++k) {
    const std::size_t slots = sim.world().num_bonds();
    ASSERT_EQ(sim.step().status, StepReport::Status::ok) << "step " << k;
    for (const BondEvent& e : sim.events()) {
      if (e.kind == BondEvent::Kind::broken) ++edits.broken;
      if (e.kind == BondEvent::Kind::formed) ++(e.bond < slots ? edits.reused : edits.appended);
    }
  }
}

// Every array of the state, bit for bit (the checkpoint's bytes hold each field).
void expect_same_state(const State& a, const State& b, const std::string& what) {
  EXPECT_EQ(serialize_state(a), serialize_state(b)) << what;
  EXPECT_TRUE(a.bonds == b.bonds) << what;
  EXPECT_EQ(a.topology_version(), b.topology_version()) << what;
}

// Whether some alive bond's rest length has flowed away from the one it was made with.
bool flowed(const Bonds& bonds) {
  for (std::size_t b = 0; b < bonds.size(); ++b)
    if (bonds.alive[b] && bonds.rest[b] != bonds.rest0[b]) return true;
  return false;
}

TEST(Topology, EditsHappenInTheTestScene) {
  const Scene scene = splash();
  Simulation sim = simulation_of(scene, scene.world);
  Edits edits;
  run(sim, 100, edits);
  // The scene exercises each kind of edit the other tests rely on, within its first 100 steps.
  EXPECT_GT(edits.broken, 0);
  EXPECT_GT(edits.appended, 0);
  EXPECT_GT(edits.reused, 0);
  EXPECT_TRUE(flowed(sim.world().state.bonds));
  EXPECT_GT(sim.world().num_bonds(), sim.world().state.bonds.first_formed);
}

// A rollback is a copy of the State: restoring the copy taken before each step and stepping again
// gives the same bits, whatever that step broke, formed or flowed; and the run goes on as if no
// step had been undone.
TEST(Topology, EditsSurviveARollbackBitForBit) {
  const Scene scene = splash();
  Simulation once = simulation_of(scene, scene.world), twice = simulation_of(scene, scene.world);
  Edits edits;
  for (int k = 0; k < 100; ++k) {
    const State before = twice.world().state;
    Edits ignored;
    run(twice, 1, ignored);
    const State first = twice.world().state;
    twice.world().state = before;  // undo the step: no other repair
    run(twice, 1, ignored);
    expect_same_state(twice.world().state, first, "step " + std::to_string(k) + " taken again");
    run(once, 1, edits);
    expect_same_state(twice.world().state, once.world().state, "step " + std::to_string(k));
  }
  EXPECT_GT(edits.broken, 0);
  EXPECT_GT(edits.appended, 0);
  EXPECT_GT(edits.reused, 0);
}

// A run resumed from a checkpoint taken after bonds broke, formed (new and reused slots) and
// flowed continues with the positions of the run that never stopped, bit for bit.
TEST(Topology, EditsSurviveACheckpointResumeBitForBit) {
  const Scene scene = splash();
  Simulation whole = simulation_of(scene, scene.world);
  Edits edits;
  run(whole, 100, edits);
  ASSERT_GT(edits.reused, 0);
  ASSERT_TRUE(flowed(whole.world().state.bonds));
  const fs::path file = fs::temp_directory_path() / ("qbond_topology_test_" + std::to_string(::getpid()) + ".qbc");
  save_checkpoint(file, "{}", whole.world().state);

  Scene again = splash();  // the world as the scene builds it, before any step
  Checkpoint ck = load_checkpoint(file);
  fs::remove(file);
  adopt_scene_bonds(ck, again.world);
  expect_same_state(ck.state, whole.world().state, "the checkpoint's state");
  again.world.state = std::move(ck.state);
  Simulation resumed = simulation_of(again, again.world);
  for (int k = 0; k < 100; ++k) {
    Edits ignored;
    run(whole, 1, edits);
    run(resumed, 1, ignored);
    const std::vector<Vec3>&x = whole.world().state.x, &y = resumed.world().state.x;
    for (std::size_t i = 0; i < x.size(); ++i) ASSERT_EQ(x[i], y[i]) << "step " << 100 + k << ", quanta " << i;
  }
  expect_same_state(resumed.world().state, whole.world().state, "after 200 steps");
  EXPECT_GT(edits.appended, 0);
}

// The Model is what the scene built, through a run that forms bonds of two materials: every law
// shape a rule can give its bonds is in the table before the first step.
TEST(Topology, TheModelIsConstThroughARunThatFormsBonds) {
  const Scene scene = splash();
  Simulation sim = simulation_of(scene, scene.world);
  EXPECT_TRUE(sim.world().model == scene.world.model);  // the rules found their shapes interned
  Edits edits;
  run(sim, 150, edits);
  EXPECT_GT(edits.appended + edits.reused, 0);
  EXPECT_TRUE(sim.world().model == scene.world.model);
}

// The topology version changes only through the state's mutators, and with each of them.
TEST(Topology, TheStatesMutatorsChangeTheTopologyVersion) {
  State s;
  s.x = {Vec3::Zero(), Vec3::UnitX(), Vec3::UnitY()};
  s.v.assign(3, Vec3::Zero());
  std::uint64_t v = s.topology_version();
  auto changed = [&] {
    const bool c = s.topology_version() != v;
    v = s.topology_version();
    return c;
  };
  s.add_bond(0, 1, {}, 1.0);
  EXPECT_TRUE(changed());
  s.bonds.rest[0] = 1.5;  // a rest length is read every step: no topology change
  EXPECT_FALSE(changed());
  s.break_bond(0);
  EXPECT_TRUE(changed());
  s.break_bond(0);  // already broken
  EXPECT_FALSE(changed());
  s.form_bond(1, 2, {}, 1.0, 1);
  EXPECT_TRUE(changed());
  EXPECT_EQ(s.bonds.first_formed, 1u);
  s.break_bond(1);
  EXPECT_TRUE(changed());
  s.form_bond(0, 2, {.strength = 3}, 2.0, 1);  // the broken formed slot, reused
  EXPECT_TRUE(changed());
  EXPECT_EQ(s.bonds.size(), 2u);
  EXPECT_EQ(s.bonds.i[1], 0u);
  EXPECT_EQ(s.bonds.strength[1], 3.0);
  EXPECT_EQ(s.bonds.rest0[1], 2.0);
  EXPECT_EQ(s.bonds.id[1], 1u);
  s.edit_bonds().law[0] = Law::inverse;
  EXPECT_TRUE(changed());
  EXPECT_THROW(s.add_bond(0, 2, {}, 1.0), std::invalid_argument);  // the scene's bonds come first
}

}  // namespace
}  // namespace qbond
