// Jogging: joint velocities and tip twists held until the next command become a reference that
// stays C² within every limit, moves the tip as asked, slows toward a singularity and stops short
// of it and of every position limit, and comes to rest when the commands stop.
#include <gtest/gtest.h>

#include <Eigen/SVD>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <string>

#include "controller/controller.hpp"
#include "controller/jog.hpp"
#include "core/kinematics/kinematics.hpp"
#include "core/lie/se3.hpp"
#include "following.hpp"
#include "support/allocation_counter.hpp"
#include "support/arm.hpp"
#include "support/decompositions.hpp"

namespace chasles::controller {
namespace {

using Eigen::VectorXd;
using testing::kMs;

// κ from Eigen's SVD of J_b, independently of JacobianSpectrum's eigenvalues of J Jᵀ.
double condition_by_svd(const Matrix6Xd& J) {
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(J);
  const VectorXd& s = svd.singularValues();  // descending
  return s(0) / s(s.size() - 1);
}

TEST(JacobianSpectrum, ConditionAndPseudoInverseMatchTheSvd) {
  std::mt19937_64 rng(17);
  std::normal_distribution<double> normal;
  JacobianSpectrum spectrum;
  for (const int n : {5, 6, 7, 9}) {
    for (int k = 0; k < 50; ++k) {
      Matrix6Xd J(6, n);
      for (int r = 0; r < 6; ++r) {
        for (int c = 0; c < n; ++c) J(r, c) = normal(rng);
      }
      Vector6d V;
      for (int r = 0; r < 6; ++r) V(r) = normal(rng);
      spectrum.compute(J);
      EXPECT_NEAR(spectrum.condition(), condition_by_svd(J), 1e-9 * condition_by_svd(J)) << "n = " << n;
      VectorXd qd(n);
      spectrum.solve(J, V, qd);
      const Eigen::JacobiSVD<Eigen::MatrixXd> svd(J, Eigen::ComputeThinU | Eigen::ComputeThinV);
      const VectorXd expected = svd.solve(V);  // least squares, minimum norm
      EXPECT_LE((qd - expected).norm(), 1e-10 * expected.norm()) << "n = " << n;
    }
  }
  // A singular Jacobian: κ is infinite and the pseudo-inverse leaves out the missing direction.
  Matrix6Xd J = Matrix6Xd::Zero(6, 6);
  for (int k = 0; k < 5; ++k) J(k, k) = 1.0 + k;
  spectrum.compute(J);
  EXPECT_EQ(spectrum.condition(), std::numeric_limits<double>::infinity());
  VectorXd qd(6);
  spectrum.solve(J, Vector6d::Ones(), qd);
  for (int k = 0; k < 5; ++k) EXPECT_NEAR(qd(k), 1.0 / (1.0 + k), 1e-14);
  EXPECT_EQ(qd(5), 0.0);
}

TEST(JogConfig, ThresholdsOutOfOrderAreRefused) {
  JogConfig config;
  EXPECT_NO_THROW(config.validate());
  config.slow_condition = 30.0;
  EXPECT_THROW(config.validate(), ArgumentError);
  config.slow_condition = 0.5;
  EXPECT_THROW(config.validate(), ArgumentError);
  config.slow_condition = 17.0;
  config.stop_condition = NAN;
  EXPECT_THROW(config.validate(), ArgumentError);
}

class Jogging : public testing::Following {
 protected:
  Jogging() = default;
  Jogging(const RobotModel& model, const VectorXd& start) : Following(model, start) {}

