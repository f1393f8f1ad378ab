// The arm's motion limits: where they come from, the exact peaks a reference is judged by, the
// guard on measured states, and JOINT goals held to them from rest and from a motion.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "controller/controller.hpp"
#include "core/motion/limits.hpp"
#include "core/error.hpp"
#include "core/model/urdf.hpp"
#include "support/arm.hpp"
#include "support/reference.hpp"
#include "following.hpp"

namespace chasles::controller {
namespace {

using Eigen::VectorXd;
using chasles::testing::panda;

constexpr double kInf = std::numeric_limits<double>::infinity();

using testing::bent_pose;
using testing::franka_acceleration;
using testing::franka_jerk;

double evaluate(const double* c, int degree, double t) {
  double value = 0.0;
  for (int k = degree; k >= 0; --k) value = value * t + c[k];
  return value;
}

TEST(Limits, PolynomialRangeIsWhereTheExtremaAre) {
  const double hump[3] = {0.0, 1.0, -1.0};  // t(1 − t): 1/4 at t = 1/2
  double low = 0, high = 0;
  motion::polynomial_range(hump, 2, 1.0, low, high);
  EXPECT_DOUBLE_EQ(high, 0.25);
  EXPECT_DOUBLE_EQ(low, 0.0);
  const double cube[4] = {-0.027, 0.27, -0.9, 1.0};  // (t − 0.3)³, monotone, a double root of p'
  motion::polynomial_range(cube, 3, 1.0, low, high);
  EXPECT_NEAR(low, -0.027, 1e-15);
  EXPECT_NEAR(high, 0.343, 1e-15);
  // The rest-to-rest quintic 10s³ − 15s⁴ + 6s⁵: its velocity peaks at 1.875 (s = 1/2), its
  // acceleration at ±10/√3 (s = 1/2 ∓ √3/6), its jerk at 60 (both ends).
  const double velocity[5] = {0, 0, 30, -60, 30}, acceleration[4] = {0, 60, -180, 120}, jerk[3] = {60, -360, 360};
  EXPECT_NEAR(motion::max_abs_polynomial(velocity, 4, 1.0), 1.875, 1e-15);
  EXPECT_NEAR(motion::max_abs_polynomial(acceleration, 3, 1.0), 10.0 / std::sqrt(3.0), 1e-14);
  EXPECT_NEAR(motion::max_abs_polynomial(jerk, 2, 1.0), 60.0, 1e-14);

  // Random polynomials against dense sampling, which can only fall short of the true extrema, and
  // by no more than the largest slope times half the spacing.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> coefficient(-10.0, 10.0), length(0.01, 3.0);
  for (int trial = 0; trial < 300; ++trial) {
    const int degree = trial % 6;
    double c[6], slope[5];
    for (double& x : c) x = coefficient(rng);
    for (int k = 1; k <= degree; ++k) slope[k - 1] = k * c[k];
    const double T = length(rng);
    motion::polynomial_range(c, degree, T, low, high);
    constexpr int kSamples = 20000;
    double sampled_low = kInf, sampled_high = -kInf, steepest = 0.0;
    for (int s = 0; s <= kSamples; ++s) {
      const double t = T * s / kSamples, value = evaluate(c, degree, t);
      sampled_low = std::min(sampled_low, value), sampled_high = std::max(sampled_high, value);
      if (degree > 0) steepest = std::max(steepest, std::abs(evaluate(slope, degree - 1, t)));
    }
    const double slack = steepest * T / kSamples + 1e-12;
    EXPECT_LE(low, sampled_low + 1e-12) << "trial " << trial;
    EXPECT_GE(low, sampled_low - slack) << "trial " << trial;
    EXPECT_GE(high, sampled_high - 1e-12) << "trial " << trial;
    EXPECT_LE(high, sampled_high + slack) << "trial " << trial;
  }
}

TEST(Limits, FromTheUrdfAndTheConfiguration) {
  const RobotModel model = panda();
  const motion::MotionLimits defaults(model, motion::LimitConfig{});
  for (int i = 0; i < 7; ++i) {
    const JointLimits& urdf = model.joint(i).limits;
    EXPECT_EQ(defaults.hard_lower(i), urdf.lower);
    EXPECT_EQ(defaults.hard_upper(i), urdf.upper);
    EXPECT_DOUBLE_EQ(defaults.lower(i), urdf.lower + 0.01);
    EXPECT_DOUBLE_EQ(defaults.upper(i), urdf.upper - 0.01);
    EXPECT_EQ(defaults.velocity(i), urdf.velocity);
    EXPECT_DOUBLE_EQ(defaults.acceleration(i), urdf.velocity / 0.4);
    EXPECT_DOUBLE_EQ(defaults.jerk(i), urdf.velocity / 0.4 / 0.02);
    // The defaults are gentler than the Panda's own limits on every joint.
    EXPECT_LT(defaults.acceleration(i), franka_acceleration()(i));
    EXPECT_LT(defaults.jerk(i), franka_jerk()(i));
  }
  motion::LimitConfig config;
  config.acceleration = franka_acceleration();
  config.jerk = franka_jerk();
  config.position_margin = 0.05;
  const motion::MotionLimits franka(model, config);
  EXPECT_EQ(franka.acceleration, franka_acceleration());
  EXPECT_EQ(franka.jerk, franka_jerk());
  EXPECT_DOUBLE_EQ(franka.upper(1), model.joint(1).limits.upper - 0.05);

  config.jerk = VectorXd::Constant(6, 1.0);
  EXPECT_THROW(motion::MotionLimits(model, config), ArgumentError);
  config.jerk = franka_jerk();
  config.acceleration(3) = -1.0;
  EXPECT_THROW(motion::MotionLimits(model, config), ArgumentError);
  config.acceleration(3) = std::nan("");
  EXPECT_THROW(motion::MotionLimits(model, config), ArgumentError);

  // Drake's iiwa gives its own acceleration limits (drake:acceleration): they, not the default;
  // the configuration's still win.
  UrdfOptions iiwa_options;
  iiwa_options.tip_link = "iiwa_link_ee";
  const RobotModel iiwa = load_urdf_file(chasles::testing::data_path("iiwa14.urdf"), iiwa_options);
  const motion::MotionLimits drake(iiwa, motion::LimitConfig{});
  EXPECT_EQ(drake.acceleration, (VectorXd(7) << 8.57, 8.57, 8.74, 11.36, 12.23, 15.72, 15.72).finished());
  EXPECT_EQ(drake.jerk, drake.acceleration / 0.02);
  motion::LimitConfig slower;
  slower.acceleration = VectorXd::Constant(7, 2.0);
  EXPECT_EQ(motion::MotionLimits(iiwa, slower).acceleration, VectorXd::Constant(7, 2.0));

  // tests/data/arm.urdf's j3 is continuous and has no velocity limit: nothing bounds it.
  UrdfOptions options;
  options.tip_link = "tip";
  const RobotModel arm = load_urdf_file(chasles::testing::data_path("arm.urdf"), options);
  const motion::MotionLimits free(arm, motion::LimitConfig{});
  EXPECT_EQ(free.lower(2), -kInf);
  EXPECT_EQ(free.upper(2), kInf);
  EXPECT_EQ(free.velocity(2), kInf);
  EXPECT_EQ(free.jerk(2), kInf);
}

TEST(Limits, TheGuardTripsOnSpeedAndOnACrossingOnly) {
  const RobotModel model = panda();
  const motion::MotionLimits limits(model, motion::LimitConfig{});
  const VectorXd q = bent_pose(), rest = VectorXd::Zero(7);
  EXPECT_FALSE(measured_excess(limits, q, q, rest));
  VectorXd qd = rest;
  qd(4) = -2.61 * 1.1 * (1 - 1e-12);  // within the 10 % tolerance
  EXPECT_FALSE(measured_excess(limits, q, q, qd));
  qd(4) = -2.61 * 1.1 * (1 + 1e-12);
  const motion::LimitExcess fast = measured_excess(limits, q, q, qd);
  EXPECT_EQ(fast.quantity, motion::LimitExcess::kVelocity);
  EXPECT_EQ(fast.joint, 4);
  EXPECT_EQ(fast.value, qd(4));

  VectorXd inside = q, outside = q;
  inside(3) = model.joint(3).limits.upper;  // on the limit is inside
  outside(3) = model.joint(3).limits.upper + 1e-9;
  const motion::LimitExcess crossed = measured_excess(limits, inside, outside, rest);
  EXPECT_EQ(crossed.quantity, motion::LimitExcess::kPosition);
  EXPECT_EQ(crossed.joint, 3);
  EXPECT_EQ(crossed.limit, model.joint(3).limits.upper);
  EXPECT_FALSE(measured_excess(limits, outside, outside, rest)) << "a joint already outside may be brought back";
}

// The controller fed its own reference as the state (perfect tracking), one tick per ms.
using Tracking = testing::Following;

// From rest the shortest quintic is known in closed form: panda_joint2 (7.5 rad/s²) over 0.5 rad
// peaks at (10/√3)·0.5/T² rad/s², so T ≥ √(5.7735·0.5/7.5) = 0.6204 s, longer than velocity's
// 1.875·0.5/2.175 = 0.431 s and jerk's ∛(60·0.5/3750) = 0.2 s.
TEST_F(Tracking, AGoalFromRestNeedsTheClosedFormDuration) {
  Controller controller(model_, config_);
  ASSERT_TRUE(tick(controller));
  VectorXd goal = bent_pose();
  goal(1) += 0.5;
  const double shortest = std::sqrt(10.0 / std::sqrt(3.0) * 0.5 / 7.5);
  EXPECT_FALSE(send(controller, goal, 0.5));
  const std::string why = controller.last_rejection();
  EXPECT_NE(why.find("panda_joint2: reaching the goal in 0.5 s needs a acceleration of 11.547"), std::string::npos) << why;
  EXPECT_NE(why.find("over its limit 7.5 rad/s²; 0.6204 s would do"), std::string::npos) << why;
  EXPECT_FALSE(send(controller, goal, shortest * (1 - 1e-6)));
  EXPECT_NE(std::string(controller.last_rejection()).find("acceleration"), std::string::npos);
  EXPECT_TRUE(send(controller, goal, shortest * (1 + 1e-6))) << controller.last_rejection();

  VectorXd too_far = bent_pose();
  too_far(3) = model_.joint(3).limits.upper - 0.005;  // inside the URDF's range, not its margin
  EXPECT_FALSE(send(controller, too_far, 5.0));
  EXPECT_NE(std::string(controller.last_rejection()).find("panda_joint4: target"), std::string::npos);
}

// The aggressive programme: goals timed at the velocity limit as from rest, each sent while the
// last runs. Every goal is taken or refused; every reference the arm is given, tick by tick,
// keeps to every limit (its jerk by finite differences of its acceleration).
TEST_F(Tracking, GoalsSentMidMotionKeepTheReferenceWithinTheLimits) {
  Controller controller(model_, config_);
  ASSERT_TRUE(tick(controller));
  const motion::MotionLimits& limits = controller.limits();
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int taken = 0, refused = 0;
  motion::Reference previous = controller.reference();
  for (int k = 0; k < 4000; ++k) {
    if (k % 60 == 0) {
      VectorXd goal(7);
      for (int i = 0; i < 7; ++i) goal(i) = limits.lower(i) + unit(rng) * (limits.upper(i) - limits.lower(i));
      const double duration =
          1.875 * ((goal - controller.reference().q).cwiseAbs().array() / limits.velocity.array()).maxCoeff();
      (send(controller, goal, duration) ? taken : refused)++;
    }
    ASSERT_TRUE(tick(controller));
    const motion::Reference& r = controller.reference();
    for (int i = 0; i < 7; ++i) {
      ASSERT_GE(r.q(i), limits.lower(i) - 1e-9) << "tick " << k << " joint " << i;
      ASSERT_LE(r.q(i), limits.upper(i) + 1e-9) << "tick " << k << " joint " << i;
      ASSERT_LE(std::abs(r.qd(i)), limits.velocity(i) * (1 + 1e-9)) << "tick " << k << " joint " << i;
      ASSERT_LE(std::abs(r.qdd(i)), limits.acceleration(i) * (1 + 1e-9)) << "tick " << k << " joint " << i;
      ASSERT_LE(std::abs(r.qdd(i) - previous.qdd(i)) / 1e-3, limits.jerk(i) * (1 + 1e-9)) << "tick " << k << " joint " << i;
    }
    previous = r;
    state_.q = r.q, state_.qd = r.qd;
  }
  EXPECT_GT(taken, 10);
  EXPECT_GT(refused, 10);
  EXPECT_EQ(controller.faults(), 0);
  EXPECT_EQ(controller.reflexes(), 0);
}

// A measured joint over its velocity limit, or across its position limit, stops the arm: REFLEX,
// naming the joint and the value.
TEST_F(Tracking, TheMeasuredStateIsGuarded) {
  Controller controller(model_, config_);
  ASSERT_TRUE(tick(controller));
  state_.qd(5) = 3.0;  // panda_joint6: 2.61 rad/s, +10 %
  ASSERT_TRUE(tick(controller));
  EXPECT_EQ(controller.mode(), Mode::kReflex);
  EXPECT_NE(std::string(controller.reflex_reason()).find("joint panda_joint6: velocity 3 rad/s past its limit 2.871"),
            std::string::npos)
      << controller.reflex_reason();
  EXPECT_EQ(controller.reference().q, state_.q) << "stopped where it was";

  state_.qd.setZero();
  ASSERT_TRUE(send(controller, bent_pose(), 1.0));  // a new goal ends the reflex
  ASSERT_TRUE(tick(controller));
  EXPECT_EQ(controller.mode(), Mode::kRunning);
  state_.q(0) = model_.joint(0).limits.lower - 1e-6;
  ASSERT_TRUE(tick(controller));
  EXPECT_EQ(controller.mode(), Mode::kReflex);
  EXPECT_NE(std::string(controller.reflex_reason()).find("joint panda_joint1: position -2.8973"), std::string::npos)
      << controller.reflex_reason();
  EXPECT_EQ(controller.reflexes(), 2);
  EXPECT_EQ(controller.faults(), 0);
}

}  // namespace
}  // namespace chasles::controller
