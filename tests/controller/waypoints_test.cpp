// Waypoint trajectories: the C² spline through them, its limits, and the controller following
// one — started from the moving reference without a jump, slowed to fit when allowed, refused
// naming the waypoint, joint and quantity otherwise, judged against its tolerances.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "chasles/controller/controller.hpp"
#include "chasles/controller/waypoints.hpp"
#include "chasles/core/dynamics/dynamics.hpp"
#include "support/allocation_counter.hpp"
#include "support/arm.hpp"
#include "following.hpp"

namespace chasles::controller {
namespace {

using Eigen::VectorXd;
using chasles::testing::panda;

using testing::bent_pose;
using testing::kMs;

// Rest-to-rest time of a trapezoidal velocity profile over d (triangular when too short).
double trapezoid_time(double d, double v, double a) { return d >= v * v / a ? d / v + v / a : 2.0 * std::sqrt(d / a); }

// `count` random waypoints within the limits, each reached in the time a trapezoidal profile at
// the limits takes from the one before (as a planner times them), at rest between none of them.
Waypoints random_waypoints(const MotionLimits& limits, const VectorXd& from, int count, unsigned seed) {
  Waypoints w(7);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  double t = 0.0;
  for (int k = 0; k < count; ++k) {
    double segment = 0.0;
    for (int i = 0; i < 7; ++i) {
      // Steps of up to a fifth of the range, so the path wanders the workspace.
      const double before = k == 0 ? from(i) : w.q(i, k - 1), range = limits.upper(i) - limits.lower(i);
      w.q(i, k) = std::clamp(before + range * 0.2 * (2 * unit(rng) - 1), limits.lower(i), limits.upper(i));
      segment = std::max(segment, trapezoid_time(std::abs(w.q(i, k) - before), limits.velocity(i), limits.acceleration(i)));
    }
    t += std::max(segment, 0.05);
    w.time(k) = t;
  }
  w.count = count;
  w.id = seed;
  return w;
}

TEST(WaypointSpline, PassesThroughEveryWaypointAtItsTimeAndIsC2) {
  const RobotModel model = panda();
  const MotionLimits limits(model, LimitConfig{});
  Reference start(7);
  start.q = bent_pose();
  start.qd = VectorXd::LinSpaced(7, -0.2, 0.2);
  start.qdd = VectorXd::LinSpaced(7, 0.5, -0.5);
  const Waypoints w = random_waypoints(limits, start.q, 20, 3);
  WaypointSpline spline(7);
  spline.build(start, w);
  Reference out(7), before(7), after(7);
  spline.sample(0.0, out);
  EXPECT_EQ(out.q, start.q);
  EXPECT_TRUE(out.qd.isApprox(start.qd, 1e-12));
  EXPECT_TRUE(out.qdd.isApprox(start.qdd, 1e-12));
  for (int k = 0; k < w.count; ++k) {
    spline.sample(w.time(k), out);
    EXPECT_LT((out.q - w.q.col(k)).cwiseAbs().maxCoeff(), 1e-12) << "waypoint " << k;
    // Continuous across the knot: one side against the other, 1 ns apart.
    spline.sample(w.time(k) - 1e-9, before);
    spline.sample(w.time(k) + 1e-9, after);
    if (k + 1 < w.count) {
      EXPECT_LT((after.qd - before.qd).cwiseAbs().maxCoeff(), 1e-6) << "waypoint " << k;
      EXPECT_LT((after.qdd - before.qdd).cwiseAbs().maxCoeff(), 1e-4) << "waypoint " << k;
    }
  }
  EXPECT_DOUBLE_EQ(spline.duration(), w.time(w.count - 1));
  spline.sample(spline.duration() + 1.0, out);
  EXPECT_EQ(out.q, w.q.col(w.count - 1));
  EXPECT_EQ(out.qd, VectorXd::Zero(7));

  // Its derivatives are those of its position (central differences).
  const double h = 1e-6;
  for (double t = 0.05; t < spline.duration(); t += 0.37) {
    spline.sample(t, out);
    spline.sample(t - h, before);
    spline.sample(t + h, after);
    EXPECT_LT(((after.q - before.q) / (2 * h) - out.qd).cwiseAbs().maxCoeff(), 1e-5) << t;
    EXPECT_LT(((after.qd - before.qd) / (2 * h) - out.qdd).cwiseAbs().maxCoeff(), 1e-4) << t;
  }
}

// The controller fed its own reference, or the model integrated, as the arm; gains stiff enough
// for sub-mrad tracking.
class Following : public testing::Following {
 protected:
  Following() : testing::Following(40.0) {}
};

// The case: 50 random waypoints timed by trapezoids, which a spline through them cannot
// follow at the limits, so it is refused as sent and taken slowed when allowed; then every tick's
// reference keeps to every limit, its jerk by differences of its acceleration, the arm follows
// it within 1 mrad RMS, and the outcome is SUCCEEDED at the last waypoint.
TEST_F(Following, FiftyTrapezoidTimedWaypointsSlowedToFitAndTracked) {
  Controller controller(model_, config_);
  Data plant(model_);
  ASSERT_TRUE(tick(controller));
  Waypoints w = random_waypoints(controller.limits(), bent_pose(), 50, 11);
  w.goal_tolerance = VectorXd::Constant(7, 1e-3);
  w.goal_time = 0.5;
  EXPECT_FALSE(controller.set_trajectory(w, now_));
  const std::string why = controller.last_rejection();
  EXPECT_NE(why.find("trajectory 11: waypoint "), std::string::npos) << why;
  EXPECT_NE(why.find("(allow time scaling)"), std::string::npos) << why;
  EXPECT_EQ(controller.trajectory().outcome, TrajectoryProgress::kRejected);
  EXPECT_EQ(controller.mode(), Mode::kHolding);

  w.time_scaling = true;
  ASSERT_TRUE(controller.set_trajectory(w, now_)) << controller.last_rejection();
  const TrajectoryProgress& p = controller.trajectory();
  EXPECT_EQ(p.outcome, TrajectoryProgress::kActive);
  EXPECT_GT(p.scale, 1.0);
  EXPECT_DOUBLE_EQ(p.duration, p.scale * w.time(49));
  const MotionLimits& limits = controller.limits();
  Reference previous = controller.reference();
  double error_sq = 0.0;
  int64_t samples = 0;
  long allocations = 0;
  while (p.outcome == TrajectoryProgress::kActive && now_ < 200'000 * kMs) {
    {
      const chasles::testing::AllocationCounter counter;
      ASSERT_TRUE(tick(controller));
      allocations += counter.count();
    }
    const Reference& r = controller.reference();
    for (int i = 0; i < 7; ++i) {
      ASSERT_LE(std::abs(r.qd(i)), limits.velocity(i) * (1 + 1e-9)) << now_;
      ASSERT_LE(std::abs(r.qdd(i)), limits.acceleration(i) * (1 + 1e-9)) << now_;
      ASSERT_LE(std::abs(r.qdd(i) - previous.qdd(i)) / 1e-3, limits.jerk(i) * (1 + 1e-9)) << now_ << " joint " << i;
    }
    previous = r;
    error_sq += controller.error().squaredNorm();
    samples += 7;
    integrate(controller, plant);
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_EQ(p.outcome, TrajectoryProgress::kSucceeded) << p.message;
  EXPECT_EQ(p.waypoint, 50);
  const double rms = std::sqrt(error_sq / static_cast<double>(samples));
  std::printf("[ trajectory ] 50 waypoints slowed %.3fx to %.2f s, tracking RMS %.3g mrad\n", p.scale, p.duration, 1e3 * rms);
  EXPECT_LT(rms, 1e-3);
  EXPECT_LT((state_.q - w.q.col(49)).cwiseAbs().maxCoeff(), 1e-3);
}

TEST_F(Following, BadTrajectoriesAreRefusedNamingWhatIsWrong) {
  Controller controller(model_, config_);
  ASSERT_TRUE(tick(controller));
  const auto refused = [&](const Waypoints& w, const char* words) {
    EXPECT_FALSE(controller.set_trajectory(w, now_)) << words;
    EXPECT_NE(std::string(controller.last_rejection()).find(words), std::string::npos) << controller.last_rejection();
    // The trajectory taken first goes on: the status tells its progress, the refusal is counted.
    EXPECT_EQ(controller.trajectory().outcome, TrajectoryProgress::kActive);
  };
  Waypoints w(7);
  w.count = 2;
  w.time(0) = 1.0, w.time(1) = 2.0;
  w.q.col(0) = bent_pose(), w.q.col(1) = bent_pose();
  w.q(1, 1) += 0.1;
  w.time_scaling = true;
  ASSERT_TRUE(controller.set_trajectory(w, now_));

  // w with one thing changed.
  const auto changed = [&w](auto change) {
    Waypoints bad(w);
    change(bad);
    return bad;
  };
  refused(changed([](Waypoints& b) { b.count = 0; }), "0 waypoints; 1 to 1000 are taken");
  refused(changed([](Waypoints& b) { b.time(1) = 1.0; }), "waypoint 1: time 1 s is not after 1 s");
  refused(changed([](Waypoints& b) { b.time(0) = 0.0; }), "waypoint 0: time 0 s is not after 0 s");
  refused(changed([](Waypoints& b) { b.q(4, 1) = std::nan(""); }), "waypoint 1, joint panda_joint5: a value that is not finite");
  // panda_joint4 ∈ [−3.07, −0.07]
  refused(changed([](Waypoints& b) { b.q(3, 0) = 0.0; }), "waypoint 0, joint panda_joint4: position 0 outside");
  refused(changed([](Waypoints& b) {
            b.has_velocities = true;
            b.qd.setZero();
            b.qd(2, 1) = 0.1;
          }),
          "the last waypoint must be at rest");
  refused(changed([](Waypoints& b) { b.path_tolerance(0) = -1.0; }), "tolerances must be finite and non-negative");
  const Waypoints hasty = changed([](Waypoints& b) {
    b.time_scaling = false;
    b.time(0) = 0.01;  // 0.1 rad of panda_joint2 in 10 ms
    b.q(1, 0) += 0.1;
  });
  refused(hasty, "waypoint 0, joint panda_joint2: ");
  refused(hasty, "(allow time scaling)");
  // None of this disturbed the trajectory taken first, which ends as it was sent.
  while (controller.mode() == Mode::kRunning) {
    ASSERT_TRUE(tick(controller));
    state_.q = controller.reference().q;
  }
  EXPECT_EQ((controller.reference().q - w.q.col(1)).cwiseAbs().maxCoeff(), 0.0);
}

// A trajectory taken mid-motion starts from the moving reference: no jump in the reference's
// position, velocity or acceleration. A joint off the path ABORTS it, naming the joint; a new
// target PREEMPTS one.
TEST_F(Following, StartsWithoutAJumpAndEndsAsItsTolerancesSay) {
  Controller controller(model_, config_);
  ASSERT_TRUE(tick(controller));
  Target target(7);
  target.mode = Target::kJoint;
  target.num_joints = 7;
  target.q = bent_pose();
  target.q(0) += 0.5;
  target.duration = 2.0;
  ASSERT_TRUE(controller.set_target(target, now_));
  for (int k = 0; k < 700; ++k) {
    ASSERT_TRUE(tick(controller));
    state_.q = controller.reference().q;
  }
  const Reference moving = controller.reference();
  ASSERT_GT(std::abs(moving.qd(0)), 0.1);
  Waypoints w(7);
  w.count = 2;
  w.time(0) = 1.0, w.time(1) = 2.0;
  w.q.col(0) = bent_pose(), w.q.col(1) = bent_pose();
  w.q(0, 1) -= 0.2;
  w.time_scaling = true;
  w.path_tolerance = VectorXd::Constant(7, 0.01);
  w.id = 5;
  ASSERT_TRUE(controller.set_trajectory(w, now_)) << controller.last_rejection();
  ASSERT_TRUE(tick(controller));
  const Reference& r = controller.reference();
  // One tick on: the reference moved on as its velocity and acceleration said.
  EXPECT_LT(std::abs(r.q(0) - (moving.q(0) + 1e-3 * moving.qd(0) + 0.5e-6 * moving.qdd(0))), 1e-6);
  EXPECT_LT(std::abs(r.qd(0) - (moving.qd(0) + 1e-3 * moving.qdd(0))), 1e-2);
  state_.q = r.q;
  for (int k = 0; k < 100; ++k) {
    ASSERT_TRUE(tick(controller));
    state_.q = controller.reference().q;
  }
  state_.q(6) += 0.02;  // pushed off the path
  ASSERT_TRUE(tick(controller));
  const TrajectoryProgress& p = controller.trajectory();
  EXPECT_EQ(p.outcome, TrajectoryProgress::kAborted);
  EXPECT_EQ(p.id, 5);
  EXPECT_NE(std::string(p.message).find("joint panda_joint7: 0.02"), std::string::npos) << p.message;
  EXPECT_EQ(controller.mode(), Mode::kHolding);
  EXPECT_EQ(controller.reference().q, state_.q) << "holds where the arm is";

  w.id = 6;
  w.path_tolerance.setZero();
  w.q.col(0) = state_.q, w.q.col(1) = state_.q;
  w.q(0, 1) += 0.1;
  ASSERT_TRUE(controller.set_trajectory(w, now_));
  ASSERT_TRUE(tick(controller));
  target.q = state_.q;
  ASSERT_TRUE(controller.set_target(target, now_));
  EXPECT_EQ(p.outcome, TrajectoryProgress::kPreempted);
  EXPECT_EQ(p.id, 6);
  EXPECT_STREQ(p.message, "a JOINT target");
}

// A control law preempts a running trajectory: the reference brakes to rest from where it was
// going, within the limits and without a jump, and holds there.
TEST_F(Following, ALawPreemptsATrajectoryAndTheReferenceBrakesToRest) {
  Controller controller(model_, config_);
  ASSERT_TRUE(tick(controller));
  Waypoints w(7);
  w.count = 1;
  w.time(0) = 1.0;
  w.q.col(0) = bent_pose();
  w.q(0, 0) += 0.6;
  ASSERT_TRUE(controller.set_trajectory(w, now_)) << controller.last_rejection();
  for (int k = 0; k < 400; ++k) {
    ASSERT_TRUE(tick(controller));
    state_.q = controller.reference().q;
  }
  const Reference moving = controller.reference();
  ASSERT_GT(moving.qd(0), 0.5);
  LawSettings settings(7);
  settings.law = Law::kJointImpedance;
  settings.joint_stiffness = VectorXd::Constant(7, 300.0);
  ASSERT_TRUE(controller.set_law(settings, now_)) << controller.mode_rejection();
  EXPECT_EQ(controller.trajectory().outcome, TrajectoryProgress::kPreempted);
  Reference before = moving;
  int ticks = 0;
  while (controller.mode() == Mode::kRunning && ticks < 2000) {
    ASSERT_TRUE(tick(controller));
    expect_within_limits(controller, before);
    ASSERT_FALSE(HasFatalFailure());
    // No jump: each tick moves on from the last by what its velocity and acceleration say.
    const Reference& r = controller.reference();
    ASSERT_LT(std::abs(r.q(0) - before.q(0) - 1e-3 * before.qd(0)), 1e-3 * 1e-3 * 15.0) << ticks;
    before = r;
    state_.q = r.q;
    ++ticks;
  }
  EXPECT_EQ(controller.mode(), Mode::kHolding);
  EXPECT_EQ(controller.reference().qd.norm(), 0.0);
  EXPECT_LT(controller.reference().q(0), bent_pose()(0) + 0.6) << "stopped before the preempted goal";
  EXPECT_LT(ticks, 300);  // from under 1.2 rad/s at 15 rad/s², jerk-limited: about 0.1 s
}

// Past the end the arm must come within the goal tolerance within goal_time, else ABORTED.
TEST_F(Following, AGoalMissedPastGoalTimeAborts) {
  Controller controller(model_, config_);
  ASSERT_TRUE(tick(controller));
  Waypoints w(7);
  w.count = 1;
  w.time(0) = 1.0;
  w.q.col(0) = bent_pose();
  w.q(2, 0) += 0.05;
  w.goal_tolerance = VectorXd::Constant(7, 1e-3);
  w.goal_time = 0.2;
  ASSERT_TRUE(controller.set_trajectory(w, now_)) << controller.last_rejection();
  const TrajectoryProgress& p = controller.trajectory();
  while (p.outcome == TrajectoryProgress::kActive && now_ < 5000 * kMs) {
    ASSERT_TRUE(tick(controller));
    state_.q = controller.reference().q;
    state_.q(2) -= 0.01;  // an arm that stops 10 mrad short
  }
  EXPECT_EQ(p.outcome, TrajectoryProgress::kAborted);
  EXPECT_NE(std::string(p.message).find("joint panda_joint3: 0.01 rad from its goal"), std::string::npos) << p.message;
  EXPECT_NEAR(1e-9 * static_cast<double>(now_) - 1e-3, 1.0 + 0.2, 2e-3);
}

}  // namespace
}  // namespace chasles::controller
