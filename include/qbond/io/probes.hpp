#pragma once
/// Probes (docs/running.md): what a run measures on a selection of quanta at each output step.
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "qbond/model/world.hpp"

namespace qbond {

/// A named selection of quanta to measure.
struct Probe {
  std::string name;
  std::vector<Index> quanta;
  std::optional<Vec3> about;  ///< torque reference point; the selection's mean position if absent
};

/// What a probe measures.
struct ProbeValue {
  Vec3 mean = Vec3::Zero();  ///< mean position of the quanta [m]
  /// Whether every quanta is kinematic (anchored or prescribed); only then is there a reaction.
  bool has_reaction = false;
  Vec3 force = Vec3::Zero();   ///< reaction force the support applies to the structure [N]
  Vec3 torque = Vec3::Zero();  ///< its torque about the reference point [N·m]
  /// Whether the quanta have volumes, so that stress means something (stress.hpp).
  bool has_stress = false;
  Mat3 stress = Mat3::Zero();  ///< volume-weighted mean virial stress of the quanta [Pa]
  double von_mises_max = 0;    ///< largest von Mises stress among them [Pa]
};

/// Whether a probe's quanta are all kinematic, so that it reports a reaction.
bool has_reaction(const Model& model, const Probe& probe);
/// Whether a probe's quanta have volumes, so that it reports stress.
bool has_stress(const Model& model, const Probe& probe);

/// Measures a probe. The reaction is minus the sum of the bond forces (elastic and damping, as
/// the integrator computes them) that the rest of the structure exerts on the probe's quanta;
/// in equilibrium it balances the loads and gravity on the structure. `sigma` is the virial
/// stress of every quanta (stress.hpp), computed here when not given.
ProbeValue measure_probe(const Model& model, const State& state, const Probe& probe, std::span<const Mat3> sigma = {});

}  // namespace qbond
