#pragma once
/// Heuristics (DESIGN §6): rules applied between a step's projection and its application. Each
/// may edit the projection (collisions), the bonds (fracture, plasticity, formation) or both.
#include <string_view>

#include "qbond/integrators.hpp"
#include "qbond/world.hpp"

namespace qbond {

/// One rule of the step pipeline. Implementations must be deterministic given State::rng.
class Heuristic {
 public:
  virtual ~Heuristic() = default;
  /// Name used in scene files and logs.
  virtual std::string_view name() const = 0;
  /// Edits the projection and/or the state's bonds. Topology changes must bump
  /// state.topology_version (World::break_bond does).
  virtual void apply(const Model& model, State& state, Projection& projection,
                     const StepContext& ctx) = 0;
};

}  // namespace qbond
