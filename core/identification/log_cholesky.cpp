#include "core/identification/log_cholesky.hpp"

#include <Eigen/Eigenvalues>
#include <cstdio>
#include <string>

#include "core/model/inertia.hpp"

namespace chasles {

Vector10d inertia_from_log_cholesky(const Vector10d& theta) {
  Vector10d pi;
  inertia_from_log_cholesky(theta.data(), pi.data());
  return pi;
}

Eigen::Matrix4d pseudo_inertia(const Vector10d& pi) {
  const SpatialInertia G = spatial_inertia(pi);
  Eigen::Matrix4d J;
  J.topLeftCorner<3, 3>() = 0.5 * G.I.trace() * Matrix3d::Identity() - G.I;
  J.topRightCorner<3, 1>() = G.h;
  J.bottomLeftCorner<1, 3>() = G.h.transpose();
  J(3, 3) = G.mass;
  return J;
}

Vector10d log_cholesky_from_inertia(const Vector10d& pi) {
  char text[400];
  if (!pi.allFinite()) throw ArgumentError("log_cholesky_from_inertia: an inertial parameter is not finite");
  const double m = pi(0);
  if (!(m > 0.0)) {
    std::snprintf(text, sizeof(text),
                  "log_cholesky_from_inertia: mass %g kg is not positive; a body needs mass to have a pseudo-inertia "
                  "J ≻ 0",
                  m);
    throw ArgumentError(text);
  }
  // S = Σ_c / m, the second moment about the centre of mass per unit mass: J / m = [[S + t tᵀ, t], [tᵀ, 1]]
  // with t = h / m, so J ≻ 0 exactly when S ≻ 0 (its Schur complement).
  const Eigen::Matrix4d J = pseudo_inertia(pi) / m;
  const Vector3d t = J.topRightCorner<3, 1>();
  const Matrix3d S = J.topLeftCorner<3, 3>() - t * t.transpose();
  // S = W Wᵀ, W upper triangular: Cholesky from the last row and column up.
  const double e3_squared = S(2, 2);
  const double e3 = std::sqrt(std::max(e3_squared, 0.0));
  const double s23 = S(1, 2) / e3, s13 = S(0, 2) / e3;
  const double e2_squared = S(1, 1) - s23 * s23;
  const double e2 = std::sqrt(std::max(e2_squared, 0.0));
  const double s12 = (S(0, 1) - s13 * s23) / e2;
  const double e1_squared = S(0, 0) - s12 * s12 - s13 * s13;
  if (!(e3_squared > 0.0 && e2_squared > 0.0 && e1_squared > 0.0)) {
    const Matrix3d I_c = inertia_about_centre_of_mass(m, pi.segment<3>(1), spatial_inertia(pi).I);
    const Vector3d moments = Eigen::SelfAdjointEigenSolver<Matrix3d>(I_c, Eigen::EigenvaluesOnly).eigenvalues();
    std::snprintf(text, sizeof(text),
                  "log_cholesky_from_inertia: the rotational inertia about the centre of mass has principal moments "
                  "(%g, %g, %g) kg*m^2; a body needs each positive and less than the sum of the other two (strictly: "
                  "point masses, rods and plates are on the boundary the map cannot reach)",
                  moments(0), moments(1), moments(2));
    throw ArgumentError(text);
  }
  Vector10d theta;
  theta << 0.5 * std::log(m), 0.5 * std::log(e1_squared), std::log(e2), std::log(e3), s12, s23, s13, t;
  return theta;
}

}  // namespace chasles
