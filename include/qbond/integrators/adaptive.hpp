#pragma once
/// Adaptive timestep (docs/integrators.md; beyond the paper): error control that grows the step when it can
/// and shrinks it before a blow-up, plus an energy-drift criterion, for any integrator.
///
/// Error estimate. Every integrator projects Δx and Δv; the trapezoidal rule would have moved each
/// quanta by h (v + v₁)/2. Their difference
///     e_i = |Δx_i − h (v_i + (v_i + Δv_i)) / 2|
/// is an embedded estimate of the step's local position error: h Δv/2 for backward Euler (whose
/// local error is (h²/2) a), h² (a₀ − a₁)/4 for velocity Verlet; it needs no second solve. A step is
/// accepted when max_i e_i ≤ `error`; the next step is h · clamp(safety √(error / e), 0.2, 2)
/// (the estimate is O(h²) for the first-order schemes, hence the square root).
///
/// Energy drift. After a step, the energy the integrator itself created or destroyed (the energy
/// budget's `numerical` term, analysis.hpp) may change by at most
///     energy · E_scale · h / horizon,
/// so that over the horizon the drift stays below `energy` · E_scale (E_scale: the larger of |E(0)|
/// and the current kinetic + bond energy). A step that breaks it, or blows up, is undone (the
/// state is restored) and retried at a quarter of the step; at `min_step` the step is taken anyway
/// and a blow-up is reported as such.
#include <functional>
#include <span>

#include "qbond/simulation/simulation.hpp"

namespace qbond {

struct AdaptiveConfig {
  bool enabled = false;
  double error = 1e-6;      ///< largest local position error per step [m]
  double energy = 1e-2;     ///< largest relative energy drift over `horizon`
  double min_step = 1e-8;   ///< [s]
  double max_step = 0;      ///< [s]; 0: no limit
  double safety = 0.9;      ///< factor on the predicted step
  double horizon = 1;       ///< [s] the run's length, over which the energy budget is spread
};

/// What one adaptive step did.
struct AdaptiveReport {
  StepReport step;          ///< of the accepted step (blow-up only at min_step)
  double h = 0;             ///< the step taken [s]
  double error = 0;         ///< its error estimate [m]
  int rejected = 0;         ///< tries undone before it
};

/// The adaptive controller's arithmetic, shared by adaptive_step and a run over MPI ranks: the
/// length of each try, the error and energy tests, and the step proposed after an accepted try.
class AdaptiveController {
 public:
  /// `proposal`: the step the last accepted one proposed (or the scene's timestep) [s].
  AdaptiveController(const AdaptiveConfig& config, double proposal);
  /// One try: its length (at most what is left to t_end), whether it reaches t_end, and whether
  /// it is at min_step (taken whatever its error, a blow-up then reported as such).
  struct Try {
    double step = 0;
    bool last = false, at_min = false;
  };
  /// The next try from time t.
  Try next_try(double t, double t_end) const;
  /// Whether try `t` with error estimate e is rejected before the step is finished: e > error
  /// and not at min_step; the next try is then h · clamp(safety √(error / e), 0.2, 0.9).
  bool rejects_error(const Try& t, double e);
  /// Whether the integrator's energy drift over try `t` (the change of the budget's `numerical`)
  /// breaks energy · scale · h / horizon.
  bool drifts(const Try& t, double numerical_change, double scale) const;
  /// Try `t` finished and undone (a blow-up or the energy drift): the next try is a quarter of it.
  void reject_undone(const Try& t);
  /// The step proposed after try `t` was accepted with error e: grown by at most 2 (not at all
  /// after a rejection), from the step the error allowed rather than from a short last step.
  double next_proposal(const Try& t, double e) const;
  int rejected() const { return rejected_; }

 private:
  const AdaptiveConfig& cfg_;
  double max_step_;
  double h_;
  int rejected_ = 0;
};

/// Takes one accepted step of at most t_end − t, starting from sim.timestep() (the proposal the
/// last call left there), and leaves the next proposal in sim.timestep(); a step that reaches
/// t_end ends exactly there. One-step forces (Simulation::add_force, e.g. a viewer's drag) must be
/// queued by `forces`, which is called before every try: a retry needs them again.
AdaptiveReport adaptive_step(Simulation& sim, const AdaptiveConfig& config, double t_end,
                             const std::function<void()>& forces = {});

/// The embedded error estimate max_i |Δx_i − h (2 v_i + Δv_i)/2| over free quanta [m].
double step_error(const Model& model, const State& state, const Projection& p, double h);
/// The same over the free quanta of `quanta` alone (a run over ranks: a rank's own) [m].
double step_error(const Model& model, const State& state, const Projection& p, double h,
                  std::span<const Index> quanta);

}  // namespace qbond
