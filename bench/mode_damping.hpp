#pragma once
// The numerical damping an integrator puts on a structure's vibration modes, measured from a run
// (docs/integrators.md, "Accuracy at frame-sized steps"): the structure is started at rest in one
// mode's shape, and the mode's energy after N steps gives the amplification per step,
// |λ| = (E_N / E_0)^(1/(2N)), and the damping ratio ζ = −ln|λ| / (ω h). Backward Euler's, for an
// undamped linear mode, is |λ| = |1 / (1 + iωh)| = (1 + ω²h²)^(−1/2).
#include <Eigen/Dense>
#include <vector>

#include "qbond/integrators/integrators.hpp"
#include "qbond/model/world.hpp"

namespace qbond::bench {

/// An undamped vibration mode about the rest state: K φ = ω² M φ over the free unknowns (3 a free
/// quanta, in the free quanta's order), φ M-normalised (φᵀ M φ = 1).
struct VibrationMode {
  double omega = 0;  ///< [rad/s]
  Eigen::VectorXd shape;
};

/// The `count` lowest modes with ω > 0 (rigid-body modes, ω ≈ 0, skipped) of `world` at rest
/// (its positions; bond damping ignored), from the stiffness the implicit step assembles (dense:
/// for small structures).
std::vector<VibrationMode> vibration_modes(const World& world, int count);

/// One mode's measured damping by one integrator at one step.
struct ModeDamping {
  double omega = 0, h = 0;
  int steps = 0;                 ///< steps measured over
  double amplification = 0;      ///< measured |λ| per step (> 1: the mode grows)
  bool stable = true;            ///< false: the run blew up or the mode's energy grew a millionfold
  double damping_ratio() const;  ///< −ln|λ| / (ω h)
  double backward_euler_amplification() const;  ///< (1 + ω²h²)^(−1/2)
  double backward_euler_damping_ratio() const;  ///< ln(1 + ω²h²) / (2 ω h)
};

/// Starts `world` (at rest, bond damping and gravity as given) displaced by `amplitude` [m] at
/// most along `mode`, runs it with `config` at step h for `periods` of the mode (at least one
/// step; stopped early once the mode keeps less than 1e-12 of its energy), and measures the
/// amplification from the mode's energy ½(q̇² + ω² q²), q = φᵀ M (x − x_rest).
ModeDamping measure_mode_damping(const World& world, const IntegratorConfig& config, double h,
                                 const VibrationMode& mode, double amplitude, double periods);

}  // namespace qbond::bench
