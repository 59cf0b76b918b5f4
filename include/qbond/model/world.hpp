#pragma once
/// The world: quanta and bonds as structure of arrays, split into what a step only
/// reads (`Model`) and what it changes (`State`, exactly what a checkpoint saves).
#include <limits>
#include <string>
#include <vector>

#include "qbond/integrators/carry.hpp"
#include "qbond/model/bonds.hpp"
#include "qbond/model/obstacle.hpp"
#include "qbond/laws/laws.hpp"
#include "qbond/core/line_vector.hpp"
#include "qbond/core/math.hpp"
#include "qbond/core/rng.hpp"

namespace qbond {

/// Prescribed motion of kinematic quanta (inverse mass 0).
enum class MotionType : std::uint8_t {
  fixed,      ///< stays at its reference position
  translate,  ///< x(t) = x0 + velocity (t - t0)
  rotate,     ///< x(t) = center + R(axis, rate (t - t0)) (x0 - center)
  keyframes,  ///< x(t) = center + R(axis, θ(t - t0)) (x0 - center) + u(t - t0), θ and u
              ///< interpolated between keyframes (Keyframe), held after the last
};

/// One pose of a keyframed motion: at `time` after the motion's start, the quanta stand rotated
/// by `angle` about the motion's axis through its center, then shifted by `offset`. The start
/// (time 0, no offset, no angle) is implicit.
struct Keyframe {
  double time = 0;             ///< [s] after the motion's start; increasing from one to the next
  Vec3 offset = Vec3::Zero();  ///< [m]
  double angle = 0;            ///< [rad], right-handed about the axis

  bool operator==(const Keyframe&) const = default;
};

/// How a keyframed motion goes from one pose to the next, with s the fraction of the interval:
/// linear, w(s) = s (constant velocity in each interval), or smooth, w(s) = 3s² − 2s³ (velocity
/// 0 at every keyframe, so that starts and holds do not jerk).
enum class Interpolation : std::uint8_t { linear, smooth };

/// A prescribed motion shared by a selection of kinematic quanta.
struct Motion {
  MotionType type = MotionType::fixed;
  Vec3 velocity = Vec3::Zero();  ///< translate: [m/s]
  Vec3 axis = Vec3::UnitZ();     ///< rotate: unit axis
  Vec3 center = Vec3::Zero();    ///< rotate: a point on the axis [m]
  double rate = 0;               ///< rotate: angular rate [rad/s], right-handed about `axis`
  std::vector<Keyframe> keyframes;                      ///< keyframes: the poses after the start, by time
  Interpolation interpolation = Interpolation::linear;  ///< keyframes
  double t0 = 0;                 ///< time at which quanta sat at their reference positions [s]
  std::vector<Index> quanta;     ///< quanta that follow this motion
  std::vector<Vec3> x0;          ///< their reference positions [m] (same length as `quanta`)

  bool operator==(const Motion&) const = default;

  /// Position and velocity at time t of the k-th quanta of this motion.
  void at(std::size_t k, double t, Vec3& x, Vec3& v) const;
};

/// A constant total force spread evenly over a selection of quanta.
struct Load {
  std::vector<Index> quanta;
  Vec3 force = Vec3::Zero();  ///< total force [N]
  /// The entries the force is shared among; 0: quanta.size(). A rank's piece of a load holds
  /// only its own quanta of the selection, each with the whole load's share.
  std::size_t entries = 0;

  /// The force on each entry of `quanta`: force / entries.
  Vec3 share() const { return force / static_cast<double>(entries > 0 ? entries : quanta.size()); }

