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
/// A rigid transform T_ab ∈ SE(3): the pose of frame b in frame a, rotation R_ab and translation
/// p_ab. Stored as the two (no 4×4 matrix with a constant bottom row), like Sophus's SE3 and
/// Pinocchio's SE3, so that every product is a plain fixed-size 3×3 or 3×1 operation; the
/// interface is the part of Eigen::Isometry3d the code uses.
class Transform {
 public:
  /// The identity.
  Transform() : R_(Matrix3d::Identity()), p_(Vector3d::Zero()) {}
  Transform(const Matrix3d& R, const Vector3d& p) : R_(R), p_(p) {}
  static Transform Identity() { return Transform(); }

  Matrix3d& linear() { return R_; }
  const Matrix3d& linear() const { return R_; }
  Vector3d& translation() { return p_; }
  const Vector3d& translation() const { return p_; }

  /// The homogeneous 4×4 matrix [[R, p], [0, 1]].
  Matrix4d matrix() const {
    Matrix4d T = Matrix4d::Identity();
    T.topLeftCorner<3, 3>() = R_;
    T.topRightCorner<3, 1>() = p_;
    return T;
  }

  /// T_ab T_bc = T_ac.
  Transform operator*(const Transform& other) const {
    Transform out;
    out.R_.noalias() = R_ * other.R_;
    out.p_.noalias() = R_ * other.p_;
    out.p_ += p_;
    return out;
  }

  /// Maps a point given in frame b to frame a.
  Vector3d operator*(const Vector3d& point) const { return R_ * point + p_; }

 private:
  Matrix3d R_;
  Vector3d p_;
};

// The 6-vector helpers of the recursive algorithms are a few flops each; called out of line their
// results travel through the stack, which the benchmarks showed costing more than the arithmetic.
#define CHASLES_ALWAYS_INLINE inline __attribute__((always_inline))
// On a whole algorithm (an RNEA pass, the CRBA): inline every call in it, Eigen's own expression
// helpers included. In functions this long GCC's inliner otherwise leaves some of them out of line
// (a 6-vector sum, the composite-inertia sum), and the profile showed 10–15 % of the time in those calls.
// Not under AddressSanitizer (GCC says so with __SANITIZE_ADDRESS__, clang with __has_feature): there
// it inlines the instrumented body of every helper into one function, which GCC 12 compiled in 206 s
// of CPU instead of 20 s (dynamics.cpp, -O1) and which ran twice as slow as the calls it replaces
// (contact_loop_test, compliance_test). It is a hint about speed only; the sanitized builds check the
// same code without it.
#if defined(__SANITIZE_ADDRESS__)
#define CHASLES_NO_FLATTEN
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define CHASLES_NO_FLATTEN
#endif
#endif
#ifdef CHASLES_NO_FLATTEN
#define CHASLES_FLATTEN
#else
#define CHASLES_FLATTEN __attribute__((flatten))
#endif

inline constexpr double kPi = 3.141592653589793238462643383279502884;

}  // namespace chasles
