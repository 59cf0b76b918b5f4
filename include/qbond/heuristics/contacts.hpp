#pragma once
/// Collisions (docs/heuristics.md): static obstacles and quanta–quanta contact, acting on the projection
/// so that no quanta ends a step inside an obstacle or inside another quanta.
#include <memory>
#include <vector>

#include "qbond/heuristics/heuristics.hpp"
#include "qbond/model/obstacle.hpp"

namespace qbond {

/// Keeps the free quanta out of the obstacles. A step's path x → x + dx is tested against each
/// obstacle, so a fast quanta cannot pass through a thin one: it stops where it enters. The
/// energy the contact removes (restitution < 1, friction) is charged as dissipated. The momentum a
/// recorded obstacle gives (m Δv of each contact, in the order of the quanta) is summed into
/// State::obstacle_impulse.
std::unique_ptr<Heuristic> make_obstacle_heuristic(std::vector<Obstacle> obstacles);
/// The contact rule of one obstacle (make_obstacle_heuristic of it alone).
std::unique_ptr<Heuristic> make_heuristic(const Obstacle& obstacle);

/// Contact between quanta that share no bond by the projection rule (QuantaContactRule, obstacle.hpp).
std::unique_ptr<Heuristic> make_heuristic(QuantaContactRule rule);

}  // namespace qbond
