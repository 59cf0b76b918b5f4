#pragma once
/// Bond force laws (Eqs. 2–3): a law supplies the scalar tension T(r), its derivative T'(r) and the
/// potential U(r) with U' = T; forces, stiffness and damping blocks are generic over laws.
/// Sign convention: positive tension pulls the two quanta together.
#include <algorithm>
#include <cmath>
#include <string_view>

#include "qbond/core/math.hpp"

namespace qbond {

/// Which scalar law a bond follows.
enum class Law : std::uint8_t {
  linear,   ///< Eq. 2: T = k (r - L), U = k (r - L)^2 / 2; `stiffness` is k [N/m].
  inverse,  ///< Eq. 3 regularised: T = F s / (s^2 + eps^2), s = r - L; `stiffness` is F [N].
};

/// How a bond damps relative motion of its ends.
enum class DampingModel : std::uint8_t {
  axial,      ///< f_i += D ((v_j - v_i)·u) u: damps stretching only, conserves angular momentum.
  isotropic,  ///< f_i += D (v_j - v_i): Eq. 2 literally; also damps rigid rotation.
};

/// Default regularisation length of the inverse law as a fraction of the rest length.
inline constexpr double kDefaultInverseEpsFraction = 0.05;

/// Tension, its derivative and the potential of one law at one length.
struct LawValue {
  double T = 0;   ///< tension [N], positive pulls together
  double dT = 0;  ///< dT/dr [N/m]
  double U = 0;   ///< potential energy [J], U(L) = 0
};

/// Evaluates a law at length r for rest length L, strength (k or F) and regularisation eps.
inline LawValue evaluate_law(Law law, double r, double L, double strength, double eps) {
  const double s = r - L;
  switch (law) {
    case Law::linear:
      return {strength * s, strength, 0.5 * strength * s * s};
    case Law::inverse: {
      // T = F s/(s²+ε²): slope F/ε² at rest, peak F/(2ε) at |s| = ε, Eq. 3's F/s for |s| ≫ ε.
      const double e2 = eps * eps;
      const double q = s * s + e2;
      return {strength * s / q, strength * (e2 - s * s) / (q * q), 0.5 * strength * std::log1p(s * s / e2)};
    }
  }
  return {};
}

/// Mean tension over a step in which the bond's length goes from r0 to r1 — the discrete
/// gradient T̄ = (U(r1) − U(r0)) / (r1 − r0), so that T̄ (r1 − r0) is exactly the change of the
/// bond's energy (the energy–momentum integrator, Gonzalez 1996) — and dT̄/dr1 (for its Newton
/// steps). Written per law without the cancellation of the quotient: T̄ → T(r) as r1 → r0.
struct MeanTension {
  double T = 0;     ///< T̄ [N]
  double dT1 = 0;   ///< ∂T̄/∂r1 [N/m]
};
inline MeanTension mean_tension(Law law, double r0, double r1, double L, double strength, double eps) {
  const double dr = r1 - r0;
  switch (law) {
    case Law::linear:
      // U quadratic in r: the quotient is T at the mean length, exactly.
      return {strength * (0.5 * (r0 + r1) - L), 0.5 * strength};
    case Law::inverse: {
      // U = F/2 log(1 + s²/ε²): U1 − U0 = F/2 log1p(z), z = (s1² − s0²)/(s0² + ε²) = dr (s0+s1)/q0,
      // so T̄ = F/2 (s0+s1)/q0 · log1p(z)/z, with log1p(z)/z from its series where z is small.
      const double s0 = r0 - L, s1 = r1 - L, q0 = s0 * s0 + eps * eps;
      const double z = dr * (s0 + s1) / q0;
      const double l = std::abs(z) < 1e-4 ? 1 - z * (0.5 - z * (1.0 / 3 - 0.25 * z)) : std::log1p(z) / z;
      MeanTension m{0.5 * strength * (s0 + s1) / q0 * l, 0};
      // ∂T̄/∂r1 = (T(r1) − T̄)/dr; below dr ~ 1e-5 ε the quotient loses digits and its limit
      // T'(r̄)/2 is closer than O((dr/ε)²).
      if (std::abs(dr) > 1e-5 * eps)
        m.dT1 = (evaluate_law(law, r1, L, strength, eps).T - m.T) / dr;
      else
        m.dT1 = 0.5 * evaluate_law(law, 0.5 * (r0 + r1), L, strength, eps).dT;
      return m;
    }
  }
  return {};
}

/// The two coefficients of a bond's stiffness block K_b = axial u uᵀ + transverse (I − u uᵀ):
/// for a law axial = T' and transverse = T/r (the Newton integrators add their damper's turning
/// and scale both by where in the step they evaluate forces). ka() and kb() give the same block
/// as ka u uᵀ + kb I, the form the solvers store.
struct StiffnessCoefficients {
  double axial = 0, transverse = 0;
  [[gnu::always_inline]] double ka() const { return axial - transverse; }
  [[gnu::always_inline]] double kb() const { return transverse; }
};

/// K_b's coefficients clamped at 0, so that the block is positive semi-definite (compression and
/// softening make it indefinite) for the implicit solvers; the force itself stays exact. Every
/// clamped K_b in qbond, scalar or lane-wise, takes its coefficients from here.
[[gnu::always_inline]] inline StiffnessCoefficients clamped_stiffness(double axial, double transverse) {
  // Always inlined, the transverse clamp first: the vectorised kernels then compile as they did
  // with the two clamps written in place.
  const double t = std::max(transverse, 0.0);
  return {std::max(axial, 0.0), t};
}

/// K_b's coefficients, clamped (clamped_stiffness) when `clamp_for_solver`.
inline StiffnessCoefficients stiffness_coefficients(double axial, double transverse, bool clamp_for_solver) {
  return clamp_for_solver ? clamped_stiffness(axial, transverse) : StiffnessCoefficients{axial, transverse};
}

/// Stiffness block K_b = T' u uᵀ + (T/r)(I - u uᵀ), with df_i/dx_i = -K_b and df_i/dx_j = +K_b
/// (clamped as stiffness_coefficients says).
inline Mat3 stiffness_block(double T, double dT, double r, const Vec3& u, bool clamp_for_solver) {
  const StiffnessCoefficients k = stiffness_coefficients(dT, r > 0 ? T / r : 0.0, clamp_for_solver);
  const Mat3 uu = u * u.transpose();
  return k.axial * uu + k.transverse * (Mat3::Identity() - uu);
}

/// Damping block C_b with df_i/dv_i = -C_b and df_i/dv_j = +C_b.
inline Mat3 damping_block(DampingModel model, double D, const Vec3& u) {
  return model == DampingModel::axial ? Mat3(D * u * u.transpose()) : Mat3(D * Mat3::Identity());
}

/// Total force of a bond on its first quanta i (the force on j is exactly its negative).
/// d = x_j - x_i, w = v_j - v_i. A zero-length bond has no direction and exerts no force.
inline Vec3 bond_force_on_i(Law law, DampingModel model, const Vec3& d, const Vec3& w, double L,
                            double strength, double D, double eps) {
  const double r = d.norm();
  if (!(r > 0)) return Vec3::Zero();
  const double inv_r = 1.0 / r;  // one division: u = d / r is applied as d · (1/r)
  const double T = evaluate_law(law, r, L, strength, eps).T;
  if (model == DampingModel::axial) return ((T + D * w.dot(d) * inv_r) * inv_r) * d;
  return (T * inv_r) * d + D * w;
}

/// Name of a law as written in scene files.
std::string_view to_string(Law law);
/// Name of a damping model as written in scene files.
std::string_view to_string(DampingModel model);

}  // namespace qbond
