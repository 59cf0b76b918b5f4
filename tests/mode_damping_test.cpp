// The measurement behind docs/integrators.md's table of modal damping (bench/mode_damping.hpp):
// on a single linear spring the default integrator is backward Euler on one linear mode, whose
// amplification per step is |1 / (1 + iωh)| exactly; the measured value must be that, at every
// step the table uses.
#include "mode_damping.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "test_util.hpp"

namespace qbond {
namespace {

TEST(ModeDamping, SingleSpringMatchesBackwardEulerExactly) {
  const double m = 1e-3, k = 1000;
  const World spring = test::two_quanta(m, k, 0.01, 0, 0);
  const std::vector<bench::VibrationMode> modes = bench::vibration_modes(spring, 3);
  ASSERT_EQ(modes.size(), 1u);  // the axial mode; translations and rotations have ω = 0
  EXPECT_NEAR(modes[0].omega, std::sqrt(2 * k / m), 1e-9 * std::sqrt(2 * k / m));
  IntegratorConfig cfg = default_integrator();
  cfg.threads = 1;
  for (double h : {1e-4, 1e-3, 1.0 / 60}) {
    SCOPED_TRACE(h);
    const bench::ModeDamping d = bench::measure_mode_damping(spring, cfg, h, modes[0], 1e-8, 3);
    ASSERT_TRUE(d.stable);
    EXPECT_GE(d.steps, 1);
    // Linear to the amplitude's relative size (1e-6 of the length: geometric terms ~1e-6 of the
    // force) and CG converged to 1e-6 (its error a step is that relative to Δv, which is ωh of the
    // state): 1e-5 relative bounds both with room.
    EXPECT_NEAR(d.amplification, d.backward_euler_amplification(), 1e-5 * d.backward_euler_amplification());
    EXPECT_NEAR(d.damping_ratio(), d.backward_euler_damping_ratio(),
                1e-4 * d.backward_euler_damping_ratio() + 1e-9);
  }
}

TEST(ModeDamping, VelocityVerletKeepsASpringsEnergyAtSmallSteps) {
  // The measurement tells a non-dissipative integrator apart: symplectic velocity Verlet keeps a
  // mode's energy to O((ωh)²) over whole periods, far from backward Euler's loss.
  const World spring = test::two_quanta(1e-3, 1000, 0.01, 0, 0);
  const bench::VibrationMode mode = bench::vibration_modes(spring, 1).at(0);
  IntegratorConfig cfg;
  cfg.type = IntegratorType::velocity_verlet;
  cfg.threads = 1;
  const double h = 1e-4;  // ωh ≈ 0.14
  const bench::ModeDamping d = bench::measure_mode_damping(spring, cfg, h, mode, 1e-8, 3);
  ASSERT_TRUE(d.stable);
  const double wh = mode.omega * h;
  EXPECT_NEAR(std::pow(d.amplification, 2 * d.steps), 1.0, wh * wh);
  EXPECT_LT(d.backward_euler_amplification(), 1 - wh * wh / 4);
}

}  // namespace
}  // namespace qbond
