// The control laws of controller/law.hpp against references built here from the model's own
// kinematics and dynamics (forward kinematics, the space Jacobian, RNEA, CRBA), never from a
// law's output, and law_problem's refusals. The Controller's side of them is law_controller_test's.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <string>

#include "controller/law.hpp"
#include "core/dynamics/dynamics.hpp"
#include "core/kinematics/kinematics.hpp"
#include "core/lie/se3.hpp"
#include "core/model/urdf.hpp"
#include "support/allocation_counter.hpp"
#include "support/arm.hpp"
#include "support/decompositions.hpp"
#include "support/reference.hpp"

namespace chasles::controller {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;
using testing::AllocationCounter;
using testing::data_path;
using testing::matrices_near;
using testing::panda;
using testing::ur5;
using testing::gravity_of;

constexpr std::array<Law, 4> kLaws = {Law::kComputedTorque, Law::kJointImpedance, Law::kCartesianImpedance,
                                      Law::kFreeDrive};

// A bent pose of each arm, inside its limits and away from its singularities.
VectorXd pose_of(const RobotModel& model) {
  VectorXd q(model.dof());
  if (model.dof() == 7) {
    q << 0.1, 0.5, -0.2, -1.2, 0.1, 1.0, 0.3;
  } else {
    q << 0.3, -1.2, 1.4, -0.9, 0.8, 0.7;
  }
  return q;
}

// A fixed, seeded vector with entries in [lo, hi].
VectorXd seeded(int n, unsigned seed, double lo, double hi) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(lo, hi);
  VectorXd v(n);
  for (int i = 0; i < n; ++i) v(i) = u(rng);
  return v;
}

// A random symmetric positive definite matrix, its eigenvalues spread over about two decades.
Matrix6d random_spd(std::mt19937& rng, double scale) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Matrix6d A;
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) A(r, c) = u(rng);
  }
  return scale * (A * A.transpose() / 6.0 + 0.02 * Matrix6d::Identity());
}

Transform tip_pose(const RobotModel& model, const VectorXd& q) {
  Data data(model);
  Data data_ref(model);
  return forward_kinematics(model, data, q);
}

// The Jacobian of frame c (T_bc on the tip) in frame c, by a route the law does not take: the
// space Jacobian moved into frame c, J_c = [Ad_{T_sc⁻¹}] J_s.
Matrix6Xd frame_jacobian(const RobotModel& model, const VectorXd& q, const Transform& T_bc) {
  Data data(model);
  Data data_ref(model);
  const Matrix6Xd J_s = space_jacobian(model, data, q);
  const Transform T_sc = Transform(data.T_sb) * T_bc;
  return adjoint(inverse(T_sc)) * J_s;
}

// c(q, q̇) + g(q) as the velocity product and the gravity torques, each by its own algorithm.
VectorXd bias_of(const RobotModel& model, const VectorXd& q, const VectorXd& qd) {
  Data data(model);
  Data data_ref(model);
  const VectorXd c = velocity_product(model, data, q, qd);
  return c + gravity_torques(model, data, q);
}

MatrixXd mass_of(const RobotModel& model, const VectorXd& q) {
  Data data(model);
  Data data_ref(model);
  return mass_matrix(model, data, q);
}

double spectral_norm(const MatrixXd& A) { return Eigen::JacobiSVD<MatrixXd>(A).singularValues()(0); }

// A coupled stiffness inside LawBounds: both diagonal blocks full, the blocks between them too.
Matrix6d coupled_stiffness() {
  Matrix6d K;
  K << 60, 5, -3, 10, -5, 2,  //
      5, 45, 2, 0, 8, -4,     //
      -3, 2, 80, 3, 1, 6,     //
      10, 0, 3, 900, 50, -30, //
      -5, 8, 1, 50, 1200, 20, //
      2, -4, 6, -30, 20, 700;
  return K;
}

Transform offset_frame() {
  return Transform(Eigen::AngleAxisd(0.4, Vector3d(1, 1, 0).normalized()).toRotationMatrix(),
                   Vector3d(0.05, -0.02, 0.08));
}

LawSettings cartesian_settings(int n) {
  LawSettings s(n);
  s.law = Law::kCartesianImpedance;
  return s;
}

std::string problem(const RobotModel& model, const LawSettings& s) {
  char why[192];
  const char* p = law_problem(model, s, why);
  return p == nullptr ? std::string() : std::string(p);
}

// --- modal damping --------------------------------------------------------------------------

