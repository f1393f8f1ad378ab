// The recursive algorithms' view of joint i's local screw axis A_i: an AlignedRevoluteAxis<K>
// (lie/axis.hpp) when RobotModel::joint_axis says it is ±e_K, else a GeneralAxis over the 6-vector,
// both with the same few operations, so that one generic loop body serves both (as Pinocchio visits
// its joint variant).
#pragma once

#include <type_traits>

#include "core/lie/axis.hpp"
#include "core/lie/se3.hpp"
#include "core/model/model.hpp"

namespace chasles {

/// Any local screw axis A (a prismatic joint's, an oblique revolute one's), by the general
/// 6-vector operations.
struct GeneralAxis {
  const Vector6d& A;

  /// Aᵀ F.
  CHASLES_ALWAYS_INLINE double dot(const Vector6d& F) const { return A.dot(F); }
  /// V ← V + A x.
  CHASLES_ALWAYS_INLINE void add_times(Vector6d& V, double x) const { V += A * x; }
  /// out ← out + [ad_V] A x.
  CHASLES_ALWAYS_INLINE void add_ad_times(Vector6d& out, const Vector6d& V, double x) const {
    out += chasles::ad_times(V, A * x);
  }
  /// [Ad_T] A for T = (R, p).
  CHASLES_ALWAYS_INLINE Vector6d adjoint(const Matrix3d& R, const Vector3d& p) const {
    Vector6d out;
    out.head<3>().noalias() = R * A.head<3>();
    out.tail<3>().noalias() = R * A.tail<3>();
    out.tail<3>() += p.cross(out.head<3>());
    return out;
  }
};

template <class Axis>
inline constexpr bool is_general_axis = std::is_same_v<std::decay_t<Axis>, GeneralAxis>;

/// Calls f(axis) with joint i's axis as an AlignedRevoluteAxis<K> or a GeneralAxis.
template <class F>
CHASLES_ALWAYS_INLINE decltype(auto) visit_axis(const RobotModel& model, int i, F&& f) {
  const JointAxis& a = model.joint_axis(i);
  switch (a.kind) {
    case AxisKind::RevoluteX: return f(AlignedRevoluteAxis<0>{a.sign});
    case AxisKind::RevoluteY: return f(AlignedRevoluteAxis<1>{a.sign});
    case AxisKind::RevoluteZ: return f(AlignedRevoluteAxis<2>{a.sign});
    case AxisKind::General: break;
  }
  return f(GeneralAxis{model.local_axis(i)});
}

/// A placement rotation (RobotModel::placement_rotation) about e_K by the angle of (c, s).
template <int K>
struct AxisPlacement {
  double c, s;
  /// R M, M this rotation: two columns of R turned.
  CHASLES_ALWAYS_INLINE const Matrix3d& after(const Matrix3d& R, Matrix3d& out) const {
    rotate_about_axis<K>(R, c, s, out);
    return out;
  }
};

/// A placement rotation (RobotModel::placement_rotation) by a quarter turn about e_K, s = ±1: R M
/// is two columns of R swapped, one negated (by s).
template <int K>
struct QuarterPlacement {
  double s;
  CHASLES_ALWAYS_INLINE const Matrix3d& after(const Matrix3d& R, Matrix3d& out) const {
    constexpr int I = (K + 1) % 3, J = (K + 2) % 3;
    out.col(I) = s * R.col(J);
    out.col(J) = -s * R.col(I);
    out.col(K) = R.col(K);
    return out;
  }
};

/// The identity placement rotation: R M is R.
struct IdentityPlacement {
  CHASLES_ALWAYS_INLINE const Matrix3d& after(const Matrix3d& R, Matrix3d&) const { return R; }
};

/// Any other placement rotation M, by the 3×3 product.
struct GeneralPlacement {
  const Matrix3d& M;
  CHASLES_ALWAYS_INLINE const Matrix3d& after(const Matrix3d& R, Matrix3d& out) const {
    out.noalias() = R * M;
    return out;
  }
};

/// Calls f(placement) with joint i's placement rotation as an AxisPlacement<K>, a
/// QuarterPlacement<K>, an IdentityPlacement or a GeneralPlacement.
template <class F>
CHASLES_ALWAYS_INLINE decltype(auto) visit_placement(const RobotModel& model, int i, F&& f) {
  const PlacementRotation& p = model.placement_rotation(i);
  switch (p.kind) {
    case PlacementKind::RotationX: return f(AxisPlacement<0>{p.c, p.s});
    case PlacementKind::RotationY: return f(AxisPlacement<1>{p.c, p.s});
    case PlacementKind::RotationZ: return f(AxisPlacement<2>{p.c, p.s});
    case PlacementKind::QuarterX: return f(QuarterPlacement<0>{p.s});
    case PlacementKind::QuarterY: return f(QuarterPlacement<1>{p.s});
    case PlacementKind::QuarterZ: return f(QuarterPlacement<2>{p.s});
    case PlacementKind::Identity: return f(IdentityPlacement{});
    case PlacementKind::General: break;
  }
  return f(GeneralPlacement{model.joint(i).T_parent_joint.linear()});
}

}  // namespace chasles
