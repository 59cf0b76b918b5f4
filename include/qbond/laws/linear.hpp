#pragma once
/// The linear (Hookean) bond, Eq. 2: T = k (r − L), U = k (r − L)² / 2.
#include "qbond/laws/law.hpp"

namespace qbond {

/// Eq. 2. The bond kernels' vector paths hard-code this law for runs of linear bonds.
struct LinearLaw {
  static constexpr std::string_view name = "linear";
  static constexpr std::string_view doc = "T = k s, U = k s²/2";
  static constexpr LawParam strength{"stiffness", "N/m", "k of Eq. 2"};
  static constexpr std::array<LawParam, 0> shape{};
  /// Its strength is its stiffness at rest, so a Young's modulus can calibrate it.
  static constexpr bool calibrated_by_modulus = true;

  [[gnu::always_inline]] static LawValue eval(double r, double L, const LawArgs& a) {
    const double k = a.strength, s = r - L;
    return {k * s, k, 0.5 * k * s * s};
  }
  /// U quadratic in r: the quotient is T at the mean length, exactly.
  static MeanTension mean(double r0, double r1, double L, const LawArgs& a) {
    return {a.strength * (0.5 * (r0 + r1) - L), 0.5 * a.strength};
  }
  static double rest_stiffness(const LawArgs& a) { return a.strength; }
  /// Never breaks by itself.
  static constexpr bool breaks = false;
  static double failure_stretch(double, const LawArgs&) { return std::numeric_limits<double>::infinity(); }
  /// Cross-parameter rule beyond each parameter's (none): empty when valid.
  static std::string_view invalid(const LawShape&) { return {}; }
};

}  // namespace qbond
