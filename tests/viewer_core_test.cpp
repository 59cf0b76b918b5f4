// The viewer's parts that need no window: the pull spring's physics path, the camera's picking
// and framing, colour ranges and input scripts. The window itself is tested by viewer_test.py.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "camera.hpp"
#include "colors.hpp"
#include "menus.hpp"
#include "qbond/simulation/interaction.hpp"
#include "qbond/model/ordering.hpp"
#include "qbond/builders/samples.hpp"
#include "script.hpp"

namespace qbond {
namespace {

// The viewer's mouse force enters the step exactly as a scene load does: pulling the pendulum with
// a spring through Simulation::add_force, and giving a second copy a load equal to the same
// spring force each step, gives the same bits.
TEST(PullSpring, PullsThroughTheSamePathAsLoads) {
  Scene scene = builtin_scene("pendulum");
  const Index q = quanta_by_id(scene.world.model)[30];
  Simulation pulled(scene.world, scene.integrator, scene.timestep);
  World loaded_world = scene.world;
  loaded_world.add_load({q}, Vec3::Zero());
  Simulation loaded(std::move(loaded_world), scene.integrator, scene.timestep);
  const Vec3 target = scene.world.state.x[q] + Vec3(0.5, 0.2, 0.3);
  const PullSpring spring = make_pull_spring(scene.world.model, q, target, body_mass(scene.world.model, q), scene.timestep);
  for (int step = 0; step < 300; ++step) {
    pulled.add_force(q, spring.force(pulled.world().state));
    loaded.world().model.loads[0].force = spring.force(loaded.world().state);
    ASSERT_EQ(pulled.step().status, StepReport::Status::ok);
    ASSERT_EQ(loaded.step().status, StepReport::Status::ok);
  }
  const State& a = pulled.world().state;
  const State& b = loaded.world().state;
  for (std::size_t i = 0; i < a.x.size(); ++i) {
    ASSERT_EQ(a.x[i], b.x[i]) << "quanta " << i;
    ASSERT_EQ(a.v[i], b.v[i]) << "quanta " << i;
  }
  EXPECT_GT((a.x[q] - scene.world.state.x[q]).norm(), 0.1);  // and it did pull
}

TEST(PullSpring, StiffnessFromTheBodyCappedByTheQuanta) {
  World w;
  w.add_quanta(Vec3::Zero(), Vec3::Zero(), 2.0);
  const double w0 = 2 * std::numbers::pi * 3.0;
  PullSpring s = make_pull_spring(w.model, 0, Vec3::UnitX(), 10.0, 1e-3, 3.0);
  EXPECT_DOUBLE_EQ(s.stiffness, 10.0 * w0 * w0);
  EXPECT_DOUBLE_EQ(s.damping, std::min(2 * std::sqrt(s.stiffness * 10.0), 2.0 / (2 * 1e-3)));
  // At a step of 0.1 s: k ≤ m/h², c ≤ m/(2h).
  s = make_pull_spring(w.model, 0, Vec3::UnitX(), 10.0, 0.1, 3.0);
  EXPECT_DOUBLE_EQ(s.stiffness, 2.0 / 0.01);
  EXPECT_DOUBLE_EQ(s.damping, 2.0 / 0.2);
  State st = w.state;
  st.v[0] = Vec3(0, 1, 0);
  EXPECT_EQ(s.force(st), Vec3(s.stiffness, -s.damping, 0));
}

TEST(OrbitCamera, PixelsAndRaysAgree) {
  view::OrbitCamera cam;
  cam.target = view::Vec3f(0.3f, -0.2f, 0.5f);
  cam.distance = 2.5f, cam.yaw = 1.1f, cam.pitch = 0.4f;
  const float w = 950, h = 720;
  for (const view::Vec3f& p : {view::Vec3f(0.3f, -0.2f, 0.5f), view::Vec3f(0.8f, 0.1f, 0.2f), view::Vec3f(-0.2f, -0.6f, 1.0f)}) {
    float px = 0, py = 0;
    ASSERT_TRUE(cam.to_pixel(p, w, h, px, py));
    const view::Ray ray = cam.ray(px, py, w, h);
    // The ray through the pixel a point lands on passes through the point (float precision).
    const Eigen::Vector3d d = p.cast<double>() - ray.origin;
    EXPECT_LT((d - d.dot(ray.dir) * ray.dir).norm(), 1e-4 * d.norm());
    EXPECT_NEAR(view::hit_sphere(ray, p.cast<double>(), 0.01), d.norm() - 0.01, 1e-4);
  }
  float px = 0, py = 0;
  ASSERT_TRUE(cam.to_pixel(cam.target, w, h, px, py));
  EXPECT_NEAR(px, w / 2, 1e-3);
  EXPECT_NEAR(py, h / 2, 1e-3);
  EXPECT_FALSE(cam.to_pixel(cam.eye() - (cam.target - cam.eye()), w, h, px, py));  // behind the eye
}

TEST(OrbitCamera, LookAtPutsTheEyeAndTargetWhereAsked) {
  view::OrbitCamera cam;
  const view::Vec3f eye(2.0f, -1.5f, 1.2f), target(0.1f, 0.3f, -0.4f);
  cam.look_at(eye, target);
  EXPECT_LT((cam.eye() - eye).norm(), 1e-5f * (eye - target).norm());
  EXPECT_EQ(cam.target, target);
  // The target is drawn at the viewport's centre; a point beside it, off the centre.
  float px = 0, py = 0;
  ASSERT_TRUE(cam.to_pixel(target, 800, 600, px, py));
  EXPECT_NEAR(px, 400, 1e-2);
  EXPECT_NEAR(py, 300, 1e-2);
  ASSERT_TRUE(cam.to_pixel(target + view::Vec3f(0, 0, 0.5f), 800, 600, px, py));
  EXPECT_LT(py, 290);  // z is up on screen
}

TEST(OrbitCamera, FramingPutsTheBoxInView) {
  view::OrbitCamera cam;
  const view::Vec3f lo(-1, -0.1f, 0), hi(3, 0.1f, 0.4f);
  for (const float aspect : {0.5f, 1.3f, 2.0f}) {
    cam.frame(lo, hi, aspect);
    const float h = 600, w = aspect * h;
    for (int c = 0; c < 8; ++c) {
      const view::Vec3f p((c & 1) ? hi.x() : lo.x(), (c & 2) ? hi.y() : lo.y(), (c & 4) ? hi.z() : lo.z());
      float px = 0, py = 0;
      ASSERT_TRUE(cam.to_pixel(p, w, h, px, py));
      EXPECT_GE(px, 0);
      EXPECT_LE(px, w);
      EXPECT_GE(py, 0);
      EXPECT_LE(py, h);
    }
  }
}

TEST(OrbitCamera, KeepInViewMovesJustEnoughAndOnlyWhenNeeded) {
  view::OrbitCamera cam;
  cam.target = view::Vec3f(0.2f, 0.1f, 0.0f);
  cam.distance = 1.5f, cam.yaw = 0.7f, cam.pitch = 0.3f;
  const float w = 1000, h = 600, zone = 0.6f;
  // Inside the middle 60 %: the camera stays.
  const view::Vec3f inside = cam.target + view::Vec3f(0.05f, 0.0f, 0.05f);
  EXPECT_FALSE(cam.keep_in_view(inside, w / h, zone));
  EXPECT_EQ(cam.target, view::Vec3f(0.2f, 0.1f, 0.0f));
  // A point gone far off to the side comes back to the zone's edge, not to the middle; the view's
  // direction and distance are kept.
  for (const view::Vec3f& away : {view::Vec3f(3.0f, -2.0f, 0.4f), view::Vec3f(0.2f, 0.1f, -4.0f)}) {
    const float yaw = cam.yaw, pitch = cam.pitch, distance = cam.distance;
    EXPECT_TRUE(cam.keep_in_view(away, w / h, zone));
    EXPECT_EQ(cam.yaw, yaw);
    EXPECT_EQ(cam.pitch, pitch);
    EXPECT_EQ(cam.distance, distance);
    float px = 0, py = 0;
    ASSERT_TRUE(cam.to_pixel(away, w, h, px, py));
    const float nx = std::abs(2 * px / w - 1), ny = std::abs(1 - 2 * py / h);
    EXPECT_NEAR(std::max(nx, ny), zone, 1e-4);  // on the edge
    EXPECT_LE(nx, zone + 1e-4f);
    EXPECT_LE(ny, zone + 1e-4f);
    EXPECT_FALSE(cam.keep_in_view(away, w / h, zone));  // and then left alone
  }
  // Behind the eye: aimed at.
  const view::Vec3f behind = cam.eye() - (cam.target - cam.eye());
  EXPECT_TRUE(cam.keep_in_view(behind, w / h, zone));
  EXPECT_EQ(cam.target, behind);
}

TEST(Colors, RangeRisesAtOnceAndDecaysSlowly) {
  view::AutoRange r;
  std::vector<double> v(100, 1.0);
  v[7] = 50;  // one outlier does not set the range
  r.see(v);
  EXPECT_DOUBLE_EQ(r.hi, 1.0);
  std::vector<double> zeros(100, 0.0);
  r.see(zeros);
  EXPECT_DOUBLE_EQ(r.hi, 0.97);
  EXPECT_EQ(view::diverging(5), view::diverging(1));  // clamped
  EXPECT_GT(view::diverging(1).x(), 0.7f);            // tension red
  EXPECT_GT(view::diverging(-1).z(), 0.7f);           // compression blue
}

TEST(Script, ParsesAndSortsEvents) {
  const auto ev = view::parse_script(R"({"events": [
      {"frame": 9, "release": true},
      {"frame": 2, "drag": {"quanta": 3, "by": [0, 0, 1]}},
      {"frame": 2, "push": {"quanta": 1, "force": [1, 2, 3]}},
      {"frame": 4, "key": "space"}]})", "s.json", 5);
  ASSERT_EQ(ev.size(), 4u);
  EXPECT_EQ(ev[0].kind, view::ScriptEvent::Kind::drag);
  EXPECT_EQ(ev[0].quanta, 3u);
  EXPECT_EQ(*ev[0].by, Vec3(0, 0, 1));
  EXPECT_EQ(ev[1].kind, view::ScriptEvent::Kind::push);
  EXPECT_EQ(ev[2].key, ' ');
  EXPECT_EQ(ev[3].frame, 9u);
}

