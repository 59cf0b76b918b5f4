#pragma once
// The one list of the keys each kind of scene object takes. The reader accepts these keys and no
// others (Obj), and scene_schema() (scene_schema.hpp) is written from them, so the schema cannot
// list a key the reader refuses or miss one it reads.
#include <string>
#include <string_view>
#include <vector>

#include "qbond/laws/registry.hpp"

namespace qbond::scene_detail {

/// One key and what it holds, for the schema: "number", "integer", "boolean", "string", "vec3"
/// (three numbers), "array", "any", "enum:a|b|c" (one of those strings), "@kind" (an object of
/// that kind), "[@kind]" (an array of them) or "{@kind}" (an object of them by name).
struct SceneKey {
  std::string name, holds;
};

/// A kind of scene object ("load", "body.chain", "material.linear") and its keys.
struct SceneObject {
  std::string kind, doc;
  std::vector<SceneKey> keys;
};

/// Every kind of object a scene file holds.
const std::vector<SceneObject>& scene_objects();
/// One kind's keys, as Obj takes them (pointers into the table, valid for the program's life);
/// std::logic_error for a kind the table lacks.
std::vector<const char*> keys_of(std::string_view kind);
/// Whether the table has `kind`.
bool has_kind(std::string_view kind);
/// The keys of a material of `law`: the common ones, its strength, youngs_modulus when a modulus
/// calibrates it, and its shape parameters.
std::vector<std::string> material_keys(const LawInfo& law);

}  // namespace qbond::scene_detail