  Jog joint_jog(const VectorXd& qd) {
    Jog jog(model_.dof());
    jog.utime = ++utime_;
    jog.kind = Jog::kJointVelocity;
    jog.joint_velocity = qd;
    return jog;
  }
  Jog twist_jog(const Vector6d& twist, Jog::Frame frame) {
    Jog jog(model_.dof());
    jog.utime = ++utime_;
    jog.kind = Jog::kTwist;
    jog.frame = frame;
    jog.twist = twist;
    return jog;
  }
  /// Ticks for `seconds`, the jog sent again every `period` (30 Hz unless said), the arm tracking
  /// the reference perfectly; every tick's reference checked against every limit, and its
  /// condition number (by SVD) below the stop threshold unless it started above. Returns the
  /// largest condition number met.
  double hold_jog(Controller& controller, const Jog& jog, double seconds, double period = 1.0 / 30.0) {
    const int64_t start = now_;
    int64_t next_send = now_;
    double worst = 0.0;
    Data data(model_);
    motion::Reference before = controller.reference();
    while (now_ < start + static_cast<int64_t>(seconds * 1e9)) {
      if (now_ >= next_send) {
        Jog again = jog;
        again.utime = ++utime_;
        EXPECT_TRUE(controller.set_jog(again, now_ + kMs)) << controller.last_rejection();
        next_send += static_cast<int64_t>(period * 1e9);
      }
      EXPECT_TRUE(tick(controller));
      expect_within_limits(controller, before);
      if (HasFatalFailure()) return worst;
      before = controller.reference();
      state_.q = controller.reference().q, state_.qd = controller.reference().qd;
      worst = std::max(worst, condition_by_svd(body_jacobian(model_, data, controller.reference().q)));
    }
    return worst;
  }
  /// Ticks while the controller is RUNNING (at most 1000), every reference within the limits;
  /// returns how many.
  int ticks_to_rest(Controller& controller) {
    motion::Reference before = controller.reference();
    int ticks = 0;
    while (controller.mode() == Mode::kRunning && ticks < 1000) {
      EXPECT_TRUE(tick(controller));
      expect_within_limits(controller, before);
      if (HasFatalFailure()) break;
      before = controller.reference();
      ++ticks;
    }
    return ticks;
  }
  int64_t utime_ = 0;
};

TEST_F(Jogging, AJointVelocityIsReachedAndHeldThenTheArmStopsWhenTheCommandsStop) {
  Controller controller(model_, config_);
  ASSERT_TRUE(tick(controller));
  VectorXd qd = VectorXd::Zero(7);
  qd(0) = 0.5, qd(5) = -0.3;
  hold_jog(controller, joint_jog(qd), 1.0);
  ASSERT_FALSE(HasFatalFailure());
  EXPECT_TRUE(controller.jogging());
  EXPECT_LE((controller.reference().qd - qd).norm(), 1e-12) << controller.reference().qd.transpose();
  EXPECT_EQ(controller.jog_progress().scale, 1.0);
  EXPECT_EQ(controller.jog_progress().limited_by, JogProgress::kNone);
  EXPECT_EQ(controller.jogs(), 30);
  // No command for the timeout: the reference brakes to rest within the limits and holds.
  const int ticks = ticks_to_rest(controller);
  ASSERT_FALSE(HasFatalFailure());
  EXPECT_EQ(controller.mode(), Mode::kHolding);
  EXPECT_FALSE(controller.jogging());
  EXPECT_EQ(controller.reference().qd.norm(), 0.0);
  // The timeout (100 ms, commands every 33 ms) and then a brake from 0.5 rad/s at 15 rad/s².
  EXPECT_GT(ticks, 60);
  EXPECT_LT(ticks, 100 + 40 + 10);
}

TEST_F(Jogging, TooFastIsSlowedByOneFactorThatKeepsTheDirection) {
  Controller controller(model_, config_);
  ASSERT_TRUE(tick(controller));
  VectorXd qd = VectorXd::Zero(7);
  qd(1) = -4.35, qd(2) = 1.0;  // joint 2 at twice its 2.175 rad/s
  hold_jog(controller, joint_jog(qd), 0.4);
  ASSERT_FALSE(HasFatalFailure());
  EXPECT_EQ(controller.jog_progress().limited_by, JogProgress::kVelocity);
  EXPECT_EQ(controller.jog_progress().joint, 1);
  EXPECT_NEAR(controller.jog_progress().scale, 0.5, 1e-12);
  EXPECT_NEAR(controller.reference().qd(1), -2.175, 1e-9);
  EXPECT_NEAR(controller.reference().qd(2), 0.5, 1e-9);
}

TEST_F(Jogging, AJointJoggedIntoItsLimitStopsShortOfIt) {
  Controller controller(model_, config_);
  ASSERT_TRUE(tick(controller));
  VectorXd qd = VectorXd::Zero(7);
  qd(3) = 1.5;  // the elbow toward its upper limit, −0.0698 rad, from −1.2
  hold_jog(controller, joint_jog(qd), 2.0);
  ASSERT_FALSE(HasFatalFailure());
  const motion::MotionLimits& l = controller.limits();
  EXPECT_EQ(controller.jog_progress().limited_by, JogProgress::kPosition);
  EXPECT_EQ(controller.jog_progress().joint, 3);
  EXPECT_LT(controller.jog_progress().scale, 1e-12);
  EXPECT_LT(std::abs(controller.reference().qd(3)), 1e-12);
  EXPECT_LE(controller.reference().q(3), l.upper(3));
  EXPECT_GT(controller.reference().q(3), l.upper(3) - 0.01) << "stopped close to the limit, not far before it";
  // Back the other way is free.
  qd(3) = -0.5;
  hold_jog(controller, joint_jog(qd), 0.5);
  EXPECT_NEAR(controller.reference().qd(3), -0.5, 1e-12);
  EXPECT_EQ(controller.jog_progress().limited_by, JogProgress::kNone);
}

// Far from singularities (libfranka's ready pose, κ ≈ 10) the tip moves with the twist asked: in
// the base frame, its origin's velocity and its angular velocity are those sent; in the tool
// frame, the body twist is.
VectorXd ready_pose() { return (VectorXd(7) << 0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785).finished(); }

TEST_F(Jogging, ATwistMovesTheTipAsAskedInTheBaseAndTheToolFrame) {
  for (const Jog::Frame frame : {Jog::kBase, Jog::kTool}) {
    Controller controller(model_, config_);
    state_.q = ready_pose(), state_.qd.setZero();
    ASSERT_TRUE(tick(controller));
    Vector6d twist;
    twist << 0.1, -0.2, 0.15, 0.05, 0.03, -0.04;  // rad/s, m/s
    hold_jog(controller, twist_jog(twist, frame), 0.5);
    ASSERT_FALSE(HasFatalFailure());
    ASSERT_EQ(controller.jog_progress().limited_by, JogProgress::kNone)
        << "frame " << int(frame) << ": " << to_string(controller.jog_progress().limited_by) << " joint "
        << controller.jog_progress().joint << " condition " << controller.jog_progress().condition;
    // The tip's twist at the reference: J_b q̇ (body), or its rotation into the base's axes.
    Data data(model_);
    const Matrix6Xd& J = body_jacobian(model_, data, controller.reference().q);
    Vector6d moved = J * controller.reference().qd;
    if (frame == Jog::kBase) {
      const Matrix3d R = data.T_sb.linear();
      moved.head<3>() = R * moved.head<3>();
      moved.tail<3>() = R * moved.tail<3>();
    }
    // Resolved at each tick's reference and reached through the jerk-limited generator, which
    // trails a velocity that keeps changing (J⁺ changes as the arm moves) by a few ticks' change.
    EXPECT_LE((moved - twist).norm(), 1e-3 * twist.norm()) << "frame " << int(frame) << ": " << moved.transpose();
    // And over time: the tip's origin moved on at that velocity (base frame, no rotation asked).
  }
  Controller controller(model_, config_);
  state_.q = ready_pose(), state_.qd.setZero();
  ASSERT_TRUE(tick(controller));
  Vector6d twist;
  twist << 0, 0, 0, 0.05, -0.03, 0.04;
  Data data(model_);
  hold_jog(controller, twist_jog(twist, Jog::kBase), 0.3);  // up to speed
  const Transform before = forward_kinematics(model_, data, controller.reference().q);
  hold_jog(controller, twist_jog(twist, Jog::kBase), 1.0);
  const Transform after = forward_kinematics(model_, data, controller.reference().q);
  EXPECT_LE((after.translation() - before.translation() - twist.tail<3>()).norm(), 1e-3)
      << (after.translation() - before.translation()).transpose();
  EXPECT_LE((after.linear() - before.linear()).norm(), 1e-3);
}

// MoveIt Servo's case on the UR5: a tool twist that turns the wrist toward alignment (wrist_2 →
// 0). The condition number rises past 17, the jog slows and halts before 30, and within limits.
class JoggingUr5 : public Jogging {
 protected:
  JoggingUr5() : Jogging(chasles::testing::ur5(), start()) {}
  static VectorXd start() { return (VectorXd(6) << 0.3, -1.2, 1.5, -1.9, 0.6, 0.3).finished(); }
};

TEST_F(JoggingUr5, IntoTheWristSingularityItSlowsAndStopsBeforeTheThreshold) {
  Controller controller(model_, config_);
  ASSERT_TRUE(tick(controller));
  Data data(model_);
  const Matrix6Xd J = body_jacobian(model_, data, start());
  const Vector6d twist = -0.4 * J.col(4);  // what wrist_2 at −0.4 rad/s gives the tool, at the start
  const double worst = hold_jog(controller, twist_jog(twist, Jog::kTool), 4.0);
  ASSERT_FALSE(HasFatalFailure());
  std::printf("[ jog ] UR5 into its wrist singularity: the largest condition number %.2f, wrist 2 at %.3f rad, "
              "speed %.2g of the asked\n",
              worst, controller.reference().q(4), controller.jog_progress().scale);
  EXPECT_LT(worst, controller.jog_config().stop_condition);
  EXPECT_GT(worst, 25.0) << "it came close to the threshold, slowing, before it stopped";
  // The speed falls with 30 − κ: the arm creeps to a stop, κ approaching 30 from below.
  EXPECT_EQ(controller.jog_progress().limited_by, JogProgress::kSingularity);
  EXPECT_LT(controller.jog_progress().scale, 1e-3);
  EXPECT_LT(controller.reference().qd.norm(), 1e-3);
  EXPECT_LT(controller.reference().q(4), 0.35);  // wrist_2 did turn toward 0
  // Leading away from it is taken at once at full speed.
  hold_jog(controller, twist_jog(-twist, Jog::kTool), 0.3);
  EXPECT_EQ(controller.jog_progress().scale, 1.0);
  EXPECT_EQ(controller.jog_progress().limited_by, JogProgress::kNone);
}

// The Panda stretched out: its elbow singularity (the shoulder–wrist distance at its greatest,
// joint 4 near −0.5 rad with the Panda's 8.25 cm offsets) reached by moving the tip away from the
// base along the ground.
TEST_F(Jogging, TheStretchedPandaStopsBeforeItsElbowSingularity) {
  state_.q = (VectorXd(7) << 0.0, 0.3, 0.0, -2.0, 0.0, 2.3, 0.785).finished();
  Controller controller(model_, config_);
  ASSERT_TRUE(tick(controller));
  Data data(model_);
  const Transform tip = forward_kinematics(model_, data, state_.q);
  Vector6d twist = Vector6d::Zero();
  twist.segment<2>(3) = 0.15 * tip.translation().head<2>().normalized();  // m/s, outward, level
  const double worst = hold_jog(controller, twist_jog(twist, Jog::kBase), 5.0);
  ASSERT_FALSE(HasFatalFailure());
  std::printf("[ jog ] the Panda stretched: the largest condition number %.2f, joint 4 at %.3f rad\n", worst,
              controller.reference().q(3));
  EXPECT_LT(worst, controller.jog_config().stop_condition);
  EXPECT_GT(worst, 25.0);
  EXPECT_EQ(controller.jog_progress().limited_by, JogProgress::kSingularity);
  EXPECT_LT(controller.reference().qd.norm(), 1e-12);
  EXPECT_LT(controller.reference().q(3), -0.6) << "short of the stretched elbow";
}

// The arm under its computed-torque law (the model integrated under the command), not a perfect
// tracker: jogged into the UR5's wrist singularity it stays below the threshold too.
TEST_F(JoggingUr5, TheSimulatedArmStaysBelowTheThresholdAndAllocatesNothing) {
  Controller controller(model_, config_);
  ASSERT_TRUE(tick(controller));
  Data data(model_), arm(model_);
  const Matrix6Xd J = body_jacobian(model_, data, start());
  const Vector6d twist = -0.4 * J.col(4);
  Jog jog = twist_jog(twist, Jog::kTool);
  double worst = 0.0;
  long allocations = 0;
  for (int k = 0; k < 4000; ++k) {
    {
      const chasles::testing::AllocationCounter counter;
      if (k % 33 == 0) {
        jog.utime = ++utime_;
        ASSERT_TRUE(controller.set_jog(jog, now_ + kMs));
      }
      ASSERT_TRUE(tick(controller)) << controller.fault_reason();
      allocations += counter.count();
    }
    integrate(controller, arm);
    worst = std::max(worst, condition_by_svd(body_jacobian(model_, data, state_.q)));
  }
  std::printf("[ jog ] the simulated UR5 into its wrist singularity: the measured arm's largest condition number %.2f\n",
              worst);
  EXPECT_EQ(allocations, 0);
  EXPECT_EQ(controller.mode(), Mode::kRunning) << to_string(controller.mode()) << " " << controller.reflex_reason();
  EXPECT_EQ(controller.jog_progress().limited_by, JogProgress::kSingularity);
  EXPECT_LT(worst, controller.jog_config().stop_condition);
}

// A Cartesian stream, as a teleoperation device sends it: the tip around a 5 cm circle at 0.5 Hz
// (16 cm/s) with its orientation kept, 30 setpoints a second, 20 % of them delayed up to 50 ms and
// 5 % lost. The reference stays C² within every limit, its tip follows the sender's path within
// 1.5 mm once the lag is taken out (the chord of 100 ms unheard is 2.5 mm), the lag is at most two stream periods, nothing is allocated, and
// when the stream stops the arm comes to rest and holds.
TEST_F(Jogging, ACartesianStreamLateAndLostIsFollowedWithinTheLimits) {
  state_.q = ready_pose();
  config_.limits.jerk_within_torque_rate = true;  // as the daemon runs it: the generator's response is then slower
  Controller controller(model_, config_);
  ASSERT_TRUE(tick(controller));
  Data data(model_);
  const Transform start = forward_kinematics(model_, data, ready_pose());
  constexpr double kRadius = 0.05, kOmega = M_PI, kPeriod = 1.0 / 30.0, kSeconds = 6.0;
  // Starts where the tip is: centre one radius along −x.
  const auto path = [&](double t) {
    Vector3d p = start.translation();
    p.x() += kRadius * (std::cos(kOmega * t) - 1.0);
    p.y() += kRadius * std::sin(kOmega * t);
    return p;
  };
  const Eigen::Quaterniond orientation(start.linear());
  std::mt19937 rng(31);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::multimap<int64_t, TipSetpoint> arrivals;
  int sent = 0;
  for (int k = 0; k * kPeriod < kSeconds; ++k) {
    const double t = k * kPeriod;
    if (unit(rng) < 0.05) continue;
    const double delay = unit(rng) < 0.2 ? 0.05 * unit(rng) : 0.0;
    TipSetpoint sp;
    const int64_t sampled = now_ + static_cast<int64_t>(t * 1e9);
    sp.utime = sampled / 1000;
    sp.position = path(t);
    sp.quaternion << orientation.w(), orientation.x(), orientation.y(), orientation.z();
    sp.twist.tail<3>() << -kRadius * kOmega * std::sin(kOmega * t), kRadius * kOmega * std::cos(kOmega * t), 0.0;
    arrivals.emplace(sampled + static_cast<int64_t>(delay * 1e9), sp);
    ++sent;
  }
  const int64_t begin = now_;
  std::vector<Vector3d> tip;
  std::vector<double> turned;
  motion::Reference before = controller.reference();
  long allocations = 0;
  while (now_ < begin + static_cast<int64_t>(kSeconds * 1e9)) {
    {
      const chasles::testing::AllocationCounter counter;
      for (auto it = arrivals.begin(); it != arrivals.end() && it->first <= now_ + kMs; it = arrivals.erase(it)) {
        controller.set_tip_setpoint(it->second, now_ + kMs);
      }
      ASSERT_TRUE(tick(controller));
      allocations += counter.count();
    }
    expect_within_limits(controller, before);
    ASSERT_FALSE(HasFatalFailure());
    before = controller.reference();
    state_.q = controller.reference().q, state_.qd = controller.reference().qd;
    const Transform T = forward_kinematics(model_, data, controller.reference().q);
    tip.push_back(T.translation());
    turned.push_back(Eigen::AngleAxisd(start.linear().transpose() * T.linear()).angle());
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_TRUE(controller.streaming());
  EXPECT_EQ(controller.setpoints() + controller.dropped_setpoints(), sent);
  EXPECT_GT(controller.dropped_setpoints(), 0);
  // tip[k] is at t = (k + 1) ms; after the first second, the lag that fits best.
  double best_rms = 1e9;
  int best_lag_ms = -1;
  for (int lag_ms = 0; lag_ms <= 150; ++lag_ms) {
    double sum = 0.0;
    int count = 0;
    for (size_t k = 1000; k < tip.size(); ++k) {
      sum += (tip[k] - path(1e-3 * (double(k) + 1 - lag_ms))).squaredNorm(), ++count;
    }
    if (std::sqrt(sum / count) < best_rms) best_rms = std::sqrt(sum / count), best_lag_ms = lag_ms;
  }
  double turn_sq = 0.0;
  for (size_t k = 1000; k < turned.size(); ++k) turn_sq += turned[k] * turned[k];
  const double turn_rms = std::sqrt(turn_sq / double(turned.size() - 1000));
  const double worst_turn = *std::max_element(turned.begin() + 1000, turned.end());
  std::printf("[ tip stream ] lag %d ms, %.3f mm RMS from the path after it; orientation %.3f mrad RMS, %.3f at "
              "worst\n",
              best_lag_ms, 1e3 * best_rms, 1e3 * turn_rms, 1e3 * worst_turn);
  EXPECT_LE(best_lag_ms, 67) << "two stream periods";
  EXPECT_LT(best_rms, 1.5e-3);
  EXPECT_LT(turn_rms, 1e-3);
  // The worst: after two setpoints lost in a row, the path has curved 2.5 mm away from the last
  // one's straight extrapolation; the joints, each reaching its new velocity in its own time,
  // turn the tip while they close that gap.
  EXPECT_LT(worst_turn, 1e-2);
  // Silence: to rest within the limits, then HOLDING.
  ticks_to_rest(controller);
  ASSERT_FALSE(HasFatalFailure());
  EXPECT_EQ(controller.mode(), Mode::kHolding);
  EXPECT_FALSE(controller.streaming());
  // A control law ends a Cartesian stream as it ends a jog: the reference brakes to rest.
  TipSetpoint again;
  again.utime = 10'000'000'000;
  again.position = start.translation() + Vector3d(0.0, 0.0, 0.01);
  again.quaternion << orientation.w(), orientation.x(), orientation.y(), orientation.z();
  ASSERT_TRUE(controller.set_tip_setpoint(again, now_));
  for (int k = 0; k < 50; ++k) ASSERT_TRUE(tick(controller));
  ASSERT_TRUE(controller.streaming());
  LawSettings settings(7);
  settings.law = Law::kJointImpedance;
  settings.joint_stiffness = VectorXd::Constant(7, 200.0);
  ASSERT_TRUE(controller.set_law(settings, now_)) << controller.mode_rejection();
  EXPECT_FALSE(controller.streaming());
  ticks_to_rest(controller);
  ASSERT_FALSE(HasFatalFailure());
  EXPECT_EQ(controller.mode(), Mode::kHolding);
  // A quaternion that is not a unit one is refused.
  TipSetpoint bad;
  bad.utime = 1;
  bad.position = start.translation();
  bad.quaternion << 0.9, 0, 0, 0;
  EXPECT_FALSE(controller.set_tip_setpoint(bad, now_));
  EXPECT_NE(std::string(controller.last_rejection()).find("quaternion of norm 0.9"), std::string::npos);
}

TEST_F(Jogging, JogsOutOfTurnAreDroppedOrRefusedAndOthersEndTheJog) {
  Controller controller(model_, config_);
  VectorXd qd = VectorXd::Zero(7);
  qd(0) = 0.2;
  EXPECT_FALSE(controller.set_jog(joint_jog(qd), now_));
  EXPECT_NE(std::string(controller.last_rejection()).find("no robot state"), std::string::npos);
  ASSERT_TRUE(tick(controller));
  Jog late = joint_jog(qd);
  ASSERT_TRUE(controller.set_jog(joint_jog(qd), now_));
  EXPECT_FALSE(controller.set_jog(late, now_));  // older than the one in force
  EXPECT_EQ(controller.dropped_jogs(), 1);
  Jog bad = joint_jog(qd);
  bad.joint_velocity(2) = NAN;
  EXPECT_FALSE(controller.set_jog(bad, now_));
  EXPECT_NE(std::string(controller.last_rejection()).find("non-finite"), std::string::npos);
  bad = joint_jog(qd);
  bad.kind = 7;
  EXPECT_FALSE(controller.set_jog(bad, now_));
  EXPECT_NE(std::string(controller.last_rejection()).find("unknown kind 7"), std::string::npos);
  bad = twist_jog(Vector6d::Zero(), Jog::kBase);
  bad.frame = 3;
  EXPECT_FALSE(controller.set_jog(bad, now_));
  EXPECT_NE(std::string(controller.last_rejection()).find("unknown frame 3"), std::string::npos);
  Jog small(6);
  small.utime = ++utime_;
  EXPECT_FALSE(controller.set_jog(small, now_));
  EXPECT_NE(std::string(controller.last_rejection()).find("wrong size"), std::string::npos);
  for (int k = 0; k < 100; ++k) ASSERT_TRUE(tick(controller));
  EXPECT_TRUE(controller.jogging());
  // A control law ends it: the reference brakes to rest within the limits, no jump.
  LawSettings settings(7);
  settings.law = Law::kJointImpedance;
  settings.joint_stiffness = VectorXd::Constant(7, 200.0);
  ASSERT_TRUE(controller.set_law(settings, now_)) << controller.mode_rejection();
  EXPECT_FALSE(controller.jogging());
  motion::Reference before = controller.reference();
  for (int k = 0; k < 200; ++k) {
    ASSERT_TRUE(tick(controller));
    expect_within_limits(controller, before);
    ASSERT_FALSE(HasFatalFailure());
    before = controller.reference();
  }
  EXPECT_EQ(controller.mode(), Mode::kHolding);
  // Free drive refuses jogs; so do REFLEX and FAULT.
  settings.law = Law::kFreeDrive;
  ASSERT_TRUE(controller.set_law(settings, now_)) << controller.mode_rejection();
  EXPECT_FALSE(controller.set_jog(joint_jog(qd), now_));
  EXPECT_NE(std::string(controller.last_rejection()).find("free drive"), std::string::npos);
  controller.stand_down("a test");
  EXPECT_FALSE(controller.set_jog(joint_jog(qd), now_));
  EXPECT_NE(std::string(controller.last_rejection()).find("FAULT"), std::string::npos);
}

}  // namespace
}  // namespace chasles::controller
