// The Controller's side of the control laws: switches between any two laws mid-motion, refusals
// before the first state and in FAULT, free drive, equilibrium steps, a payload model, what a tick
// costs in the model's terms, and no allocation. The laws themselves are law_test's.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <array>
#include <string>

#include "controller/controller.hpp"
#include "controller/law.hpp"
#include "core/dynamics/dynamics.hpp"
#include "core/geometry/collision_model.hpp"
#include "core/kinematics/kinematics.hpp"
#include "core/model/payload.hpp"
#include "support/allocation_counter.hpp"
#include "support/arm.hpp"
#include "support/reference.hpp"

namespace chasles::controller {
namespace {

using Eigen::VectorXd;
using testing::AllocationCounter;
using testing::matrices_near;
using testing::panda;
using testing::ur5;
using testing::gravity_of;

constexpr int64_t kMs = 1'000'000;
constexpr std::array<Law, 4> kLaws = {Law::kComputedTorque, Law::kJointImpedance, Law::kCartesianImpedance,
                                      Law::kFreeDrive};

// --- the Controller's laws ------------------------------------------------------------------

class LawController : public ::testing::Test {
 protected:
  LawController()
      : model_(panda()),
        data_(model_),
        config_(Config::critically_damped(7, 20.0)),
        state_(7),
        q0_((VectorXd(7) << 0.1, 0.5, -0.2, -1.2, 0.1, 1.0, 0.3).finished()),  // bent, clear of singularities
        velocity_(7),
        zero_(VectorXd::Zero(7)) {
    velocity_ << 0.10, -0.08, 0.06, 0.10, -0.15, 0.12, 0.15;
    // The states are the test's, their effort not the torque applied: the torque-semantics check
    // is semantics_check_test's and the World's.
    config_.check_torque_semantics = false;
    state_.q = q0_;
    state_.seq = 1;
  }

  // The arm passing q0 + v t at constant velocity v, a new state each millisecond, with the applied
  // effort c + g that explains that motion, so that the contact observer sees no external torque.
  const JointState* moving(int64_t t) {
    state_.q = q0_ + velocity_ * (1e-9 * static_cast<double>(t));
    state_.qd = velocity_;
    state_.seq = 1 + t / kMs;
    state_.effort = inverse_dynamics(model_, data_, state_.q, state_.qd, zero_);
    state_.arrival_ns = t;
    return &state_;
  }
  // The arm at rest where it is, the same state again.
  const JointState* fresh(int64_t t) {
    state_.arrival_ns = t;
    return &state_;
  }

  static Target joint_target(const VectorXd& q, double duration) {
    Target target(7);
    target.mode = Target::kJoint;
    target.num_joints = 7;
    target.q = q;
    target.duration = duration;
    return target;
  }

  static LawSettings settings(Law law) {
    LawSettings s(7);
    s.law = law;
    if (law == Law::kJointImpedance) s.joint_stiffness << 400, 400, 300, 300, 50, 50, 20;
    return s;
  }

  // The torque `settings` commands at this state and reference, computed afresh.
  VectorXd law_torque(const LawSettings& s, const motion::Reference& ref, const VectorXd& q, const VectorXd& qd) const {
    Data data(model_);
    Data data_ref(model_);
    LawWorkspace work(7);
    VectorXd tau(7), scratch(7);
    switch (s.law) {
      case Law::kComputedTorque:
        compute_tick_terms(model_, data, q, qd);
        computed_torque(model_, data, config_.kp, config_.kd, ref, q, qd, scratch, tau);
        break;
      case Law::kJointImpedance:
        compute_tick_terms(model_, data, q, qd);
        joint_impedance(model_, data, work, s, ref, q, qd, tau);
        break;
      case Law::kCartesianImpedance:
        compute_tick_terms(model_, data, q, qd);
        body_jacobian(model_, data_ref, ref.q);
        cartesian_impedance(model_, data, data_ref, work, s, ref, q, qd, tau);
        break;
      case Law::kFreeDrive:
        compute_tick_terms(model_, data, q, qd);
        free_drive(model_, data, s, qd, tau);
        break;
    }
    return tau;
  }

  VectorXd rate_step() const {
    VectorXd step(7);
    for (int i = 0; i < 7; ++i) step(i) = model_.joint(i).limits.effort / config_.torque_ramp * config_.period;
    return step;
  }