// In the generalized eigenbasis of (K, Λ), K v = σ Λ v, the modes decouple: Vᵀ Λ V and Vᵀ K V are
// diagonal, and the damping must be too, with each mode's entry 2ζ√σ times its modal mass. V is
// invertible, so this fixes D entirely.
TEST(LawModalDamping, DampsEveryGeneralizedEigenmodeByZeta) {
  std::mt19937 rng(20240611);
  for (int trial = 0; trial < 40; ++trial) {
    const Matrix6d Lambda = random_spd(rng, 4.0);
    const Matrix6d K = random_spd(rng, 900.0);
    const test::Eigen6 modes = test::generalized_symmetric_eigen(K, Lambda);  // K v = σ Λ v
    const Matrix6d V = modes.vectors;
    const Vector6d sigma = modes.values;
    const Matrix6d modal_mass = V.transpose() * Lambda * V;
    for (double zeta : {1.0, 0.3, 1.7}) {
      SCOPED_TRACE("trial " + std::to_string(trial) + ", zeta " + std::to_string(zeta));
      const Matrix6d D = modal_damping(Lambda, K, zeta);
      EXPECT_LE((D - D.transpose()).cwiseAbs().maxCoeff(), 1e-12 * D.cwiseAbs().maxCoeff()) << "D symmetric";
      Matrix6d expected = Matrix6d::Zero();
      for (int i = 0; i < 6; ++i) expected(i, i) = 2.0 * zeta * std::sqrt(sigma(i)) * modal_mass(i, i);
      const Matrix6d modal = V.transpose() * D * V;
      EXPECT_TRUE(matrices_near(modal, expected, 1e-9 * expected.cwiseAbs().maxCoeff()));
      // The same D as the matrix geometric mean, 2ζ Λ^½ (Λ^-½ K Λ^-½)^½ Λ^½, by symmetric square
      // roots instead of a Cholesky factor.
      const Matrix6d S = test::symmetric_sqrt(Lambda), S_inv = test::symmetric_inverse_sqrt(Lambda);
      const Matrix6d mean = 2.0 * zeta * S * test::symmetric_sqrt(S_inv * K * S_inv) * S;
      EXPECT_TRUE(matrices_near(D, mean, 1e-9 * mean.cwiseAbs().maxCoeff()));
    }
  }
}

TEST(LawModalDamping, IsotropicAndDiagonalCasesAreTwoZetaRootKM) {
  for (const auto& [m, k, zeta] : {std::array<double, 3>{3.2, 750.0, 1.0}, std::array<double, 3>{0.05, 40.0, 0.7},
                                   std::array<double, 3>{12.0, 4800.0, 2.0}}) {
    const Matrix6d D = modal_damping(m * Matrix6d::Identity(), k * Matrix6d::Identity(), zeta);
    const Matrix6d expected = 2.0 * zeta * std::sqrt(k * m) * Matrix6d::Identity();
    EXPECT_TRUE(matrices_near(D, expected, 1e-12 * expected(0, 0))) << "m " << m << ", k " << k;
  }
  Vector6d masses, stiffnesses;
  masses << 0.3, 0.5, 0.8, 4.0, 6.0, 9.0;
  stiffnesses << 40.0, 20.0, 90.0, 1000.0, 3000.0, 500.0;
  const Matrix6d D = modal_damping(Matrix6d(masses.asDiagonal()), Matrix6d(stiffnesses.asDiagonal()), 1.0);
  const Matrix6d expected(Vector6d(2.0 * (masses.cwiseProduct(stiffnesses)).cwiseSqrt()).asDiagonal());
  EXPECT_TRUE(matrices_near(D, expected, 1e-12 * expected.maxCoeff()));
}

// --- Cartesian impedance --------------------------------------------------------------------

TEST(LawCartesianImpedance, AtRestOnTheReferenceIsGravityCompensation) {
  for (const RobotModel* model : {&panda(), &ur5()}) {
    for (const Transform& T_bc : {Transform::Identity(), offset_frame()}) {
      SCOPED_TRACE(model->name());
      const int n = model->dof();
      Data data(*model);
      Data data_ref(*model);
      LawWorkspace work(n);
      LawSettings s = cartesian_settings(n);
      s.T_tip_frame = T_bc;
      ASSERT_EQ(problem(*model, s), "");
      const VectorXd q = pose_of(*model), qd = VectorXd::Zero(n);
      motion::Reference ref(n);
      ref.hold(q);
      VectorXd tau(n);
      compute_tick_terms(*model, data, q, qd);
      body_jacobian(*model, data_ref, ref.q);
      cartesian_impedance(*model, data, data_ref, work, s, ref, q, qd, tau);
      EXPECT_TRUE(matrices_near(tau, gravity_of(*model, q), 1e-9));
      EXPECT_TRUE(matrices_near(work.xi, Vector6d::Zero(), 1e-12));
    }
  }
}

