#pragma once
/// Colour maps and legends of the viewer (no OpenGL).
#include <string_view>

#include "camera.hpp"

namespace qbond::view {

/// What colours the bonds.
enum class BondColor : int { strain, tension, none };
/// What colours the quanta.
enum class QuantaColor : int { body, von_mises, speed };

inline constexpr const char* kBondColorNames[] = {"strain (r - L)/L", "tension [N]", "plain"};
inline constexpr const char* kQuantaColorNames[] = {"body", "von Mises stress [Pa]", "speed [m/s]"};

/// Blue (t = −1, compression) through light grey (0) to red (t = +1, tension); t is clamped.
Vec3f diverging(double t);
/// Viridis-like dark blue (t = 0) to yellow (t = 1); t is clamped.
Vec3f sequential(double t);
/// A distinct colour for body b.
Vec3f body_color(unsigned b);
/// Colour of kinematic (anchored or prescribed) quanta.
inline Vec3f anchored_color() { return {0.95f, 0.45f, 0.05f}; }

/// A legend's range that only grows until reset, so that colours mean the same values from one
/// frame to the next (a range that followed each frame's extremes would make every frame look
/// alike). Diverging ranges are symmetric [−hi, hi], sequential ones [0, hi].
struct HeldRange {
  double hi = 0;
  void see(double magnitude) { if (magnitude > hi) hi = magnitude; }
  void reset(double floor) { hi = floor; }
};

}  // namespace qbond::view
