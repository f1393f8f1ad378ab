// What flows into and out of a control tick, as plain values: the measured state, the goals,
// setpoints and jog commands a sender gives, and the modes and outcomes the status reports. The
// transport decodes messages into them and encodes them back (lcm_io.hpp); the control logic
// (controller.hpp) takes and gives them. Sized for one arm; no logic here.
#pragma once

#include <Eigen/Core>
#include <cstdint>

#include "core/lie/types.hpp"

namespace chasles::controller {

/// A measured joint state, already checked for size and finiteness by whoever decoded it.
struct JointState {
  int64_t seq = -1;         ///< the sender's counter
  int64_t utime = 0;        ///< the sender's timestamp, µs
  int64_t arrival_ns = 0;   ///< CLOCK_MONOTONIC time it arrived here
  Eigen::VectorXd q, qd;
  Eigen::VectorXd effort;   ///< the torque applied over the step that ended at this state
  explicit JointState(int n = 0)
      : q(Eigen::VectorXd::Zero(n)), qd(Eigen::VectorXd::Zero(n)), effort(Eigen::VectorXd::Zero(n)) {}
};

/// A goal as received (arm_target_t's content); checked by Controller::set_target.
struct Target {
  enum Mode : int8_t { kHold = 0, kJoint = 1, kCartesian = 2 };
  int8_t mode = kHold;
  int num_joints = 0;  ///< entries of q the sender filled
  Eigen::VectorXd q;   ///< capacity for the arm's joints
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Vector4d quaternion = Eigen::Vector4d(1, 0, 0, 0);  ///< (w, x, y, z)
  double duration = 0.0;
  explicit Target(int n = 0) : q(Eigen::VectorXd::Zero(n)) {}
};

/// One setpoint of a stream (joint_setpoint_t's content, sized and finite).
struct Setpoint {
  int64_t utime = 0;  ///< the sender's sample time, µs: orders the stream
  Eigen::VectorXd q, qd;
  explicit Setpoint(int n = 0) : q(Eigen::VectorXd::Zero(n)), qd(Eigen::VectorXd::Zero(n)) {}
};

/// One setpoint of a Cartesian stream (tip_setpoint_t's content, finite).
struct TipSetpoint {
  int64_t utime = 0;  ///< the sender's sample time, µs: orders the stream
  Eigen::Vector3d position = Eigen::Vector3d::Zero();        ///< p_sb, m
  Eigen::Vector4d quaternion = Eigen::Vector4d(1, 0, 0, 0);  ///< R_sb as (w, x, y, z), unit norm within 1e-3
  /// How the pose moves on: the tip's angular velocity and its origin's velocity, rad/s and m/s,
  /// both in the base frame's axes.
  Vector6d twist = Vector6d::Zero();
};

enum class Mode : int8_t { kWaiting = 0, kRunning = 1, kHolding = 2, kFault = 3, kReflex = 4 };
const char* to_string(Mode mode);

/// How the latest waypoint trajectory went (control_msgs' FollowJointTrajectory outcomes).
struct TrajectoryProgress {
  enum Outcome : int8_t { kNone = 0, kActive = 1, kSucceeded = 2, kAborted = 3, kPreempted = 4, kRejected = 5 };
  int64_t id = 0;
  Outcome outcome = kNone;
  double elapsed = 0.0;   ///< s since it started (frozen at its outcome)
  double duration = 0.0;  ///< s, after time scaling
  double scale = 1.0;     ///< the factor its times were multiplied by to fit the limits (1: none)
  int waypoint = 0;       ///< the waypoint being approached, 0-based; count once past the last
  char message[192] = {};  ///< why ABORTED, REJECTED or PREEMPTED, or what scaled it
};
const char* to_string(TrajectoryProgress::Outcome outcome);

/// One jog command as received (jog_command_t's content, sized and finite).
struct Jog {
  enum Kind : int8_t { kJointVelocity = 0, kTwist = 1 };
  /// The twist's frame: kBase, the tip's angular velocity and the velocity of its origin, both in
  /// the base frame's axes (Pinocchio's LOCAL_WORLD_ALIGNED; what a space mouse in the robot's
  /// frame means); kTool, the body twist V_b in the tip frame.
  enum Frame : int8_t { kBase = 0, kTool = 1 };
  int64_t utime = 0;  ///< the sender's sample time, µs: orders the commands
  int8_t kind = kJointVelocity;
  int8_t frame = kBase;
  Eigen::VectorXd joint_velocity;     ///< rad/s (m/s), root to tip (kJointVelocity)
  Vector6d twist = Vector6d::Zero();  ///< (ω, v), rad/s and m/s, in `frame` (kTwist)
  explicit Jog(int n = 0) : joint_velocity(Eigen::VectorXd::Zero(n)) {}
};

/// How the latest jog tick went.
struct JogProgress {
  /// What cut the command's speed, if anything: a joint's velocity limit, a joint that would
  /// otherwise not stop before its position limit, a singularity ahead.
  enum Limit : int8_t { kNone = 0, kVelocity = 1, kPosition = 2, kSingularity = 3 };
  double condition = 0.0;  ///< κ(J_b) at the reference (σ_max / σ_min of its min(6, n) largest)
  double scale = 1.0;      ///< the speed taken over the speed asked, in [0, 1]; 0: halted
  Limit limited_by = kNone;
  int joint = -1;          ///< the joint at its velocity or position limit (kVelocity, kPosition)
};
const char* to_string(JogProgress::Limit limit);

}  // namespace chasles::controller