// q̇ = 0 and the reference a small joint increment away: the spring alone, τ − g = J_cᵀ K ξ with
// ξ = log(T_sc⁻¹ T_sd) from forward kinematics at q and at q_d (the posture held at q, so the
// nullspace adds nothing).
TEST(LawCartesianImpedance, StaticsAreTheJacobianTransposeOfTheSpringWrench) {
  for (const RobotModel* model : {&panda(), &ur5()}) {
    for (const Transform& T_bc : {Transform::Identity(), offset_frame()}) {
      SCOPED_TRACE(model->name());
      const int n = model->dof();
      Data data(*model);
      Data data_ref(*model);
      LawWorkspace work(n);
      LawSettings s = cartesian_settings(n);
      s.cartesian_stiffness = coupled_stiffness();
      s.T_tip_frame = T_bc;
      const VectorXd q = pose_of(*model), qd = VectorXd::Zero(n);
      s.fixed_posture = true;
      s.nullspace_posture = q;
      ASSERT_EQ(problem(*model, s), "");
      const VectorXd q_d = q + seeded(n, 3, -0.012, 0.012);
      motion::Reference ref(n);
      ref.hold(q_d);
      VectorXd tau(n);
      compute_tick_terms(*model, data, q, qd);
      body_jacobian(*model, data_ref, ref.q);
      cartesian_impedance(*model, data, data_ref, work, s, ref, q, qd, tau);

      const Transform T_sc = tip_pose(*model, q) * T_bc, T_sd = tip_pose(*model, q_d) * T_bc;
      const Vector6d xi = log6(inverse(T_sc) * T_sd);
      ASSERT_GT(xi.tail<3>().norm(), 1e-3) << "the frame must be displaced for the test to mean anything";
      const Matrix6Xd J_c = frame_jacobian(*model, q, T_bc);
      const VectorXd expected = J_c.transpose() * (s.cartesian_stiffness * xi);
      EXPECT_TRUE(matrices_near(work.xi, xi, 1e-12));
      EXPECT_TRUE(matrices_near(work.xi_dot, Vector6d::Zero(), 1e-12));
      EXPECT_TRUE(matrices_near(work.J_c, J_c, 1e-12));
      EXPECT_TRUE(matrices_near(tau - gravity_of(*model, q), expected, 1e-9));
    }
  }
}

// The posture torque is filtered by N = I − J_cᵀ Λ J_c M⁻¹: whatever it is, the acceleration it
// causes, M⁻¹ N τ₀, moves frame c by J_c M⁻¹ N τ₀ = 0. At rest and moving along the reference (so
// that the posture damping acts too) with a posture far from q.
TEST(LawCartesianImpedance, TheNullspaceTorqueNeverAcceleratesFrameC) {
  const RobotModel& model = panda();
  const int n = model.dof();
  Data data(model);
  Data data_ref(model);
  LawWorkspace work(n);
  LawSettings s = cartesian_settings(n);
  s.T_tip_frame = offset_frame();
  s.fixed_posture = true;
  s.nullspace_posture << -1.0, 0.2, 0.8, -2.0, -0.9, 2.2, -1.0;
  s.nullspace_stiffness = 40.0;
  ASSERT_EQ(problem(model, s), "");
  const VectorXd q = pose_of(model);
  const MatrixXd M = mass_of(model, q);
  const Matrix6Xd J_c = frame_jacobian(model, q, s.T_tip_frame);
  const MatrixXd Jc_Minv = J_c * test::matrix_inverse(M);
  const Matrix6d Lambda = test::matrix_inverse(Jc_Minv * J_c.transpose());
  ASSERT_LT(test::symmetric_eigen(Lambda).values.maxCoeff(), kMaxCartesianInertia)
      << "a regular pose: the inertia bound must not act";
  for (const VectorXd& qd : {VectorXd(VectorXd::Zero(n)), seeded(n, 5, -0.4, 0.4)}) {
    motion::Reference ref(n);
    ref.hold(q);
    ref.qd = qd;  // moving with the reference: no Cartesian error and no error rate
    VectorXd tau(n);
    compute_tick_terms(model, data, q, qd);
    body_jacobian(model, data_ref, ref.q);
    cartesian_impedance(model, data, data_ref, work, s, ref, q, qd, tau);
    const VectorXd posture_part = tau - bias_of(model, q, qd);
    const VectorXd tau_0 =
        s.nullspace_stiffness * (s.nullspace_posture - q) -
        (2.0 * s.damping_ratio * (s.nullspace_stiffness * M.diagonal()).cwiseSqrt()).cwiseProduct(qd);
    const VectorXd expected = tau_0 - J_c.transpose() * (Lambda * (Jc_Minv * tau_0));
    EXPECT_GT(posture_part.norm(), 1.0) << "a posture far from q must pull";
    EXPECT_TRUE(matrices_near(Jc_Minv * posture_part, Vector6d::Zero(), 1e-9));
    EXPECT_TRUE(matrices_near(posture_part, expected, 1e-9));
  }
}

