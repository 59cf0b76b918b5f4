#pragma once
/// Analysis: energies, momenta, speeds of a world's state. Kinematic quanta are
/// drivers, not part of the system: they carry no kinetic energy, momentum or gravity potential.
#include <vector>

#include "qbond/model/world.hpp"

namespace qbond {

/// Energies of a state [J].
struct Energies {
  double kinetic = 0;  ///< Σ ½ m |v|² over free quanta
  double bonds = 0;    ///< Σ U(r) over alive bonds
  double gravity = 0;  ///< -Σ m g·x over free quanta
  double total() const { return kinetic + bonds + gravity; }
};

/// Kinetic, bond and gravity energies of the state; `threads` as IntegratorConfig::threads (the
/// same bits for any count).
Energies energies(const Model& model, const State& state, int threads = 1);
/// The kinetic and gravity energies alone (bonds left 0), in one pass over the quanta, with the
/// bits energies() gives them: for a caller that has the bonds' energy already.
Energies quanta_energies(const Model& model, const State& state, int threads = 1);
/// Opens `ledger` at `state` unless it is open already: E(0) = energies(model, state).total(),
/// its gravity part and the time, so that the ledger's columns count from there.
void open_ledger(const Model& model, const State& state, EnergyLedger& ledger);

/// Σ m v over free quanta [kg·m/s].
Vec3 linear_momentum(const Model& model, const State& state);
/// Σ m x × v over free quanta, about the origin [kg·m²/s].
Vec3 angular_momentum(const Model& model, const State& state);
/// Largest angular frequency of the free quanta's small vibrations about the state [rad/s]:
/// ω_max = √λ_max(M^-1/2 K M^-1/2), K the bonds' stiffness blocks at their current lengths (kinematic
/// quanta held). Dense eigenvalues of a 3n × 3n matrix: for small systems (tests, experiments);
/// scene.hpp's explicit_step_hint bounds it cheaply for large ones.
double max_angular_frequency(const Model& model, const State& state);

/// Largest speed of a free quanta [m/s], and which one (n when there is none).
std::pair<double, Index> max_speed(const Model& model, const State& state);

/// Tension [N] and strain (r - L)/L of every bond (0 for broken ones).
void bond_tension_strain(const Model& model, const State& state, std::vector<double>& tension,
                         std::vector<double>& strain);

/// The energy budget as one line of numbers [J]. What the integrator itself dissipated is
/// numerical_damping (backward Euler's, in closed form) plus the remainder dissipated_numerical:
/// work_loads + work_anchors - dissipated_damping - dissipated_heuristics - dissipated_contact
/// - numerical_damping - ΔE, E counting the contact springs' energy (contact_stored).
struct EnergyBudget {
  Energies now;
  double initial_total = 0;
  double work_loads = 0;
  double work_anchors = 0;
  double dissipated_damping = 0;
  double dissipated_heuristics = 0;
  double dissipated_contact = 0;
  double contact_stored = 0;
  double numerical_damping = 0;
  double dissipated_numerical = 0;
  /// Everything the integrator lost: numerical_damping + dissipated_numerical [J].
  double integrator_loss() const { return numerical_damping + dissipated_numerical; }
};
EnergyBudget energy_budget(const Model& model, const State& state);

}  // namespace qbond
