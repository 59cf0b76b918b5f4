#pragma once
/// Basic numeric types shared by every qbond header.
#include <cstdint>

#include <Eigen/Dense>

namespace qbond {

/// Dense id of a quanta or a bond (creation order; stable for the user).
using Index = std::uint32_t;
/// The index that names nothing (no quanta, no bond, no slot yet).
inline constexpr Index kNone = ~Index{0};
/// 3-vector [SI units of whatever it holds].
using Vec3 = Eigen::Vector3d;
/// 3×3 matrix (bond stiffness and damping blocks, per-quanta solves).
using Mat3 = Eigen::Matrix3d;

}  // namespace qbond
