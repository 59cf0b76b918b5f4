#pragma once
/// FENE about the rest length (LAMMPS bond_style fene/expand without its LJ term):
/// U = −½ K R0² ln(1 − (s/R0)²), T = K s / (1 − (s/R0)²), s = r − L.
#include "qbond/laws/law.hpp"

namespace qbond {

/// Finitely extensible: the tension diverges as |s| → R0. A step must never see that infinity
/// (or the NaN past it), so from |s| = kFeneLinearFrom R0 on the tension is continued along its
/// tangent there (T and T' continuous, U quadratic): the bond stays very stiff (T' is 200 K
/// there, 1/(1 - 0.95²)² (1 + 0.95²)) but finite. A bond that must not pass R0 needs a break
/// rule (max_strain) or a smaller timestep; docs/materials.md says so.
struct FeneLaw {
  static constexpr std::string_view name = "fene";
  static constexpr std::string_view doc =
      "U = −½ K R0² ln(1 − (s/R0)²), T = K s/(1 − (s/R0)²) (LAMMPS `fene/expand` without its LJ term); "
      "stiffness K at rest";
  static constexpr LawParam strength{"stiffness", "N/m", "K"};
  static constexpr std::array<LawParam, 1> shape{LawParam{
      "R0", "m", "the largest extension |s|", {},
      "From |s| = 0.95 R0 on the tension continues along its tangent there (T, T′ continuous, 200 K stiff), so a "
      "step never meets the infinite U at R0; a bond that must not pass R0 needs a `break` rule (`max_strain`) or a "
      "smaller step"}};
  static constexpr bool calibrated_by_modulus = true;
  /// Fraction of R0 past which the tension is continued linearly.
  static constexpr double kFeneLinearFrom = 0.95;

  /// The law inside |s| ≤ kFeneLinearFrom R0, from q = R0² − s².
  [[gnu::always_inline]] static LawValue inner(double s, double K, double R0) {
    const double R2 = R0 * R0, q = R2 - s * s;
    return {K * s * R2 / q, K * R2 * (R2 + s * s) / (q * q), -0.5 * K * R2 * std::log1p(-s * s / R2)};
  }
  [[gnu::always_inline]] static LawValue eval(double r, double L, const LawArgs& a) {
    const double K = a.strength, R0 = a.shape[0], s = r - L, c = kFeneLinearFrom * R0;
    if (std::abs(s) <= c) return inner(s, K, R0);
    const double sc = std::copysign(c, s), ds = s - sc;
    const LawValue v = inner(sc, K, R0);
    return {v.T + v.dT * ds, v.dT, v.U + ds * (v.T + 0.5 * v.dT * ds)};
  }
  /// T̄ over [s0, s1] split where it crosses ±kFeneLinearFrom R0: the pieces' mean tensions
  /// weighted by their share of dr (weights in [0, 1], no cancellation). Inside, with
  /// q0 = R0² − s0², U1 − U0 = −½ K R0² log1p(z), z = −dr (s0 + s1)/q0, so
  /// T̄ = ½ K R0² (s0 + s1)/q0 · log1p(z)/z; outside, U is quadratic and T̄ = T(r̄).
  static MeanTension mean(double r0, double r1, double L, const LawArgs& a) {
    const double K = a.strength, R0 = a.shape[0], c = kFeneLinearFrom * R0, dr = r1 - r0;
    const double s0 = r0 - L, s1 = r1 - L;
    auto piece = [&](double p, double q) {  // T̄ over [p, q] within one piece
      if (std::abs(0.5 * (p + q)) <= c) {
        const double q0 = R0 * R0 - p * p;
        return 0.5 * K * R0 * R0 * (p + q) / q0 * log1p_ratio(-(q - p) * (p + q) / q0);
      }
      return eval(L + 0.5 * (p + q), L, a).T;
    };
    MeanTension m;
    // Crossings of ±c between s0 and s1, in the order the step meets them.
    double cuts[2];
    int n = 0;
    for (double b : {-c, c})
      if ((s0 - b) * (s1 - b) < 0) cuts[n++] = b;
    if (n == 2 && s1 < s0) std::swap(cuts[0], cuts[1]);
    if (n == 0) {
      m.T = piece(s0, s1);
    } else {
      double from = s0;
      for (int k = 0; k <= n; ++k) {
        const double to = k < n ? cuts[k] : s1;
        m.T += (to - from) / dr * piece(from, to);
        from = to;
      }
    }
    m.dT1 = secant_slope(eval(r1, L, a).T, m.T, dr, R0 - c, [&] { return 0.5 * eval(0.5 * (r0 + r1), L, a).dT; });
    return m;
  }
  static double rest_stiffness(const LawArgs& a) { return a.strength; }
  static constexpr bool breaks = false;
  static double failure_stretch(double, const LawArgs&) { return std::numeric_limits<double>::infinity(); }
  static std::string_view invalid(const LawShape&) { return {}; }
};

}  // namespace qbond
