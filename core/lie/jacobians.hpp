// The Jacobians of SO(3) and SE(3): how the logarithm moves when a small twist is applied, and
// how the exponential moves when its coordinates do. (ω, v) order throughout; right Jacobians act
// on body-frame increments: exp(ξ + δ) ≈ exp(ξ) exp(Jr(ξ) δ) and log(T e^[η]) ≈ log T + Jr⁻¹ η
// (Barfoot, *State Estimation for Robotics*, §7.1.5 and §7.2.5, reordered for angular first).
// IK (Jr⁻¹ of the pose error) and calibration (Jr of the parameter twists) both need them.
#pragma once

#include "core/lie/se3.hpp"

namespace chasles {

/// Jl(φ) of SO(3) = I + b[φ] + c[φ]², b = (1 − cos θ)/θ², c = (θ − sin θ)/θ³; Jr(φ) = Jl(−φ).
inline Matrix3d so3_left_jacobian(const Vector3d& phi) {
  const auto k = detail::rodrigues_coefficients(phi.norm());
  const Matrix3d P = hat3(phi);
  return Matrix3d::Identity() + k.b * P + k.c * (P * P);
}

/// Jl⁻¹(φ) = I − [φ]/2 + D(θ)[φ]², with log6's D, finite up to and at θ = π (Barfoot eq. 7.45).
inline Matrix3d so3_left_jacobian_inverse(const Vector3d& phi) {
  const double d = detail::log_coefficient(phi.norm());
  const Matrix3d P = hat3(phi);
  return Matrix3d::Identity() - 0.5 * P + d * (P * P);
}

/// Jr⁻¹(φ) = Jl⁻¹(−φ): log(R e^[ω]) ≈ log R + Jr⁻¹(log R) ω.
inline Matrix3d so3_right_jacobian_inverse(const Vector3d& phi) { return so3_left_jacobian_inverse(-phi); }

namespace detail {
// Below this angle the coefficients of Q take their Taylor series (to θ⁴; the first dropped term
// is O(θ⁶) ≈ 1e-6 relative to the leading one at the cut-off, below 1e-11 absolute). Above it the
// closed forms, whose worst cancellation ((2θ − 3 sin θ + θ cos θ)/θ⁵) loses ~1e-10 relative
// here: plenty for a Jacobian.
inline constexpr double kQSeriesCutoff = 0.1;
}  // namespace detail

/// Q(φ, ρ), the off-diagonal block of SE(3)'s left Jacobian (Barfoot eq. 7.86).
inline Matrix3d se3_q(const Vector3d& phi, const Vector3d& rho) {
  const double theta = phi.norm();
  const double t2 = theta * theta;
  double c1, c2, c3;
  if (theta < detail::kQSeriesCutoff) {
    c1 = 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0;      // (θ − sin θ)/θ³
    c2 = 1.0 / 24.0 - t2 / 720.0 + t2 * t2 / 40320.0;    // (θ² + 2 cos θ − 2)/(2θ⁴)
    c3 = 1.0 / 120.0 - t2 / 2520.0 + t2 * t2 / 120960.0;  // (2θ − 3 sin θ + θ cos θ)/(2θ⁵)
  } else {
    const double s = std::sin(theta), c = std::cos(theta);
    c1 = (theta - s) / (t2 * theta);
    c2 = (t2 + 2.0 * c - 2.0) / (2.0 * t2 * t2);
    c3 = (2.0 * theta - 3.0 * s + theta * c) / (2.0 * t2 * t2 * theta);
  }
  const Matrix3d P = hat3(phi), X = hat3(rho);
  const Matrix3d PX = P * X, XP = X * P, PXP = PX * P, PP = P * P;
  return 0.5 * X + c1 * (PX + XP + PXP) + c2 * (PP * X + X * PP - 3.0 * PXP) + c3 * (PXP * P + P * PXP);
}

/// Jr(ξ) of SE(3) for ξ = (φ, ρ): Jr(ξ) = Jl(−ξ) = [[Jl3(−φ), 0], [Q(−φ, −ρ), Jl3(−φ)]].
inline Matrix6d se3_right_jacobian(const Vector6d& xi) {
  const Vector3d phi = -xi.head<3>(), rho = -xi.tail<3>();
  const Matrix3d J = so3_left_jacobian(phi);
  Matrix6d out;
  out << J, Matrix3d::Zero(), se3_q(phi, rho), J;
  return out;
}

/// Jr⁻¹(ξ) of SE(3): Jl⁻¹ = [[Jl3⁻¹, 0], [−Jl3⁻¹ Q Jl3⁻¹, Jl3⁻¹]] at −ξ (Barfoot eq. 7.95).
inline Matrix6d se3_right_jacobian_inverse(const Vector6d& xi) {
  const Vector3d phi = -xi.head<3>(), rho = -xi.tail<3>();
  const Matrix3d Jinv = so3_left_jacobian_inverse(phi);
  Matrix6d out;
  out.topLeftCorner<3, 3>() = Jinv;
  out.topRightCorner<3, 3>().setZero();
  out.bottomLeftCorner<3, 3>() = -Jinv * se3_q(phi, rho) * Jinv;
  out.bottomRightCorner<3, 3>() = Jinv;
  return out;
}

}  // namespace chasles
