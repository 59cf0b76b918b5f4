#pragma once
/// Scripted input for the viewer (`qbond view --script FILE`): what a person would do with the
/// mouse and keys, at given frames, so that tests and recordings need nobody at the keyboard.
///
///     {"events": [
///       {"frame": 30, "drag": {"quanta": 22, "by": [0.3, 0, 0]}},  // mouse spring to x + by
///       {"frame": 30, "drag": {"quanta": 22, "to": [0.3, 0, 0.2]}}, // ... or to a point
///       {"frame": 90, "release": true},                             // let go (drag and push)
///       {"frame": 0,  "push": {"quanta": 13, "force": [2, 0, 0]}},  // a constant force [N]
///       {"frame": 120, "key": "r"},                                 // space . r h f
///       {"frame": 10, "mouse": {"press_on": 30}},  // the left button, on the pixel of quanta 30
///       {"frame": 11, "mouse": {"move_by": [200, -50]}},            // pixels, y down
///       {"frame": 40, "mouse": {"release": true}}
///     ]}
/// `mouse` events go through the same handlers as the real mouse: picking, the spring's target
/// on the plane through the grab point, orbiting when the press misses every quanta.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "qbond/core/math.hpp"

namespace qbond::view {

struct ScriptEvent {
  enum class Kind : std::uint8_t { drag, release, push, key, mouse_press, mouse_move, mouse_release };
  std::uint64_t frame = 0;
  Kind kind = Kind::key;
  Index quanta = 0;                 ///< drag, push
  std::optional<Vec3> to, by;       ///< drag: target point, or offset from the quanta [m]
  Vec3 force = Vec3::Zero();        ///< push [N]
  char key = 0;                     ///< key
  Eigen::Vector2d pixels = Eigen::Vector2d::Zero();  ///< mouse_move [px], y down
};

/// Parses a script; events come back sorted by frame (stable). `num_quanta` bounds the ids.
/// Throws std::invalid_argument "SOURCE: events[K].drag.quanta: RULE" on any error.
std::vector<ScriptEvent> parse_script(const std::string& json_text, const std::string& source, std::size_t num_quanta);

}  // namespace qbond::view