// A six-joint arm away from singularities has no nullspace: J_c is square and invertible, N = 0.
TEST(LawCartesianImpedance, ASixJointArmHasNoNullspace) {
  const RobotModel& model = ur5();
  const int n = model.dof();
  Data data(model);
  Data data_ref(model);
  LawWorkspace work(n);
  LawSettings s = cartesian_settings(n);
  s.fixed_posture = true;
  s.nullspace_posture << -1.0, -2.0, 2.0, 0.5, 2.0, -1.0;
  s.nullspace_stiffness = 40.0;
  ASSERT_EQ(problem(model, s), "");
  const VectorXd q = pose_of(model), qd = VectorXd::Zero(n);
  motion::Reference ref(n);
  ref.hold(q);
  VectorXd tau(n);
  compute_tick_terms(model, data, q, qd);
  body_jacobian(model, data_ref, ref.q);
  cartesian_impedance(model, data, data_ref, work, s, ref, q, qd, tau);
  EXPECT_TRUE(matrices_near(tau, gravity_of(model, q), 1e-9));
}

// The UR5's wrist singularity: wrist 2 at 0 lines wrist 1 and wrist 3 up, and J loses rank. Near
// it and at it the Cartesian inertia is clamped at kMaxCartesianInertia and the torque stays
// bounded by what the clamp allows, Λ ≤ Λ_max:
//   spring   |J_cᵀ K ξ|, which involves no Λ
//   damping  |J_cᵀ D ξ̇| ≤ |J_c| 2ζ √(Λ_max |K|) |ξ̇|   (D = 2ζ Λ # K, the matrix geometric mean, and
//                                                     |Λ # K| ≤ √(|Λ| |K|))
//   posture  |N τ₀| ≤ |τ₀| + |J_c| Λ_max |J_c M⁻¹ τ₀|
TEST(LawCartesianImpedance, StaysBoundedNearAndAtTheUr5WristSingularity) {
  const RobotModel& model = ur5();
  const int n = model.dof();
  LawSettings s = cartesian_settings(n);
  s.cartesian_stiffness = coupled_stiffness();
  ASSERT_EQ(problem(model, s), "");
  for (double wrist_2 : {1e-4, 0.0}) {
    SCOPED_TRACE("wrist 2 at " + std::to_string(wrist_2));
    VectorXd q(n);
    q << 0.3, -1.2, 1.4, -0.9, wrist_2, 0.7;
    const Matrix6Xd J_c = frame_jacobian(model, q, s.T_tip_frame);
    const Eigen::JacobiSVD<MatrixXd> svd(J_c);
    ASSERT_LT(svd.singularValues()(5), 1e-3) << "a (near-)singular configuration";
    const VectorXd q_d = q + seeded(n, 11, -0.01, 0.01), qd = seeded(n, 12, -0.3, 0.3);
    motion::Reference ref(n);
    ref.hold(q_d);
    Data data(model);
    Data data_ref(model);
    LawWorkspace work(n);
    VectorXd tau(n);
    compute_tick_terms(model, data, q, qd);
    body_jacobian(model, data_ref, ref.q);
    cartesian_impedance(model, data, data_ref, work, s, ref, q, qd, tau);
    ASSERT_TRUE(tau.allFinite());

    const Vector6d inertia = test::symmetric_eigen(work.Lambda).values;
    EXPECT_NEAR(inertia.maxCoeff(), kMaxCartesianInertia, 1e-9 * kMaxCartesianInertia)
        << "the lost direction's inertia is clamped";
    EXPECT_GT(inertia.minCoeff(), 0.0);

    const Vector6d xi = log6(inverse(tip_pose(model, q)) * tip_pose(model, q_d));
    const Vector6d xi_dot = -(J_c * qd);  // q̇_d = 0
    const MatrixXd M = mass_of(model, q);
    const VectorXd tau_0 =
        s.nullspace_stiffness * (q_d - q) -
        (2.0 * s.damping_ratio * (s.nullspace_stiffness * M.diagonal()).cwiseSqrt()).cwiseProduct(qd);
    const double J_norm = svd.singularValues()(0), K_norm = spectral_norm(s.cartesian_stiffness);
    const double bound = (J_c.transpose() * (s.cartesian_stiffness * xi)).norm() +
                         J_norm * 2.0 * s.damping_ratio * std::sqrt(kMaxCartesianInertia * K_norm) * xi_dot.norm() +
                         tau_0.norm() + J_norm * kMaxCartesianInertia * (J_c * test::matrix_inverse(M) * tau_0).norm();
    const double law_part = (tau - bias_of(model, q, qd)).norm();
    EXPECT_LE(law_part, bound);
    EXPECT_TRUE(matrices_near(work.xi, xi, 1e-12));
  }
}

