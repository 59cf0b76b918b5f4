#pragma once
/// `qbond statics`: a scene's static equilibrium (solve_static, statics.hpp) with a run's kinds of
/// output (docs/running.md, "Statics"), written into `out_dir`:
///   static.vtp       the equilibrium as a ParaView frame (a run's arrays, plus displacement and
///                    reaction per quanta)
///   quanta.csv       per quanta: id, body, kinematic, position, displacement, reaction, von Mises
///                    and virial stress (stress.hpp)
///   bonds.csv        per alive bond: id, its quanta, strain, tension
///   diagnostics.csv  the run's header and one row, at the equilibrium (probes' positions,
///                    reactions and stresses)
///   statics.json     whether it converged, iterations, residual, the sums of the external loads
///                    and of the reactions, the largest displacement, the resolved scene
/// Heuristics (fracture, contact, formation) and prescribed motions do not act: kinematic quanta
/// stay at their positions at t = 0.
#include <filesystem>

#include "qbond/io/scene.hpp"
#include "qbond/solvers/statics.hpp"

namespace qbond {

/// Where and how closely statics solves.
struct StaticsSettings {
  std::filesystem::path out_dir = "out";
  double tolerance = 1e-8;  ///< solve_static's relative residual
  int max_iterations = 50;  ///< Newton iterations at most
  bool vtk = true;          ///< write static.vtp
};

/// What the equilibrium came to.
struct StaticsReport {
  StaticResult result;
  Vec3 load = Vec3::Zero();      ///< Σ external force on the free quanta (loads and gravity) [N]
  Vec3 reaction = Vec3::Zero();  ///< Σ reaction the supports apply: −Σ bond forces on kinematic quanta [N]
  double max_displacement = 0;   ///< largest |x − x(t = 0)| [m]
};

/// Solves the scene's static equilibrium in place (its world ends at it) and writes the outputs
/// above, locking `out_dir` as a run does (DirectoryBusy). At equilibrium load + reaction = 0.
StaticsReport run_statics(Scene& scene, const StaticsSettings& settings);

}  // namespace qbond
