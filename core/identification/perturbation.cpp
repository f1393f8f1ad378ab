#include "core/identification/perturbation.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdio>
#include <random>

#include "core/error.hpp"
#include "core/lie/so3.hpp"
#include "core/model/inertia.hpp"

namespace chasles {
namespace {

// [−1, 1) from the top 53 bits: every value a multiple of 2⁻⁵², the same on every platform.
double symmetric_unit(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-52 - 1.0; }

}  // namespace

Vector10d perturbed_body_parameters(const Vector10d& pi, double fraction, const Vector10d& u) {
  const double m = pi(0);
  if (!(m > 0.0)) return pi;
  const SpatialInertia G = spatial_inertia(pi);
  const Vector3d c = G.h / m;
  const Matrix3d I_c = inertia_about_centre_of_mass(m, G.h, G.I);
  const Matrix3d Sigma_c = 0.5 * I_c.trace() * Matrix3d::Identity() - I_c;  // model/inertia.hpp
  const Eigen::SelfAdjointEigenSolver<Matrix3d> principal(Sigma_c);
  const double rho = std::sqrt(std::max(Sigma_c.trace(), 0.0) / m);

  const double m_new = m * (1.0 + fraction * u(0));
  const Vector3d c_new = c + fraction * rho * u.segment<3>(1);
  const Vector3d sigma_new = principal.eigenvalues().cwiseProduct(Vector3d::Ones() + fraction * u.segment<3>(4));
  // The axis from (z, φ) uniform on [−1, 1) × [−π, π): uniform on the sphere (Archimedes).
  const double z = u(7), phi = kPi * u(8), r = std::sqrt(std::max(1.0 - z * z, 0.0));
  const Vector3d axis(r * std::cos(phi), r * std::sin(phi), z);
  const Matrix3d R = exp3(fraction * u(9) * axis) * principal.eigenvectors();
  const Matrix3d Sigma_new = R * sigma_new.asDiagonal() * R.transpose();
  // Back to π: I_c = tr(Σ) 1 − Σ, then about the frame's origin, I = I_c + m([c]ᵀ[c]) (MR eq. 8.32).
  const Matrix3d I_c_new = Sigma_new.trace() * Matrix3d::Identity() - Sigma_new;
  SpatialInertia perturbed;
  perturbed.mass = m_new;
  perturbed.h = m_new * c_new;
  perturbed.I = I_c_new + m_new * (c_new.squaredNorm() * Matrix3d::Identity() - c_new * c_new.transpose());
  return body_parameters(perturbed);
}

RobotModel with_perturbed_inertias(const RobotModel& model, double fraction, uint64_t seed) {
  if (!(fraction >= 0.0 && fraction < 1.0)) {
    char text[200];
    std::snprintf(text, sizeof(text),
                  "with_perturbed_inertias: fraction %g is not in [0, 1): a mass scaled by 1 - fraction must stay "
                  "positive",
                  fraction);
    throw ArgumentError(text);
  }
  std::mt19937_64 rng(seed);
  Eigen::MatrixXd parameters = inertial_parameters(model);
  for (Eigen::Index i = 0; i < parameters.rows(); ++i) {
    Vector10d u;
    for (double& x : u) x = symmetric_unit(rng);
    parameters.row(i) = perturbed_body_parameters(parameters.row(i).transpose(), fraction, u).transpose();
  }
  return with_inertial_parameters(model, parameters);
}

}  // namespace chasles
