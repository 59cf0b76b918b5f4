#pragma once
/// Heuristics (docs/heuristics.md): rules applied between a step's projection and its application. Each
/// may edit the projection (collisions), the bonds (fracture, plasticity) or both.
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "qbond/integrators/integrators.hpp"
#include "qbond/model/world.hpp"

namespace qbond {

/// A change of topology, recorded for events.csv.
struct BondEvent {
  enum class Kind : std::uint8_t { broken, formed };
  /// Why: which threshold a broken bond passed (`failure`: its law's failure stretch), or
  /// `capture` for a formed one.
  enum class Reason : std::uint8_t { strain, compression, tension, ductility, stress, von_mises, capture, failure };
  Kind kind = Kind::broken;
  Reason reason = Reason::strain;
  std::uint64_t step = 0;  ///< index of the step during which it happened
  double time = 0;         ///< [s] at the end of that step
  Index bond = 0, i = 0, j = 0;  ///< indices in the world (events.csv writes their user ids)
  double strain = 0;   ///< (r - L)/L at the projected end-of-step positions
  double tension = 0;  ///< [N] elastic tension there
};

std::string_view to_string(BondEvent::Kind k);
std::string_view to_string(BondEvent::Reason r);

/// What a heuristic may read besides the world and the projection.
struct HeuristicContext {
  StepContext step;
  const Adjacency& adj;           ///< alive bonds at the start of the step
  int threads = 1;                ///< as IntegratorConfig::threads
  std::vector<BondEvent>& events; ///< append topology changes here
  /// The projection's velocity change as the integrator made it, before any heuristic edited it
  /// (n; empty: unknown, taken as the projection's). Contacts subtract it from a quanta's velocity
  /// to get the one it brought into the step plus what earlier contacts gave it: the approach
  /// speed restitution returns (a gas's quanta meets a wall and another quanta in one step).
  std::span<const Vec3> dv_forces = {};
  /// 1 for each quanta whose edits this simulation charges to its books (n; empty: every quanta).
  /// A piece of a run over ranks charges its owned quanta's and bonds (those whose first end it
  /// owns) alone, each once over the ranks.
  std::span<const std::uint8_t> counted = {};
};

/// One rule of the step pipeline. Implementations must be deterministic given State::rng and
/// must charge the energy they remove to state.energy.dissipated_heuristics (so the budget
/// closes), evaluated at the projected end-of-step state.
class Heuristic {
 public:
  virtual ~Heuristic() = default;
  /// Name used in scene files and logs.
  virtual std::string_view name() const = 0;
  /// Called once when the rule joins a simulation, before any step: a rule that makes bonds
  /// interns their law's shape in the model here (Model::intern_shape), so a step never writes it.
  virtual void bind(Model& /*model*/) {}
  /// Edits the projection and/or the state's bonds. Bonds appear and break through the state's
  /// mutators (State::break_bond, State::form_bond), which change its topology version.
  virtual void apply(const Model& model, State& state, Projection& projection, const HeuristicContext& ctx) = 0;
};

/// Projected end-of-step position x + dx of quanta i.
inline Vec3 projected(const State& s, const Projection& p, Index i) { return s.x[i] + p.dx[i]; }

}  // namespace qbond
