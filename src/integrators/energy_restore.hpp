#pragma once
// Energy restoration (IntegratorConfig::restore_energy; docs/integrators.md): a velocity
// correction applied after a step that changes the kinetic energy by a given amount while keeping
// every free component's linear and angular momentum.
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "qbond/model/world.hpp"

namespace qbond {

/// The free quanta's components (joined by alive bonds), numbered in the order of their smallest
/// quanta: each quanta's component (kNone for kinematic quanta), and whether each component has a
/// bond to a kinematic quanta.
struct MotionComponents {
  std::vector<Index> of;
  std::vector<std::uint8_t> anchored;
};
MotionComponents motion_components(const Model& model, const Adjacency& adj);

/// What scale_internal_velocities did: the scale λ and the internal kinetic energy K_u it scaled;
/// the kinetic energy changed by (λ² − 1) K_u.
struct InternalScaling {
  double lambda = 1;
  double internal_kinetic = 0;
};

/// A component with no bond to a kinematic quanta has its velocities written
/// v = v_cm + ω × (x − x_cm) + u, with ω from I ω = L about the centre of mass, so that Σ m u = 0
/// and Σ m (x − x_cm) × u = 0 and the kinetic energy splits into a rigid part and K_u = ½ Σ m |u|²;
/// an anchored component's u is its whole velocity (anchors exchange momentum anyway). Scales
/// every u by one λ ≥ 0 with
///     λ² = 1 + ΔK / Σ K_u,   clamped to [0, 100] (λ ≤ 10: a deficit over 99 times the internal
/// kinetic energy, as at a turning point where the energy is all potential, is only partly given
/// back),
/// so the kinetic energy changes by ΔK when the clamp does not bind. Momenta of free components are
/// unchanged (to round-off).
///
/// For a world held in parts (ranks): `quanta` are the free quanta this part holds (indices into
/// model and state), `component` each one's component of `anchored`; `add` adds its argument's
/// sums over every part in place (the same on every part), called three times.
InternalScaling scale_internal_velocities(const Model& model, std::span<const Index> quanta,
                                          std::span<const Index> component, std::span<const std::uint8_t> anchored,
                                          State& state, double delta_kinetic,
                                          const std::function<void(std::span<double>)>& add);

/// The same over a whole world: every free quanta, its components from adj. Returns λ (1 when
/// there is no internal motion to scale).
double scale_internal_velocities(const Model& model, const Adjacency& adj, State& state, double delta_kinetic);

}  // namespace qbond
