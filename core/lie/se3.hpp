// SE(3) and se(3): hat, vee, exponential, logarithm, inverse, Adjoint and ad
// (Modern Robotics §3.3). Twists V = (ω, v), wrenches F = (m, f).
#pragma once

#include "core/lie/sincos.hpp"
#include "core/lie/so3.hpp"

namespace chasles {

/// [V] ∈ se(3) as a 4×4 matrix (MR eq. 3.70).
template <typename Derived>
Matrix4d hat6(const Eigen::MatrixBase<Derived>& V) {
  Matrix4d X = Matrix4d::Zero();
  X.topLeftCorner<3, 3>() = hat3(V.template head<3>());
  X.topRightCorner<3, 1>() = V.template tail<3>();
  return X;
}

/// V from [V]; reads only the entries hat6 writes.
template <typename Derived>
Vector6d vee6(const Eigen::MatrixBase<Derived>& X) {
  Vector6d V;
  V << vee3(X.template topLeftCorner<3, 3>()), X.template topRightCorner<3, 1>();
  return V;
}

/// A transform from a rotation and a translation (MR RpToTrans).
inline Transform make_transform(const Matrix3d& R, const Vector3d& p) { return Transform(R, p); }

/// exp([V]) for a twist V = (ω, v) taken over unit time, so θ = |ω| (MR eq. 3.88 with
/// G(θ) = Iθ + (1 − cos θ)[ω̂] + (θ − sin θ)[ω̂]² written for the unnormalised ω).
template <typename Derived>
Transform exp6(const Eigen::MatrixBase<Derived>& V) {
  const Vector3d w = V.template head<3>();
  const Vector3d v = V.template tail<3>();
  const auto k = detail::rodrigues_coefficients(w.norm());
  const Matrix3d W = hat3(w);
  const Matrix3d W2 = W * W;
  Transform T = Transform::Identity();
  T.linear() = Matrix3d::Identity() + k.a * W + k.b * W2;
  T.translation() = v + k.b * (W * v) + k.c * (W2 * v);
  return T;
}

namespace detail {
/// D(θ) = (1 − (θ/2)cot(θ/2))/θ², the [ω]² coefficient of G⁻¹ and of SO(3)'s inverse Jacobians;
/// finite up to and at θ = π, by its series below the cut-off.
inline double log_coefficient(double theta) {
  if (theta < series_cutoff()) {
    const double t2 = theta * theta;
    return 1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0;
  }
  const double half = 0.5 * theta;
  return (1.0 - half * std::cos(half) / std::sin(half)) / (theta * theta);
}
}  // namespace detail

/// log(T) as a twist V = (ω̂θ, vθ) with θ ∈ [0, π] (MR algorithm 3.3), using
/// G⁻¹(θ)θ = I − [ω]/2 + D(θ)[ω]², D = (1 − (θ/2)cot(θ/2))/θ², which stays finite at θ = π.
inline Vector6d log6(const Transform& T) {
  const Vector3d w = log3(T.linear());
  const double d = detail::log_coefficient(w.norm());
  const Matrix3d W = hat3(w);
  const Vector3d& p = T.translation();
  Vector6d V;
  V << w, p - 0.5 * (W * p) + d * (W * (W * p));
  return V;
}

/// T⁻¹ = (Rᵀ, −Rᵀp) (MR eq. 3.64).
inline Transform inverse(const Transform& T) {
  const Matrix3d Rt = T.linear().transpose();
  return make_transform(Rt, -(Rt * T.translation()));
}

/// [Ad_T] = [[R, 0], [[p]R, R]] (MR definition 3.20).
inline Matrix6d adjoint(const Transform& T) {
  const Matrix3d& R = T.linear();
  Matrix6d Ad;
  Ad << R, Matrix3d::Zero(), hat3(T.translation()) * R, R;
  return Ad;
}

/// [Ad_T] V without forming the 6×6 matrix: changes the frame of a twist or screw axis.
template <typename Derived>
CHASLES_ALWAYS_INLINE Vector6d adjoint_times(const Transform& T, const Eigen::MatrixBase<Derived>& V) {
  Vector6d out;
  out.head<3>().noalias() = T.linear() * V.template head<3>();
  out.tail<3>().noalias() = T.linear() * V.template tail<3>();
  out.tail<3>() += T.translation().cross(out.head<3>());
  return out;
}

/// [Ad_{T⁻¹}] V = [Ad_T]⁻¹ V without inverting T.
template <typename Derived>
CHASLES_ALWAYS_INLINE Vector6d adjoint_inverse_times(const Transform& T, const Eigen::MatrixBase<Derived>& V) {
  const Matrix3d& R = T.linear();
  const Vector3d w = V.template head<3>();
  const Vector3d v = V.template tail<3>() - T.translation().cross(w);
  // Rᵀ ω and Rᵀ v side by side, entry k of each in one SSE2 register (sincos.hpp's vector
  // extensions): one pass of 2-wide products and sums turns both halves, where Eigen's 3-vector
  // products run one lane at a time (RNEA's forward pass has two of these per joint).
  const detail::Double2 x[3] = {{w(0), v(0)}, {w(1), v(1)}, {w(2), v(2)}};
  Vector6d out;
  for (int k = 0; k < 3; ++k) {
    const detail::Double2 y = R(0, k) * x[0] + R(1, k) * x[1] + R(2, k) * x[2];
    out(k) = y[0];
    out(3 + k) = y[1];
  }
  return out;
}

/// [Ad_T]ᵀ F: moves a wrench F_b in frame b to frame a when T = T_ba (MR eq. 3.98).
template <typename Derived>
CHASLES_ALWAYS_INLINE Vector6d adjoint_transpose_times(const Transform& T, const Eigen::MatrixBase<Derived>& F) {
  const Matrix3d& R = T.linear();
  const Vector3d f = F.template tail<3>();
  const Vector3d m = F.template head<3>() + f.cross(T.translation());
  Vector6d out;
  out.head<3>().noalias() = R.transpose() * m;
  out.tail<3>().noalias() = R.transpose() * f;
  return out;
}

/// [Ad_{T⁻¹}]ᵀ F = (R m + p × R f, R f): moves a wrench F_b in frame b to frame a when T = T_ab.
template <typename Derived>
CHASLES_ALWAYS_INLINE Vector6d adjoint_inverse_transpose_times(const Transform& T, const Eigen::MatrixBase<Derived>& F) {
  Vector6d out;
  out.tail<3>().noalias() = T.linear() * F.template tail<3>();
  out.head<3>().noalias() = T.linear() * F.template head<3>();
  out.head<3>() += T.translation().cross(out.tail<3>());
  return out;
}

/// [ad_V] = [[ [ω], 0 ], [ [v], [ω] ]] (MR definition 8.1): the Lie bracket with V.
template <typename Derived>
Matrix6d ad(const Eigen::MatrixBase<Derived>& V) {
  const Matrix3d W = hat3(V.template head<3>());
  Matrix6d out;
  out << W, Matrix3d::Zero(), hat3(V.template tail<3>()), W;
  return out;
}

/// [ad_V1] V2 = (ω1 × ω2, ω1 × v2 + v1 × ω2) without forming the 6×6 matrix.
template <typename D1, typename D2>
CHASLES_ALWAYS_INLINE Vector6d ad_times(const Eigen::MatrixBase<D1>& V1, const Eigen::MatrixBase<D2>& V2) {
  const Vector3d w1 = V1.template head<3>();
  const Vector3d w2 = V2.template head<3>();
  Vector6d out;
  out.head<3>() = w1.cross(w2);
  out.tail<3>() = w1.cross(V2.template tail<3>()) + V1.template tail<3>().cross(w2);
  return out;
}

/// [ad_V]ᵀ F = (m × ω + f × v, f × ω): the velocity-product term of the Newton-Euler equations
/// (MR eq. 8.42).
template <typename D1, typename D2>
CHASLES_ALWAYS_INLINE Vector6d ad_transpose_times(const Eigen::MatrixBase<D1>& V, const Eigen::MatrixBase<D2>& F) {
  const Vector3d w = V.template head<3>();
  const Vector3d v = V.template tail<3>();
  const Vector3d m = F.template head<3>();
  const Vector3d f = F.template tail<3>();
  Vector6d out;
  out.head<3>() = m.cross(w) + f.cross(v);
  out.tail<3>() = f.cross(w);
  return out;
}

}  // namespace chasles
