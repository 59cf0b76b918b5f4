#pragma once
/// The Morse bond (LAMMPS bond_style morse): U = D0 (1 − e^{−α s})², s = r − L.
#include "qbond/laws/law.hpp"

namespace qbond {

/// U = D0 (1 − e^{−α s})², T = 2 D0 α e^{−α s} (1 − e^{−α s}), T' = 2 D0 α² e^{−α s} (2 e^{−α s} − 1):
/// stiffness 2 D0 α² at rest, the largest tension D0 α / 2 at s = ln 2 / α, and U → D0 (the
/// well's depth, the energy to pull the bond apart) as s → ∞. Compression stiffens exponentially.
struct MorseLaw {
  static constexpr std::string_view name = "morse";
  static constexpr std::string_view doc =
      "U = D0 (1 − e^(−α s))², T = 2 D0 α e^(−α s)(1 − e^(−α s)); stiffness 2 D0 α² at rest, largest tension "
      "D0 α/2 at s = ln 2/α, U → D0 as s → ∞ (LAMMPS `bond_style morse`)";
  static constexpr LawParam strength{"D0", "J", "the well's depth"};
  static constexpr std::array<LawParam, 1> shape{LawParam{"alpha", "1/m", "α, the well's inverse width"}};
  static constexpr bool calibrated_by_modulus = false;

  [[gnu::always_inline]] static LawValue eval(double r, double L, const LawArgs& a) {
    const double D = a.strength, alpha = a.shape[0], s = r - L;
    const double e = std::exp(-alpha * s), y = -std::expm1(-alpha * s);  // y = 1 − e, exact near rest
    return {2 * D * alpha * e * y, 2 * D * alpha * alpha * e * (2 * e - 1), D * y * y};
  }
  /// U1 − U0 = D0 (y1 − y0)(y1 + y0), y1 − y0 = e0 (1 − e^{−α dr}) = e0 α dr φ(α dr) with
  /// φ(x) = −expm1(−x)/x (no cancellation), so T̄ = D0 α e0 (y0 + y1) φ(α dr).
  static MeanTension mean(double r0, double r1, double L, const LawArgs& a) {
    const double D = a.strength, alpha = a.shape[0], dr = r1 - r0, s0 = r0 - L, s1 = r1 - L;
    const double x = alpha * dr;
    const double phi = x == 0 ? 1.0 : -std::expm1(-x) / x;
    const double y0 = -std::expm1(-alpha * s0), y1 = -std::expm1(-alpha * s1);
    MeanTension m{D * alpha * std::exp(-alpha * s0) * (y0 + y1) * phi, 0};
    m.dT1 = secant_slope(eval(r1, L, a).T, m.T, dr, 1 / alpha, [&] { return 0.5 * eval(0.5 * (r0 + r1), L, a).dT; });
    return m;
  }
  static double rest_stiffness(const LawArgs& a) { return 2 * a.strength * a.shape[0] * a.shape[0]; }
  /// Never breaks by itself (its tension fades instead).
  static constexpr bool breaks = false;
  static double failure_stretch(double, const LawArgs&) { return std::numeric_limits<double>::infinity(); }
  static std::string_view invalid(const LawShape&) { return {}; }
};

}  // namespace qbond
