#pragma once
/// Static obstacles (ground, planes, spheres, boxes), quanta–quanta contact and their contact materials: kept apart from
/// the quanta by the post-projection contact rule (heuristics/contacts.hpp) or inside the
/// implicit step's solve (docs/heuristics.md).
#include <cstdint>

#include "qbond/core/math.hpp"

namespace qbond {

/// Restitution and Coulomb friction of a contact. A quanta that arrives at a surface with
/// normal speed v_n (at the start of the step) leaves it with e |v_n|; pressed into it by the
/// step's forces it stops (no bounce); its tangential velocity loses at most μ |Δv_n| (it stops
/// sliding when that is enough).
struct ContactMaterial {
  double restitution = 0;  ///< e in [0, 1]
  double friction = 0;     ///< kinetic μ_k ≥ 0
  /// Static μ_s ≥ μ_k: a contact in the step's solve sticks while its tangential force stays
  /// within μ_s times its normal force (negative: equal to `friction`).
  double static_friction = -1;

  /// μ_s, `friction` when no static coefficient was given.
  double static_coefficient() const { return static_friction >= 0 ? static_friction : friction; }
  bool operator==(const ContactMaterial&) const = default;
};

/// How an obstacle keeps the quanta out.
enum class ContactMethod : std::uint8_t {
  projection,  ///< edits the projected step afterwards (the `contacts` heuristic)
  implicit,    ///< penalty springs inside the implicit step's linear solve (coupled_implicit)
  penalty,     ///< penalty forces evaluated with the bond forces (the explicit integrators)
};

/// The penalty κ of a contact held by ContactMethod::penalty unless the scene gives one, and the
/// largest it takes: the contact spring's ω h = √κ stays within the stability limits of velocity
/// Verlet, symplectic Euler and RK4.
inline constexpr double kPenaltyForceDefault = 0.01;
inline constexpr double kPenaltyForceMost = 1;

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
  ContactMethod method = ContactMethod::projection;
  /// implicit, penalty: the penalty spring's stiffness as κ in k = κ m / h² (m the quanta's mass,
  /// h the step). implicit: the solve's contact block h² k = κ m outweighs the quanta's inertia;
  /// penalty: κ ≤ kPenaltyForceMost keeps the explicit step stable.
  double penalty = 1000;

  /// Signed distance of p from the surface, positive on the free side (outside, or inside a
  /// container) [m], and the unit normal of the nearest surface point pointing to the free side.
  double distance(const Vec3& p, Vec3& normal) const;
  /// Area of the surface the centres of quanta `margin` away touch [m²] (the wall area of a
  /// container's pressure); infinite for a plane.
  double contact_area() const;
  /// Volume the centres of quanta may reach inside a container [m³] (the gas's V); 0 otherwise.
  double contact_volume() const;
  /// Smallest t in [0, 1] at which the path a + t (b − a) enters the obstacle grown by its margin
  /// (leaves a container shrunk by it), given that a is on the free side; negative when it does not.
  double entry(const Vec3& a, const Vec3& b) const;

  bool operator==(const Obstacle&) const = default;
};

/// Contact between quanta that share no bond: spheres of `radius`, found with a uniform-grid
/// spatial hash (cost linear in the quanta), including quanta of the same body (self-collision).
/// By projection: overlaps in the projected positions are pushed apart along the line of centres in inverse-mass
/// proportion (the centre of mass does not move), approaching pairs exchange equal and opposite
/// impulses (restitution, Coulomb friction): linear momentum is conserved exactly.
struct QuantaContactRule {
  double radius = 0;       ///< [m] contact radius of every quanta
  ContactMaterial material;
  int iterations = 4;      ///< Gauss–Seidel passes over the contacts (stacks need several)
  bool same_body = true;   ///< whether quanta of one body collide with each other
  /// projection: the heuristic edits the projected step; implicit: each touching pair is a penalty
  /// spring inside coupled_implicit's solve (Model::quanta_contact); penalty: a penalty force of
  /// the explicit integrators (Model::quanta_contact).
  ContactMethod method = ContactMethod::projection;
  /// implicit, penalty: κ in the pair's spring k = κ μ / h² (μ the pair's reduced mass), as Obstacle::penalty.
  double penalty = 1000;

  bool operator==(const QuantaContactRule&) const = default;
};

}  // namespace qbond