  const RobotModel& model_;
  Data data_;
  Config config_;
  JointState state_;
  VectorXd q0_, velocity_, zero_;
};

// Mid-motion (a JOINT target running, or free drive), the arm moving, a switch to each law: at
// the switch tick the command is the previous one, and from there it is the new law's torque plus
// the difference at the switch, fading linearly to nothing over torque_ramp.
TEST_F(LawController, ASwitchBetweenAnyTwoLawsMidMotionFadesInWithoutAJump) {
  const VectorXd step = rate_step();
  VectorXd goal = q0_;
  goal(1) += 0.4;
  goal(3) -= 0.3;
  goal(5) += 0.3;
  for (Law from : kLaws) {
    for (Law to : kLaws) {
      SCOPED_TRACE(std::string(to_string(from)) + " -> " + to_string(to));
      Controller controller(model_, config_);
      ASSERT_TRUE(controller.tick(0, moving(0)));
      ASSERT_TRUE(controller.set_law(settings(from), 0)) << controller.mode_rejection();
      if (from != Law::kFreeDrive) {
        ASSERT_TRUE(controller.set_target(joint_target(goal, 2.0), 0)) << controller.last_rejection();
      }
      for (int64_t t = kMs; t <= 100 * kMs; t += kMs) ASSERT_TRUE(controller.tick(t, moving(t)));
      ASSERT_EQ(controller.mode(), from == Law::kFreeDrive ? Mode::kHolding : Mode::kRunning);
      VectorXd previous = controller.torque();
      ASSERT_TRUE(controller.set_law(settings(to), 100 * kMs)) << controller.mode_rejection();

      VectorXd offset;
      const int64_t t_switch = 101 * kMs;
      double largest_offset = 0.0;
      for (int64_t t = t_switch; t <= 170 * kMs; t += kMs) {
        SCOPED_TRACE("t " + std::to_string(t / kMs) + " ms");
        ASSERT_TRUE(controller.tick(t, moving(t)));
        ASSERT_NE(controller.mode(), Mode::kReflex) << controller.reflex_reason();
        const VectorXd& tau = controller.torque();
        EXPECT_TRUE(((tau - previous).cwiseAbs().array() <= step.array() * (1 + 1e-12)).all())
            << "a step over the rate limit: " << (tau - previous).transpose();
        const VectorXd law = law_torque(settings(to), controller.reference(), state_.q, state_.qd);
        if (t == t_switch) {
          EXPECT_TRUE(matrices_near(tau, previous, 1e-9)) << "the switch tick commands what the last one did";
          offset = previous - law;
          largest_offset = offset.cwiseAbs().maxCoeff();
        }
        const double fade = std::max(0.0, 1.0 - 1e-9 * static_cast<double>(t - t_switch) / config_.torque_ramp);
        EXPECT_TRUE(matrices_near(tau, law + fade * offset, 1e-9)) << "fade " << fade;
        previous = tau;
      }
      if (from != to) {
        EXPECT_GT(largest_offset, 0.01) << "the laws must differ for the fade to be tested";
      }
    }
  }
}

// What a tick costs in the model's terms, for every law and every source of the reference: the
// joint transforms and J_b once at the state, whatever the observer, the contact monitor and the
// law read of them, and at most once at the reference — frame c's desired pose under the Cartesian
// law, the Jacobian a jog or a tip stream resolves through and looks ahead along. The one tick
// that needs two at the reference is the first of a jog or tip stream taken in the same period as
// a switch to the Cartesian law: the jog resolves at the reference it starts from, which no tick
// has computed yet, and the law reads the one the jog moved to; from its second tick on, the jog
// reads what the law computed the tick before.
enum class Source { kHold, kGoal, kWaypoints, kPath, kStream, kTipStream, kJointJog, kTwistJog, kStop };
constexpr std::array<Source, 9> kSources = {Source::kHold,   Source::kGoal,      Source::kWaypoints,
                                            Source::kPath,   Source::kStream,    Source::kTipStream,
                                            Source::kJointJog, Source::kTwistJog, Source::kStop};
const char* to_string(Source source) {
  constexpr std::array<const char*, 9> kNames = {"hold",   "goal",       "waypoints",  "path", "stream",
                                                 "tip stream", "joint jog", "twist jog", "stop"};
  return kNames[static_cast<size_t>(source)];
}

class TickCost : public LawController {
 protected:
  // Starts `source` at t = 0 (the arm holding at q0): true once it drives the reference.
  bool start(Controller& controller, Source source) {
    VectorXd goal = q0_;
    goal(1) += 0.3;
    switch (source) {
      case Source::kHold:
        return true;
      case Source::kGoal:
        return controller.set_target(joint_target(goal, 2.0), 0);
      case Source::kWaypoints: {
        motion::Waypoints w(7);
        w.id = 1;
        w.count = 2;
        w.time << 1.0, 2.0, VectorXd::Zero(motion::Waypoints::kMaxPoints - 2);
        w.q.col(0) = 0.5 * (q0_ + goal);
        w.q.col(1) = goal;
        return controller.set_trajectory(w, 0);
      }
      case Source::kPath: {
        Target target(7);
        target.mode = Target::kCartesian;
        const Transform T = forward_kinematics(model_, data_, controller.reference().q);
        target.position = T.translation() + Eigen::Vector3d(0.02, 0.0, 0.0);
        const Eigen::Quaterniond r(T.linear());
        target.quaternion << r.w(), r.x(), r.y(), r.z();
        target.duration = 1.0;
        CartesianRequest request(7);
        if (!controller.set_target(target, 0) || !controller.take_request(request)) return false;
        JointPath path(7);  // two waypoints at rest: what the sampler follows, whatever IK found
        path.request_id = request.id;
        path.ok = true;
        path.count = 2;
        path.dt = 1.0;
        path.q.col(0) = request.q_start;
        path.q.col(1) = request.q_start + VectorXd::Constant(7, 0.05);
        return controller.follow(path, 0);
      }
      default:
        return feed(controller, source, 0) && (controller.streaming() || controller.jogging());
    }
  }
  // The stream's or the jog's message due at t, every 10 ms (a stop: none after the first, so the
  // stream times out and the reference brakes).
  bool feed(Controller& controller, Source source, int64_t t) {
    if (t % (10 * kMs) != 0 || (source == Source::kStop && t > 0)) return true;
    const double s = 1e-9 * static_cast<double>(t);
    const int64_t utime = t / 1000 + 1;
    switch (source) {
      case Source::kStream:
      case Source::kStop: {
        Setpoint setpoint(7);
        setpoint.utime = utime;
        setpoint.q = q0_ + VectorXd::Constant(7, 0.05 * s);
        setpoint.qd = VectorXd::Constant(7, 0.05);
        return controller.set_setpoint(setpoint, t);
      }
      case Source::kTipStream: {
        TipSetpoint setpoint;
        setpoint.utime = utime;
        const Transform T = forward_kinematics(model_, data_, q0_);
        setpoint.position = T.translation() + Eigen::Vector3d(0.02 * s, 0.0, 0.0);
        const Eigen::Quaterniond r(T.linear());
        setpoint.quaternion << r.w(), r.x(), r.y(), r.z();
        setpoint.twist(3) = 0.02;
        return controller.set_tip_setpoint(setpoint, t);
      }
      case Source::kJointJog:
      case Source::kTwistJog: {
        Jog jog(7);
        jog.utime = utime;
        jog.kind = source == Source::kJointJog ? Jog::kJointVelocity : Jog::kTwist;
        jog.joint_velocity.setConstant(0.05);
        jog.twist(3) = 0.02;
        return controller.set_jog(jog, t);
      }
      default:
        return true;
    }
  }
};

TEST_F(TickCost, EveryTickComputesTheKinematicsOnceAtTheStateAndAtMostOnceAtTheReference) {
  // With the arm's geometry and a scene too: the clearance reads the kinematics at the reference
  // before the source moves it, where a jog reads them and the Cartesian law read them last tick.
  const std::string packages = chasles::testing::data_path("packages");
  geometry::Scene scene;
  scene.planes.push_back({"floor", Eigen::Vector3d::UnitZ(), -0.5, {}, {}});
  ClearanceWorld world(model_, geometry::Proximity(geometry::load_collision_model(
                                                       chasles::testing::data_path("panda.urdf"), model_,
                                                       {{packages}, packages + "/example-robot-data/robots/"
                                                                              "panda_description/srdf/panda.srdf"}),
                                                   scene));
  for (bool clear : {false, true})
  for (Law law : kLaws) {
    for (Source source : kSources) {
      if (law == Law::kFreeDrive && source != Source::kHold) continue;  // free drive follows no reference
      SCOPED_TRACE(std::string(to_string(law)) + ", " + to_string(source) + (clear ? ", with a scene" : ""));
      Controller controller(model_, config_);
      ASSERT_TRUE(controller.set_clearance_world(clear ? &world : nullptr));
      ASSERT_TRUE(controller.tick(0, moving(0)));
      ASSERT_TRUE(controller.set_law(settings(law), 0)) << controller.mode_rejection();
      ASSERT_TRUE(start(controller, source)) << controller.last_rejection();
      const bool reads_reference = law == Law::kCartesianImpedance || source == Source::kTipStream ||
                                   source == Source::kJointJog || source == Source::kTwistJog;
      const bool jog_under_cartesian = law == Law::kCartesianImpedance && reads_reference &&
                                       source != Source::kHold && source != Source::kGoal;
      constexpr int kTicks = 200;
      int64_t reference_passes = 0;
      for (int64_t t = kMs; t <= kTicks * kMs; t += kMs) {
        SCOPED_TRACE("t " + std::to_string(t / kMs) + " ms");
        const Data::Passes at_state = controller.data().passes, at_reference = controller.reference_data().passes;
        ASSERT_TRUE(feed(controller, source, t)) << controller.last_rejection();
        ASSERT_TRUE(controller.tick(t, moving(t)));
        EXPECT_EQ(controller.data().passes.joint_transforms - at_state.joint_transforms, 1);
        EXPECT_EQ(controller.data().passes.body_jacobians - at_state.body_jacobians, 1);
        const int64_t transforms = controller.reference_data().passes.joint_transforms - at_reference.joint_transforms;
        const int64_t jacobians = controller.reference_data().passes.body_jacobians - at_reference.body_jacobians;
        EXPECT_EQ(transforms, jacobians);
        const bool first_jog_tick = t == kMs && jog_under_cartesian &&
                                    (source == Source::kTipStream || source == Source::kJointJog ||
                                     source == Source::kTwistJog);
        // The first tick under the Cartesian law with a scene: no law has read the reference the
        // clearance starts from yet.
        const bool first_clear_tick = t == kMs && clear && law == Law::kCartesianImpedance;
        EXPECT_LE(jacobians, first_jog_tick || first_clear_tick ? 2 : 1);
        if (!reads_reference && !clear) {
          EXPECT_EQ(jacobians, 0);
        }
        reference_passes += jacobians;
      }
      ASSERT_NE(controller.mode(), Mode::kReflex) << controller.reflex_reason();
      EXPECT_EQ(controller.mode(), source == Source::kHold || source == Source::kStop ? Mode::kHolding : Mode::kRunning);
      // Those that read the reference's kinematics do, every tick its position moved.
      if (reads_reference && source != Source::kHold && source != Source::kStop) {
        EXPECT_GE(reference_passes, kTicks);
      }
    }
  }
}

TEST_F(LawController, ALawIsRefusedBeforeTheFirstStateAndInFault) {
  Controller controller(model_, config_);
  EXPECT_FALSE(controller.set_law(settings(Law::kJointImpedance), 0));
  EXPECT_EQ(controller.rejected_modes(), 1);
  EXPECT_NE(std::string(controller.mode_rejection()).find("no robot state has arrived"), std::string::npos)
      << controller.mode_rejection();
  EXPECT_EQ(controller.law().law, Law::kComputedTorque);

  ASSERT_TRUE(controller.tick(0, fresh(0)));
  LawSettings bad = settings(Law::kJointImpedance);
  bad.joint_stiffness(4) = 0.0;
  EXPECT_FALSE(controller.set_law(bad, 0));
  EXPECT_EQ(controller.rejected_modes(), 2);
  EXPECT_NE(std::string(controller.mode_rejection()).find("joint panda_joint5: stiffness 0"), std::string::npos)
      << controller.mode_rejection();
  EXPECT_EQ(controller.law().law, Law::kComputedTorque);

  EXPECT_FALSE(controller.tick(config_.stale_ns + 1, &state_));
  ASSERT_EQ(controller.mode(), Mode::kFault);
  EXPECT_FALSE(controller.set_law(settings(Law::kFreeDrive), config_.stale_ns + 1));
  EXPECT_EQ(controller.rejected_modes(), 3);
  EXPECT_NE(std::string(controller.mode_rejection()).find("FAULT"), std::string::npos) << controller.mode_rejection();
  EXPECT_EQ(controller.law().law, Law::kComputedTorque);

  const int64_t t = config_.stale_ns + 5 * kMs;
  ASSERT_TRUE(controller.tick(t, fresh(t)));  // a fresh state: HOLDING again, and laws are taken
  EXPECT_TRUE(controller.set_law(settings(Law::kFreeDrive), t)) << controller.mode_rejection();
  EXPECT_EQ(controller.law().law, Law::kFreeDrive);
  EXPECT_EQ(controller.rejected_modes(), 3);
}

TEST_F(LawController, FreeDriveRefusesJointTargetsTakesHoldAndFollowsTheArm) {
  Controller controller(model_, config_);
  ASSERT_TRUE(controller.tick(0, moving(0)));
  VectorXd goal = q0_;
  goal(2) += 0.3;
  ASSERT_TRUE(controller.set_target(joint_target(goal, 2.0), 0));
  ASSERT_TRUE(controller.tick(kMs, moving(kMs)));
  ASSERT_EQ(controller.mode(), Mode::kRunning);
  ASSERT_TRUE(controller.set_law(settings(Law::kFreeDrive), kMs)) << controller.mode_rejection();
  EXPECT_EQ(controller.mode(), Mode::kHolding) << "free drive ends the motion";

  EXPECT_FALSE(controller.set_target(joint_target(goal, 2.0), kMs));
  EXPECT_EQ(controller.rejected_targets(), 1);
  EXPECT_NE(std::string(controller.last_rejection()).find("free drive follows no target"), std::string::npos)
      << controller.last_rejection();
  Target hold(7);
  hold.mode = Target::kHold;
  EXPECT_TRUE(controller.set_target(hold, kMs)) << controller.last_rejection();
  EXPECT_EQ(controller.mode(), Mode::kHolding);
  EXPECT_EQ(controller.rejected_targets(), 1);
  for (int64_t t = 2 * kMs; t <= 20 * kMs; t += kMs) {
    ASSERT_TRUE(controller.tick(t, moving(t)));
    EXPECT_TRUE(matrices_near(controller.reference().q, state_.q, 0.0)) << "the reference is where the arm is";
    EXPECT_TRUE(matrices_near(controller.reference().qd, VectorXd::Zero(7), 0.0));
  }
}

TEST_F(LawController, ADurationOfZeroStepsTheEquilibriumOnlyUnderAnImpedanceLaw) {
  Controller controller(model_, config_);
  ASSERT_TRUE(controller.tick(0, fresh(0)));
  VectorXd goal = q0_;
  goal(1) += 0.15;
  goal(3) -= 0.1;
  EXPECT_FALSE(controller.set_target(joint_target(goal, 0.0), 0)) << "computed torque follows motions only";
  EXPECT_NE(std::string(controller.last_rejection()).find("positive, finite duration"), std::string::npos)
      << controller.last_rejection();
  EXPECT_TRUE(matrices_near(controller.reference().q, q0_, 0.0));

  for (Law law : {Law::kJointImpedance, Law::kCartesianImpedance}) {
    SCOPED_TRACE(to_string(law));
    Controller c(model_, config_);
    ASSERT_TRUE(c.tick(0, fresh(0)));
    ASSERT_TRUE(c.set_law(settings(law), 0)) << c.mode_rejection();
    ASSERT_TRUE(c.tick(kMs, fresh(kMs)));
    ASSERT_TRUE(c.set_target(joint_target(goal, 0.0), kMs)) << c.last_rejection();
    EXPECT_TRUE(matrices_near(c.reference().q, goal, 0.0)) << "the equilibrium jumps to the goal at once";
    EXPECT_EQ(c.mode(), Mode::kHolding);
    ASSERT_TRUE(c.tick(2 * kMs, fresh(2 * kMs)));
    EXPECT_TRUE(matrices_near(c.reference().q, goal, 0.0));
    EXPECT_TRUE(matrices_near(c.reference().qd, VectorXd::Zero(7), 0.0));
    EXPECT_TRUE(matrices_near(c.error(), goal - q0_, 0.0));

    VectorXd far = goal;
    far(0) += 0.21;  // from the current equilibrium, not from the arm
    EXPECT_FALSE(c.set_target(joint_target(far, 0.0), 2 * kMs));
    EXPECT_NE(std::string(c.last_rejection()).find("joint panda_joint1: a step of 0.21"), std::string::npos)
        << c.last_rejection();
    EXPECT_NE(std::string(c.last_rejection()).find("over 0.2"), std::string::npos) << c.last_rejection();
    EXPECT_TRUE(matrices_near(c.reference().q, goal, 0.0)) << "the equilibrium stays";
    far(0) = goal(0) + 0.19;
    EXPECT_TRUE(c.set_target(joint_target(far, 0.0), 2 * kMs)) << c.last_rejection();
    EXPECT_TRUE(matrices_near(c.reference().q, far, 0.0));
  }
}

// The point-mass payload's gravity torque by its own formula: the load at p (base frame) weighs
// m g, and τ_i = −m (v_i + ω_i × p) · g with (ω_i, v_i) the i-th column of J_s.
VectorXd payload_gravity(const RobotModel& model, const VectorXd& q, const Payload& payload) {
  Data data(model);
  Data data_ref(model);
  const Matrix6Xd J_s = space_jacobian(model, data, q);
  const Vector3d p = Transform(data.T_sb) * payload.centre;
  VectorXd tau(model.dof());
  for (int i = 0; i < model.dof(); ++i) {
    const Vector3d v_point = J_s.col(i).tail<3>() + J_s.col(i).head<3>().cross(p);
    tau(i) = -payload.mass * v_point.dot(model.gravity());
  }
  return tau;
}

TEST_F(LawController, APayloadModelChangesTheHoldingTorqueByThePayloadsGravity) {
  Payload payload;
  payload.mass = 1.5;
  payload.centre = Vector3d(0.02, -0.01, 0.05);
  payload.inertia = Matrix3d(Vector3d(2e-3, 3e-3, 1e-3).asDiagonal());
  const RobotModel loaded = with_payload(model_, payload);
  const VectorXd g0 = gravity_of(model_, q0_), g1 = gravity_of(loaded, q0_);
  ASSERT_TRUE(matrices_near(g1 - g0, payload_gravity(model_, q0_, payload), 1e-9));
  ASSERT_GT((g1 - g0).cwiseAbs().maxCoeff(), 1.0);

  for (Law law : kLaws) {
    SCOPED_TRACE(to_string(law));
    Controller controller(model_, config_);
    ASSERT_TRUE(controller.tick(0, fresh(0)));
    ASSERT_TRUE(controller.set_law(settings(law), 0)) << controller.mode_rejection();
    int64_t t = kMs;
    for (; t <= 100 * kMs; t += kMs) ASSERT_TRUE(controller.tick(t, fresh(t)));
    const VectorXd before = controller.torque();
    EXPECT_TRUE(matrices_near(before, g0, 1e-9));

    controller.set_model(ur5());  // another arm: ignored
    EXPECT_EQ(&controller.model(), &model_);
    controller.set_model(loaded);
    EXPECT_EQ(&controller.model(), &loaded);
    for (; t <= 200 * kMs; t += kMs) ASSERT_TRUE(controller.tick(t, fresh(t)));  // through the rate limit
    EXPECT_TRUE(matrices_near(controller.torque(), g1, 1e-9));
    EXPECT_TRUE(matrices_near(controller.torque() - before, payload_gravity(model_, q0_, payload), 1e-9));
    EXPECT_EQ(controller.mode(), Mode::kHolding);
  }
}

TEST_F(LawController, NoTickAllocatesUnderAnyLawOrThroughASwitch) {
  VectorXd goal = q0_;
  goal(1) += 0.4;
  goal(3) -= 0.3;
  for (size_t k = 0; k < kLaws.size(); ++k) {
    const Law law = kLaws[k], next = kLaws[(k + 1) % kLaws.size()];
    SCOPED_TRACE(std::string(to_string(law)) + " then " + to_string(next));
    const LawSettings first = settings(law), second = settings(next);
    Controller controller(model_, config_);
    ASSERT_TRUE(controller.tick(0, moving(0)));
    if (law != Law::kFreeDrive) {
      ASSERT_TRUE(controller.set_target(joint_target(goal, 5.0), 0)) << controller.last_rejection();
    }
    int64_t t = kMs;
    long allocations = 0;
    bool taken_both = false;
    {
      AllocationCounter counter;
      const bool taken = controller.set_law(first, 0);
      for (; t <= 1000 * kMs; t += kMs) controller.tick(t, moving(t));
      const bool switched = controller.set_law(second, t);
      for (; t <= 2000 * kMs; t += kMs) controller.tick(t, moving(t));
      allocations = counter.count();
      taken_both = taken && switched;
    }
    ASSERT_TRUE(taken_both) << controller.mode_rejection();
    EXPECT_EQ(allocations, 0);
    EXPECT_TRUE(controller.mode() == Mode::kRunning || controller.mode() == Mode::kHolding)
        << to_string(controller.mode()) << ": " << controller.fault_reason() << controller.reflex_reason();
    EXPECT_EQ(controller.law().law, next);
  }
}

}  // namespace
}  // namespace chasles::controller
