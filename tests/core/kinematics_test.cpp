// Forward kinematics and Jacobians: against the independent reference, against each other, by
// the first-order property of the space Jacobian, and for heap allocations.
#include "core/kinematics/kinematics.hpp"

#include <gtest/gtest.h>

#include <random>

#include "core/lie/se3.hpp"
#include "core/model/urdf.hpp"
#include "support/allocation_counter.hpp"
#include "support/reference.hpp"

namespace chasles {
namespace {

using testing::matrices_near;

class Kinematics : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    ref_ = testing::load_reference(GetParam());
    UrdfOptions options;
    options.tip_link = ref_.tip_link;
    model_ = std::make_unique<RobotModel>(load_urdf_file(ref_.urdf, options));
    data_ = std::make_unique<Data>(*model_);
  }

  // Seeded random configurations within the joint limits.
  std::vector<Eigen::VectorXd> random_configurations(int count) const {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::vector<Eigen::VectorXd> qs;
    for (int k = 0; k < count; ++k) {
      Eigen::VectorXd q(model_->dof());
      for (int i = 0; i < model_->dof(); ++i) {
        const auto& l = model_->joint(i).limits;
        q(i) = l.lower + (l.upper - l.lower) * unit(rng);
      }
      qs.push_back(q);
    }
    return qs;
  }

  testing::Reference ref_;
  std::unique_ptr<RobotModel> model_;
  std::unique_ptr<Data> data_;
};

TEST_P(Kinematics, MatchesTheReference) {
  double worst = 0.0;
  for (size_t k = 0; k < ref_.cases.size(); ++k) {
    const auto& c = ref_.cases[k];
    SCOPED_TRACE("case " + std::to_string(k));
    const Matrix4d T = forward_kinematics(*model_, *data_, c.q).matrix();
    EXPECT_TRUE(matrices_near(T, c.T, 1e-10));
    const Eigen::MatrixXd J_s = space_jacobian(*model_, *data_, c.q);
    EXPECT_TRUE(matrices_near(J_s, c.J_s, 1e-10));
    const Eigen::MatrixXd J_b = body_jacobian(*model_, *data_, c.q);
    EXPECT_TRUE(matrices_near(J_b, c.J_b, 1e-10));
    worst = std::max(
        {worst, testing::max_abs_diff(T, c.T), testing::max_abs_diff(J_s, c.J_s), testing::max_abs_diff(J_b, c.J_b)});
    const auto& poses = link_poses(*model_, *data_, c.q);
    ASSERT_EQ(poses.size(), c.link_T.size());
    for (size_t l = 0; l < poses.size(); ++l) {
      const std::string& name = model_->links()[l].name;
      ASSERT_TRUE(c.link_T.count(name)) << name;
      EXPECT_TRUE(matrices_near(poses[l].matrix(), c.link_T.at(name), 1e-10)) << name;
      worst = std::max(worst, testing::max_abs_diff(poses[l].matrix(), c.link_T.at(name)));
    }
  }
  RecordProperty("max_abs_error", std::to_string(worst));
  std::cout << GetParam() << ": max abs error over T, J_s, J_b, link_T = " << worst << "\n";
}

TEST_P(Kinematics, SpaceAndBodyFormsAgree) {
  for (const auto& q : random_configurations(100)) {
    const Matrix4d T = forward_kinematics(*model_, *data_, q).matrix();
    EXPECT_TRUE(matrices_near(forward_kinematics_space(*model_, q).matrix(), T, 1e-13));
    EXPECT_TRUE(matrices_near(forward_kinematics_body(*model_, q).matrix(), T, 1e-13));
  }
}

TEST_P(Kinematics, SpaceJacobianIsTheAdjointOfTheBodyJacobian) {
  for (const auto& q : random_configurations(100)) {
    const Eigen::MatrixXd J_b = body_jacobian(*model_, *data_, q);
    const Eigen::MatrixXd J_s = space_jacobian(*model_, *data_, q);
    EXPECT_TRUE(matrices_near(J_s, adjoint(data_->T_sb) * J_b, 1e-13));  // MR eq. 5.22
  }
}

