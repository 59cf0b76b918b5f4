#pragma once
/// The inverse law, Eq. 3 regularised: T = F s / (s² + ε²), s = r − L, U = F/2 ln(1 + s²/ε²).
#include "qbond/laws/law.hpp"

namespace qbond {

/// Default regularisation length of the inverse law as a fraction of the rest length.
inline constexpr double kDefaultInverseEpsFraction = 0.05;

/// Eq. 3 regularised: slope F/ε² at rest, peak F/(2ε) at |s| = ε, Eq. 3's F/s for |s| ≫ ε.
struct InverseLaw {
  static constexpr std::string_view name = "inverse";
  static constexpr std::string_view doc =
      "T = F s/(s² + ε²), U = F/2 ln(1 + s²/ε²); slope F/ε² at rest, peak F/(2ε) at |s| = ε";
  static constexpr LawParam strength{"stiffness", "N", "F of Eq. 3 regularised"};
  static constexpr std::array<LawParam, 1> shape{
      LawParam{"eps", "m", "ε, the regularisation length", "0.05 × the rest length the bond was made with"}};
  static constexpr bool calibrated_by_modulus = false;

  /// ε: the material's, or kDefaultInverseEpsFraction of the rest length the bond was made with.
  [[gnu::always_inline]] static double eps(const LawArgs& a) {
    return a.shape[0] > 0 ? a.shape[0] : kDefaultInverseEpsFraction * (a.rest0 > 0 ? a.rest0 : 1.0);
  }
  [[gnu::always_inline]] static LawValue eval(double r, double L, const LawArgs& a) {
    const double F = a.strength, s = r - L, e2 = eps(a) * eps(a);
    const double q = s * s + e2;
    return {F * s / q, F * (e2 - s * s) / (q * q), 0.5 * F * std::log1p(s * s / e2)};
  }
  /// U1 − U0 = F/2 log1p(z), z = (s1² − s0²)/(s0² + ε²) = dr (s0+s1)/q0, so
  /// T̄ = F/2 (s0+s1)/q0 · log1p(z)/z.
  static MeanTension mean(double r0, double r1, double L, const LawArgs& a) {
    const double F = a.strength, e = eps(a), dr = r1 - r0;
    const double s0 = r0 - L, s1 = r1 - L, q0 = s0 * s0 + e * e;
    MeanTension m{0.5 * F * (s0 + s1) / q0 * log1p_ratio(dr * (s0 + s1) / q0), 0};
    m.dT1 = secant_slope(eval(r1, L, a).T, m.T, dr, e, [&] { return 0.5 * eval(0.5 * (r0 + r1), L, a).dT; });
    return m;
  }
  static double rest_stiffness(const LawArgs& a) { return a.strength / (eps(a) * eps(a)); }
  static constexpr bool breaks = false;
  static double failure_stretch(double, const LawArgs&) { return std::numeric_limits<double>::infinity(); }
  static std::string_view invalid(const LawShape&) { return {}; }
};

}  // namespace qbond
