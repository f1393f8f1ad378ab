#include "core/model/inertia.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdio>

#include "core/lie/so3.hpp"
#include "core/number_text.hpp"

namespace chasles {
namespace {

std::string moments(const Vector3d& lambda) {
  return "(" + number_text(lambda(0)) + ", " + number_text(lambda(1)) + ", " + number_text(lambda(2)) + ") kg·m²";
}

}  // namespace

InertiaCheck check_inertia(double mass, const Matrix3d& I_c) {
  InertiaCheck check;
  if (!std::isfinite(mass) || !I_c.allFinite()) {
    check.problem = "mass or inertia is not finite";
    return check;
  }
  if (mass < 0.0) {
    check.problem = "mass " + number_text(mass) + " kg is negative";
    return check;
  }
  const Matrix3d I_sym = 0.5 * (I_c + I_c.transpose());
  check.principal_moments = Eigen::SelfAdjointEigenSolver<Matrix3d>(I_sym, Eigen::EigenvaluesOnly).eigenvalues();
  const Vector3d& lambda = check.principal_moments;
  const double largest = lambda.cwiseAbs().maxCoeff();
  const double floor = mass * InertiaTolerance::gyration_radius * InertiaTolerance::gyration_radius;
  check.tolerance = InertiaTolerance::relative * largest + floor;
  const std::string within = " (beyond the tolerance of " + number_text(check.tolerance) + " kg·m² = " +
                             number_text(InertiaTolerance::relative) + " × the largest moment + m·(1 µm)²)";
  if (mass == 0.0) {
    // No mass, no second moment: a massless frame carries no rotational inertia either.
    if (largest > 0.0) check.problem = "mass 0 but principal moments " + moments(lambda) + within;
    return check;
  }
  check.point_mass = lambda(2) <= floor;
  // λ ascending: Σ's smallest eigenvalue is (λ0 + λ1 − λ2) / 2, and λ0 < 0 is the worse failure.
  if (lambda(0) < -check.tolerance) {
    check.problem = "principal moments " + moments(lambda) + " include a negative one" + within;
  } else if (lambda(0) + lambda(1) - lambda(2) < -2.0 * check.tolerance) {
    check.problem = "principal moments " + moments(lambda) + " break the triangle inequality: " + number_text(lambda(0)) +
                    " + " + number_text(lambda(1)) + " < " + number_text(lambda(2)) + within;
  }
  return check;
}

Matrix3d inertia_about_centre_of_mass(double mass, const Vector3d& h, const Matrix3d& I) {
  if (mass <= 0.0) return I;
  const Matrix3d C = hat3(h / mass);
  return I + mass * C * C;  // I − m [c][c]ᵀ, with [c]ᵀ = −[c]
}

}  // namespace chasles
