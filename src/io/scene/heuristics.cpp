// Builder: the `heuristics` section. Each entry is read by its type's reader, which the rule's
// own file defines (its header's from_scene, or scene_readers in its source: heuristic_entry.hpp);
// this file joins them and shares the conversions they use.
#include "io/scene/heuristic_entry.hpp"

namespace qbond::scene_detail {

std::vector<std::uint8_t> HeuristicEntry::quanta_mask() const {
  if (!o.has("select")) return {};
  std::vector<std::uint8_t> in(w.num_quanta(), 0);
  for (Index i : builder.selection(o["select"], o.at("select"), w)) in[i] = 1;
  return in;
}

ContactMaterial HeuristicEntry::contact_material() const {
  ContactMaterial c;
  if (o.has("restitution")) {
    c.restitution = non_negative(o["restitution"], o.at("restitution"));
    if (c.restitution > 1)
      scene_detail::bad(o.at("restitution"), "must be <= 1, got " + num_str(c.restitution));
  }
  if (o.has("friction")) c.friction = non_negative(o["friction"], o.at("friction"));
  if (o.has("static_friction")) {
    c.static_friction = non_negative(o["static_friction"], o.at("static_friction"));
    if (c.static_friction < c.friction)
      scene_detail::bad(o.at("static_friction"), "must be >= friction (" + num_str(c.friction) + "), got " +
                                                     num_str(c.static_friction));
  }
  return c;
}

BondSpec HeuristicEntry::bond_material(const char* key) const { return builder.bond_material(o.required(key), o.at(key)); }

const IntegratorConfig& HeuristicEntry::integrator() const { return builder.integrator_; }

std::int32_t HeuristicEntry::next_obstacle_record() const { return static_cast<std::int32_t>(builder.obstacles_++); }

double HeuristicEntry::number(const char* key) const {
  return scene_detail::number(o.required(key), o.at(key));
}

double HeuristicEntry::positive(const char* key) const {
  return scene_detail::positive(o.required(key), o.at(key));
}

Vec3 HeuristicEntry::vec3(const char* key) const { return scene_detail::vec3(o.required(key), o.at(key)); }

void HeuristicEntry::bad(const char* key, const std::string& message) const {
  scene_detail::bad(o.at(key), message);
}

namespace {

// A registered rule's scene types: from its header (scene_type, scene_keys, from_scene) when the
// rule is whole there, else from its source (scene_readers).
template <class Rule>
std::span<const HeuristicReader> readers_of() {
  if constexpr (requires { Rule::scene_type; }) {
    static const HeuristicReader rows[] = {
        {Rule::scene_type.data(), Rule::scene_doc.data(),
         [] {
           std::vector<SceneKey> keys;
           for (const auto& [name, holds] : Rule::scene_keys)
             keys.push_back({std::string(name), std::string(holds)});
           return keys;
         }(),
         [](const HeuristicEntry& e) { e.out.emplace_back(Rule::from_scene(e)); }}};
    return rows;
  } else {
    return scene_readers(std::type_identity<Rule>{});
  }
}

}  // namespace

// The registered rules' types, in the registry's order: what the reader accepts, what
// heuristic_types() lists and the JSON Schema holds.
std::span<const HeuristicReader> Builder::heuristic_readers() {
  static const std::vector<HeuristicReader> rows = [] {
    std::vector<HeuristicReader> all;
    auto add = [&](std::span<const HeuristicReader> r) { all.insert(all.end(), r.begin(), r.end()); };
#define QBOND_ADD_SCENE_READERS(Rule) add(readers_of<Rule>());
    QBOND_HEURISTICS(QBOND_ADD_SCENE_READERS)
#undef QBOND_ADD_SCENE_READERS
    return all;
  }();
  return rows;
}

std::vector<HeuristicSpec> Builder::heuristics(const json& j, World& w) {
  std::vector<std::string> types;
  for (const HeuristicReader& r : heuristic_readers()) types.emplace_back(r.type);
  std::vector<HeuristicSpec> out;
  for (std::size_t k = 0; k < j.size(); ++k) {
    const std::string path = item("heuristics", k);
    if (!j[k].is_object() || !j[k].contains("type"))
      bad(path, "expected an object with a \"type\" (" + join(types) + ")");
    const std::string type = string(j[k]["type"], path + ".type");
    const auto rows = heuristic_readers();
    const auto row = std::find_if(rows.begin(), rows.end(), [&](const HeuristicReader& r) { return type == r.type; });
    if (row == rows.end()) bad(path + ".type", "unknown heuristic '" + type + "' (accepted: " + join(types) + ")");
    const Obj o(j[k], path, keys_of("heuristic." + type));
    row->read(HeuristicEntry{*this, o, type, w, out});
  }
  return out;
}

}  // namespace qbond::scene_detail

namespace qbond {

const std::vector<SceneType>& heuristic_types() {
  static const std::vector<SceneType> types = scene_detail::Builder::scene_types(scene_detail::Builder::heuristic_readers());
  return types;
}

}  // namespace qbond
