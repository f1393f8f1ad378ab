// The log-Cholesky parametrisation of a rigid body: round trips θ → π → θ and π → θ → π on random
// bodies and on the arms' own links, every θ physical, non-physical π refused with the reason, and
// the templated map's derivative (what Ceres differentiates) against central differences.
#include "core/identification/log_cholesky.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <iomanip>
#include <iostream>
#include <limits>
#include <random>
#include <unsupported/Eigen/AutoDiff>

#include "core/lie/so3.hpp"
#include "core/model/inertia.hpp"
#include "core/model/urdf.hpp"
#include "support/reference.hpp"

namespace chasles {
namespace {

using testing::relative_error;

// A random body with J ≻ 0: mass in [0.1, 10] kg, centre of mass within 0.5 m, and a second moment
// about it Σ_c = m R diag(σ) Rᵀ with σ in [1e-4, 1e-1] m² (a body 2 cm to 60 cm across).
Vector10d random_body(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> normal;
  const double m = 0.1 + 9.9 * unit(rng);
  const Vector3d c(unit(rng) - 0.5, unit(rng) - 0.5, unit(rng) - 0.5);
  const Vector3d sigma(std::pow(10.0, -4.0 + 3.0 * unit(rng)), std::pow(10.0, -4.0 + 3.0 * unit(rng)),
                       std::pow(10.0, -4.0 + 3.0 * unit(rng)));
  const Matrix3d R = exp3(Vector3d(normal(rng), normal(rng), normal(rng)));
  const Matrix3d Sigma_c = m * R * sigma.asDiagonal() * R.transpose();
  const Matrix3d I_c = Sigma_c.trace() * Matrix3d::Identity() - Sigma_c;
  SpatialInertia G;
  G.mass = m;
  G.h = m * c;
  G.I = I_c - m * hat3(c) * hat3(c);  // about the origin (parallel axes)
  return body_parameters(G);
}

// θ → π loses what the parallel-axis theorem loses: Σ = m (D Dᵀ + t tᵀ) keeps D Dᵀ only to
// ε (|t|² + |D|²), so θ → π → θ comes back to ε times κ = (|t|² + |D|²_F) / e^{2 min d} (the centre of
// mass's distance over the body's smallest radius of gyration, squared), whatever the algorithm.
// An arm's links have κ below 10³ (a 2 cm radius 0.5 m out: 625). The reverse Cholesky's own
// steps multiply it by a modest factor: measured ≤ 11 × 8 ε κ over 1000 standard-normal θ, held to
// 256 ε κ.
double conditioning(const Vector10d& theta) {
  const Vector3d e = theta.segment<3>(1).array().exp();
  const double size = e.squaredNorm() + theta.segment<3>(4).squaredNorm() + theta.tail<3>().squaredNorm();
  return size / std::exp(2.0 * theta.segment<3>(1).minCoeff());
}

TEST(LogCholesky, RoundTripsOnRandomBodies) {
  std::mt19937_64 rng(21);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  double worst_pi = 0.0, worst_theta = 0.0, worst_wide = 0.0;
  for (int k = 0; k < 1000; ++k) {
    const Vector10d pi = random_body(rng);
    const Vector10d back = inertia_from_log_cholesky(log_cholesky_from_inertia(pi));
    EXPECT_LE(relative_error(back, pi), 1e-12) << "body " << k;
    worst_pi = std::max(worst_pi, relative_error(back, pi));

    // Arm-like θ: mass 0.1–10 kg, radii of gyration 1–30 cm, centre of mass within 0.5 m.
    Vector10d theta;
    theta(0) = 0.5 * std::log(0.1 + 9.9 * unit(rng));
    for (int i = 1; i < 4; ++i) theta(i) = std::log(0.01 + 0.29 * unit(rng));
    for (int i = 4; i < 7; ++i) theta(i) = 0.05 * normal(rng);
    for (int i = 7; i < 10; ++i) theta(i) = unit(rng) - 0.5;
    const Vector10d theta_back = log_cholesky_from_inertia(inertia_from_log_cholesky(theta));
    EXPECT_LE(relative_error(theta_back, theta), 1e-12) << "theta " << k;
    worst_theta = std::max(worst_theta, relative_error(theta_back, theta));

    // Any θ, standard normal: within the conditioning's bound.
    for (int i = 0; i < 10; ++i) theta(i) = normal(rng);
    const double error = relative_error(log_cholesky_from_inertia(inertia_from_log_cholesky(theta)), theta);
    const double bound = 256.0 * std::numeric_limits<double>::epsilon() * std::max(1.0, conditioning(theta));
    EXPECT_LE(error, bound) << "theta " << k;
    worst_wide = std::max(worst_wide, error / bound);
  }
  std::cout << std::setprecision(3) << "log-Cholesky round trips, 1000 each: pi->theta->pi " << worst_pi
            << ", theta->pi->theta " << worst_theta << " (max relative error); any theta: at most " << worst_wide
            << " of 256 eps kappa\n";
}

TEST(LogCholesky, RoundTripsOnTheArmsLinks) {
  double worst = 0.0;
  int bodies = 0;
  for (const auto& [name, tip] : {std::pair<std::string, std::string>{"ur5", "tool0"}, {"panda", "panda_hand"},
                                  {"iiwa14", "iiwa_link_ee"}}) {
    UrdfOptions options;
    options.tip_link = tip;
    const RobotModel model = load_urdf_file(testing::data_path(name + ".urdf"), options);
    for (int i = 0; i < model.dof(); ++i) {
      const Vector10d pi = body_parameters(model.body_inertia(i));
      const Vector10d back = inertia_from_log_cholesky(log_cholesky_from_inertia(pi));
      EXPECT_LE(relative_error(back, pi), 1e-12) << name << " body " << i + 1;
      worst = std::max(worst, relative_error(back, pi));
      ++bodies;
    }
  }
  EXPECT_EQ(bodies, 20);
  std::cout << std::setprecision(3) << "log-Cholesky pi->theta->pi on the 20 links of ur5, panda, iiwa14: " << worst
            << "\n";
}

// Every θ, even far out, is a body: J ≻ 0 and the triangle inequalities hold strictly, by the same
// check the URDF loader applies (model/inertia.hpp).
TEST(LogCholesky, EveryThetaIsAPhysicalBody) {
  std::mt19937_64 rng(22);
  std::normal_distribution<double> normal;
  for (int k = 0; k < 1000; ++k) {
    Vector10d theta;
    for (int i = 0; i < 10; ++i) theta(i) = 1.5 * normal(rng);
    const Vector10d pi = inertia_from_log_cholesky(theta);
    const Eigen::Matrix4d J = pseudo_inertia(pi);
    EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d>(J).eigenvalues()(0), 0.0) << "theta " << k;
    EXPECT_GT(pi(0), 0.0);
    const Matrix3d I_c = inertia_about_centre_of_mass(pi(0), pi.segment<3>(1), spatial_inertia(pi).I);
    const Vector3d l = Eigen::SelfAdjointEigenSolver<Matrix3d>(I_c).eigenvalues();  // ascending
    EXPECT_GT(l(0), 0.0) << "theta " << k;
    EXPECT_LT(l(2), l(0) + l(1)) << "theta " << k;
    EXPECT_TRUE(check_inertia(pi(0), I_c).physical()) << check_inertia(pi(0), I_c).problem;
  }
}

::testing::AssertionResult refused_with(const Vector10d& pi, const std::string& needle) {
  try {
    log_cholesky_from_inertia(pi);
  } catch (const ArgumentError& e) {
    if (std::string(e.what()).find(needle) != std::string::npos) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << "'" << needle << "' is not in '" << e.what() << "'";
  }
  return ::testing::AssertionFailure() << "accepted";
}

TEST(LogCholesky, RefusesBodiesNoMassDistributionHas) {
  // A 2 kg box-like body at the origin: moments (0.03, 0.04, 0.05) kg·m², physical.
  Vector10d pi;
  pi << 2.0, 0.0, 0.0, 0.0, 0.03, 0.0, 0.0, 0.04, 0.0, 0.05;
  ASSERT_NO_THROW(log_cholesky_from_inertia(pi));
  Vector10d negative = pi;
  negative(0) = -1.0;
  EXPECT_TRUE(refused_with(negative, "mass -1 kg is not positive"));
  Vector10d zero = pi;
  zero(0) = 0.0;
  EXPECT_TRUE(refused_with(zero, "mass 0 kg is not positive"));
  Vector10d triangle = pi;
  triangle(9) = 0.08;  // 0.08 > 0.03 + 0.04
  EXPECT_TRUE(refused_with(triangle, "principal moments (0.03, 0.04, 0.08)"));
  Vector10d rod = pi;  // the boundary: 0.05 = 0.01 + 0.04, a flat plate
  rod(4) = 0.01;
  EXPECT_TRUE(refused_with(rod, "less than the sum of the other two"));
  // The centre of mass 0.5 m out along x with I unchanged about the origin: I_c = I − m (|c|² 1 − c cᵀ)
  // has I_yy = 0.04 − 0.5 < 0, an inertia about the origin too small for a body that far from it.
  Vector10d far = pi;
  far(1) = 2.0 * 0.5;
  EXPECT_TRUE(refused_with(far, "principal moments"));
  Vector10d nan = pi;
  nan(3) = std::nan("");
  EXPECT_TRUE(refused_with(nan, "not finite"));
}

// The map templated on the scalar, differentiated by forward-mode autodiff (Eigen's AutoDiffScalar,
// as ceres::Jet would), against central differences with step 1e-6: error O(h²) ≈ 1e-12 times the
// third derivative, held to 1e-7 relative.
TEST(LogCholesky, DerivativeMatchesCentralDifferences) {
  using Dual = Eigen::AutoDiffScalar<Vector10d>;
  std::mt19937_64 rng(23);
  std::normal_distribution<double> normal;
  double worst = 0.0;
  for (int k = 0; k < 20; ++k) {
    Vector10d theta;
    for (int i = 0; i < 10; ++i) theta(i) = 0.5 * normal(rng);
    Dual theta_dual[10], pi_dual[10];
    for (int i = 0; i < 10; ++i) theta_dual[i] = Dual(theta(i), 10, i);
    inertia_from_log_cholesky(theta_dual, pi_dual);
    Eigen::Matrix<double, 10, 10> J_auto, J_numeric;
    for (int r = 0; r < 10; ++r) J_auto.row(r) = pi_dual[r].derivatives().transpose();
    const double h = 1e-6;
    for (int c = 0; c < 10; ++c) {
      Vector10d plus = theta, minus = theta;
      plus(c) += h;
      minus(c) -= h;
      J_numeric.col(c) = (inertia_from_log_cholesky(plus) - inertia_from_log_cholesky(minus)) / (2.0 * h);
    }
    const double error = (J_auto - J_numeric).cwiseAbs().maxCoeff() / std::max(1.0, J_numeric.cwiseAbs().maxCoeff());
    EXPECT_LT(error, 1e-7) << "theta " << k;
    worst = std::max(worst, error);
    // Its value is the double version's, bit for bit.
    for (int r = 0; r < 10; ++r) EXPECT_EQ(pi_dual[r].value(), inertia_from_log_cholesky(theta)(r));
  }
  std::cout << std::setprecision(3) << "log-Cholesky Jacobian vs central differences, 20 thetas: " << worst << "\n";
}

}  // namespace
}  // namespace chasles
