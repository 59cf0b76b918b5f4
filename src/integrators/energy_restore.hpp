#pragma once
// Energy restoration (IntegratorConfig::restore_energy; docs/integrators.md): a velocity
// correction applied after a step that changes the kinetic energy by a given amount while keeping
// every free component's linear and angular momentum.
#include "qbond/model/world.hpp"

namespace qbond {

// Splits the free quanta into components (joined by alive bonds). A component with no bond to a
// kinematic quanta has its velocities written v = v_cm + ω × (x − x_cm) + u, with ω from
// I ω = L about the centre of mass, so that Σ m u = 0 and Σ m (x − x_cm) × u = 0 and the kinetic
// energy splits into a rigid part and K_u = ½ Σ m |u|²; an anchored component's u is its whole
// velocity (anchors exchange momentum anyway). Scales every u by one λ ≥ 0 with
//     λ² = 1 + ΔK / Σ K_u,   clamped to [0, 100] (λ ≤ 10: a deficit over 99 times the internal
// kinetic energy, as at a turning point where the energy is all potential, is only partly given back),
// so the kinetic energy changes by ΔK when the clamp does not bind. Momenta of free components are
// unchanged (to round-off). Returns λ (1 when there is no internal motion to scale).
double scale_internal_velocities(const Model& model, const Adjacency& adj, State& state, double delta_kinetic);

}  // namespace qbond
