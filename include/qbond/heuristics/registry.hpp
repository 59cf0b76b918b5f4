#pragma once
/// The registry of heuristics: every rule is declared once, in its own header (fracture.hpp,
/// contacts.hpp, …) with its factory `make_heuristic(Rule)`, and listed once in QBOND_HEURISTICS
/// below. HeuristicSpec (a scene's `heuristics` entries), make_heuristic(const HeuristicSpec&),
/// the scene reader's heuristic types, their keys in the JSON Schema, heuristic_types() and the
/// docs test all derive from this list.
///
/// Adding a heuristic touches three files: its header here, which holds the whole rule (its
/// parameters, its step, its factory, and its scene type: `scene_type`, `scene_doc`,
/// `scene_keys` and `from_scene(entry)`, as damping_zone.hpp does), its tests, and this file (its
/// #include and its line of QBOND_HEURISTICS). A rule whose step needs the library's private
/// helpers (the spatial hash of contacts and formation) puts its step, its factory and its scene
/// types — `scene_readers(std::type_identity<Rule>)`, src/io/scene/heuristic_entry.hpp — in a
/// source of src/heuristics/ instead: one file more, as its struct is public and those helpers
/// are not. Its rows of the docs' tables are written from its scene types by `qbond key-tables`.
#include <memory>
#include <variant>

#include "qbond/heuristics/contacts.hpp"
#include "qbond/heuristics/damping_zone.hpp"
#include "qbond/heuristics/formation.hpp"
#include "qbond/heuristics/fracture.hpp"
#include "qbond/model/obstacle.hpp"

namespace qbond {

/// X(rule type), in the order the scene reader lists the types each rule reads.
#define QBOND_HEURISTICS(X) \
  X(BreakRule)              \
  X(PlasticRule)            \
  X(Obstacle)               \
  X(QuantaContactRule)      \
  X(FormRule)               \
  X(DampingZone)

namespace heuristics_detail {
struct First {};  // leads the list below so that every rule can follow a comma
template <class V>
struct DropFirst;
template <class F, class... R>
struct DropFirst<std::variant<F, R...>> {
  using type = std::variant<R...>;
};
}  // namespace heuristics_detail

/// One rule of a scene's `heuristics` list: one of the registered rule types.
#define QBOND_HEURISTIC_ALTERNATIVE(Rule) , Rule
using HeuristicSpec = heuristics_detail::DropFirst<
    std::variant<heuristics_detail::First QBOND_HEURISTICS(QBOND_HEURISTIC_ALTERNATIVE)>>::type;
#undef QBOND_HEURISTIC_ALTERNATIVE

/// Creates the heuristic a rule describes (the rule's own make_heuristic).
std::unique_ptr<Heuristic> make_heuristic(const HeuristicSpec& spec);

}  // namespace qbond
