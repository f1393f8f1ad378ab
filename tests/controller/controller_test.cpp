// The controller's parts without threads or transport: reference motions, the control law and its
// safety pipeline, the lock-free hand-over, timing statistics, and the checks on received bytes.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chasles/arm_target_t.hpp>
#include <chasles/control_mode_t.hpp>
#include <chasles/joint_torque_command_t.hpp>
#include <chasles/robot_state_t.hpp>
#include <cmath>
#include <limits>
#include <random>
#include <thread>
#include <vector>

#include "controller/controller.hpp"
#include "controller/transport/lcm_io.hpp"
#include "controller/transport/realtime/mailbox.hpp"
#include "controller/statistics.hpp"
#include "core/motion/quintic.hpp"
#include "core/dynamics/dynamics.hpp"
#include "core/lie/se3.hpp"
#include "core/model/payload.hpp"
#include "core/model/urdf.hpp"
#include "support/allocation_counter.hpp"
#include "support/arm.hpp"
#include "support/contact_off.hpp"
#include "support/reference.hpp"

namespace chasles::controller {
namespace {

using Eigen::VectorXd;
using testing::AllocationCounter;
using testing::data_path;
using testing::panda;
using testing::matrices_near;

constexpr int64_t kMs = 1'000'000;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

VectorXd bent_pose() {
  VectorXd q(7);
  q << 0.1, 0.5, -0.2, -1.2, 0.1, 1.0, 0.3;
  return q;
}

// --- trajectory -------------------------------------------------------------------------------

TEST(Trajectory, RestToRestIsTheClassicQuintic) {
  motion::Reference from(2), out(2);
  from.hold(VectorXd::Constant(2, 0.5));
  const VectorXd goal = (VectorXd(2) << 1.5, -0.5).finished();
  motion::QuinticTrajectory trajectory(2);
  trajectory.start(from, goal, 2.0);
  for (double t = 0.0; t <= 2.0; t += 0.125) {
    trajectory.sample(t, out);
    const double s = t / 2.0, scale = 10 * std::pow(s, 3) - 15 * std::pow(s, 4) + 6 * std::pow(s, 5);
    EXPECT_TRUE(matrices_near(out.q, from.q + (goal - from.q) * scale, 1e-14)) << "t " << t;
  }
  trajectory.sample(5.0, out);  // past the end: the goal, at rest
  EXPECT_TRUE(matrices_near(out.q, goal, 1e-14));
  EXPECT_TRUE(matrices_near(out.qd, VectorXd::Zero(2), 1e-14));
  EXPECT_TRUE(matrices_near(out.qdd, VectorXd::Zero(2), 1e-13));
}

TEST(Trajectory, ContinuesAMovingReferenceAndItsDerivativesAreConsistent) {
  motion::Reference from(3), out(3), before(3), after(3);
  from.q << 0.1, -0.2, 0.3;
  from.qd << 0.5, 0.0, -1.0;
  from.qdd << -2.0, 1.0, 0.5;
  const VectorXd goal = (VectorXd(3) << 1.0, 0.4, -0.3).finished();
  motion::QuinticTrajectory trajectory(3);
  trajectory.start(from, goal, 1.5);
  trajectory.sample(0.0, out);  // no jump in position, velocity or acceleration
  EXPECT_TRUE(matrices_near(out.q, from.q, 1e-15));
  EXPECT_TRUE(matrices_near(out.qd, from.qd, 1e-15));
  EXPECT_TRUE(matrices_near(out.qdd, from.qdd, 1e-15));
  trajectory.sample(1.5, out);
  EXPECT_TRUE(matrices_near(out.q, goal, 1e-14));
  EXPECT_TRUE(matrices_near(out.qd, VectorXd::Zero(3), 1e-13));
  EXPECT_TRUE(matrices_near(out.qdd, VectorXd::Zero(3), 1e-12));
  const double h = 1e-5;
  for (int k = 0; k < 7; ++k) {  // central differences of q and q̇, inside (0, T)
    const double t = 0.1 + 0.2 * k;
    trajectory.sample(t, out);
    trajectory.sample(t - h, before);
    trajectory.sample(t + h, after);
    EXPECT_TRUE(matrices_near(out.qd, (after.q - before.q) / (2 * h), 1e-8)) << "t " << t;
    EXPECT_TRUE(matrices_near(out.qdd, (after.qd - before.qd) / (2 * h), 1e-7)) << "t " << t;
  }
}

// --- statistics -------------------------------------------------------------------------------

TEST(Histogram, PercentilesAreExactToTheBinWidth) {
  std::mt19937 rng(7);
  std::lognormal_distribution<double> draw(3.5, 0.8);  // a long tail, like wake-up jitter
  std::vector<double> samples;
  Histogram h;
  for (int i = 0; i < 20000; ++i) {
    samples.push_back(draw(rng));
    h.record(samples.back());
  }
  std::sort(samples.begin(), samples.end());
  for (double p : {0.5, 0.9, 0.99}) {
    const double exact = samples[static_cast<size_t>(std::ceil(p * samples.size())) - 1];
    EXPECT_GE(h.percentile(p), exact) << p;  // never optimistic
    EXPECT_LE(h.percentile(p), exact + 1.0) << p;
  }
  EXPECT_EQ(h.max(), samples.back());
  EXPECT_EQ(h.count(), 20000);
  Histogram other;
  other.record(50'000.0);  // 50 ms: a coarse bin
  h.merge(other);
  EXPECT_EQ(h.max(), 50'000.0);
  EXPECT_EQ(h.percentile(1.0), 50'000.0);
  h.reset();
  EXPECT_EQ(h.count(), 0);
  EXPECT_EQ(h.percentile(0.99), 0.0);
}

// --- lock-free hand-over --------------------------------------------------------------------

TEST(Mailbox, TheReaderSeesOnlyWholeValuesInOrderAndTheLatestLast) {
  struct Pair {
    int64_t a = 0, b = 0;
  };
  Mailbox<Pair> mailbox{Pair{}};
  constexpr int64_t kCount = 200'000;
  std::thread writer([&] {
    for (int64_t k = 1; k <= kCount; ++k) mailbox.write(Pair{k, -k});
  });
  Pair seen, value;
  int64_t reads = 0;
  while (seen.a < kCount) {
    if (!mailbox.read(value)) continue;
    ASSERT_EQ(value.b, -value.a) << "a torn value";
    ASSERT_GT(value.a, seen.a) << "a value read twice or out of order";
    seen = value;
    ++reads;
  }
  writer.join();
  EXPECT_FALSE(mailbox.read(value)) << "nothing new after the last value";
  EXPECT_GT(reads, 0);
}

TEST(SpscRing, KeepsOrderAndRefusesWhenFull) {
  SpscRing<int> ring(3);
  EXPECT_TRUE(ring.push(1));
  EXPECT_TRUE(ring.push(2));
  EXPECT_TRUE(ring.push(3));
  EXPECT_FALSE(ring.push(4));
  int x = 0;
  for (int expected : {1, 2, 3}) {
    ASSERT_TRUE(ring.pop(x));
    EXPECT_EQ(x, expected);
  }
  EXPECT_FALSE(ring.pop(x));
}

// --- the control law and its safety pipeline -------------------------------------------------

class ControllerTest : public ::testing::Test {
 protected:
  ControllerTest() : model_(panda()), data_(model_), state_(7), target_(7) {
    config_ = Config::critically_damped(7, 20.0);
    // The states are the test's, their effort not the torque applied: the torque-semantics check
    // is semantics_check_test's and the World's.
    config_.check_torque_semantics = false;
    state_.q = bent_pose();
    state_.seq = 1;
  }

  // A state that arrived just now at time t.
  const JointState* fresh(int64_t t) {
    state_.arrival_ns = t;
    return &state_;
  }

  Target joint_target(const VectorXd& q, double duration) {
    Target target(7);
    target.mode = Target::kJoint;
    target.num_joints = 7;
    target.q = q;
    target.duration = duration;
    return target;
  }

  RobotModel model_;
  Data data_;
  Config config_;
  JointState state_;
  Target target_;
};

TEST_F(ControllerTest, WaitsForAStateThenHoldsAgainstGravity) {
  Controller controller(model_, config_);
  EXPECT_FALSE(controller.tick(0, nullptr));
  EXPECT_EQ(controller.mode(), Mode::kWaiting);
  EXPECT_FALSE(controller.set_target(joint_target(bent_pose(), 1.0), 0));
  ASSERT_TRUE(controller.tick(kMs, fresh(kMs)));
  EXPECT_EQ(controller.mode(), Mode::kHolding);
  // At rest on the reference the computed torque is exactly the gravity torque, computed here
  // by the independent mass-matrix path: g = τ − M·0 − c(q, 0).
  const VectorXd g = gravity_torques(model_, data_, state_.q);
  EXPECT_TRUE(matrices_near(controller.torque(), g, 1e-12));
  EXPECT_TRUE(matrices_near(controller.reference().q, state_.q, 0.0));
}

// An arm whose gravity torque is over a joint's effort limit (a heavy payload, stretched out): the
// first command after WAITING starts from g(q) clamped to the limits, so no command exceeds them
// (found by the fuzzer: the rate limit started from the unclamped g and let the command follow it).
TEST_F(ControllerTest, TheFirstCommandStaysWithinTheEffortLimitsWhenGravityIsNot) {
  Payload load;
  load.mass = 15.0;
  const RobotModel heavy = with_payload(model_, load);
  Controller controller(heavy, config_);
  state_.q << 0.0, 1.5, 0.0, -0.1, 0.0, 1.5, 0.0;
  Data data(heavy);
  const VectorXd g = gravity_torques(heavy, data, state_.q);
  const VectorXd limit = VectorXd::NullaryExpr(7, [&](Eigen::Index i) { return heavy.joint(int(i)).limits.effort; });
  ASSERT_GT((g.cwiseAbs() - limit).maxCoeff(), 0.0) << "the pose must ask for more than the limits";
  for (int k = 0; k < 3; ++k) {
    ASSERT_TRUE(controller.tick(k * kMs, fresh(k * kMs)));
    EXPECT_LE((controller.torque().cwiseAbs() - limit).maxCoeff(), 0.0) << "tick " << k;
  }
}

TEST_F(ControllerTest, ComputedTorqueIsMassMatrixTimesDesiredAccelerationPlusBias) {
  config_.torque_ramp = 1e-9;  // effectively no rate limit: this test is about the law
  Controller controller(model_, config_);
  ASSERT_TRUE(controller.tick(0, fresh(0)));
  VectorXd goal = bent_pose();
  goal(1) += 0.3;
  goal(3) -= 0.2;
  ASSERT_TRUE(controller.set_target(joint_target(goal, 1.0), 0)) << controller.last_rejection();
  // Off the reference and moving: e and ė both non-zero.
  state_.q = bent_pose() + VectorXd::Constant(7, 0.01);
  state_.qd = VectorXd::LinSpaced(7, -0.3, 0.3);
  const int64_t t = 400 * kMs;
  ASSERT_TRUE(controller.tick(t, fresh(t)));
  EXPECT_EQ(controller.mode(), Mode::kRunning);
  const motion::Reference& r = controller.reference();
  const VectorXd qdd = r.qdd + config_.kd.cwiseProduct(r.qd - state_.qd) + config_.kp.cwiseProduct(r.q - state_.q);
  const VectorXd expected = mass_matrix(model_, data_, state_.q) * qdd + velocity_product(model_, data_, state_.q, state_.qd) +
                            gravity_torques(model_, data_, state_.q);
  const VectorXd limit = VectorXd::NullaryExpr(7, [&](Eigen::Index i) { return model_.joint(int(i)).limits.effort; });
  EXPECT_TRUE(matrices_near(controller.torque(), expected.cwiseMax(-limit).cwiseMin(limit), 1e-9));
  EXPECT_TRUE(matrices_near(controller.error(), r.q - state_.q, 0.0));
}

TEST_F(ControllerTest, ClampsToEffortLimitsAndLimitsTheTorqueRate) {
  config_.kp = VectorXd::Constant(7, 1e6);  // a huge error gain asks for far more than the limits
  Controller controller(model_, config_);
  ASSERT_TRUE(controller.tick(0, fresh(0)));
  const VectorXd g = controller.torque();
  state_.q = bent_pose() + VectorXd::Constant(7, 0.2);  // the arm is knocked away from the hold
  VectorXd previous = g;
  const VectorXd effort = VectorXd::NullaryExpr(7, [&](Eigen::Index i) { return model_.joint(int(i)).limits.effort; });
  const VectorXd step = effort / config_.torque_ramp * config_.period;
  bool saturated = false;
  for (int k = 1; k <= 200; ++k) {
    ASSERT_TRUE(controller.tick(k * kMs, fresh(k * kMs)));
    const VectorXd& tau = controller.torque();
    EXPECT_TRUE(((tau - previous).cwiseAbs().array() <= step.array() * (1 + 1e-12)).all()) << "tick " << k;
    EXPECT_TRUE((tau.cwiseAbs().array() <= effort.array()).all()) << "tick " << k;
    saturated = saturated || ((tau.cwiseAbs() - effort).cwiseAbs().array() < 1e-9).any();
    previous = tau;
  }
  EXPECT_TRUE(saturated) << "the effort limit should have been reached";
}

// Where the rate limit binds, it shortens the law's change as a whole: the command moves from the
// last one towards the law's torque (a controller without the limit, at the same state) by the one
// fraction that brings the most limited joint to its limit, so the torque keeps the law's direction
// through the joints' coupling (clamped joint by joint, the Panda's joints 1 and 3 were driven the
// wrong way after a FAULT at 200 Hz).
TEST_F(ControllerTest, TheTorqueRateLimitKeepsTheLawsDirection) {
  // The knock below is the test's, not a collision: no reflex, so the law acts on the hold.
  chasles::testing::never_trip(config_.contact, 7);
  Controller limited(model_, config_);
  Config free_config = config_;
  free_config.torque_ramp = 1e-9;
  Controller law(model_, free_config);
  ASSERT_TRUE(limited.tick(0, fresh(0)));
  ASSERT_TRUE(law.tick(0, fresh(0)));
  const VectorXd g = limited.torque();
  state_.q = bent_pose() + VectorXd::LinSpaced(7, 0.02, -0.02);  // knocked away from the hold, moving
  state_.qd = VectorXd::LinSpaced(7, 0.2, -0.1);
  state_.seq = 2;
  ASSERT_TRUE(limited.tick(kMs, fresh(kMs)));
  ASSERT_TRUE(law.tick(kMs, fresh(kMs)));
  ASSERT_EQ(limited.mode(), Mode::kHolding);
  ASSERT_EQ(law.mode(), Mode::kHolding);
  const VectorXd effort = VectorXd::NullaryExpr(7, [&](Eigen::Index i) { return model_.joint(int(i)).limits.effort; });
  ASSERT_LT((law.torque().cwiseAbs() - effort).maxCoeff(), 0.0) << "the law's torque must be within the effort limits";
  const VectorXd step = effort / config_.torque_ramp * config_.period;
  const VectorXd asked = law.torque() - g;
  const double fraction = (step.array() / asked.cwiseAbs().array()).minCoeff();
  ASSERT_LT(fraction, 0.5) << "the limit must bind";
  const VectorXd taken = limited.torque() - g;
  EXPECT_LT((taken - fraction * asked).cwiseAbs().maxCoeff(), 1e-12 * asked.cwiseAbs().maxCoeff());
  EXPECT_LT((taken.cwiseAbs() - step).maxCoeff(), 1e-12) << "every joint within its limit";
  EXPECT_LT((taken.cwiseAbs() - step).cwiseAbs().minCoeff(), 1e-12) << "the most limited joint at it";
}

// Known Coulomb friction is fed forward on the reference's velocity, f_c tanh(q̇_d / v_c): two
// controllers, told of it and not, differ by exactly that on every tick of a move (the rate limit
// off: this is about the law).
TEST_F(ControllerTest, KnownCoulombFrictionIsFedForwardOnTheReferencesVelocity) {
  config_.torque_ramp = 1e-9;
  // The states here are the reference itself, not an arm's response to the torque: no reflex.
  chasles::testing::never_trip(config_.contact, 7);
  Controller without(model_, config_);
  config_.coulomb = VectorXd::LinSpaced(7, 0.6, 0.2);
  Controller with(model_, config_);
  VectorXd goal = bent_pose();
  goal(0) += 0.3, goal(2) -= 0.2, goal(5) += 0.1;
  ASSERT_TRUE(with.tick(0, fresh(0)));
  ASSERT_TRUE(without.tick(0, fresh(0)));
  ASSERT_TRUE(with.set_target(joint_target(goal, 1.0), 0));
  ASSERT_TRUE(without.set_target(joint_target(goal, 1.0), 0));
  double worst = 0.0, largest = 0.0;
  for (int k = 1; k <= 500; ++k) {
    state_.seq = k + 1;
    ASSERT_TRUE(with.tick(k * kMs, fresh(k * kMs)));
    ASSERT_TRUE(without.tick(k * kMs, fresh(k * kMs)));
    const VectorXd fed = config_.coulomb.array() * (with.reference().qd.array() / kCoulombVelocity).tanh();
    worst = std::max(worst, (with.torque() - without.torque() - fed).cwiseAbs().maxCoeff());
    largest = std::max(largest, fed.cwiseAbs().maxCoeff());
    state_.q = with.reference().q;  // the arm follows exactly
    state_.qd = with.reference().qd;
  }
  EXPECT_GT(largest, 0.5) << "the reference must have moved";
  EXPECT_LT(worst, 1e-12);
  config_.coulomb = VectorXd::Constant(7, -0.1);
  EXPECT_THROW(Controller(model_, config_), ArgumentError);
}

TEST_F(ControllerTest, RefusesBadTargetsAndKeepsTheCurrentOne) {
  Controller controller(model_, config_);
  ASSERT_TRUE(controller.tick(0, fresh(0)));
  VectorXd goal = bent_pose();
  goal(0) += 0.2;
  ASSERT_TRUE(controller.set_target(joint_target(goal, 2.0), 0));

  const auto refused = [&](const Target& target, const char* words) {
    const int64_t before = controller.rejected_targets();
    EXPECT_FALSE(controller.set_target(target, 0)) << words;
    EXPECT_EQ(controller.rejected_targets(), before + 1);
    EXPECT_NE(std::string(controller.last_rejection()).find(words), std::string::npos) << controller.last_rejection();
  };
  Target wrong_size = joint_target(goal, 1.0);
  wrong_size.num_joints = 6;
  refused(wrong_size, "for 6 joints");
  VectorXd nan = goal;
  nan(2) = kNaN;
  refused(joint_target(nan, 1.0), "not finite");
  VectorXd outside = goal;
  outside(3) = 0.5;  // panda_joint4 ∈ [−3.07, −0.07]
  refused(joint_target(outside, 1.0), "panda_joint4: target 0.5 is outside [");
  refused(joint_target(goal, 0.0), "positive, finite duration");
  refused(joint_target(goal, std::numeric_limits<double>::infinity()), "positive, finite duration");
  VectorXd far = goal;
  far(0) = 2.5;
  refused(joint_target(far, 0.1), "panda_joint1: reaching the goal in 0.1 s needs a velocity of");
  Target cartesian(7);
  cartesian.mode = Target::kCartesian;
  cartesian.duration = 1.0;
  refused(cartesian, "while a motion runs");
  Target unknown(7);
  unknown.mode = 9;
  refused(unknown, "unknown target mode 9");

  // The accepted motion goes on and ends, holding at its goal.
  ASSERT_TRUE(controller.tick(2500 * kMs, fresh(2500 * kMs)));
  EXPECT_EQ(controller.mode(), Mode::kHolding);
  EXPECT_TRUE(matrices_near(controller.reference().q, goal, 1e-12));
}

TEST_F(ControllerTest, CartesianTargetsArePlannedOffTheTickThenFollowed) {
  Controller controller(model_, config_);
  ASSERT_TRUE(controller.tick(0, fresh(0)));
  Data data(model_);
  VectorXd q_goal = bent_pose();
  q_goal(0) += 0.3;
  q_goal(1) -= 0.2;
  const Transform T_goal = forward_kinematics(model_, data, q_goal);
  const Eigen::Quaterniond r(T_goal.linear());
  Target target(7);
  target.mode = Target::kCartesian;
  target.position = T_goal.translation();
  target.quaternion << r.w(), r.x(), r.y(), r.z();
  target.duration = 1.0;

  Target bad = target;
  bad.quaternion *= 1.1;
  EXPECT_FALSE(controller.set_target(bad, 0));
  EXPECT_NE(std::string(controller.last_rejection()).find("norm 1.1"), std::string::npos);
  bad = target;
  bad.position(1) = kNaN;
  EXPECT_FALSE(controller.set_target(bad, 0));

  CartesianRequest request(7);
  ASSERT_TRUE(controller.set_target(target, 0));
  ASSERT_TRUE(controller.take_request(request));
  EXPECT_FALSE(controller.take_request(request)) << "a request is handed over once";
  EXPECT_EQ(controller.mode(), Mode::kHolding) << "holding while the worker plans";
  IkSolver solver(model_);
  JointPath path(7);
  plan_cartesian_path(solver, controller.limits(), request, path);
  ASSERT_TRUE(path.ok) << path.reason;
  ASSERT_TRUE(controller.follow(path, 10 * kMs));
  EXPECT_EQ(controller.mode(), Mode::kRunning);
  ASSERT_TRUE(controller.tick(1100 * kMs, fresh(1100 * kMs)));
  EXPECT_EQ(controller.mode(), Mode::kHolding);
  const Transform T_end = forward_kinematics(model_, data, controller.reference().q);
  EXPECT_LT((T_end.translation() - T_goal.translation()).norm(), 1e-6);
  EXPECT_LT(log3(T_end.linear().transpose() * T_goal.linear()).norm(), 1e-6);
  EXPECT_TRUE(controller.ik_converged());

  // A path planned for a request that a newer target superseded is dropped.
  ASSERT_TRUE(controller.set_target(target, 0));
  ASSERT_TRUE(controller.take_request(request));
  plan_cartesian_path(solver, controller.limits(), request, path);
  ASSERT_TRUE(controller.set_target(joint_target(bent_pose(), 2.0), 1200 * kMs));
  EXPECT_FALSE(controller.follow(path, 1300 * kMs));
}

TEST_F(ControllerTest, StaleStateFaultsAndFreshStateResumesHoldingWithoutATorqueJump) {
  Controller controller(model_, config_);
  ASSERT_TRUE(controller.tick(0, fresh(0)));
  // The state stops: within the limit the tick still commands, past it FAULT and silence.
  EXPECT_TRUE(controller.tick(config_.stale_ns, &state_));
  EXPECT_FALSE(controller.tick(config_.stale_ns + 1, &state_));
  EXPECT_EQ(controller.mode(), Mode::kFault);
  EXPECT_EQ(controller.faults(), 1);
  EXPECT_NE(std::string(controller.fault_reason()).find("no fresh robot state"), std::string::npos);
  EXPECT_FALSE(controller.tick(config_.stale_ns + 2 * kMs, &state_));
  EXPECT_EQ(controller.faults(), 1) << "one fault, however long it lasts";
  EXPECT_EQ(controller.stale_ticks(), 2);
  EXPECT_FALSE(controller.set_target(joint_target(bent_pose(), 1.0), 0)) << "no targets during a FAULT";

  // The arm has sagged while nothing was commanded; the state comes back.
  state_.q = bent_pose() + VectorXd::Constant(7, 0.05);
  const int64_t t = 100 * kMs;
  ASSERT_TRUE(controller.tick(t, fresh(t)));
  EXPECT_EQ(controller.mode(), Mode::kHolding);
  EXPECT_TRUE(matrices_near(controller.reference().q, state_.q, 0.0)) << "hold where the arm is, not where it was";
  EXPECT_TRUE(matrices_near(controller.torque(), gravity_torques(model_, data_, state_.q), 1e-12));
}

TEST_F(ControllerTest, NonFiniteStateFaults) {
  Controller controller(model_, config_);
  ASSERT_TRUE(controller.tick(0, fresh(0)));
  state_.qd(3) = kNaN;
  EXPECT_FALSE(controller.tick(kMs, fresh(kMs)));
  EXPECT_EQ(controller.mode(), Mode::kFault);
}

// Another sender on the command channel: the daemon stands the controller down. Unlike a stale
// state's FAULT, fresh states do not bring it back, and it is counted even during another FAULT.
TEST_F(ControllerTest, StandingDownIsLatchedAgainstFreshStatesAndTargets) {
  Controller controller(model_, config_);
  ASSERT_TRUE(controller.tick(0, fresh(0)));
  EXPECT_FALSE(controller.tick(config_.stale_ns + 1, &state_));
  ASSERT_EQ(controller.faults(), 1);
  AllocationCounter counter;
  controller.stand_down("another sender is commanding %s", "CHASLES_COMMAND");
  controller.stand_down("a second reason %d", 2);
  EXPECT_EQ(counter.count(), 0);
  EXPECT_TRUE(controller.stood_down());
  EXPECT_EQ(controller.faults(), 2);
  EXPECT_STREQ(controller.fault_reason(), "another sender is commanding CHASLES_COMMAND");
  for (int64_t t = 20 * kMs; t < 40 * kMs; t += kMs) EXPECT_FALSE(controller.tick(t, fresh(t))) << t;
  EXPECT_EQ(controller.mode(), Mode::kFault);
  EXPECT_FALSE(controller.set_target(joint_target(bent_pose(), 1.0), 40 * kMs));
  EXPECT_NE(std::string(controller.last_rejection()).find("another sender"), std::string::npos)
      << controller.last_rejection();
  EXPECT_EQ(controller.faults(), 2);
}

TEST_F(ControllerTest, TheTickAllocatesNothing) {
  Controller controller(model_, config_);
  CommandWriter publisher(Protocol::kChasles, 7, TorqueSemantics::kFull);
  const VectorXd no_gravity = VectorXd::Zero(7);
  ASSERT_TRUE(controller.tick(0, fresh(0)));
  VectorXd goal = bent_pose();
  goal(1) += 0.4;
  ASSERT_TRUE(controller.set_target(joint_target(goal, 5.0), 0));
  AllocationCounter counter;
  for (int k = 1; k <= 10'000; ++k) {
    state_.q(1) += 4e-5;
    state_.seq = k + 1;  // a new state each tick: the contact observer runs (and, with no effort, trips)
    if (controller.tick(k * kMs / 2, fresh(k * kMs / 2))) publisher.write(k, k, state_, controller.torque(), no_gravity);
  }
  controller.tick(state_.arrival_ns + 2 * config_.stale_ns, &state_);  // a FAULT formats its reason
  EXPECT_EQ(counter.count(), 0);
  EXPECT_EQ(controller.mode(), Mode::kFault);
}

// --- received bytes ---------------------------------------------------------------------------

template <typename Message>
std::vector<uint8_t> encode(const Message& message) {
  std::vector<uint8_t> bytes(size_t(message.getEncodedSize()));
  message.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

robot_state_t state_message(int n) {
  robot_state_t m;
  m.utime = 1;
  m.seq = 42;
  m.num_joints = n;
  m.position.assign(size_t(n), 0.25);
  m.velocity.assign(size_t(n), -0.5);
  m.effort.assign(size_t(n), 1.0);
  return m;
}

TEST(StateReceiver, AcceptsAWellFormedStateAndRefusesEveryMalformedOne) {
  Mailbox<JointState> mailbox{JointState(7)};
  StateReceiver receiver(7, mailbox);
  JointState out(7);

  const auto good = encode(state_message(7));
  EXPECT_EQ(receiver.receive(good.data(), good.size(), 123), "");
  ASSERT_TRUE(mailbox.read(out));
  EXPECT_EQ(out.seq, 42);
  EXPECT_EQ(out.arrival_ns, 123);
  EXPECT_TRUE(matrices_near(out.q, VectorXd::Constant(7, 0.25), 0.0));
  EXPECT_TRUE(matrices_near(out.qd, VectorXd::Constant(7, -0.5), 0.0));

  const auto refused = [&](const std::vector<uint8_t>& bytes, const std::string& words) {
    const std::string why = receiver.receive(bytes.data(), bytes.size(), 0);
    EXPECT_NE(why.find(words), std::string::npos) << "got '" << why << "', expected '" << words << "'";
    EXPECT_FALSE(mailbox.read(out)) << words;
  };
  refused(encode(state_message(6)), "for 6 joints; the arm has 7");
  auto forged = good;  // a count of 2^31 − 1 in a short message: refused before any decoding
  forged[24] = 0x7f, forged[25] = forged[26] = forged[27] = 0xff;
  refused(forged, "num_joints 2147483647 in a message of 196 bytes");
  refused(std::vector<uint8_t>(good.begin(), good.end() - 8), "bytes; expected");
  refused(std::vector<uint8_t>(good.begin(), good.begin() + 10), "truncated");
  auto nan = state_message(7);
  nan.velocity[2] = kNaN;
  refused(encode(nan), "non-finite");
  refused(encode(arm_target_t{}), "wrong fingerprint");
}

TEST(TargetReceiver, PassesHoldAndJointTargetsAndRefusesAnOversizedCount) {
  SpscRing<Target> queue(4, Target(7));
  TargetReceiver receiver(7, queue);
  Target out(7);
  arm_target_t hold{};
  hold.mode = arm_target_t::HOLD;
  const auto hold_bytes = encode(hold);
  EXPECT_EQ(receiver.receive(hold_bytes.data(), hold_bytes.size()), "");
  ASSERT_TRUE(queue.pop(out));
  EXPECT_EQ(out.mode, Target::kHold);

  arm_target_t joint{};
  joint.mode = arm_target_t::JOINT;
  joint.num_joints = 7;
  joint.joint_position.assign(7, 0.1);
  joint.duration = 2.0;
  const auto joint_bytes = encode(joint);
  EXPECT_EQ(receiver.receive(joint_bytes.data(), joint_bytes.size()), "");
  ASSERT_TRUE(queue.pop(out));
  EXPECT_EQ(out.num_joints, 7);
  EXPECT_EQ(out.duration, 2.0);
  EXPECT_TRUE(matrices_near(out.q, VectorXd::Constant(7, 0.1), 0.0));

  joint.num_joints = 9;
  joint.joint_position.assign(9, 0.1);
  const auto too_many = encode(joint);
  EXPECT_NE(receiver.receive(too_many.data(), too_many.size()).find("for 9 joints"), std::string::npos);
  EXPECT_FALSE(queue.pop(out));
}

std::vector<uint8_t> command_bytes(int64_t seq, int64_t utime, int64_t state_seq) {
  joint_torque_command_t command{};
  command.utime = utime;
  command.seq = seq;
  command.state_seq = state_seq;
  command.num_joints = 2;
  command.torque = {1.0, -1.0};
  std::vector<uint8_t> bytes(size_t(command.getEncodedSize()));
  command.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

// Our own commands come back over multicast and are recognised by (seq, utime); anything else on
// the command channel is foreign: a second controller counting from 1 with its own clock, a copy
// of one of ours heard again (a replay), junk. The first foreign command's numbers are kept for the report.
TEST(CommandWatch, TellsOurOwnCommandsFromAnotherSendersAndJunk) {
  SentCommands sent;
  CommandWatch watch(sent);
  for (int64_t seq = 1; seq <= 10; ++seq) sent.record(seq, 1'000'000 + 1000 * seq);
  for (int64_t seq = 1; seq <= 10; ++seq) {
    const auto own = command_bytes(seq, 1'000'000 + 1000 * seq, seq + 100);
    EXPECT_FALSE(watch.receive(own.data(), own.size())) << seq;
  }
  EXPECT_EQ(watch.foreign(), 0);
  const auto again = command_bytes(5, 1'000'000 + 5000, 105);  // one of ours, heard a second time
  EXPECT_TRUE(watch.receive(again.data(), again.size())) << "a replay of our own command";
  EXPECT_EQ(watch.foreign(), 1);
  EXPECT_EQ(watch.first_seq(), 5);

  const auto other = command_bytes(3, 1'000'000 + 3000 + 1, 42);  // same seq, another clock
  EXPECT_TRUE(watch.receive(other.data(), other.size()));
  EXPECT_EQ(watch.foreign(), 2);
  const auto ahead = command_bytes(11, 1'000'000 + 11'000, 0);  // a seq we have not sent yet
  EXPECT_TRUE(watch.receive(ahead.data(), ahead.size()));
  const uint8_t junk[5] = {1, 2, 3, 4, 5};
  EXPECT_TRUE(watch.receive(junk, sizeof(junk)));
  auto truncated = command_bytes(1, 1'001'000, 0);
  EXPECT_TRUE(watch.receive(truncated.data(), 20));
  EXPECT_EQ(watch.foreign(), 5);
  EXPECT_EQ(watch.first_seq(), 5) << "the first foreign command is the one reported";
  EXPECT_EQ(watch.first_state_seq(), 105);

  // Older than the window: no longer known as ours.
  for (int64_t seq = 11; seq <= 10 + SentCommands::kWindow; ++seq) sent.record(seq, 1'000'000 + 1000 * seq);
  EXPECT_FALSE(sent.take(10, 1'000'000 + 10'000));
  EXPECT_TRUE(sent.take(11, 1'000'000 + 11'000));
  EXPECT_FALSE(sent.take(11, 1'000'000 + 11'000)) << "taken once";
  EXPECT_TRUE(sent.take(10 + SentCommands::kWindow, 1'000'000 + 1000 * (10 + SentCommands::kWindow)));
  EXPECT_FALSE(sent.take(0, 0));
}

// Recording runs on the real-time loop: it allocates nothing.
TEST(CommandWatch, RecordingAllocatesNothing) {
  SentCommands sent;
  AllocationCounter counter;
  for (int64_t seq = 1; seq <= 10'000; ++seq) sent.record(seq, seq);
  EXPECT_EQ(counter.count(), 0);
  EXPECT_TRUE(sent.take(10'000, 10'000));
}

}  // namespace
}  // namespace chasles::controller
