#pragma once
/// A JSON Schema (draft-07) of scene files, for editors: completion, types and unknown keys
/// underlined. Written from the key table the scene reader accepts keys by, so the two agree on
/// every object's keys; the reader's other rules (ranges, references, overlaps) are its own.
#include <nlohmann/json.hpp>

namespace qbond {

/// The schema (docs/scene.schema.json is its text, `qbond schema` prints it).
nlohmann::json scene_schema();

}  // namespace qbond