  bool operator==(const Load&) const = default;
};

/// Everything a step only reads: masses, the bonds' table of law shapes, gravity, loads,
/// prescribed motions. Built with the world, then const for the whole run.
struct Model {
  // quanta (n)
  std::vector<double> mass;      ///< [kg] (n)
  std::vector<double> inv_mass;  ///< [1/kg] (n); 0 = kinematic (anchored or prescribed)
  std::vector<Index> body;       ///< body id (n)
  std::vector<double> volume;    ///< volume the quanta stands for [m³] (n); 0 = unknown, then
                                 ///< it has no stress (stress.hpp). Builders set it.
  std::vector<Index> quanta_id;  ///< the user's id of each quanta (n): creation order, kept when
                                 ///< the world is renumbered for locality (ordering.hpp)
  std::vector<std::string> body_names;  ///< (bodies)
  /// The table of the bonds' law shape parameters (Bonds::shape indexes it), shared by the bonds
  /// of one material as LAMMPS's bond types share their coefficients. Every row a run can use is
  /// added while the world is built (add_bond, a formation rule's Heuristic::bind), so a step
  /// never writes the Model.
  std::vector<LawShape> shapes;
  // environment
  Vec3 gravity = Vec3::Zero();    ///< [m/s²]
  std::vector<Load> loads;
  std::vector<Motion> motions;
  /// Obstacles the step keeps the quanta out of, all of one method: inside coupled_implicit's solve
  /// (ContactMethod::implicit) or as penalty forces of the explicit integrators
  /// (ContactMethod::penalty). The post-projection ones are heuristics.
  std::vector<Obstacle> obstacles;
  /// Quanta–quanta contact the step holds, by the obstacles' method; radius 0: none. The
  /// post-projection rule is a heuristic.
  QuantaContactRule quanta_contact;

  /// Whether the step holds contacts (obstacles or quanta–quanta).
  bool solves_contact() const { return !obstacles.empty() || quanta_contact.radius > 0; }
  /// How the step holds them (implicit or penalty); projection when it holds none.
  ContactMethod step_contact_method() const {
    if (!obstacles.empty()) return obstacles.front().method;
    return quanta_contact.radius > 0 ? quanta_contact.method : ContactMethod::projection;
  }

  std::size_t num_quanta() const { return mass.size(); }
  bool is_kinematic(Index i) const { return inv_mass[i] == 0.0; }
  /// The row of `shapes` holding `shape`, added when there is none yet.
  std::uint32_t intern_shape(const LawShape& shape);

  bool operator==(const Model&) const = default;  ///< field by field (tests)
};

/// Running energy accounts (docs/integrators.md); with the current energies they close the budget
/// E(t) + contact_stored - E(0) = work_loads + work_anchors - dissipated_damping
///               - dissipated_heuristics - dissipated_contact - numerical_damping
///               - (numerical dissipation), see analysis.hpp.
struct EnergyLedger {
  double initial_total = 0;         ///< E(0) = kinetic + bond + gravity potential [J]
  double initial_gravity = 0;       ///< gravity potential at t = 0 [J]
  double initial_time = 0;          ///< time at which the accounts were opened [s]
  double work_loads = 0;            ///< work of loads and user forces on free quanta [J]
  double work_anchors = 0;          ///< work done on the structure by prescribed quanta [J]
  double dissipated_damping = 0;    ///< energy removed by bond dampers [J]
  double dissipated_heuristics = 0; ///< energy removed by heuristics (plastic work, contacts) and fracture [J]
  bool initialised = false;
  /// Energy the contacts inside the step's solve removed (restitution < 1, friction, the penalty
  /// springs' own damping) [J]
  double dissipated_contact = 0;
  /// Energy the solve's contact penalty springs hold at the current state, Σ ½ k δ² [J]
  double contact_stored = 0;
  /// Backward Euler's own numerical damping, in closed form for each linearised step
  /// (coupled_implicit; 0 for the other integrators): ½ Δvᵀ M Δv + ½ Δxᵀ K Δx less the contacts'
  /// share ½ Σ J·Δv, summed over the steps [J]
  double numerical_damping = 0;

  bool operator==(const EnergyLedger&) const = default;
};

/// The impulse an obstacle has given the quanta since the world was built: its contacts' momentum
/// changes, summed (contacts.hpp). The normal part over the time and the wall's area is the
/// pressure on it (docs/gases.md).
struct ObstacleImpulse {
  Vec3 total = Vec3::Zero();  ///< Σ m Δv over its contacts [N·s]
  double normal = 0;          ///< Σ m Δv · n, n the surface normal toward the free side [N·s]

  bool operator==(const ObstacleImpulse&) const = default;
};

/// Everything a step changes; a checkpoint of this continues a run bit for bit.
struct State {
  std::vector<Vec3> x;           ///< position [m] (n)
  std::vector<Vec3> v;           ///< velocity [m/s] (n)
  /// The bonds: ends, laws, rest lengths, alive. Code that only reads them, and plasticity's
  /// rest lengths, use the arrays; bonds appear, break or change law through the mutators below.
  Bonds bonds;
  double time = 0;               ///< [s]
  std::uint64_t step = 0;
  Rng rng;
  EnergyLedger energy;
  /// What the integrator carries from one step to the next (carry.hpp): the last solver
  /// solutions, BDF2's previous state or velocity Verlet's last bond forces. Kept here so that
  /// checkpoints and rollbacks carry it; after editing bond parameters by hand, call
  /// drop_after_bond_edit on it.
  Carry carry;
  /// Per recorded obstacle (Obstacle::record), the impulse it has given (n_obstacles).
  std::vector<ObstacleImpulse> obstacle_impulse;

