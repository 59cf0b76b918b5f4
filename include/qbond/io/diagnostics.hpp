#pragma once
/// diagnostics.csv (columns documented in docs/running.md): one row per output step.
#include <string>
#include <vector>

#include "qbond/heuristics/contacts.hpp"
#include "qbond/integrators/integrators.hpp"
#include "qbond/io/probes.hpp"

namespace qbond {

/// Formats the rows of diagnostics.csv: the fifteen fixed columns, then per probe its mean
/// position, its reaction force and torque when anchored, its mean stress tensor and largest
/// von Mises stress when its quanta have volumes (stress.hpp), then per recorded obstacle k the
/// impulse it has given (obstacle<k>_jx, _jy, _jz, _jn: State::obstacle_impulse) and, for a
/// container, its mean pressure since the accounts opened, jn / (contact area × elapsed time)
/// (obstacle<k>_pressure), then work, numerical dissipation and the last step's solver iterations
/// and residual. Numbers are printed with 17
/// significant digits so that they read back exactly.
class Diagnostics {
 public:
  Diagnostics(const Model& model, std::vector<Probe> probes, std::vector<Obstacle> obstacles = {});
  /// The header line (no newline).
  std::string header() const;
  /// The row of a state (no newline); `timestep` is the step that led to it [s] (adaptive runs
  /// vary it).
  std::string row(const Model& model, const State& state, const SolveStats& stats, double timestep = 0) const;
  /// Whether the run charges the energy ledger; without it the columns the ledger alone knows
  /// (dissipated, work, numerical_damping, numerical, the contacts' energies, and total where
  /// contact springs hold energy) are nan.
  void set_ledger(bool on) { ledger_ = on; }

 private:
  std::vector<Probe> probes_;
  std::vector<bool> reaction_, stress_;
  std::vector<Obstacle> obstacles_;  // the recorded ones
  bool contact_columns_ = false;     // the model has obstacles in the step's solve
  bool ledger_ = true;
};

}  // namespace qbond
