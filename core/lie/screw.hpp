// Screw axes {q, ŝ, h} and their twists; unit screw axis and exponential coordinates (S, θ)
// (Modern Robotics §3.3.2 and §3.3.3).
#pragma once

#include <limits>

#include "core/lie/se3.hpp"

namespace chasles {

/// A screw axis: a point q on the axis, the unit direction ŝ and the pitch h (m/rad).
/// h = ∞ is a pure translation along ŝ (q is then meaningless).
struct ScrewAxis {
  Vector3d q = Vector3d::Zero();
  Vector3d s = Vector3d::UnitZ();
  double h = 0.0;

  bool is_translation() const { return h == std::numeric_limits<double>::infinity(); }
};

/// The twist of a screw motion at rate θ̇: S θ̇ with S = (ŝ, −ŝ × q + hŝ), or (0, ŝ) for
/// h = ∞ (MR §3.3.2.2).
inline Vector6d twist_from_screw(const ScrewAxis& screw, double theta_dot = 1.0) {
  Vector6d S;
  if (screw.is_translation()) {
    S << Vector3d::Zero(), screw.s;
  } else {
    S << screw.s, -screw.s.cross(screw.q) + screw.h * screw.s;
  }
  return S * theta_dot;
}

/// The unit screw axis S and the magnitude θ of a twist V = Sθ (MR AxisAng6): |ω| = 1, or
/// ω = 0 and |v| = 1. A zero twist has no axis: S = 0, θ = 0.
struct ExponentialCoordinates {
  Vector6d S = Vector6d::Zero();
  double theta = 0.0;
};

template <typename Derived>
ExponentialCoordinates exponential_coordinates(const Eigen::MatrixBase<Derived>& V) {
  double theta = V.template head<3>().norm();
  if (theta == 0.0) theta = V.template tail<3>().norm();
  if (theta == 0.0) return {};
  return {V / theta, theta};
}

/// (S, θ) with exp([S]θ) = T, θ ∈ [0, π] for the rotation part.
inline ExponentialCoordinates exponential_coordinates(const Transform& T) { return exponential_coordinates(log6(T)); }

/// The screw axis of a twist: ŝ = ω/|ω|, h = ω·v/|ω|², q = ω × v/|ω|² (the point of the axis
/// nearest the origin); for ω = 0, a translation along v/|v|. The rate θ̇ is
/// exponential_coordinates(V).theta. A zero twist gives the default axis.
template <typename Derived>
ScrewAxis screw_from_twist(const Eigen::MatrixBase<Derived>& V) {
  const Vector3d w = V.template head<3>();
  const Vector3d v = V.template tail<3>();
  ScrewAxis screw;
  const double w2 = w.squaredNorm();
  if (w2 > 0.0) {
    screw.s = w / std::sqrt(w2);
    screw.h = w.dot(v) / w2;
    screw.q = w.cross(v) / w2;
  } else if (v.squaredNorm() > 0.0) {
    screw.s = v.normalized();
    screw.h = std::numeric_limits<double>::infinity();
  }
  return screw;
}

}  // namespace chasles
