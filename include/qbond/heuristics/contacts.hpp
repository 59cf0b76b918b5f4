#pragma once
/// Collisions (docs/heuristics.md): static obstacles and quanta–quanta contact, acting on the projection
/// so that no quanta ends a step inside an obstacle or inside another quanta.
#include <memory>
#include <vector>

#include "qbond/heuristics/heuristics.hpp"

namespace qbond {

/// Restitution and Coulomb friction of a contact. A quanta that arrives at a surface with
/// normal speed v_n (at the start of the step) leaves it with e |v_n|; pressed into it by the
/// step's forces it stops (no bounce); its tangential velocity loses at most μ |Δv_n| (it stops
/// sliding when that is enough).
struct ContactMaterial {
  double restitution = 0;  ///< e in [0, 1]
  double friction = 0;     ///< μ ≥ 0
};

/// A static obstacle. Quanta are kept `margin` away from its surface (their radius): outside a
/// sphere or box, or, for a container (`inside`), inside it.
struct Obstacle {
  enum class Shape : std::uint8_t { plane, sphere, box };
  Shape shape = Shape::plane;
  Vec3 center = Vec3::Zero();        ///< plane: a point on it; sphere, box: the centre [m]
  Vec3 normal = Vec3::UnitZ();       ///< plane: unit normal pointing to the free side
  double radius = 0;                 ///< sphere [m]
  Vec3 half_extents = Vec3::Zero();  ///< box, in its own axes [m]
  Mat3 rotation = Mat3::Identity();  ///< box: world-from-box rotation
  double margin = 0;                 ///< [m]
  ContactMaterial material;
  /// sphere, box: a container that keeps the quanta inside (a gas's box) instead of out.
  bool inside = false;
  /// Index into State::obstacle_impulse where the impulse the obstacle gives is summed (its
  /// wall pressure); -1: not recorded. Scenes number their obstacles 0, 1, ... in order.
  std::int32_t record = -1;

  /// Signed distance of p from the surface, positive on the free side (outside, or inside a
  /// container) [m], and the unit normal of the nearest surface point pointing to the free side.
  double distance(const Vec3& p, Vec3& normal) const;
  /// Area of the surface the centres of quanta `margin` away touch [m²] (the wall area of a
  /// container's pressure); infinite for a plane.
  double contact_area() const;
  /// Volume the centres of quanta may reach inside a container [m³] (the gas's V); 0 otherwise.
  double contact_volume() const;
};

/// Keeps the free quanta out of the obstacles. A step's path x → x + dx is tested against each
/// obstacle, so a fast quanta cannot pass through a thin one: it stops where it enters. The
/// energy the contact removes (restitution < 1, friction) is charged as dissipated. The momentum a
/// recorded obstacle gives (m Δv of each contact, in the order of the quanta) is summed into
/// State::obstacle_impulse.
std::unique_ptr<Heuristic> make_obstacle_heuristic(std::vector<Obstacle> obstacles);

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
std::unique_ptr<Heuristic> make_quanta_contact_heuristic(QuantaContactRule rule);

}  // namespace qbond
