// The perturbed inertias the simulated plant integrates: a body of known shape perturbed by hand
// (a box stretched along its sides, turned about one of them), every body of three arms physical
// for the log-Cholesky map after the perturbation, each parameter within the bound the header
// states and spread over most of it, the same model for the same seed, the kinematics untouched.
#include "core/identification/perturbation.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "core/identification/log_cholesky.hpp"
#include "core/dynamics/dynamics.hpp"
#include "core/model/inertia.hpp"
#include "core/model/urdf.hpp"
#include "support/reference.hpp"

namespace chasles {
namespace {

using testing::matrices_near;
using testing::matrices_near_relative;

struct LoadedArm {
  std::string name;
  RobotModel model;
};

std::vector<LoadedArm> arms() {
  const auto load = [](const std::string& file, const std::string& tip) {
    UrdfOptions options;
    options.tip_link = tip;
    return load_urdf_file(testing::data_path(file), options);
  };
  return {{"panda", load("panda.urdf", "panda_hand")},
          {"ur5", load("ur5.urdf", "tool0")},
          {"iiwa14", load("iiwa14.urdf", "iiwa_link_ee")}};
}

// A uniform box of mass m with sides (a, b, c) along the frame's axes, centred at `centre`:
// I_c = m/12 diag(b² + c², a² + c², a² + b²), then moved to the origin (MR eq. 8.32).
Vector10d box(double m, const Vector3d& sides, const Vector3d& centre, const Matrix3d& R = Matrix3d::Identity()) {
  const Vector3d s2 = sides.cwiseProduct(sides);
  const Vector3d moments(s2.y() + s2.z(), s2.x() + s2.z(), s2.x() + s2.y());
  SpatialInertia G;
  G.mass = m;
  G.h = m * centre;
  G.I = R * (m / 12.0 * moments).asDiagonal() * R.transpose() +
        m * (centre.squaredNorm() * Matrix3d::Identity() - centre * centre.transpose());
  return body_parameters(G);
}

Vector10d draws(double u0, const Vector3d& u_centre, const Vector3d& u_spread, double z, double phi_over_pi,
                double u_angle) {
  Vector10d u;
  u << u0, u_centre, u_spread, z, phi_over_pi, u_angle;
  return u;
}

Matrix3d rotation_z(double angle) {
  Matrix3d R;
  R << std::cos(angle), -std::sin(angle), 0, std::sin(angle), std::cos(angle), 0, 0, 0, 1;
  return R;
}

// The header's recipe, checked on a body whose every number is known: a box's second moment
// along its side k is m s_k² / 12, so scaling it by (1 + f u) is a box of that mass with the side
// scaled by √(1 + f u); its rms radius is √((a² + b² + c²) / 12). Then the same box turned about
// its z side by f rad (z = 1 gives the axis +z) and nothing else.
TEST(perturbation, ABoxIsStretchedMovedAndTurnedAsTheHeaderSays) {
  const double m = 2.0, f = 0.2;
  const Vector3d sides(0.1, 0.2, 0.4), centre(0.05, -0.02, 0.3);
  const double rho = std::sqrt(sides.squaredNorm() / 12.0);
  const Vector3d u_centre(0.5, -1.0, 0.25), u_spread(-0.5, 0.75, 1.0);

  const Vector10d stretched =
      perturbed_body_parameters(box(m, sides, centre), f, draws(0.5, u_centre, u_spread, 0.3, -0.4, 0.0));
  const double m_new = m * (1.0 + f * 0.5);
  const Vector3d centre_new = centre + f * rho * u_centre;
  const Vector3d sides_new = sides.cwiseProduct((Vector3d::Ones() + f * u_spread).cwiseSqrt());
  // I_c is the stretched box's (the spread of the original mass); the new mass at the new centre
  // brings the rest: a point mass m' at c' (a box with no sides) has π = (m', m' c', m' [c']ᵀ[c']).
  const Vector10d point_mass = box(m_new, Vector3d::Zero(), centre_new);
  Vector10d expected = box(m, sides_new, Vector3d::Zero());
  expected.head<4>() = point_mass.head<4>();
  expected.tail<6>() += point_mass.tail<6>();
  EXPECT_TRUE(matrices_near(stretched, expected, 1e-14));

  const Vector10d turned =
      perturbed_body_parameters(box(m, sides, centre), f, draws(0.0, Vector3d::Zero(), Vector3d::Zero(), 1.0, 0.7, 1.0));
  EXPECT_TRUE(matrices_near(turned, box(m, sides, centre, rotation_z(f)), 1e-14));
  EXPECT_GT(testing::max_abs_diff(turned, box(m, sides, centre)), 1e-4) << "the turn should show";

  EXPECT_TRUE(matrices_near(perturbed_body_parameters(box(m, sides, centre), 0.0, Vector10d::Ones()),
                            box(m, sides, centre), 1e-14))
      << "fraction 0 leaves the body as it is";
  const Vector10d massless = Vector10d::Zero();
  EXPECT_EQ(perturbed_body_parameters(massless, f, Vector10d::Ones()), massless);
}

// What the bound is checked against, for one body: its mass, centre, rms radius and principal
// moments about the centre (ascending).
struct Body {
  double m, rho;
  Vector3d c, moments;
};

Body body_of(const Vector10d& pi) {
  const SpatialInertia G = spatial_inertia(pi);
  const Matrix3d I_c = inertia_about_centre_of_mass(G.mass, G.h, G.I);
  return {G.mass, std::sqrt(0.5 * I_c.trace() / G.mass), G.h / G.mass,
          Eigen::SelfAdjointEigenSolver<Matrix3d>(I_c, Eigen::EigenvaluesOnly).eigenvalues()};
}

// Over the three arms and five seeds at ±20 %, every body is physical (the log-Cholesky map takes
// it: pseudo-inertia ≻ 0), each mass within ±f of its own, each coordinate of each centre within
// f ρ, each principal moment within ±f (sorted: the k-th smallest of values each within ±f of its
// own is within ±f of the k-th smallest). And the draws fill the bounds: over the 100 bodies the
// relative changes of mass, the centre's moves and the moments' changes each reach beyond 85 % of
// the bound both ways. The same with the draws at the corners of [−1, 1]¹⁰ and f = 0.95, where a
// body is squeezed to 5 % of its spread: still physical.
TEST(perturbation, EveryBodyStaysPhysicalAndWithinTheBound) {
  constexpr double f = 0.2;
  constexpr double kRounding = 1e-12;  // relative: the recomposition of I and its eigenvalues
  double mass_low = 0, mass_high = 0, centre_low = 0, centre_high = 0, moment_low = 0, moment_high = 0;
  int bodies = 0;
  for (const LoadedArm& arm : arms()) {
    const Eigen::MatrixXd nominal = inertial_parameters(arm.model);
    for (uint64_t seed = 1; seed <= 5; ++seed) {
      SCOPED_TRACE(arm.name + ", seed " + std::to_string(seed));
      const Eigen::MatrixXd perturbed = inertial_parameters(with_perturbed_inertias(arm.model, f, seed));
      for (Eigen::Index i = 0; i < nominal.rows(); ++i) {
        ++bodies;
        const Vector10d pi = perturbed.row(i).transpose();
        EXPECT_NO_THROW(log_cholesky_from_inertia(pi)) << "body " << i;
        const Body before = body_of(nominal.row(i).transpose()), after = body_of(pi);
        const double dm = after.m / before.m - 1.0;
        const Vector3d dc = (after.c - before.c) / (f * before.rho);
        const Vector3d dI = after.moments.cwiseQuotient(before.moments) - Vector3d::Ones();
        EXPECT_LE(std::abs(dm), f * (1 + kRounding)) << "body " << i;
        EXPECT_LE(dc.cwiseAbs().maxCoeff(), 1.0 + 1e-9) << "body " << i;
        EXPECT_LE(dI.cwiseAbs().maxCoeff(), f * (1 + 1e-9)) << "body " << i;
        mass_low = std::min(mass_low, dm / f);
        mass_high = std::max(mass_high, dm / f);
        centre_low = std::min(centre_low, dc.minCoeff());
        centre_high = std::max(centre_high, dc.maxCoeff());
        moment_low = std::min(moment_low, dI.minCoeff() / f);
        moment_high = std::max(moment_high, dI.maxCoeff() / f);
      }
    }
  }
  EXPECT_EQ(bodies, 5 * (7 + 6 + 7));
  for (const double low : {mass_low, centre_low, moment_low}) EXPECT_LT(low, -0.85);
  for (const double high : {mass_high, centre_high, moment_high}) EXPECT_GT(high, 0.85);

  for (const LoadedArm& arm : arms()) {
    const Eigen::MatrixXd nominal = inertial_parameters(arm.model);
    for (int corner = 0; corner < 1 << 7; ++corner) {
      Vector10d u;  // the mass, centre and spread draws at ±1, the axis and angle varied with them
      for (int k = 0; k < 7; ++k) u(k) = ((corner >> k) & 1) != 0 ? 1.0 : -1.0;
      u.tail<3>() << u(1), u(2) * 0.5, u(3);
      for (Eigen::Index i = 0; i < nominal.rows(); ++i) {
        EXPECT_NO_THROW(log_cholesky_from_inertia(perturbed_body_parameters(nominal.row(i).transpose(), 0.95, u)))
            << arm.name << ", body " << i << ", corner " << corner;
      }
    }
  }
}

// A seed is a model: the same seed gives the same parameters bit for bit, another seed other
// parameters for every body. The kinematics are the nominal model's exactly (forward kinematics
// at seeded configurations, the joints, the armature), the dynamics not (M(q) differs).
TEST(perturbation, TheSeedIsTheModelAndTheKinematicsAreUntouched) {
  for (const LoadedArm& arm : arms()) {
    SCOPED_TRACE(arm.name);
    const RobotModel a = with_perturbed_inertias(arm.model, 0.2, 11);
    const RobotModel again = with_perturbed_inertias(arm.model, 0.2, 11);
    const RobotModel other = with_perturbed_inertias(arm.model, 0.2, 12);
    EXPECT_EQ(inertial_parameters(a), inertial_parameters(again));
    const Eigen::MatrixXd difference = inertial_parameters(a) - inertial_parameters(other);
    for (Eigen::Index i = 0; i < difference.rows(); ++i) {
      EXPECT_GT(std::abs(difference(i, 0)), 0.0) << "body " << i << ": another seed, another mass";
    }
    EXPECT_EQ(a.armature(), arm.model.armature());
    ASSERT_EQ(a.dof(), arm.model.dof());
    Data data_nominal(arm.model), data_perturbed(a);
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    double mass_matrix_change = 0.0;
    for (int trial = 0; trial < 20; ++trial) {
      Eigen::VectorXd q(a.dof());
      for (Eigen::Index k = 0; k < q.size(); ++k) q[k] = 2.0 * unit(rng);
      EXPECT_EQ(forward_kinematics(a, data_perturbed, q).matrix(), forward_kinematics(arm.model, data_nominal, q).matrix());
      mass_matrix_change = std::max(mass_matrix_change, testing::max_abs_diff(mass_matrix(a, data_perturbed, q),
                                                                              mass_matrix(arm.model, data_nominal, q)));
    }
    EXPECT_GT(mass_matrix_change, 1e-3);
    for (int i = 0; i < a.dof(); ++i) {
      EXPECT_EQ(a.joint(i).name, arm.model.joint(i).name);
      EXPECT_EQ(a.joint(i).limits.lower, arm.model.joint(i).limits.lower);
    }
  }
}

TEST(perturbation, AFractionOutsideZeroToOneIsRefused) {
  const RobotModel model = arms().front().model;
  for (const double f : {1.0, 1.5, -0.01, std::nan("")}) {
    try {
      with_perturbed_inertias(model, f, 1);
      ADD_FAILURE() << "fraction " << f << " accepted";
    } catch (const ArgumentError& e) {
      EXPECT_NE(std::string(e.what()).find("is not in [0, 1)"), std::string::npos) << e.what();
    }
  }
  EXPECT_NO_THROW(with_perturbed_inertias(model, 0.0, 1));
  EXPECT_NO_THROW(with_perturbed_inertias(model, 0.999, 1));
}

}  // namespace
}  // namespace chasles