TEST(Script, ErrorsNameThePathAndTheRule) {
  auto error = [](const char* text) {
    try {
      view::parse_script(text, "s.json", 5);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error(R"({"events": [{"frame": 1, "drag": {"quanta": 5, "by": [0, 0, 1]}}]})"),
            "s.json: events[0].drag.quanta: must be a quanta id in [0, 5)");
  EXPECT_EQ(error(R"({"events": [{"frame": 1}]})"),
            "s.json: events[0]: must have exactly one of 'drag', 'release', 'push', 'key', 'mouse'");
  EXPECT_EQ(error(R"({"events": [{"frame": -1, "release": true}]})"), "s.json: events[0].frame: must be an integer >= 0");
  EXPECT_EQ(error(R"({"events": [{"frame": 0, "push": {"quanta": 0, "force": [1, 2]}}]})"),
            "s.json: events[0].push.force: must be an array of 3 numbers");
  EXPECT_EQ(error(R"({"events": [{"frame": 0, "key": "q"}]})"),
            "s.json: events[0].key: must be one of \"space\", \".\", \"r\", \"h\", \"f\", got \"q\"");
  EXPECT_EQ(error(R"({"events": [{"frame": 0, "drag": {"quanta": 0, "to": [0, 0, 0], "by": [0, 0, 0]}}]})"),
            "s.json: events[0].drag: must have exactly one of 'to', 'by'");
  EXPECT_NE(error("{").find("not valid JSON"), std::string::npos);
  EXPECT_EQ(error("{}"), "s.json: missing 'events'");
  EXPECT_EQ(error(R"({"events": [{"frame": 0, "mouse": {"move_by": [1]}}]})"),
            "s.json: events[0].mouse.move_by: must be an array of 2 numbers (pixels)");
  EXPECT_EQ(error(R"({"events": [{"frame": 0, "mouse": {"press_on": 9}}]})"),
            "s.json: events[0].mouse.press_on: must be a quanta id in [0, 5)");
}

// The panel's menus are the integrator table's: every integrator by name in the table's order,
// and for each the solvers it takes, so that a menu entry never names an integrator by position.
TEST(Menus, ComeFromTheIntegratorTable) {
  const view::Menu<IntegratorType> menu = view::integrator_menu();
  const auto table = integrator_table();
  ASSERT_EQ(menu.names.size(), table.size());
  ASSERT_EQ(menu.labels().size(), table.size());
  for (std::size_t k = 0; k < table.size(); ++k) {
    EXPECT_EQ(menu.names[k], table[k].key);
    EXPECT_STREQ(menu.labels()[k], std::string(table[k].key).c_str());
    EXPECT_EQ(menu.values[k], table[k].type);
    EXPECT_EQ(menu.index(table[k].type), static_cast<int>(k));
    const view::Menu<CoupledSolver> solvers = view::solver_menu(table[k].type);
    ASSERT_EQ(solvers.values.size(), table[k].solvers.size()) << table[k].key;
    for (std::size_t s = 0; s < solvers.values.size(); ++s) {
      EXPECT_EQ(solvers.values[s], table[k].solvers[s]);
      EXPECT_EQ(solvers.names[s], to_string(table[k].solvers[s]));
    }
  }
  const view::Menu<NeighbourModel> models = view::neighbour_menu();
  ASSERT_EQ(models.values.size(), neighbour_models().size());
  for (std::size_t k = 0; k < models.values.size(); ++k) EXPECT_EQ(models.names[k], to_string(models.values[k]));
  const view::Menu<Preconditioner> preconditioners = view::preconditioner_menu();
  ASSERT_EQ(preconditioners.values.size(), qbond::preconditioners().size());
  for (std::size_t k = 0; k < preconditioners.values.size(); ++k)
    EXPECT_EQ(preconditioners.names[k], to_string(preconditioners.values[k]));
}

}  // namespace
}  // namespace qbond
