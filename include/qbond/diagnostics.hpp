#pragma once
/// diagnostics.csv (DESIGN §10; columns documented in docs/running.md): one row per output step.
#include <string>
#include <vector>

#include "qbond/integrators.hpp"
#include "qbond/probes.hpp"

namespace qbond {

/// Formats the rows of diagnostics.csv: DESIGN §10's fifteen columns, then per probe its mean
/// position, its reaction force and torque when anchored, its mean stress tensor and largest
/// von Mises stress when its quanta have volumes (stress.hpp), then work, numerical
/// dissipation and the last step's solver iterations and residual. Numbers are printed with 17
/// significant digits so that they read back exactly.
class Diagnostics {
 public:
  Diagnostics(const Model& model, std::vector<Probe> probes);
  /// The header line (no newline).
  std::string header() const;
  /// The row of a state (no newline); `timestep` is the step that led to it [s] (adaptive runs
  /// vary it).
  std::string row(const Model& model, const State& state, const SolveStats& stats, double timestep = 0) const;

 private:
  std::vector<Probe> probes_;
  std::vector<bool> reaction_, stress_;
};

}  // namespace qbond
