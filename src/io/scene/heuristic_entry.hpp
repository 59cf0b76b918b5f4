#pragma once
// One `heuristics` entry as its type's reader reads it: the entry's keys, the world, the list of
// rules it appends to, and the checks and conversions the heuristic types share. Each rule of
// QBOND_HEURISTICS (qbond/heuristics/registry.hpp) lists its scene types in its own file, as
// `scene_readers(std::type_identity<Rule>)`; Builder::heuristic_readers() joins the lists.
#include <cstdint>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include "io/scene/builder.hpp"

namespace qbond::scene_detail {

struct HeuristicEntry {
  Builder& builder;
  const Obj& o;
  const std::string& type;
  World& w;
  std::vector<HeuristicSpec>& out;  // the rules read so far; the reader appends its own

  // The entry's `select`: per quanta, 1 when selected (empty without a `select`: all).
  std::vector<std::uint8_t> quanta_mask() const;
  // `restitution`, `friction` and `static_friction`, checked.
  ContactMaterial contact_material() const;
  // The material named at `key` for single bonds (it must give a stiffness, not a modulus).
  BondSpec bond_material(const char* key) const;
  // The scene's integrator (obstacles solved inside the step need coupled_implicit).
  const IntegratorConfig& integrator() const;
  // The number of the next obstacle that records its impulse (diagnostics' obstacle<k>_ columns).
  std::int32_t next_obstacle_record() const;
};

// Each registered rule's scene types, defined in the rule's own file (src/heuristics/).
#define QBOND_HEURISTIC_SCENE_READERS(Rule) std::span<const HeuristicReader> scene_readers(std::type_identity<Rule>);
QBOND_HEURISTICS(QBOND_HEURISTIC_SCENE_READERS)
#undef QBOND_HEURISTIC_SCENE_READERS

}  // namespace qbond::scene_detail
