#pragma once
/// Bond force laws (Eqs. 2–3 and the laws of registry.hpp): a law supplies the scalar tension T(r), its derivative T'(r) and the
/// potential U(r) with U' = T (registry.hpp lists them); forces, stiffness and damping blocks are
/// generic over laws. Sign convention: positive tension pulls the two quanta together.
#include <algorithm>
#include <cmath>
#include <string_view>

#include "qbond/core/math.hpp"
#include "qbond/laws/registry.hpp"

namespace qbond {

/// How a bond damps relative motion of its ends.
enum class DampingModel : std::uint8_t {
  axial,      ///< f_i += D ((v_j - v_i)·u) u: damps stretching only, conserves angular momentum.
  isotropic,  ///< f_i += D (v_j - v_i): Eq. 2 literally; also damps rigid rotation.
};

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
/// Bonds::force_on_i gives a bond's.
inline Vec3 bond_force_on_i(Law law, DampingModel model, const Vec3& d, const Vec3& w, double L, double D,
                            const LawArgs& a) {
  const double r = d.norm();
  if (!(r > 0)) return Vec3::Zero();
  const double inv_r = 1.0 / r;  // one division: u = d / r is applied as d · (1/r)
  const double T = evaluate_law(law, r, L, a).T;
  if (model == DampingModel::axial) return ((T + D * w.dot(d) * inv_r) * inv_r) * d;
  return (T * inv_r) * d + D * w;
}

/// Name of a damping model as written in scene files.
std::string_view to_string(DampingModel model);

}  // namespace qbond
