// Cartesian goals' joint paths (controller/cartesian.hpp) on their own: the screw line followed to
// the goal, the tip moved at the line's twist, every limit kept tick by tick, a continuous joint
// crossing π. The Controller's side of them — the request, the hand-over, the follow — is
// controller_test's.
#include <gtest/gtest.h>

#include <cmath>

#include "controller/cartesian.hpp"
#include "core/ik/ik.hpp"
#include "core/kinematics/kinematics.hpp"
#include "core/lie/se3.hpp"
#include "core/model/urdf.hpp"
#include "support/arm.hpp"
#include "support/reference.hpp"

namespace chasles::controller {
namespace {

using Eigen::VectorXd;
using testing::data_path;
using testing::matrices_near;
using testing::panda;

VectorXd start_pose() {
  VectorXd q(7);
  q << 0.1, 0.5, -0.2, -1.2, 0.1, 1.0, 0.3;
  return q;
}

TEST(CartesianPath, FollowsTheScrewLineAndReachesTheGoal) {
  const RobotModel model = panda();
  Data data(model);
  IkSolver solver(model);
  CartesianRequest request(7);
  request.id = 1;
  request.q_start = start_pose();
  VectorXd q_goal = start_pose();
  q_goal << -0.3, 0.2, 0.3, -1.9, -0.2, 1.6, 0.5;
  request.T_goal = forward_kinematics(model, data, q_goal);
  request.duration = 2.0;
  JointPath path(7);
  plan_cartesian_path(solver, motion::MotionLimits(model, {}), request, path);
  ASSERT_TRUE(path.ok) << path.reason;
  EXPECT_EQ(path.request_id, 1);
  EXPECT_EQ(path.count, 201);
  const Transform T0 = forward_kinematics(model, data, request.q_start);
  const Vector6d V = log6(inverse(T0) * request.T_goal);
  for (int k = 0; k < path.count; k += 20) {
    const double tau = double(k) / (path.count - 1), s = tau * tau * tau * (10 - 15 * tau + 6 * tau * tau);
    const Transform expected = T0 * exp6(V * s);
    const Transform T = forward_kinematics(model, data, path.q.col(k));
    EXPECT_LT((T.translation() - expected.translation()).norm(), 1e-6) << "waypoint " << k;
    EXPECT_LT(log3(T.linear().transpose() * expected.linear()).norm(), 1e-6) << "waypoint " << k;
  }
  // The sampler passes through the waypoints, at rest at both ends, its derivatives consistent.
  JointPathSampler sampler(7);
  sampler.start(path);
  motion::Reference r(7), before(7), after(7);
  for (int k : {0, 37, 100, 200}) {
    sampler.sample(k * path.dt, r);
    EXPECT_TRUE(matrices_near(r.q, path.q.col(k), 1e-12)) << k;
  }
  sampler.sample(0.0, r);
  EXPECT_TRUE(matrices_near(r.qd, VectorXd::Zero(7), 0.0));
  sampler.sample(5.0, r);
  EXPECT_TRUE(matrices_near(r.qd, VectorXd::Zero(7), 0.0));
  const double h = 1e-6;
  for (double t : {0.333, 1.0051, 1.777}) {
    sampler.sample(t, r);
    sampler.sample(t - h, before);
    sampler.sample(t + h, after);
    EXPECT_TRUE(matrices_near(r.qd, (after.q - before.q) / (2 * h), 1e-6)) << t;
  }

  // Far out of reach: the line leaves the workspace, through a stretched-out singularity first.
  request.T_goal.translation() << 10.0, 0.0, 0.5;
  plan_cartesian_path(solver, motion::MotionLimits(model, {}), request, path);
  EXPECT_FALSE(path.ok);
  const std::string why = path.reason;
  EXPECT_TRUE(why.find("cannot follow") != std::string::npos || why.find("singularity") != std::string::npos) << why;
}

// The tip's body twist on the screw line T_0 exp([V] s(t)) is V ṡ, and its rate V s̈: what the
// joint path's velocity and acceleration must give through J_b, whatever the arm's redundancy.
TEST(CartesianPath, TheSampledJointMotionMovesTheTipAtTheScrewLinesTwist) {
  const RobotModel& model = panda();
  Data data(model);
  IkSolver solver(model);
  const motion::MotionLimits limits(model, {});
  CartesianRequest request(7);
  request.id = 3;
  request.q_start = start_pose();
  VectorXd q_goal(7);
  q_goal << -0.3, 0.2, 0.3, -1.9, -0.2, 1.6, 0.5;
  request.T_goal = forward_kinematics(model, data, q_goal);
  request.duration = 1.5;
  JointPath path(7);
  plan_cartesian_path(solver, limits, request, path);
  ASSERT_TRUE(path.ok) << path.reason;
  const Transform T0 = forward_kinematics(model, data, request.q_start);
  const Vector6d V = log6(inverse(T0) * request.T_goal);
  const double T = request.duration;
  JointPathSampler sampler(7);
  sampler.start(path);
  motion::Reference r(7), before(7), after(7);
  const auto body_twist = [&](const motion::Reference& at) -> Vector6d { return body_jacobian(model, data, at.q) * at.qd; };
  const double peak_twist = 1.875 / T * V.norm(), peak_rate = 5.7735 / (T * T) * V.norm();
  const double h = 1e-5;
  for (double t = 0.013; t < T; t += 0.0517) {
    const double tau = t / T;
    const double s = tau * tau * tau * (10 - 15 * tau + 6 * tau * tau);
    const double s_dot = 30 * tau * tau * (1 - tau) * (1 - tau) / T;
    const double s_ddot = 60 * tau * (1 - tau) * (1 - 2 * tau) / (T * T);
    sampler.sample(t, r);
    const Transform expected = T0 * exp6(V * s);
    const Transform at = forward_kinematics(model, data, r.q);
    EXPECT_LT((at.translation() - expected.translation()).norm(), 2e-6) << t;
    EXPECT_LT(log3(at.linear().transpose() * expected.linear()).norm(), 2e-6) << t;
    EXPECT_LT((body_twist(r) - V * s_dot).norm(), 1e-4 * peak_twist) << t;
    sampler.sample(t - h, before);
    sampler.sample(t + h, after);
    const Vector6d rate = (body_twist(after) - body_twist(before)) / (2 * h);
    EXPECT_LT((rate - V * s_ddot).norm(), 1e-3 * peak_rate) << t;
  }
}

TEST(CartesianPath, EveryLimitHoldsAlongThePathTickByTick) {
  const RobotModel& model = panda();
  Data data(model);
  IkSolver solver(model);
  const motion::MotionLimits limits(model, {});
  CartesianRequest request(7);
  request.id = 4;
  request.q_start = start_pose();
  VectorXd q_goal(7);
  q_goal << 0.6, 0.1, -0.5, -2.0, 0.4, 1.4, -0.2;
  request.T_goal = forward_kinematics(model, data, q_goal);
  request.duration = 1.2;
  JointPath path(7);
  plan_cartesian_path(solver, limits, request, path);
  ASSERT_TRUE(path.ok) << path.reason;
  JointPathSampler sampler(7);
  sampler.start(path);
  motion::Reference r(7);
  const double dt = 1e-4;
  VectorXd qdd_before = VectorXd::Zero(7);
  double worst_jerk = 0.0;  // of its limit
  for (int k = 0; k * dt <= request.duration + 0.01; ++k) {
    sampler.sample(k * dt, r);
    for (int i = 0; i < 7; ++i) {
      ASSERT_GE(r.q(i), limits.lower(i)) << i;
      ASSERT_LE(r.q(i), limits.upper(i)) << i;
      ASSERT_LE(std::abs(r.qd(i)), limits.velocity(i)) << i << " at " << k * dt;
      ASSERT_LE(std::abs(r.qdd(i)), limits.acceleration(i)) << i << " at " << k * dt;
      if (k > 0) worst_jerk = std::max(worst_jerk, std::abs(r.qdd(i) - qdd_before(i)) / dt / limits.jerk(i));
      qdd_before(i) = r.qdd(i);
    }
  }
  EXPECT_LE(worst_jerk, 1.0 + 1e-3);
  // The same move in 0.4 s is 27× the jerk: refused, naming the least duration that does, which
  // then plans (the waypoints move with the duration, so to their rounding: 0.98 of it does not).
  request.duration = 0.4;
  plan_cartesian_path(solver, limits, request, path);
  ASSERT_FALSE(path.ok);
  const std::string why = path.reason;
  const size_t at = why.find("; ");
  ASSERT_NE(why.find(" s would do"), std::string::npos) << why;
  const double enough = std::stod(why.substr(at + 2));
  EXPECT_GT(enough, 0.4) << why;
  request.duration = enough;
  plan_cartesian_path(solver, limits, request, path);
  EXPECT_TRUE(path.ok) << path.reason;
  request.duration = 0.98 * enough;
  plan_cartesian_path(solver, limits, request, path);
  EXPECT_FALSE(path.ok) << "at 0.98 of " << enough << " s";
}

TEST(CartesianPath, AContinuousJointCrossingPiMovesOnInsteadOfJumpingBack) {
  // tests/data/arm.urdf: j3 is continuous, without a velocity limit. A turn of j3 alone is a
  // straight screw line of the tip, so a 3-joint arm can follow it; from 3.0 to 3.5 rad it crosses
  // π, where IK answers −2.78.
  UrdfOptions options;
  options.tip_link = "tip";
  const RobotModel model = load_urdf_file(data_path("arm.urdf"), options);
  ASSERT_EQ(model.joint(2).type, JointType::Continuous);
  Data data(model);
  IkSolver solver(model);
  CartesianRequest request(3);
  request.id = 2;
  request.q_start = Eigen::Vector3d(0.3, 0.2, 3.0);
  request.T_goal = forward_kinematics(model, data, Eigen::Vector3d(0.3, 0.2, 3.5));
  request.duration = 1.0;
  JointPath path(3);
  plan_cartesian_path(solver, motion::MotionLimits(model, {}), request, path);
  ASSERT_TRUE(path.ok) << path.reason;
  for (int k = 1; k < path.count; ++k) {
    EXPECT_LT(std::abs(path.q(2, k) - path.q(2, k - 1)), 0.02) << "waypoint " << k;
  }
  EXPECT_NEAR(path.q(2, path.count - 1), 3.5, 1e-6);
}

}  // namespace
}  // namespace chasles::controller
