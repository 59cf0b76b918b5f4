#pragma once
// One `heuristics` entry as its type's reader reads it: the entry's keys, the world, the list of
// rules it appends to, and the checks and conversions the heuristic types share. Each rule of
// QBOND_HEURISTICS (qbond/heuristics/registry.hpp) declares its scene types in its own file:
// a rule whole in its header by its `scene_type`, `scene_keys` and `from_scene(entry)`, a rule
// with a source in src/heuristics/ there, as `scene_readers(std::type_identity<Rule>)`;
// Builder::heuristic_readers() joins them.
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

  // Keys read by name and checked, for the rules whole in their headers (`from_scene`): each
  // throws naming the key's path when the key is missing or its value is out of range.
  bool has(const char* key) const { return o.has(key); }
  double number(const char* key) const;    // any finite number
  double positive(const char* key) const;  // > 0
  Vec3 vec3(const char* key) const;
  [[noreturn]] void bad(const char* key, const std::string& message) const;
};

// The scene types of a registered rule with a source in src/heuristics/, defined there.
#define QBOND_HEURISTIC_SCENE_READERS(Rule) std::span<const HeuristicReader> scene_readers(std::type_identity<Rule>);
QBOND_HEURISTICS(QBOND_HEURISTIC_SCENE_READERS)
#undef QBOND_HEURISTIC_SCENE_READERS

}  // namespace qbond::scene_detail
