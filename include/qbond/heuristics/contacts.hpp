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

/// Contact between quanta that share no bond: spheres of `radius`, found with a uniform-grid
/// spatial hash (cost linear in the quanta), including quanta of the same body (self-collision).
/// Overlaps in the projected positions are pushed apart along the line of centres in inverse-mass
/// proportion (the centre of mass does not move), approaching pairs exchange equal and opposite
/// impulses (restitution, Coulomb friction): linear momentum is conserved exactly.
struct QuantaContactRule {
  double radius = 0;       ///< [m] contact radius of every quanta
  ContactMaterial material;
  int iterations = 4;      ///< Gauss–Seidel passes over the contacts (stacks need several)
  bool same_body = true;   ///< whether quanta of one body collide with each other
};
std::unique_ptr<Heuristic> make_heuristic(QuantaContactRule rule);

}  // namespace qbond
