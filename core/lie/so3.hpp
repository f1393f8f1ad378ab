// SO(3) and so(3): hat, vee, exponential and logarithm (Modern Robotics §3.2).
#pragma once

#include <cmath>
#include <limits>

#include "core/lie/types.hpp"

namespace chasles {

/// How far from 1 a quaternion's norm may be for it to be taken as a rotation (and normalised):
/// one typed by hand or written with few digits is off by ~1e-5; one further off is a mistake (a
/// missing component, Euler angles, (x, y, z, w) order with a typo), refused rather than guessed
/// at. Every reader of a quaternion (the controller, the CLI, calibration datasets, the Python
/// client) holds it to this.
inline constexpr double kQuaternionNormTolerance = 1e-3;

/// The angle in (−π, π] equal to x modulo 2π: where a continuous joint at x is.
inline double wrap_angle(double x) {
  x = std::remainder(x, 2.0 * kPi);  // [−π, π]
  return x <= -kPi ? x + 2.0 * kPi : x;
}

namespace detail {
// Below this angle the Taylor series of the Rodrigues coefficients, kept to θ⁴, are exact to
// machine precision (the first dropped term is O(θ⁶)), while the closed forms lose digits to
// cancellation or divide 0 by 0. Derived from ε rather than picked.
inline double series_cutoff() {
  static const double cutoff = std::pow(std::numeric_limits<double>::epsilon(), 1.0 / 6.0);
  return cutoff;
}

// sin θ / θ, (1 − cos θ) / θ², (θ − sin θ) / θ³ — the coefficients of exp on SO(3) and SE(3).
struct RodriguesCoefficients {
  double a, b, c;
};

inline RodriguesCoefficients rodrigues_coefficients(double theta) {
  const double t2 = theta * theta;
  if (theta < series_cutoff()) {
    return {1.0 - t2 / 6.0 * (1.0 - t2 / 20.0), 0.5 - t2 / 24.0 * (1.0 - t2 / 30.0),
            1.0 / 6.0 - t2 / 120.0 * (1.0 - t2 / 42.0)};
  }
  const double s = std::sin(theta);
  // 1 − cos θ = 2 sin²(θ/2) has no cancellation at small θ.
  const double half_sin = std::sin(0.5 * theta);
  return {s / theta, 2.0 * half_sin * half_sin / t2, (theta - s) / (t2 * theta)};
}
}  // namespace detail

/// [ω]: the skew-symmetric matrix with [ω] x = ω × x (MR eq. 3.30).
template <typename Derived>
Matrix3d hat3(const Eigen::MatrixBase<Derived>& w) {
  Matrix3d W;
  W << 0.0, -w(2), w(1),  //
      w(2), 0.0, -w(0),   //
      -w(1), w(0), 0.0;
  return W;
}

/// ω from [ω]; reads the lower triangle only.
template <typename Derived>
Vector3d vee3(const Eigen::MatrixBase<Derived>& W) {
  return Vector3d(W(2, 1), W(0, 2), W(1, 0));
}

/// exp([ω]) by Rodrigues' formula for an angle θ = |ω| (MR eq. 3.51).
template <typename Derived>
Matrix3d exp3(const Eigen::MatrixBase<Derived>& w) {
  const double theta = w.norm();
  const auto k = detail::rodrigues_coefficients(theta);
  const Matrix3d W = hat3(w);
  return Matrix3d::Identity() + k.a * W + k.b * W * W;
}

/// Rotation by angle θ about a unit axis ω̂: cos θ I + sin θ [ω̂] + (1 − cos θ) ω̂ω̂ᵀ, the same
/// Rodrigues formula arranged for a known unit axis (the joint-motion hot path).
template <typename Derived>
CHASLES_ALWAYS_INLINE Matrix3d exp3_unit(const Eigen::MatrixBase<Derived>& w_hat, double theta) {
  const double s = std::sin(theta);
  const double c = std::cos(theta);
  const Vector3d w = w_hat;
  const Vector3d k = (1.0 - c) * w;
  Matrix3d R;
  R << c + k.x() * w.x(), k.x() * w.y() - s * w.z(), k.x() * w.z() + s * w.y(),  //
      k.y() * w.x() + s * w.z(), c + k.y() * w.y(), k.y() * w.z() - s * w.x(),   //
      k.z() * w.x() - s * w.y(), k.z() * w.y() + s * w.x(), c + k.z() * w.z();
  return R;
}

/// log(R) as exponential coordinates ω̂θ with θ ∈ [0, π] (MR algorithm 3.2), accurate at every
/// angle: θ from atan2 (not acos), the axis from the symmetric part of R once θ > π/2, where the
/// skew part vanishes.
template <typename Derived>
Vector3d log3(const Eigen::MatrixBase<Derived>& R) {
  const Vector3d skew(0.5 * (R(2, 1) - R(1, 2)), 0.5 * (R(0, 2) - R(2, 0)), 0.5 * (R(1, 0) - R(0, 1)));
  const double sin_theta = skew.norm();
  const double cos_theta = 0.5 * (R.trace() - 1.0);
  const double theta = std::atan2(sin_theta, cos_theta);

  if (cos_theta >= 0.0) {
    // θ / sin θ, by its series near 0.
    const double t2 = theta * theta;
    const double scale = theta < detail::series_cutoff() ? 1.0 + t2 / 6.0 + 7.0 * t2 * t2 / 360.0 : theta / sin_theta;
    return scale * skew;
  }
  // (R + Rᵀ)/2 = cos θ I + (1 − cos θ) ω̂ω̂ᵀ: read ω̂ from the column of the largest diagonal.
  const double one_minus_c = 1.0 - cos_theta;
  Eigen::Index k;
  R.diagonal().maxCoeff(&k);
  Vector3d w_hat;
  const double wk = std::sqrt(std::max(0.0, (R(k, k) - cos_theta) / one_minus_c));
  for (Eigen::Index j = 0; j < 3; ++j) {
    w_hat(j) = j == k ? wk : 0.5 * (R(j, k) + R(k, j)) / (one_minus_c * wk);
  }
  // The skew part is sin θ ω̂: it fixes the sign (at θ = π exactly both signs are correct).
  if (w_hat.dot(skew) < 0.0) w_hat = -w_hat;
  return theta * w_hat.normalized();
}

}  // namespace chasles
