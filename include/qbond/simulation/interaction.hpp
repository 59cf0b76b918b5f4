#pragma once
/// Interaction (docs/viewer.md, "The mouse spring"): a spring that pulls one quanta toward
/// a point, as a viewer's mouse drag does. Its force reaches the step through
/// Simulation::add_force, the same path as the scene's loads.
#include "qbond/model/world.hpp"

namespace qbond {

/// A damped spring from quanta `quanta` to the point `target`:
///     f = k (target − x) − c v
/// k and c are chosen from the mass M the pull has to move and a frequency f₀, so that it feels
/// the same on light and heavy structures: k = M (2π f₀)², c = 2 ζ √(k M) (ζ = 1: critically
/// damped for M alone). The force is explicit (fixed over a step), so both are capped for the
/// pulled quanta's own mass m at step h: k ≤ m / h² (hω ≤ 1) and c ≤ m / (2h).
struct PullSpring {
  Index quanta = 0;
  Vec3 target = Vec3::Zero();  ///< [m]
  double stiffness = 0;        ///< k [N/m]
  double damping = 0;          ///< c [N·s/m]

  /// The spring's force on the quanta at the state's position and velocity [N].
  Vec3 force(const State& state) const { return stiffness * (target - state.x[quanta]) - damping * state.v[quanta]; }
};

/// A pull spring on quanta i (see PullSpring) for a body of mass `mass` [kg] at frequency
/// `frequency` [Hz] and damping ratio `zeta`, capped for timestep h [s].
PullSpring make_pull_spring(const Model& model, Index i, const Vec3& target, double mass, double h,
                            double frequency = 4.0, double zeta = 1.0);

/// Total mass of the body quanta i belongs to [kg] (the mass a pull on i has to move).
double body_mass(const Model& model, Index i);

}  // namespace qbond