// Frame c 0.1 m out along the last joint's axis from the tip (which lies on that axis, for both
// arms) and turned: turning the last joint by θ turns frame c about its own origin, by θ about
// R_bcᵀ a, a the axis in the tip frame. The error is a pure rotation, ξ = (θ R_bcᵀ a, 0): the
// wrench has no force, and its moment is K_rot ξ_ω in frame c.
TEST(LawCartesianImpedance, APureRotationAboutAnOffsetFrameGivesAPureMoment) {
  for (const RobotModel* model : {&panda(), &ur5()}) {
    for (double theta : {0.4, -1.3, 3.0}) {
      SCOPED_TRACE(model->name() + ", theta " + std::to_string(theta));
      const int n = model->dof();
      const VectorXd q = pose_of(*model), qd = VectorXd::Zero(n);
      VectorXd q_d = q;
      q_d(n - 1) += theta;
      const Transform T_bb = inverse(tip_pose(*model, q)) * tip_pose(*model, q_d);
      ASSERT_LT(T_bb.translation().norm(), 1e-12) << "the tip must lie on the last joint's axis";
      const Eigen::AngleAxisd turn(T_bb.linear());
      ASSERT_NEAR(turn.angle(), std::abs(theta), 1e-12);
      const Vector3d a = turn.axis();  // the turn is |θ| about a

      LawSettings s = cartesian_settings(n);
      const Matrix3d R_bc = Eigen::AngleAxisd(0.7, Vector3d(1, 2, -1).normalized()).toRotationMatrix();
      s.T_tip_frame = Transform(R_bc, 0.1 * a);
      Matrix3d K_rot;
      K_rot << 60, 10, 5, 10, 80, -8, 5, -8, 100;
      s.cartesian_stiffness.setZero();
      s.cartesian_stiffness.topLeftCorner<3, 3>() = K_rot;
      s.cartesian_stiffness.bottomRightCorner<3, 3>() = Matrix3d(Vector3d(900, 1500, 2500).asDiagonal());
      s.fixed_posture = true;
      s.nullspace_posture = q;
      ASSERT_EQ(problem(*model, s), "");
      motion::Reference ref(n);
      ref.hold(q_d);
      Data data(*model);
      Data data_ref(*model);
      LawWorkspace work(n);
      VectorXd tau(n);
      compute_tick_terms(*model, data, q, qd);
      body_jacobian(*model, data_ref, ref.q);
      cartesian_impedance(*model, data, data_ref, work, s, ref, q, qd, tau);

      const Vector3d rotation = std::abs(theta) * (R_bc.transpose() * a);
      Vector6d xi;
      xi << rotation, Vector3d::Zero();
      EXPECT_TRUE(matrices_near(work.xi, xi, 1e-12));
      EXPECT_TRUE(matrices_near(work.wrench.tail<3>(), Vector3d::Zero(), 1e-9)) << "no force";
      EXPECT_TRUE(matrices_near(work.wrench.head<3>(), K_rot * rotation, 1e-9)) << "the moment, in frame c";
      const Matrix6Xd J_c = frame_jacobian(*model, q, s.T_tip_frame);
      Vector6d wrench;
      wrench << K_rot * rotation, Vector3d::Zero();
      EXPECT_TRUE(matrices_near(tau - gravity_of(*model, q), J_c.transpose() * wrench, 1e-9));
    }
  }
}

// --- joint impedance and free drive ---------------------------------------------------------

