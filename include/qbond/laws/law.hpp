#pragma once
/// What every bond force law provides and reads (docs/materials.md, "Force laws"): a scalar
/// tension T(r), its derivative T'(r), the potential U(r) with U' = T, and the discrete-gradient
/// mean tension of a step. Sign convention: positive tension pulls the two quanta together.
#include <array>
#include <cmath>
#include <limits>
#include <string_view>

namespace qbond {

/// Tension, its derivative and the potential of one law at one length.
struct LawValue {
  double T = 0;   ///< tension [N], positive pulls together
  double dT = 0;  ///< dT/dr [N/m]
  double U = 0;   ///< potential energy [J], U(L) = 0
};

/// Mean tension over a step in which the bond's length goes from r0 to r1 — the discrete
/// gradient T̄ = (U(r1) − U(r0)) / (r1 − r0), so that T̄ (r1 − r0) is exactly the change of the
/// bond's energy (the energy–momentum integrator, Gonzalez 1996) — and dT̄/dr1 (for its Newton
/// steps). Each law writes it without the cancellation of the quotient: T̄ → T(r) as r1 → r0.
struct MeanTension {
  double T = 0;    ///< T̄ [N]
  double dT1 = 0;  ///< ∂T̄/∂r1 [N/m]
};

/// Most shape parameters a law has (those besides its per-bond strength).
inline constexpr std::size_t kMaxLawShape = 2;
/// A row of the model's table of shape parameters (Model::shapes), in the order the law declares
/// them; 0 stands for a parameter's default where it has one.
using LawShape = std::array<double, kMaxLawShape>;

/// What a law reads of one bond: its strength (Bonds::strength), the rest length it was made
/// with (Bonds::rest0, for defaults relative to it) and its row of shape parameters.
struct LawArgs {
  double strength = 0;
  double rest0 = 0;
  LawShape shape{};
};

/// One parameter of a law as a scene gives it.
struct LawParam {
  std::string_view key;   ///< its key in a scene's material
  std::string_view unit;  ///< SI unit, as docs write it ("1" for a ratio)
  std::string_view doc;   ///< what it is, one line (the scene reader's errors quote it)
  /// Default as docs write it; empty: the parameter is required. A defaulted parameter is stored
  /// as 0 and resolved by the law (its default may depend on the rest length).
  std::string_view fallback = {};
  /// What the docs' table says of it after `doc`: its behaviour at its bounds, what it implies.
  std::string_view note = {};
};

/// ∂T̄/∂r1 = (T(r1) − T̄)/dr where that quotient keeps its digits, else its limit T'(r̄)/2 (the
/// quotient's round-off grows as scale/dr: below dr = 1e-5 scale the limit is the closer one).
/// `scale` is the length over which the law's tension changes; `half_dT_mid()` gives T'(r̄)/2.
template <class HalfSlope>
double secant_slope(double T1, double mean, double dr, double scale, HalfSlope half_dT_mid) {
  return std::abs(dr) > 1e-5 * scale ? (T1 - mean) / dr : half_dT_mid();
}

/// log1p(z)/z, from its series where z is small (the quotient loses digits there).
inline double log1p_ratio(double z) {
  return std::abs(z) < 1e-4 ? 1 - z * (0.5 - z * (1.0 / 3 - 0.25 * z)) : std::log1p(z) / z;
}

}  // namespace qbond
