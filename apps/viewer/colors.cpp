#include "colors.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace qbond::view {

namespace {
Vec3f lerp_table(const std::array<Vec3f, 5>& t, double x) {
  x = std::clamp(x, 0.0, 1.0) * 4;
  const int k = std::min(3, static_cast<int>(x));
  const float a = static_cast<float>(x - k);
  return (1 - a) * t[k] + a * t[k + 1];
}
}  // namespace

Vec3f diverging(double t) {
  static const std::array<Vec3f, 5> table = {Vec3f(0.10f, 0.25f, 0.80f), Vec3f(0.45f, 0.65f, 0.95f),
                                             Vec3f(0.85f, 0.85f, 0.85f), Vec3f(0.97f, 0.55f, 0.40f),
                                             Vec3f(0.80f, 0.08f, 0.08f)};
  return lerp_table(table, (std::clamp(t, -1.0, 1.0) + 1) / 2);
}

Vec3f sequential(double t) {
  static const std::array<Vec3f, 5> table = {Vec3f(0.27f, 0.00f, 0.33f), Vec3f(0.23f, 0.32f, 0.55f),
                                             Vec3f(0.13f, 0.57f, 0.55f), Vec3f(0.37f, 0.79f, 0.38f),
                                             Vec3f(0.99f, 0.91f, 0.14f)};
  return lerp_table(table, t);
}

Vec3f body_color(unsigned b) {
  static const std::array<Vec3f, 6> palette = {Vec3f(0.55f, 0.62f, 0.72f), Vec3f(0.62f, 0.72f, 0.52f),
                                               Vec3f(0.75f, 0.60f, 0.50f), Vec3f(0.62f, 0.55f, 0.75f),
                                               Vec3f(0.50f, 0.72f, 0.72f), Vec3f(0.75f, 0.70f, 0.45f)};
  return palette[b % palette.size()];
}

void AutoRange::see(std::vector<double>& magnitudes) {
  double top = 0;
  if (!magnitudes.empty()) {
    const auto k = static_cast<std::ptrdiff_t>(0.98 * static_cast<double>(magnitudes.size() - 1));
    std::nth_element(magnitudes.begin(), magnitudes.begin() + k, magnitudes.end());
    top = magnitudes[static_cast<std::size_t>(k)];
  }
  hi = std::max(top, 0.97 * hi);
}

}  // namespace qbond::view