TEST(LawJointImpedance, IsStiffnessDampingFeedforwardAndBias) {
  for (const RobotModel* model : {&panda(), &ur5()}) {
    SCOPED_TRACE(model->name());
    const int n = model->dof();
    const VectorXd q = pose_of(*model) + seeded(n, 21, -0.1, 0.1), qd = seeded(n, 22, -0.5, 0.5);
    motion::Reference ref(n);
    ref.q = q + seeded(n, 23, -0.05, 0.05);
    ref.qd = seeded(n, 24, -0.5, 0.5);
    ref.qdd = seeded(n, 25, -2.0, 2.0);
    LawSettings s(n);
    s.law = Law::kJointImpedance;
    s.joint_stiffness = seeded(n, 26, 50.0, 800.0);
    s.damping_ratio = 0.8;
    ASSERT_EQ(problem(*model, s), "");
    const MatrixXd M = mass_of(*model, q);
    const VectorXd bias = bias_of(*model, q, qd), e = ref.q - q, e_dot = ref.qd - qd;
    Data data(*model);
    Data data_ref(*model);
    LawWorkspace work(n);
    VectorXd tau(n);

    const VectorXd D = 2.0 * 0.8 * (s.joint_stiffness.cwiseProduct(M.diagonal())).cwiseSqrt();
    compute_tick_terms(*model, data, q, qd);
    joint_impedance(*model, data, work, s, ref, q, qd, tau);
    const VectorXd expected = s.joint_stiffness.cwiseProduct(e) + D.cwiseProduct(e_dot) + M * ref.qdd + bias;
    EXPECT_TRUE(matrices_near(tau, expected, 1e-9));

    // A loop of period T renders a joint's damping up to m_i / T, m_i = 1 / (M⁻¹)_ii the inertia
    // it feels with the others free: at 100 Hz that bounds some joints of each arm.
    work.period = 0.01;
    const VectorXd bound = test::matrix_inverse(M).diagonal().cwiseInverse() / work.period;
    const VectorXd D_bounded = D.cwiseMin(bound);
    ASSERT_GT((D - D_bounded).maxCoeff(), 0.0) << "the bound must bind somewhere";
    joint_impedance(*model, data, work, s, ref, q, qd, tau);
    EXPECT_TRUE(matrices_near(work.damping, D_bounded, 1e-9));
    EXPECT_TRUE(matrices_near(tau, s.joint_stiffness.cwiseProduct(e) + D_bounded.cwiseProduct(e_dot) + M * ref.qdd + bias,
                              1e-9));
    work.period = 0.0;

    s.damping_from_ratio = false;
    s.joint_damping = seeded(n, 27, 0.0, 30.0);
    ASSERT_EQ(problem(*model, s), "");
    compute_tick_terms(*model, data, q, qd);
    joint_impedance(*model, data, work, s, ref, q, qd, tau);
    const VectorXd explicit_expected =
        s.joint_stiffness.cwiseProduct(e) + s.joint_damping.cwiseProduct(e_dot) + M * ref.qdd + bias;
    EXPECT_TRUE(matrices_near(tau, explicit_expected, 1e-9));
  }
}

TEST(LawFreeDrive, IsBiasCompensationMinusDamping) {
  for (const RobotModel* model : {&panda(), &ur5()}) {
    SCOPED_TRACE(model->name());
    const int n = model->dof();
    const VectorXd q = pose_of(*model) + seeded(n, 31, -0.1, 0.1), qd = seeded(n, 32, -0.8, 0.8);
    const MatrixXd M = mass_of(*model, q);
    const VectorXd bias = bias_of(*model, q, qd);
    LawSettings s(n);
    s.law = Law::kFreeDrive;
    ASSERT_EQ(problem(*model, s), "");
    Data data(*model);
    Data data_ref(*model);
    LawWorkspace work(n);
    VectorXd tau(n);
    compute_tick_terms(*model, data, q, qd);
    free_drive(*model, data, s, qd, tau);
    EXPECT_TRUE(matrices_near(tau, bias - LawDefaults::kFreeDriveRate * M * qd, 1e-9));

    s.damping_from_ratio = false;
    s.joint_damping = seeded(n, 33, 0.5, 20.0);
    ASSERT_EQ(problem(*model, s), "");
    compute_tick_terms(*model, data, q, qd);
    free_drive(*model, data, s, qd, tau);
    EXPECT_TRUE(matrices_near(tau, bias - s.joint_damping.cwiseProduct(qd), 1e-9));

    compute_tick_terms(*model, data, q, VectorXd::Zero(n));
    free_drive(*model, data, s, VectorXd::Zero(n), tau);
    EXPECT_TRUE(matrices_near(tau, gravity_of(*model, q), 1e-9)) << "at rest it only holds the arm up";
  }
}

