#pragma once
/// Strict reading of JSON text (scene files, checkpoint metadata): one streaming pass checks the
/// text before any document is built, so that what the JSON library would get wrong silently or
/// fatally is refused with the JSON path where it happens.
#include <cstddef>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <string_view>

namespace qbond {

/// The deepest nesting of arrays and objects accepted: a scene needs fewer than ten levels, and
/// building or copying a document recurses once per level, so a limit keeps a hostile file from
/// overflowing the stack.
inline constexpr std::size_t kMaxJsonDepth = 64;

/// JSON text that breaks a rule: `path` is where ("bodies[0].size[2]", empty for the document).
class JsonTextError : public std::runtime_error {
 public:
  JsonTextError(std::string p, std::string r)
      : std::runtime_error(p.empty() ? r : p + ": " + r), path(std::move(p)), rule(std::move(r)) {}
  std::string path, rule;
};

/// Parses `text`, refusing (JsonTextError) syntax errors, numbers out of the double range
/// (1e999), nesting deeper than `max_depth` and duplicate keys (which the library would silently
/// resolve to the last one). The check is a streaming (SAX) pass with a stack of its own, so no
/// input can overflow the call stack; the document is built only once the text has passed.
/// With `comments`, `//` line and `/* */` block comments are read as white space (scene files).
nlohmann::json parse_json_strict(std::string_view text, std::size_t max_depth = kMaxJsonDepth,
                                 bool comments = false);

}  // namespace qbond
