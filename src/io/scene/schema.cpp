#include "io/scene/scene_keys.hpp"
#include "qbond/io/scene_schema.hpp"

namespace qbond {
using json = nlohmann::json;
using namespace scene_detail;

namespace {

json ref_to(const std::string& kind) { return {{"$ref", "#/definitions/" + kind}}; }

json text() {
  return {
      {"anyOf", json::array({{{"type", "string"}}, {{"type", "array"}, {"items", {{"type", "string"}}}}})}};
}

// What a key holds (scene_keys.hpp) as a schema.
json holds(const std::string& h) {
  if (h == "number" || h == "integer" || h == "boolean" || h == "string" || h == "array")
    return {{"type", h}};
  if (h == "vec3")
    return {{"type", "array"}, {"items", {{"type", "number"}}}, {"minItems", 3}, {"maxItems", 3}};
  if (h == "any") return json::object();
  if (h.starts_with("enum:")) {
    json values = json::array();
    for (std::size_t a = 5, b; a <= h.size(); a = b + 1) {
      b = std::min(h.find('|', a), h.size());
      values.push_back(h.substr(a, b - a));
    }
    return {{"enum", values}};
  }
  if (h.starts_with("[@")) return {{"type", "array"}, {"items", ref_to(h.substr(2, h.size() - 3))}};
  if (h.starts_with("{@"))
    return {{"type", "object"},
            {"properties", {{"description", text()}, {"notes", text()}}},
            {"additionalProperties", ref_to(h.substr(2, h.size() - 3))}};
  return ref_to(h.substr(1));  // "@kind"
}

// An object of one kind: its keys and the annotations, nothing else.
json object_of(const SceneObject& o) {
  json props = json::object();
  for (const SceneKey& k : o.keys) props[k.name] = holds(k.holds);
  if (!props.contains("description")) props["description"] = text();
  props["notes"] = text();
  return {{"description", o.doc}, {"type", "object"}, {"properties", props}, {"additionalProperties", false}};
}

// An object whose kind a key's value chooses: `prefix.VALUE` when `key` is VALUE, `absent` when
// the key is missing (empty: then it is required).
json chosen_by(const std::string& key, const std::string& prefix, const std::string& absent,
               const std::string& doc) {
  json cases = json::array(), values = json::array();
  for (const SceneObject& o : scene_objects()) {
    if (!o.kind.starts_with(prefix + ".")) continue;
    const std::string value = o.kind.substr(prefix.size() + 1);
    values.push_back(value);
    json when = {{"properties", {{key, {{"const", value}}}}}, {"required", json::array({key})}};
    cases.push_back({{"if", when}, {"then", ref_to(o.kind)}});
  }
  json s = {{"description", doc}, {"type", "object"}, {"properties", {{key, {{"enum", values}}}}}};
  if (absent.empty()) {
    s["required"] = json::array({key});
  } else {
    json missing = {{"not", {{"required", json::array({key})}}}};
    cases.push_back({{"if", missing}, {"then", ref_to(prefix + "." + absent)}});
  }
  s["allOf"] = cases;
  return s;
}

}  // namespace

json scene_schema() {
  json defs = json::object();
  for (const SceneObject& o : scene_objects()) defs[o.kind] = object_of(o);
  defs["body"] = chosen_by("type", "body", "", "a body: its `type` chooses its keys");
  defs["heuristic"] = chosen_by("type", "heuristic", "", "a heuristic: its `type` chooses its keys");
  defs["material"] =
      chosen_by("law", "material", "linear", "a bond material: its `law` (default linear) chooses its keys");
  defs["bond"] = {{"description", "extra bonds: one `between` two quanta, or all pairs `within` a distance"},
                  {"type", "object"},
                  {"if", {{"required", json::array({"between"})}}},
                  {"then", ref_to("bond.between")},
                  {"else", ref_to("bond.within")}};
  defs["motion"]["minProperties"] = 1;
  json s = object_of(scene_objects().front());  // the top level
  s["$schema"] = "http://json-schema.org/draft-07/schema#";
  s["title"] = "qbond scene";
  s["required"] = json::array({"timestep", "bodies"});
  s["definitions"] = defs;
  return s;
}

}  // namespace qbond
