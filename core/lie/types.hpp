// Fixed-size types of the Lie-group layer. Twists and screw axes are (ω, v), angular first;
// wrenches are (m, f) (Lynch & Park, Modern Robotics).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace chasles {

using Vector3d = Eigen::Vector3d;
using Matrix3d = Eigen::Matrix3d;
using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Matrix4d = Eigen::Matrix4d;
// A rigid transform T_ab: rotation R_ab and translation p_ab. Eigen's Isometry3d multiplies and
// inverts as a rigid transform (no general 4x4 arithmetic).
using Transform = Eigen::Isometry3d;

// The 6-vector helpers of the recursive algorithms are a few flops each; called out of line their
// results travel through the stack, which the benchmarks showed costing more than the arithmetic.
#define CHASLES_ALWAYS_INLINE inline __attribute__((always_inline))

inline constexpr double kPi = 3.141592653589793238462643383279502884;

}  // namespace chasles