  /// Changes whenever bonds appear, break or change ends, law or damping model: what was derived
  /// from the bonds (adjacency, bond partitions) is rebuilt when it differs. Only the mutators
  /// below change it.
  std::uint64_t topology_version() const { return topology_version_; }
  /// Appends a bond of the scene between quanta i and j with rest length (and rest0) L.
  Index add_bond(Index i, Index j, const BondLaw& law, double L);
  /// Marks bond b broken at the current time (nothing when it is already).
  void break_bond(Index b);
  /// Makes a bond during the run (formation): rest length and rest0 L, made at the current time,
  /// in formed slot `slot` (a broken one to reuse) or appended when slot == bonds.size().
  Index form_bond(Index i, Index j, const BondLaw& law, double L, Index slot);
  /// The bonds for an edit of their ends, laws or damping models by hand (or a renumbering):
  /// changes the topology version. Edits of strengths or rest lengths need no call (they are read
  /// every step), but a carry-over may not hold after them (drop_after_bond_edit).
  Bonds& edit_bonds() {
    ++topology_version_;
    return bonds;
  }

 private:
  std::uint64_t topology_version_ = 0;
  friend struct StateFile;  // the checkpoint reader restores it
};

/// CSR adjacency of alive bonds, derived from the bond list (never edited by hand).
struct Adjacency {
  std::vector<Index> offset;    ///< (n + 1): quanta i's entries are [offset[i], offset[i+1])
  std::vector<Index> bond;      ///< bond id of each entry
  std::vector<Index> other;     ///< the other endpoint of each entry
  std::uint64_t version = ~0ull;  ///< the State::topology_version() it was built from
};

/// Builds the CSR adjacency of the alive bonds (entries ordered by bond id).
void build_adjacency(const Model& model, const State& state, Adjacency& adj);

/// Parameters of a new bond.
struct BondSpec {
  Law law = Law::linear;
  double stiffness = 0;  ///< the law's strength (Bonds::strength): k [N/m] (linear), F [N] (inverse), …
  double damping = 0;    ///< D [N·s/m]
  DampingModel damping_model = DampingModel::axial;
  double rest_length = -1;  ///< [m]; negative: the current distance
  /// The law's shape parameters in the order its header declares them (inverse: eps [m], 0 for
  /// kDefaultInverseEpsFraction × rest length; morse: alpha; fene: R0; cohesive: peak and
  /// failure strain). add_bond checks them (invalid_law_shape).
  LawShape shape{};
};

/// The bond law `spec` describes, its shape interned in the model's table (Model::shapes).
/// Throws std::invalid_argument for an unknown law or invalid shape parameters.
BondLaw bond_law(Model& model, const BondSpec& spec);

/// A model and its state, with helpers that keep the arrays consistent.
struct World {
  Model model;
  State state;

  /// Adds a body name and returns its id.
  Index add_body(std::string name);
  /// Adds a quanta standing for `volume` m³ (0: unknown); mass 0 makes it kinematic (inverse
  /// mass 0). Returns its id.
  Index add_quanta(const Vec3& x, const Vec3& v, double mass, Index body = 0, double volume = 0);
  /// Adds a bond between quanta i and j. Returns its id.
  Index add_bond(Index i, Index j, const BondSpec& spec);
  /// Makes quanta kinematic with a prescribed motion, starting from their current positions at
  /// the current time; their velocities are set to the prescribed ones.
  void prescribe(std::vector<Index> quanta, Motion motion);
  /// Adds a constant load (total force spread evenly over `quanta`).
  void add_load(std::vector<Index> quanta, const Vec3& total_force);
  /// Marks a bond broken at the current time; it leaves the solver from the next adjacency build.
  void break_bond(Index b) { state.break_bond(b); }
  std::size_t num_quanta() const { return model.num_quanta(); }
  std::size_t num_bonds() const { return state.bonds.size(); }
  std::size_t num_alive_bonds() const;
};

}  // namespace qbond