// Each law writes into its preallocated workspace and torque: no call allocates, whatever the
// arm and the settings.
TEST(LawFunctions, NoneAllocates) {
  for (const RobotModel* model : {&panda(), &ur5()}) {
    SCOPED_TRACE(model->name());
    const int n = model->dof();
    const VectorXd q = pose_of(*model), qd = seeded(n, 41, -0.3, 0.3), kp = VectorXd::Constant(n, 400.0),
                   kd = VectorXd::Constant(n, 40.0);
    motion::Reference ref(n);
    ref.q = q + seeded(n, 42, -0.02, 0.02);
    ref.qd = seeded(n, 43, -0.3, 0.3);
    ref.qdd = seeded(n, 44, -1.0, 1.0);
    LawSettings joint(n), cartesian = cartesian_settings(n), drive(n), posture = cartesian_settings(n);
    joint.law = Law::kJointImpedance;
    joint.joint_stiffness.setConstant(300.0);
    drive.law = Law::kFreeDrive;
    posture.fixed_posture = true;
    posture.nullspace_posture = q;
    posture.T_tip_frame = offset_frame();
    Data data(*model);
    Data data_ref(*model);
    LawWorkspace work(n);
    VectorXd tau(n), scratch(n);
    const char* const names[] = {"computed torque", "joint impedance", "Cartesian impedance",
                                 "Cartesian impedance with a fixed posture and an offset frame", "free drive"};
    for (int law = 0; law < 5; ++law) {
      long allocations = 0;
      {
        AllocationCounter counter;
        for (int k = 0; k < 10; ++k) {
          switch (law) {
            case 0:
              compute_tick_terms(*model, data, q, qd);
              computed_torque(*model, data, kp, kd, ref, q, qd, scratch, tau);
              break;
            case 1:
              compute_tick_terms(*model, data, q, qd);
              joint_impedance(*model, data, work, joint, ref, q, qd, tau);
              break;
            case 2:
              compute_tick_terms(*model, data, q, qd);
              body_jacobian(*model, data_ref, ref.q);
              cartesian_impedance(*model, data, data_ref, work, cartesian, ref, q, qd, tau);
              break;
            case 3:
              compute_tick_terms(*model, data, q, qd);
              body_jacobian(*model, data_ref, ref.q);
              cartesian_impedance(*model, data, data_ref, work, posture, ref, q, qd, tau);
              break;
            default:
              compute_tick_terms(*model, data, q, qd);
              free_drive(*model, data, drive, qd, tau);
          }
        }
        allocations = counter.count();
      }
      EXPECT_EQ(allocations, 0) << names[law] << ": over 10 calls";
    }
  }
}

// --- law_problem ----------------------------------------------------------------------------

::testing::AssertionResult refused_with(const RobotModel& model, const LawSettings& s, const std::string& words) {
  const std::string why = problem(model, s);
  if (why.empty()) return ::testing::AssertionFailure() << "accepted; expected a refusal saying \"" << words << "\"";
  if (why.find(words) == std::string::npos) {
    return ::testing::AssertionFailure() << "refused with \"" << why << "\"; expected it to say \"" << words << "\"";
  }
  return ::testing::AssertionSuccess();
}

TEST(LawProblem, DefaultsOfEveryLawAreAcceptedOnceAJointStiffnessIsGiven) {
  for (const RobotModel* model : {&panda(), &ur5()}) {
    const int n = model->dof();
    for (Law law : kLaws) {
      LawSettings s(n);
      s.law = law;
      if (law == Law::kJointImpedance) {
        EXPECT_TRUE(refused_with(*model, s, "joint " + model->joint(0).name + ": stiffness 0 is not in (0, 5000]"))
            << "a joint impedance must be given its K";
        s.joint_stiffness.setConstant(300.0);
      }
      EXPECT_EQ(problem(*model, s), "") << to_string(law);
    }
  }
}

