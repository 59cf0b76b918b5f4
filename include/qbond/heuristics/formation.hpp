#pragma once
/// Bond formation (docs/heuristics.md): quanta that come within a capture radius bond — welding,
/// sticking, cohesion, and with breaking, liquids (the paper's further research).
#include <cstdint>
#include <memory>
#include <vector>

#include "qbond/heuristics/heuristics.hpp"

namespace qbond {

/// Which pairs of quanta a formation rule may bond.
enum class FormPairs : std::uint8_t {
  any,         ///< every pair
  same_body,   ///< quanta of the same body (healing, cohesion within a body)
  other_body,  ///< quanta of different bodies (welding, sticking)
};

/// Non-bonded quanta closer than `capture_radius` at their projected end-of-step positions bond,
/// in a fixed order (increasing first quanta, then grid order), so the outcome is deterministic.
/// A new bond's rest length is their distance (no energy changes hands) or `rest_length` when
/// set (then the bond's energy at that distance is charged to the ledger, as energy the rule
/// added). Kinematic pairs never bond.
struct FormRule {
  double capture_radius = 0;  ///< [m]
  FormPairs pairs = FormPairs::any;
  int max_bonds = 0;     ///< bonds made during the run a quanta may hold (the scene's own bonds
                         ///< do not count); 0: no limit
  double min_age = 0;    ///< [s] a pair whose bond broke less than this ago does not bond again
  double rest_length = -1;  ///< [m]; negative: the distance at formation
  BondSpec bond{};          ///< law, stiffness, damping of the new bonds
  /// Per quanta: 1 when it may bond (empty: all).
  std::vector<std::uint8_t> quanta{};
};

std::unique_ptr<Heuristic> make_heuristic(FormRule rule);

}  // namespace qbond
