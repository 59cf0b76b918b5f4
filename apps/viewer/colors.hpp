#pragma once
/// Colour maps and legends of the viewer (no OpenGL).
#include <string_view>
#include <vector>

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

/// A legend's range that follows what is on screen without flickering: each frame it rises at
/// once to the frame's 98th percentile of |value| (so that one overstretched bond does not wash out
/// the rest) and otherwise decays by 3 % a frame, so that colours keep their meaning from one
/// frame to the next and adapt within a second or two after a transient. Diverging ranges are
/// symmetric [−hi, hi], sequential ones [0, hi].
struct AutoRange {
  double hi = 0;
  /// Takes a frame's values (reordered in place).
  void see(std::vector<double>& magnitudes);
  void reset() { hi = 0; }
};

}  // namespace qbond::view
