// Blow-ups: detected, reported the same on any thread count, and leaving the last good state
// (the paper's central claim, implicit steps staying stable where explicit ones blow up, is in
// stiff_lattice_test.cpp).
#include <gtest/gtest.h>

#include <cstring>
#include <string>

#include "test_util.hpp"

namespace qbond {
namespace {

TEST(Stability, BlowupKeepsTheLastGoodState) {
  // Explicit Euler at h ω = 100: the step that would go non-finite or too fast is refused.
  Simulation sim(test::lattice(3, 3, 3, 1000, 1e-3, 0.0, false), test::config(IntegratorType::explicit_euler), 0.1);
  test::perturb(sim.world(), 1e-4, 0.0);
  sim.limits().energy_growth = 1e300;  // leave it to the projection check
  StepReport r;
  for (int n = 0; n < 10000 && r.status == StepReport::Status::ok; ++n) r = sim.step();
  ASSERT_EQ(r.status, StepReport::Status::blowup);
  for (const Vec3& v : sim.world().state.v) EXPECT_TRUE(v.allFinite());
  EXPECT_NE(r.message.find("quanta"), std::string::npos);
}

// The projection check on its own: a free quanta faster than the limit, or a position or velocity
// that would go non-finite, stops the step and leaves the world as it was; a prescribed quanta
// may move faster than the limit.
TEST(Stability, ProjectionCheckStopsTooFastAndNonFiniteSteps) {
  auto world = [](Vec3 x_free, Vec3 v_free) {
    World w;
    w.add_quanta(x_free, v_free, 1.0);
    const Index k = w.add_quanta(Vec3(1, 0, 0), Vec3::Zero(), 1.0);
    Motion fast;
    fast.type = MotionType::translate;
    fast.velocity = Vec3(5, 0, 0);
    w.prescribe({k}, fast);
    return w;
  };
  auto first_step = [](World w) {
    Simulation sim(w, test::config(IntegratorType::symplectic_euler), 0.01);
    sim.limits().max_speed = 2;
    sim.limits().energy_growth = 1e300;  // leave it to the projection check
    const StepReport r = sim.step();
    if (r.status != StepReport::Status::ok) {
      EXPECT_EQ(std::memcmp(sim.world().state.x.data(), w.state.x.data(), 2 * sizeof(Vec3)), 0);
      EXPECT_EQ(sim.world().state.step, 0u);
    }
    return r;
  };
  EXPECT_EQ(first_step(world(Vec3::Zero(), Vec3(1.9, 0, 0))).status, StepReport::Status::ok);
  const StepReport fast = first_step(world(Vec3::Zero(), Vec3(0, 2.1, 0)));
  EXPECT_EQ(fast.status, StepReport::Status::blowup);
  EXPECT_EQ(fast.worst, 0u);
  const StepReport nan = first_step(world(Vec3(0, std::nan(""), 0), Vec3::Zero()));
  EXPECT_EQ(nan.status, StepReport::Status::blowup);
  EXPECT_NE(nan.message.find("non-finite"), std::string::npos) << nan.message;
}

// The projection check is a reduction over chunks of quanta: any thread count names the same
// quanta (the fastest free one, the first of equals) at the same step. 20³ quanta, so the chunks
// really run on several threads.
TEST(Stability, BlowupReportIsTheSameOnAnyThreadCount) {
  auto first_blowup = [](int threads) {
    IntegratorConfig c = test::config(IntegratorType::explicit_euler);
    c.threads = threads;
    Simulation sim(test::lattice(20, 20, 20, 1000, 1e-3, 0.0, false), c, 0.02);
    test::perturb(sim.world(), 1e-4, 0.0);
    sim.limits().energy_growth = 1e300;  // leave it to the projection check
    StepReport r;
    for (int n = 0; n < 1000 && r.status == StepReport::Status::ok; ++n) r = sim.step();
    return r;
  };
  const StepReport one = first_blowup(1);
  ASSERT_EQ(one.status, StepReport::Status::blowup);
  for (int threads : {2, 3}) {
    const StepReport many = first_blowup(threads);
    EXPECT_EQ(many.message, one.message) << threads << " threads";
    EXPECT_EQ(many.worst, one.worst) << threads << " threads";
  }
}

TEST(Stability, FirstExplicitStepFromRestIsNotABlowup) {
  // Gravity gives velocity before it moves anything: the first step stores kinetic energy while
  // gravity has done no work yet. That is not a runaway.
  for (auto t : {IntegratorType::explicit_euler, IntegratorType::symplectic_euler}) {
    Simulation sim(test::lattice(3, 3, 3, 1000, 1e-3, 0.01, true, Vec3(0, 0, -9.81)), test::config(t), 1e-5);
    for (int n = 0; n < 100; ++n) ASSERT_EQ(sim.step().status, StepReport::Status::ok) << to_string(t) << " step " << n;
  }
}

}  // namespace
}  // namespace qbond