TEST_P(Kinematics, SpaceJacobianIsTheFirstOrderMotion) {
  // T(q + εδ) = exp([J_s δ] ε) T(q) + O(ε²): the error shrinks fourfold when ε halves.
  std::mt19937_64 rng(11);
  std::normal_distribution<double> normal;
  for (const auto& q : random_configurations(30)) {
    Eigen::VectorXd delta(model_->dof());
    for (int i = 0; i < delta.size(); ++i) delta(i) = normal(rng);
    const Transform T = forward_kinematics(*model_, *data_, q);
    const Vector6d V_s = space_jacobian(*model_, *data_, q) * delta;
    auto error = [&](double eps) {
      const Eigen::VectorXd q_eps = q + eps * delta;
      const Transform T_eps = forward_kinematics(*model_, *data_, q_eps);
      return (T_eps.matrix() - (exp6(V_s * eps) * T).matrix()).norm();
    };
    const double e1 = error(1e-3), e2 = error(5e-4);
    EXPECT_LT(e1, 1e-4);
    EXPECT_NEAR(e1 / e2, 4.0, 0.2);
    // The body Jacobian likewise, on the right: T(q + εδ) ≈ T(q) exp([J_b δ] ε).
    const Vector6d V_b = body_jacobian(*model_, *data_, q) * delta;
    const Eigen::VectorXd q_eps = q + 1e-6 * delta;
    const Transform T_eps = forward_kinematics(*model_, *data_, q_eps);
    EXPECT_TRUE(matrices_near(log6(inverse(T) * T_eps) / 1e-6, V_b, 1e-5));
  }
}

TEST_P(Kinematics, TheBodyJacobiansChangeIsItsFirstOrderMotion) {
  // J_b(q + εδ) = J_b(q) + ε dJ_b[δ] + O(ε²): the error shrinks fourfold when ε halves.
  std::mt19937_64 rng(12);
  std::normal_distribution<double> normal;
  Matrix6Xd dJ(6, model_->dof());
  for (const auto& q : random_configurations(30)) {
    Eigen::VectorXd delta(model_->dof());
    for (int i = 0; i < delta.size(); ++i) delta(i) = normal(rng);
    const Matrix6Xd J = body_jacobian(*model_, *data_, q);
    body_jacobian_change(J, delta, dJ);
    auto error = [&](double eps) {
      const Eigen::VectorXd q_eps = q + eps * delta;
      return (body_jacobian(*model_, *data_, q_eps) - (J + eps * dJ)).norm();
    };
    const double e1 = error(1e-3), e2 = error(5e-4);
    EXPECT_LT(e1, 1e-4);
    EXPECT_NEAR(e1 / e2, 4.0, 0.2);
  }
}

TEST_P(Kinematics, AllocatesNothing) {
  const auto qs = random_configurations(10);
  testing::AllocationCounter counter;
  for (const auto& q : qs) {
    forward_kinematics(*model_, *data_, q);
    link_poses(*model_, *data_, q);
    space_jacobian(*model_, *data_, q);
    body_jacobian(*model_, *data_, q);
    forward_kinematics_space(*model_, q);
    forward_kinematics_body(*model_, q);
  }
  EXPECT_EQ(counter.count(), 0);
}

TEST(AllocationCounter, SeesAllocations) {
  // The counter itself must work, or AllocatesNothing proves nothing.
  testing::AllocationCounter counter;
  Eigen::VectorXd v(1000);
  v.setZero();
  auto p = std::make_unique<int>(3);
  EXPECT_GE(counter.count(), 2);
}

TEST_P(Kinematics, WrongSizeIsRejected) {
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(model_->dof() + 1);
  EXPECT_THROW(forward_kinematics(*model_, *data_, q), ArgumentError);
  EXPECT_THROW(space_jacobian(*model_, *data_, q), ArgumentError);
  EXPECT_THROW(forward_kinematics_space(*model_, q), ArgumentError);
}

INSTANTIATE_TEST_SUITE_P(Robots, Kinematics, ::testing::Values("ur5", "panda", "tiago", "talos_left_arm", "finger_edu", "iiwa14"));

}  // namespace
}  // namespace chasles
