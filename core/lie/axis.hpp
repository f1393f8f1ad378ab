// A revolute screw axis along ±x, ±y or ±z of its frame, A = (σ e_K, 0) with σ = ±1: the local
// axis of nearly every URDF revolute joint. Its products with twists, wrenches and rotations pick
// or swap entries, a few flops where the general 6-vector operations of se3.hpp take dozens
// (Pinocchio's JointModelRX/RY/RZ do the same).
#pragma once

#include "core/lie/types.hpp"

namespace chasles {

/// R Rot_K(θ) from c = cos θ and s = sin θ, Rot_K the rotation about e_K: only columns I and J of R
/// turn (MR eq. 3.51 about a coordinate axis), 12 multiplications against 27 for a 3×3 product.
template <int K>
CHASLES_ALWAYS_INLINE void rotate_about_axis(const Matrix3d& R, double c, double s, Matrix3d& out) {
  constexpr int I = (K + 1) % 3, J = (K + 2) % 3;
  out.col(I) = c * R.col(I) + s * R.col(J);
  out.col(J) = c * R.col(J) - s * R.col(I);
  out.col(K) = R.col(K);
}

template <int K>
struct AlignedRevoluteAxis {
  static_assert(K >= 0 && K < 3, "K is the axis index: 0 = x, 1 = y, 2 = z");
  // e_K × e_I = e_J, e_I × e_J = e_K: the other two indices in cyclic order.
  static constexpr int kIndex = K;
  static constexpr int I = (K + 1) % 3;
  static constexpr int J = (K + 2) % 3;

  double sign = 1.0;  ///< σ = ±1

  /// Aᵀ F: the joint's share of a wrench (its K-th moment).
  CHASLES_ALWAYS_INLINE double dot(const Vector6d& F) const { return sign * F(K); }

  /// V ← V + A x, A x being the twist of a unit-rate joint scaled by x: one entry. In place: a
  /// whole 6-vector A x added to V took inverse dynamics 25 % longer.
  CHASLES_ALWAYS_INLINE void add_times(Vector6d& V, double x) const { V(K) += sign * x; }

  /// out ← out + [ad_V] A x, [ad_V] A x = (ω × a, v × a) x (MR definition 8.1) with
  /// w × e_K = (…, w_J, −w_I) at (I, J): four entries.
  CHASLES_ALWAYS_INLINE void add_ad_times(Vector6d& out, const Vector6d& V, double x) const {
    const double u = sign * x;
    out(I) += V(J) * u;
    out(J) -= V(I) * u;
    out(3 + I) += V(3 + J) * u;
    out(3 + J) -= V(3 + I) * u;
  }

  /// R exp([a] θ) from c = cos θ and s = sin θ: 12 flops against 45 for Rodrigues and a 3×3
  /// product.
  CHASLES_ALWAYS_INLINE void rotate(const Matrix3d& R, double c, double s, Matrix3d& out) const {
    rotate_about_axis<K>(R, c, sign * s, out);
  }

  /// [Ad_T] A = (R a, p × R a) for T = (R, p): the axis seen from another frame (MR definition
  /// 3.20); R a is a column of R.
  CHASLES_ALWAYS_INLINE Vector6d adjoint(const Matrix3d& R, const Vector3d& p) const {
    const Vector3d w = sign * R.col(K);
    Vector6d out;
    out.head<3>() = w;
    out.tail<3>() = p.cross(w);
    return out;
  }
};

}  // namespace chasles