TEST(LawProblem, EachRefusalNamesItsProblem) {
  const RobotModel& model = panda();
  const int n = model.dof();
  const LawSettings cartesian = cartesian_settings(n);

  LawSettings s = cartesian;
  s.cartesian_stiffness(0, 0) = -5.0;
  EXPECT_TRUE(refused_with(model, s, "not positive definite"));
  s = cartesian;  // each block definite, the whole not: the coupling is larger than both blocks allow
  s.cartesian_stiffness(0, 3) = s.cartesian_stiffness(3, 0) = 300.0;
  EXPECT_TRUE(refused_with(model, s, "not positive definite"));
  s = cartesian;
  s.cartesian_stiffness(1, 4) = 2.0;  // its transpose entry stays 0
  EXPECT_TRUE(refused_with(model, s, "not symmetric"));
  s = cartesian;
  s.cartesian_stiffness(2, 2) = std::nan("");
  EXPECT_TRUE(refused_with(model, s, "not finite"));
  s = cartesian;
  s.cartesian_stiffness(2, 2) = 600.0;
  EXPECT_TRUE(refused_with(model, s, "rotational stiffness reaches 600"));
  s.cartesian_stiffness(2, 2) = LawBounds::kMaxRotationalStiffness;
  EXPECT_EQ(problem(model, s), "") << "the bound itself is allowed";
  s = cartesian;
  s.cartesian_stiffness(4, 4) = 6000.0;
  EXPECT_TRUE(refused_with(model, s, "translational stiffness reaches 6000"));
  s = cartesian;
  s.nullspace_stiffness = 501.0;
  EXPECT_TRUE(refused_with(model, s, "nullspace stiffness 501"));
  s.nullspace_stiffness = -1.0;
  EXPECT_TRUE(refused_with(model, s, "nullspace stiffness -1"));

  for (double zeta : {0.05, 2.5, std::nan("")}) {
    for (Law law : kLaws) {
      s = cartesian;
      s.law = law;
      s.joint_stiffness.setConstant(100.0);
      s.damping_ratio = zeta;
      EXPECT_TRUE(refused_with(model, s, "damping ratio")) << zeta << " " << to_string(law);
    }
  }
  s = cartesian;
  for (double zeta : {LawBounds::kMinDampingRatio, LawBounds::kMaxDampingRatio}) {
    s.damping_ratio = zeta;
    EXPECT_EQ(problem(model, s), "") << zeta;
  }

  s = cartesian;
  s.T_tip_frame.linear() *= 1.01;  // scaled
  EXPECT_TRUE(refused_with(model, s, "not a rigid transform"));
  s = cartesian;
  s.T_tip_frame.linear() = Matrix3d(Vector3d(1, 1, -1).asDiagonal());  // a reflection
  EXPECT_TRUE(refused_with(model, s, "not a rigid transform"));
  s = cartesian;
  s.T_tip_frame.translation() = Vector3d(0.0, 1.2, 0.5);
  EXPECT_TRUE(refused_with(model, s, "stiffness frame is 1.3 m from the tip, over 1"));

  s = cartesian;
  s.fixed_posture = true;
  s.nullspace_posture = pose_of(model);
  EXPECT_EQ(problem(model, s), "");
  s.nullspace_posture(3) = 0.1;  // panda_joint4 reaches only −0.0698
  EXPECT_TRUE(refused_with(model, s, "joint panda_joint4: nullspace posture 0.1 is outside its limits"));
  s.fixed_posture = false;
  EXPECT_EQ(problem(model, s), "") << "a posture not in use is not checked";

  s = LawSettings(n);
  s.law = Law::kJointImpedance;
  s.joint_stiffness.setConstant(200.0);
  s.joint_stiffness(2) = 0.0;
  EXPECT_TRUE(refused_with(model, s, "joint panda_joint3: stiffness 0 is not in (0, 5000]"));
  s.joint_stiffness(2) = -10.0;
  EXPECT_TRUE(refused_with(model, s, "joint panda_joint3: stiffness -10"));
  s.joint_stiffness(2) = 5001.0;
  EXPECT_TRUE(refused_with(model, s, "joint panda_joint3: stiffness 5001"));
  s.joint_stiffness(2) = LawBounds::kMaxJointStiffness;
  EXPECT_EQ(problem(model, s), "");
  s.damping_from_ratio = false;
  s.joint_damping.setConstant(3.0);
  s.joint_damping(5) = -1.0;
  EXPECT_TRUE(refused_with(model, s, "joint panda_joint6: damping -1"));

  s = LawSettings(n);
  s.law = Law::kFreeDrive;
  s.damping_from_ratio = false;
  s.joint_damping.setConstant(4.0);
  EXPECT_EQ(problem(model, s), "");
  s.joint_damping(0) = 0.0;
  EXPECT_TRUE(refused_with(model, s, "joint panda_joint1: free-drive damping 0 must be positive"));

  s = LawSettings(6);
  EXPECT_TRUE(refused_with(model, s, "sized for another arm (the arm has 7 joints)"));
}

}  // namespace
}  // namespace chasles::controller
