// The LCM message contracts on the wire: every field survives an encode/decode round trip
// bit for bit, the encoded size is the contract's, and a damaged buffer (truncated, or of another
// type) is refused rather than half-read. For control_mode_t and payload_t, also what their checked
// decoder (lcmtypes/checked.hpp) refuses, and the reason it gives.
#include <gtest/gtest.h>

#include <chasles/arm_target_t.hpp>
#include <chasles/control_mode_t.hpp>
#include <chasles/contact_estimate_t.hpp>
#include <chasles/controller_status_t.hpp>
#include <chasles/sim_truth_t.hpp>
#include <chasles/jog_command_t.hpp>
#include <chasles/tip_setpoint_t.hpp>
#include <chasles/joint_torque_command_t.hpp>
#include <chasles/joint_setpoint_t.hpp>
#include <chasles/joint_trajectory_t.hpp>
#include <chasles/payload_t.hpp>
#include <chasles/robot_state_t.hpp>
#include <cmath>
#include <cstdint>
#include <limits>
#include <set>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "lcmtypes/checked.hpp"
#include "wire.hpp"

namespace chasles::testing {
namespace {

// Every proper prefix of a valid encoding must be refused, and so must the encoding with its
// fingerprint changed.
template <class Message>
void expect_damage_refused(const std::vector<uint8_t>& buffer) {
  for (size_t length = 0; length < buffer.size(); ++length) {
    Message message;
    EXPECT_LT(message.decode(buffer.data(), 0, static_cast<int>(length)), 0) << "truncated to " << length << " bytes";
  }
  std::vector<uint8_t> wrong_hash = buffer;
  wrong_hash[3] ^= 0x10;
  Message message;
  EXPECT_LT(message.decode(wrong_hash.data(), 0, static_cast<int>(wrong_hash.size())), 0);
}

robot_state_t make_state(int n) {
  robot_state_t state;
  state.utime = 1'790'000'000'123'456;
  state.seq = (int64_t{1} << 40) + 3;
  state.num_joints = n;
  state.position = values(n, 1.0);
  state.velocity = values(n, -2.5);
  state.effort = values(n, 87.0);
  if (n > 1) state.effort[1] = std::numeric_limits<double>::denorm_min();
  return state;
}

joint_torque_command_t make_command() {
  joint_torque_command_t command;
  command.utime = 1'790'000'000'654'321;
  command.seq = 123'456'789'012;
  command.state_seq = -1;
  command.num_joints = kJoints;
  command.torque = values(kJoints, 12.0);
  return command;
}

arm_target_t make_target() {
  arm_target_t target;
  target.utime = 42;
  target.mode = arm_target_t::CARTESIAN;
  target.num_joints = kJoints;
  target.joint_position = values(kJoints, 0.7);
  const double p_sb[3] = {0.3, -0.25, 0.6};
  const double quaternion[4] = {0.5, -0.5, 0.5, 0.5};  // (w, x, y, z)
  for (int i = 0; i < 3; ++i) target.tip_position[i] = p_sb[i];
  for (int i = 0; i < 4; ++i) target.tip_quaternion[i] = quaternion[i];
  target.duration = 2.75;
  return target;
}

controller_status_t make_status() {
  controller_status_t status;
  status.utime = -7;
  status.state = controller_status_t::FAULT;
  status.message = "torque limit on joint 4: 90.1 N·m";  // UTF-8 survives
  status.num_joints = kJoints;
  status.q = values(kJoints, 1.0);
  status.q_desired = values(kJoints, 1.1);
  status.tracking_error = values(kJoints, 0.1);
  for (int i = 0; i < 3; ++i) status.tip_position[i] = 0.1 * (i + 1);
  for (int i = 0; i < 4; ++i) status.tip_quaternion[i] = i == 0 ? 1.0 : 0.0;
  status.torque = values(kJoints, -30.0);
  status.ik_iterations = 17;
  status.ik_residual = 3.5e-13;
  status.ik_converged = true;
  status.jitter_p50_us = 13.25;
  status.jitter_p99_us = 45.5;
  status.jitter_max_us = 13'000.0;
  status.compute_p50_us = 4.0;
  status.compute_p99_us = 9.0;
  status.compute_max_us = 31.0;
  status.latency_p50_us = 64.0;
  status.latency_p99_us = 100.0;
  status.latency_max_us = 2'500.0;
  status.ticks = 20'000;
  status.overruns = 2;
  status.stale_states = 3;
  status.rejected_messages = 5;
  status.faults = 1;
  status.tau_ext = values(kJoints, 0.5);
  status.generator_velocity_limit = values(kJoints, 2.0);
  status.generator_acceleration_limit = values(kJoints, 10.0);
  status.generator_jerk_limit = values(kJoints, 3000.0);
  status.clearance_pair = "panda_hand/0 and table";
  status.clearance_distance = 0.0125;
  for (int k = 0; k < 3; ++k) status.clearance_points[0][k] = 0.5 + k, status.clearance_points[1][k] = -0.25 * k;
  status.clearance_slowed_by = "panda_link7/0 and wall";
  status.clearance_kept = 0.25;
  status.contact_link = "panda_link4";
  status.contact_located_flag = true;
  for (int k = 0; k < 3; ++k) status.contact_point[k] = 0.1 * (k + 1), status.contact_force[k] = -2.0 * (k + 1);
  for (int i = 0; i < 6; ++i) status.tip_wrench_ext[i] = 0.25 * (i - 2);
  status.contact = true;
  status.collision = false;
  status.contacts = 4;
  status.reflexes = 1;
  status.law = control_mode_t::CARTESIAN_IMPEDANCE;
  status.payload_mass = 1.375;
  status.state_period = 0.005;
  status.trajectory_id = -42;
  status.trajectory_outcome = controller_status_t::TRAJECTORY_ABORTED;
  status.trajectory_elapsed = 1.25;
  status.trajectory_duration = 4.5;
  status.trajectory_time_scale = 1.5;
  status.trajectory_waypoint = 3;
  status.trajectory_message = "joint j2: 0.02 rad off the path at 1.250 s, over its tolerance 0.01";
  status.streaming = true;
  status.setpoints = 1234;
  status.setpoints_dropped = 56;
  status.jogging = true;
  status.jogs = 789;
  status.jogs_dropped = 12;
  status.jog_condition = 23.5;
  status.jog_scale = 0.5;
  status.jog_limited_by = controller_status_t::JOG_SINGULARITY;
  status.jog_joint = -1;
  return status;
}

joint_trajectory_t make_trajectory(int points, bool velocities, bool accelerations) {
  joint_trajectory_t t;
  t.utime = 1'790'000'000'000'001;
  t.id = 77;
  t.num_joints = kJoints;
  t.num_points = points;
  t.num_velocities = velocities ? points : 0;
  t.num_accelerations = accelerations ? points : 0;
  for (int i = 0; i < kJoints; ++i) t.joint_names.push_back("joint_" + std::string(size_t(i + 1), 'x'));
  for (int k = 0; k < points; ++k) {
    t.time_from_start.push_back(0.5 * (k + 1));
    t.positions.push_back(values(kJoints, 0.1 * k));
    if (velocities) t.velocities.push_back(values(kJoints, -0.2 * k));
    if (accelerations) t.accelerations.push_back(values(kJoints, 0.3 * k));
  }
  t.path_tolerance = values(kJoints, 0.01);
  t.goal_tolerance = values(kJoints, 0.002);
  t.goal_time_tolerance = 0.5;
  t.time_scaling = true;
  return t;
}

// A mode with num_joints = joints and num_posture = posture; every number differs from the others
// (values the law would refuse are fine here: only the wire is under test).
control_mode_t make_mode(int joints, int posture) {
  control_mode_t mode;
  mode.utime = 1'790'000'000'777'001;
  mode.law = control_mode_t::CARTESIAN_IMPEDANCE;
  mode.num_joints = joints;
  mode.joint_stiffness = values(joints, 300.0);
  mode.joint_damping = values(joints, -4.5);
  mode.damping_ratio = 0.7;
  const std::vector<double> k = values(36, 50.0);
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) mode.cartesian_stiffness[r][c] = k[size_t(6 * r + c)];
  }
  const double position[3] = {0.01, -0.02, 0.105};
  const double quaternion[4] = {0.5, 0.5, -0.5, 0.5};  // (w, x, y, z)
  for (int i = 0; i < 3; ++i) mode.stiffness_frame_position[i] = position[i];
  for (int i = 0; i < 4; ++i) mode.stiffness_frame_quaternion[i] = quaternion[i];
  mode.num_posture = posture;
  mode.nullspace_posture = values(posture, 0.9);
  mode.nullspace_stiffness = 12.5;
  return mode;
}

payload_t make_payload() {
  payload_t payload;
  payload.utime = 1'790'000'000'888'002;
  payload.mass = 0.73;
  const double centre[3] = {0.002, -0.011, 0.087};
  for (int i = 0; i < 3; ++i) payload.centre_of_mass[i] = centre[i];
  const double inertia[3][3] = {{1.5e-3, -2e-5, 3e-6}, {-2e-5, 1.25e-3, 4e-6}, {3e-6, 4e-6, 7.5e-4}};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) payload.inertia[r][c] = inertia[r][c];
  }
  return payload;
}

void expect_same_mode(const control_mode_t& back, const control_mode_t& mode) {
  EXPECT_EQ(back.utime, mode.utime);
  EXPECT_EQ(back.law, mode.law);
  EXPECT_EQ(back.num_joints, mode.num_joints);
  EXPECT_EQ(back.joint_stiffness, mode.joint_stiffness);
  EXPECT_EQ(back.joint_damping, mode.joint_damping);
  EXPECT_EQ(back.damping_ratio, mode.damping_ratio);
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) EXPECT_EQ(back.cartesian_stiffness[r][c], mode.cartesian_stiffness[r][c]) << r << c;
  }
  for (int i = 0; i < 3; ++i) EXPECT_EQ(back.stiffness_frame_position[i], mode.stiffness_frame_position[i]);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(back.stiffness_frame_quaternion[i], mode.stiffness_frame_quaternion[i]);
  EXPECT_EQ(back.num_posture, mode.num_posture);
  EXPECT_EQ(back.nullspace_posture, mode.nullspace_posture);
  EXPECT_EQ(back.nullspace_stiffness, mode.nullspace_stiffness);
}

void expect_same_payload(const payload_t& back, const payload_t& payload) {
  EXPECT_EQ(back.utime, payload.utime);
  EXPECT_EQ(back.mass, payload.mass);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(back.centre_of_mass[i], payload.centre_of_mass[i]);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) EXPECT_EQ(back.inertia[r][c], payload.inertia[r][c]) << r << c;
  }
}

TEST(lcmtypes, RobotStateRoundTrips) {
  for (const int n : {0, 1, kJoints}) {
    const robot_state_t state = make_state(n);
    const std::vector<uint8_t> buffer = encode(state);
    // fingerprint, utime, seq, num_joints, then three arrays of n doubles
    EXPECT_EQ(buffer.size(), static_cast<size_t>(kHash + 8 + 8 + 4 + 3 * 8 * n));
    const auto back = decode<robot_state_t>(buffer);
    EXPECT_EQ(back.utime, state.utime);
    EXPECT_EQ(back.seq, state.seq);
    EXPECT_EQ(back.num_joints, n);
    EXPECT_EQ(back.position, state.position);
    EXPECT_EQ(back.velocity, state.velocity);
    EXPECT_EQ(back.effort, state.effort);
    expect_damage_refused<robot_state_t>(buffer);
  }
}

TEST(lcmtypes, JointTorqueCommandRoundTrips) {
  const joint_torque_command_t command = make_command();
  const std::vector<uint8_t> buffer = encode(command);
  EXPECT_EQ(buffer.size(), static_cast<size_t>(kHash + 8 + 8 + 8 + 4 + 8 * kJoints));
  const auto back = decode<joint_torque_command_t>(buffer);
  EXPECT_EQ(back.utime, command.utime);
  EXPECT_EQ(back.seq, command.seq);
  EXPECT_EQ(back.state_seq, -1);
  EXPECT_EQ(back.num_joints, kJoints);
  EXPECT_EQ(back.torque, command.torque);
  expect_damage_refused<joint_torque_command_t>(buffer);
}

TEST(lcmtypes, ArmTargetRoundTrips) {
  EXPECT_EQ(arm_target_t::HOLD, 0);
  EXPECT_EQ(arm_target_t::JOINT, 1);
  EXPECT_EQ(arm_target_t::CARTESIAN, 2);
  const arm_target_t target = make_target();
  const std::vector<uint8_t> buffer = encode(target);
  // fingerprint, utime, mode, num_joints, joint_position[n], tip_position[3], tip_quaternion[4],
  // duration
  EXPECT_EQ(buffer.size(), static_cast<size_t>(kHash + 8 + 1 + 4 + 8 * kJoints + 8 * 3 + 8 * 4 + 8));
  const auto back = decode<arm_target_t>(buffer);
  EXPECT_EQ(back.utime, target.utime);
  EXPECT_EQ(back.mode, arm_target_t::CARTESIAN);
  EXPECT_EQ(back.num_joints, kJoints);
  EXPECT_EQ(back.joint_position, target.joint_position);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(back.tip_position[i], target.tip_position[i]);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(back.tip_quaternion[i], target.tip_quaternion[i]);
  EXPECT_EQ(back.duration, target.duration);
  expect_damage_refused<arm_target_t>(buffer);
}

TEST(lcmtypes, ControllerStatusRoundTrips) {
  EXPECT_EQ(controller_status_t::WAITING, 0);
  EXPECT_EQ(controller_status_t::RUNNING, 1);
  EXPECT_EQ(controller_status_t::HOLDING, 2);
  EXPECT_EQ(controller_status_t::FAULT, 3);
  EXPECT_EQ(controller_status_t::REFLEX, 4);
  const controller_status_t status = make_status();
  const std::vector<uint8_t> buffer = encode(status);
  const size_t string_size = 4 + status.message.size() + 1;  // length (with the NUL), bytes, NUL
  // fingerprint, utime, state, message, num_joints, q, q_desired, tracking_error, tip position
  // and quaternion, torque, ik (int32, double, boolean), nine timing doubles, five counters,
  // tau_ext, the tip wrench, contact and collision, two counters, the law (int8), the payload's
  // mass and the state period (doubles), the trajectory's id, outcome, three doubles, waypoint
  // and message, the stream's and the jog's fields, the generator's three limits per joint, the
  // clearance's two strings, two doubles and the two witness points
  const size_t trajectory_string = 4 + status.trajectory_message.size() + 1;
  const size_t clearance_strings = 4 + status.clearance_pair.size() + 1 + 4 + status.clearance_slowed_by.size() + 1;
  EXPECT_EQ(buffer.size(), kHash + 8 + 1 + string_size + 4 + 3 * 8 * kJoints + 8 * 3 + 8 * 4 + 8 * kJoints +
                               (4 + 8 + 1) + 9 * 8 + 5 * 8 + 8 * kJoints + 6 * 8 + 2 + 2 * 8 + 1 + 8 + 8 +
                               (8 + 1 + 3 * 8 + 4) + trajectory_string + (1 + 8 + 8) + (1 + 8 + 8 + 8 + 8 + 1 + 4) +
                               3 * 8 * kJoints + clearance_strings + 2 * 8 + 6 * 8 +
                               (4 + status.contact_link.size() + 1) + 1 + 6 * 8);
  const auto back = decode<controller_status_t>(buffer);
  EXPECT_EQ(back.utime, status.utime);
  EXPECT_EQ(back.state, controller_status_t::FAULT);
  EXPECT_EQ(back.message, status.message);
  EXPECT_EQ(back.num_joints, kJoints);
  EXPECT_EQ(back.q, status.q);
  EXPECT_EQ(back.q_desired, status.q_desired);
  EXPECT_EQ(back.tracking_error, status.tracking_error);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(back.tip_position[i], status.tip_position[i]);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(back.tip_quaternion[i], status.tip_quaternion[i]);
  EXPECT_EQ(back.torque, status.torque);
  EXPECT_EQ(back.ik_iterations, 17);
  EXPECT_EQ(back.ik_residual, status.ik_residual);
  EXPECT_TRUE(back.ik_converged);
  EXPECT_EQ(back.jitter_p50_us, status.jitter_p50_us);
  EXPECT_EQ(back.jitter_p99_us, status.jitter_p99_us);
  EXPECT_EQ(back.jitter_max_us, status.jitter_max_us);
  EXPECT_EQ(back.compute_p50_us, status.compute_p50_us);
  EXPECT_EQ(back.compute_p99_us, status.compute_p99_us);
  EXPECT_EQ(back.compute_max_us, status.compute_max_us);
  EXPECT_EQ(back.latency_p50_us, status.latency_p50_us);
  EXPECT_EQ(back.latency_p99_us, status.latency_p99_us);
  EXPECT_EQ(back.latency_max_us, status.latency_max_us);
  EXPECT_EQ(back.ticks, status.ticks);
  EXPECT_EQ(back.overruns, status.overruns);
  EXPECT_EQ(back.stale_states, status.stale_states);
  EXPECT_EQ(back.rejected_messages, status.rejected_messages);
  EXPECT_EQ(back.faults, status.faults);
  EXPECT_EQ(back.tau_ext, status.tau_ext);
  EXPECT_EQ(back.generator_velocity_limit, status.generator_velocity_limit);
  EXPECT_EQ(back.generator_acceleration_limit, status.generator_acceleration_limit);
  EXPECT_EQ(back.generator_jerk_limit, status.generator_jerk_limit);
  EXPECT_EQ(back.clearance_pair, status.clearance_pair);
  EXPECT_EQ(back.clearance_distance, status.clearance_distance);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(back.clearance_points[0][k], status.clearance_points[0][k]);
    EXPECT_EQ(back.clearance_points[1][k], status.clearance_points[1][k]);
  }
  EXPECT_EQ(back.clearance_slowed_by, status.clearance_slowed_by);
  EXPECT_EQ(back.clearance_kept, status.clearance_kept);
  EXPECT_EQ(back.contact_link, status.contact_link);
  EXPECT_TRUE(back.contact_located_flag);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(back.contact_point[k], status.contact_point[k]);
    EXPECT_EQ(back.contact_force[k], status.contact_force[k]);
  }
  for (int i = 0; i < 6; ++i) EXPECT_EQ(back.tip_wrench_ext[i], status.tip_wrench_ext[i]);
  EXPECT_TRUE(back.contact);
  EXPECT_FALSE(back.collision);
  EXPECT_EQ(back.contacts, 4);
  EXPECT_EQ(back.reflexes, 1);
  EXPECT_EQ(back.law, control_mode_t::CARTESIAN_IMPEDANCE);
  EXPECT_EQ(back.payload_mass, status.payload_mass);
  EXPECT_EQ(back.state_period, status.state_period);
  EXPECT_EQ(back.trajectory_id, -42);
  EXPECT_EQ(back.trajectory_outcome, controller_status_t::TRAJECTORY_ABORTED);
  EXPECT_EQ(back.trajectory_elapsed, 1.25);
  EXPECT_EQ(back.trajectory_duration, 4.5);
  EXPECT_EQ(back.trajectory_time_scale, 1.5);
  EXPECT_EQ(back.trajectory_waypoint, 3);
  EXPECT_EQ(back.trajectory_message, status.trajectory_message);
  EXPECT_TRUE(back.streaming);
  EXPECT_EQ(back.setpoints, 1234);
  EXPECT_EQ(back.setpoints_dropped, 56);
  EXPECT_TRUE(back.jogging);
  EXPECT_EQ(back.jogs, 789);
  EXPECT_EQ(back.jogs_dropped, 12);
  EXPECT_EQ(back.jog_condition, 23.5);
  EXPECT_EQ(back.jog_scale, 0.5);
  EXPECT_EQ(back.jog_limited_by, 3);
  EXPECT_EQ(back.jog_joint, -1);
  expect_damage_refused<controller_status_t>(buffer);
  // The checked decoder finds both strings' lengths in the raw bytes, with any message length.
  for (const std::string message : {"", "x", "a longer message of the controller's"}) {
    controller_status_t other = status;
    other.message = message;
    other.trajectory_message = message + "!";
    const std::vector<uint8_t> bytes = encode(other);
    controller_status_t checked;
    ASSERT_EQ(messages::decode_checked(bytes.data(), bytes.size(), checked, kJoints), "");
    EXPECT_EQ(checked.message, message);
    EXPECT_EQ(checked.trajectory_message, message + "!");
    EXPECT_EQ(checked.state_period, status.state_period);
    EXPECT_EQ(checked.setpoints_dropped, 56);
    EXPECT_EQ(checked.jog_joint, -1);
  }
}

TEST(lcmtypes, JointSetpointRoundTripsAndIsChecked) {
  joint_setpoint_t setpoint;
  setpoint.utime = 1'790'000'000'000'777;
  setpoint.num_joints = kJoints;
  setpoint.position = values(kJoints, 0.25);
  setpoint.velocity = values(kJoints, -0.5);
  const std::vector<uint8_t> buffer = encode(setpoint);
  // fingerprint, utime, num_joints, position[n], velocity[n]
  EXPECT_EQ(buffer.size(), static_cast<size_t>(kHash + 8 + 4 + 2 * 8 * kJoints));
  joint_setpoint_t checked;
  ASSERT_EQ(messages::decode_checked(buffer.data(), buffer.size(), checked, kJoints, messages::Finite::Required), "");
  EXPECT_EQ(checked.utime, setpoint.utime);
  EXPECT_EQ(checked.position, setpoint.position);
  EXPECT_EQ(checked.velocity, setpoint.velocity);
  expect_damage_refused<joint_setpoint_t>(buffer);
  EXPECT_EQ(decode_checked<joint_setpoint_t>(with_int32(buffer, 16, 6)), "for 6 joints; the arm has 7");
  EXPECT_EQ(decode_checked<joint_setpoint_t>(with_int32(buffer, 16, 6), messages::kAnyArm),
            "of " + std::to_string(buffer.size()) + " bytes; expected " + std::to_string(buffer.size() - 16) +
                " for 6 joints");
  setpoint.velocity[2] = std::numeric_limits<double>::infinity();
  EXPECT_EQ(decode_checked<joint_setpoint_t>(encode(setpoint)), "with non-finite velocity");
}

TEST(lcmtypes, JogCommandRoundTripsAndIsChecked) {
  EXPECT_EQ(jog_command_t::JOINT_VELOCITY, 0);
  EXPECT_EQ(jog_command_t::TWIST, 1);
  EXPECT_EQ(jog_command_t::BASE, 0);
  EXPECT_EQ(jog_command_t::TOOL, 1);
  jog_command_t jog;
  jog.utime = 1'790'000'000'000'999;
  jog.kind = jog_command_t::JOINT_VELOCITY;
  jog.frame = jog_command_t::BASE;
  jog.num_joints = kJoints;
  jog.joint_velocity = values(kJoints, 0.125);
  for (int k = 0; k < 6; ++k) jog.twist[k] = 0.01 * (k + 1);
  const std::vector<uint8_t> buffer = encode(jog);
  // fingerprint, utime, kind, frame, num_joints, joint_velocity[n], twist[6]
  EXPECT_EQ(buffer.size(), static_cast<size_t>(kHash + 8 + 1 + 1 + 4 + 8 * kJoints + 6 * 8));
  jog_command_t checked;
  ASSERT_EQ(messages::decode_checked(buffer.data(), buffer.size(), checked, kJoints, messages::Finite::Required), "");
  EXPECT_EQ(checked.utime, jog.utime);
  EXPECT_EQ(checked.joint_velocity, jog.joint_velocity);
  for (int k = 0; k < 6; ++k) EXPECT_EQ(checked.twist[k], jog.twist[k]);
  expect_damage_refused<jog_command_t>(buffer);
  EXPECT_EQ(decode_checked<jog_command_t>(with_int32(buffer, 18, 6)), "for 6 joints; the arm has 7");
  // A twist may leave the joints out.
  jog.kind = jog_command_t::TWIST;
  jog.num_joints = 0;
  jog.joint_velocity.clear();
  EXPECT_EQ(decode_checked<jog_command_t>(encode(jog)), "");
  jog.twist[4] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(decode_checked<jog_command_t>(encode(jog)), "with non-finite twist");
}

TEST(lcmtypes, TipSetpointRoundTripsAndIsChecked) {
  tip_setpoint_t setpoint;
  setpoint.utime = 1'790'000'000'000'555;
  for (int k = 0; k < 3; ++k) setpoint.position[k] = 0.1 * (k + 1);
  for (int k = 0; k < 4; ++k) setpoint.quaternion[k] = k == 0 ? 1.0 : 0.0;
  for (int k = 0; k < 6; ++k) setpoint.twist[k] = -0.01 * (k + 1);
  const std::vector<uint8_t> buffer = encode(setpoint);
  // fingerprint, utime, position[3], quaternion[4], twist[6]: no count, one size
  EXPECT_EQ(buffer.size(), static_cast<size_t>(kHash + 8 + 13 * 8));
  tip_setpoint_t checked;
  ASSERT_EQ(messages::decode_checked(buffer.data(), buffer.size(), checked, kJoints, messages::Finite::Required), "");
  EXPECT_EQ(checked.utime, setpoint.utime);
  for (int k = 0; k < 6; ++k) EXPECT_EQ(checked.twist[k], setpoint.twist[k]);
  expect_damage_refused<tip_setpoint_t>(buffer);
  std::vector<uint8_t> longer = buffer;
  longer.push_back(0);
  EXPECT_EQ(decode_checked<tip_setpoint_t>(longer), "of 121 bytes; expected 120");
  setpoint.quaternion[1] = std::numeric_limits<double>::infinity();
  EXPECT_EQ(decode_checked<tip_setpoint_t>(encode(setpoint)), "with non-finite quaternion");
}

TEST(lcmtypes, JointTrajectoryRoundTripsAndItsCheckedDecoderReadsEveryCount) {
  for (const auto& [points, velocities, accelerations] :
       {std::tuple{1, false, false}, std::tuple{3, true, false}, std::tuple{4, true, true}}) {
    SCOPED_TRACE(std::to_string(points) + " points");
    const joint_trajectory_t t = make_trajectory(points, velocities, accelerations);
    const std::vector<uint8_t> buffer = encode(t);
    size_t names = 0;
    for (const std::string& name : t.joint_names) names += 4 + name.size() + 1;
    // fingerprint, utime, id, four counts, the names, times, the rows, two tolerances, goal time,
    // time_scaling
    const size_t rows = size_t(points) * (1 + size_t(velocities) + size_t(accelerations));
    EXPECT_EQ(buffer.size(), kHash + 8 + 8 + 4 * 4 + names + 8 * size_t(points) + 8 * kJoints * rows +
                                 2 * 8 * kJoints + 8 + 1);
    joint_trajectory_t checked;
    ASSERT_EQ(messages::decode_checked(buffer.data(), buffer.size(), checked, kJoints, messages::Finite::Required), "");
    EXPECT_EQ(checked.id, 77);
    EXPECT_EQ(checked.joint_names, t.joint_names);
    EXPECT_EQ(checked.time_from_start, t.time_from_start);
    EXPECT_EQ(checked.positions, t.positions);
    EXPECT_EQ(checked.velocities, t.velocities);
    EXPECT_EQ(checked.accelerations, t.accelerations);
    EXPECT_EQ(checked.path_tolerance, t.path_tolerance);
    EXPECT_EQ(checked.goal_tolerance, t.goal_tolerance);
    EXPECT_EQ(checked.goal_time_tolerance, 0.5);
    EXPECT_TRUE(checked.time_scaling);
    expect_damage_refused<joint_trajectory_t>(buffer);
  }
  const std::vector<uint8_t> bytes = encode(make_trajectory(2, false, false));
  // The counts sit after the fingerprint, utime and id; the first name's length after them.
  EXPECT_EQ(decode_checked<joint_trajectory_t>(with_int32(bytes, 24, uint32_t(-1))),
            "num_joints -1 in a message of " + std::to_string(bytes.size()) + " bytes");
  EXPECT_EQ(decode_checked<joint_trajectory_t>(with_int32(bytes, 28, 1'000'000)),
            "num_points 1000000 for " + std::to_string(kJoints) + " joints in a message of " +
                std::to_string(bytes.size()) + " bytes");
  EXPECT_EQ(decode_checked<joint_trajectory_t>(with_int32(bytes, 40, 100'000)),
            "a joint name of 100000 bytes in a message of " + std::to_string(bytes.size()) + " bytes");
  EXPECT_EQ(decode_checked<joint_trajectory_t>(bytes, kJoints + 1), "for " + std::to_string(kJoints) +
                                                                        " joints; the arm has " +
                                                                        std::to_string(kJoints + 1));
  joint_trajectory_t nan = make_trajectory(2, false, false);
  nan.positions[1][0] = std::nan("");
  EXPECT_EQ(decode_checked<joint_trajectory_t>(encode(nan)), "with non-finite positions");
}

TEST(lcmtypes, ControlModeRoundTrips) {
  EXPECT_EQ(control_mode_t::COMPUTED_TORQUE, 0);
  EXPECT_EQ(control_mode_t::JOINT_IMPEDANCE, 1);
  EXPECT_EQ(control_mode_t::CARTESIAN_IMPEDANCE, 2);
  EXPECT_EQ(control_mode_t::FREE_DRIVE, 3);
  for (const auto& [joints, posture] :
       {std::pair{0, 0}, std::pair{kJoints, 0}, std::pair{0, kJoints}, std::pair{kJoints, kJoints}}) {
    SCOPED_TRACE("num_joints " + std::to_string(joints) + ", num_posture " + std::to_string(posture));
    const control_mode_t mode = make_mode(joints, posture);
    const std::vector<uint8_t> buffer = encode(mode);
    // fingerprint, utime, law, num_joints, joint_stiffness and joint_damping[num_joints],
    // damping_ratio, cartesian_stiffness[6][6], the stiffness frame's position[3] and
    // quaternion[4], num_posture, nullspace_posture[num_posture], nullspace_stiffness
    EXPECT_EQ(buffer.size(), static_cast<size_t>(kHash + 8 + 1 + 4 + 2 * 8 * joints + 8 + 8 * 36 + 8 * 3 + 8 * 4 +
                                                 4 + 8 * posture + 8));
    expect_same_mode(decode<control_mode_t>(buffer), mode);
    control_mode_t checked;
    ASSERT_EQ(messages::decode_checked(buffer.data(), buffer.size(), checked, kJoints, messages::Finite::Required), "");
    expect_same_mode(checked, mode);
    expect_damage_refused<control_mode_t>(buffer);
  }
}

TEST(lcmtypes, PayloadRoundTrips) {
  const payload_t payload = make_payload();
  const std::vector<uint8_t> buffer = encode(payload);
  // fingerprint, utime, mass, centre_of_mass[3], inertia[3][3]: no count, one size
  EXPECT_EQ(buffer.size(), static_cast<size_t>(kHash + 8 + 8 + 8 * 3 + 8 * 9));
  EXPECT_EQ(buffer.size(), 120u);
  expect_same_payload(decode<payload_t>(buffer), payload);
  payload_t checked;
  ASSERT_EQ(messages::decode_checked(buffer.data(), buffer.size(), checked, kJoints, messages::Finite::Required), "");
  expect_same_payload(checked, payload);
  expect_damage_refused<payload_t>(buffer);
}

// control_mode_t's checked decoder, which the controller's mode receiver uses:
// each of its two counts must be 0 or the arm's, a count is read from the bytes and judged before
// anything is sized for it, the size must then be exact, and with Finite::Required every number
// must be finite. Each refusal says which.
TEST(lcmtypes, ControlModeCheckedDecoderRefusesWhatIsNotAMode) {
  const std::vector<uint8_t> bytes = encode(make_mode(kJoints, kJoints));
  ASSERT_EQ(bytes.size(), 553u);  // 385 with no joint arrays, + 16 per joint, + 8 per posture entry
  EXPECT_EQ(decode_checked<control_mode_t>(bytes), "");
  EXPECT_EQ(decode_checked<control_mode_t>(bytes, messages::kAnyArm), "");

  // Another type, or too few bytes for a fingerprint.
  EXPECT_EQ(decode_checked<control_mode_t>(encode(make_payload())), "not a control_mode_t (wrong fingerprint)");
  EXPECT_EQ(decode_checked<control_mode_t>(std::vector<uint8_t>(bytes.begin(), bytes.begin() + 7)),
            "not a control_mode_t (wrong fingerprint)");
  // Truncated before num_joints (at byte 17, after the fingerprint, utime and law), and before
  // num_posture (at byte 17 + 4 + 16 × 7 + 8 × (1 + 36 + 3 + 4) = 485).
  EXPECT_EQ(decode_checked<control_mode_t>(std::vector<uint8_t>(bytes.begin(), bytes.begin() + 20)),
            "truncated: 20 bytes");
  EXPECT_EQ(decode_checked<control_mode_t>(std::vector<uint8_t>(bytes.begin(), bytes.begin() + 488)),
            "truncated: 488 bytes");

  // Counts that are neither 0 nor the arm's, in either field; 0 and 7 in any combination are taken.
  EXPECT_EQ(decode_checked<control_mode_t>(encode(make_mode(6, 0))),
            "for 6 joints and a posture of 0; the arm has 7 (give 0 or 7 in each)");
  EXPECT_EQ(decode_checked<control_mode_t>(encode(make_mode(kJoints, 6))),
            "for 7 joints and a posture of 6; the arm has 7 (give 0 or 7 in each)");
  EXPECT_EQ(decode_checked<control_mode_t>(encode(make_mode(8, 8))),
            "for 8 joints and a posture of 8; the arm has 7 (give 0 or 7 in each)");
  EXPECT_EQ(decode_checked<control_mode_t>(encode(make_mode(kJoints, kJoints)), 6),
            "for 7 joints and a posture of 7; the arm has 6 (give 0 or 6 in each)");
  EXPECT_EQ(decode_checked<control_mode_t>(encode(make_mode(6, 6)), messages::kAnyArm), "") << "any arm: any count";
  for (const auto& [joints, posture] : {std::pair{0, 0}, std::pair{kJoints, 0}, std::pair{0, kJoints}}) {
    EXPECT_EQ(decode_checked<control_mode_t>(encode(make_mode(joints, posture))), "") << joints << " " << posture;
  }

  // Impossible counts (negative, or more doubles than there are bytes), refused before anything
  // is sized for them.
  EXPECT_EQ(decode_checked<control_mode_t>(with_int32(bytes, 17, 0xffffffffu)),
            "num_joints -1 in a message of 553 bytes");
  EXPECT_EQ(decode_checked<control_mode_t>(with_int32(bytes, 17, 0x7fffffffu), messages::kAnyArm),
            "num_joints 2147483647 in a message of 553 bytes");
  EXPECT_EQ(decode_checked<control_mode_t>(with_int32(bytes, 485, 0x80000000u)),
            "num_posture -2147483648 in a message of 553 bytes");
  EXPECT_EQ(decode_checked<control_mode_t>(with_int32(bytes, 485, 0x7f000007u), messages::kAnyArm),
            "num_posture 2130706439 in a message of 553 bytes");
  // A possible count that puts num_posture past the end: 30 joints (240 bytes of the 553 as the
  // first check sees it) move it to 17 + 4 + 16 × 30 + 352 = 853.
  EXPECT_EQ(decode_checked<control_mode_t>(with_int32(bytes, 17, 30), messages::kAnyArm), "truncated: 553 bytes");

  // Sizes that do not match the counts: a byte too few or too many, and counts that lie.
  EXPECT_EQ(decode_checked<control_mode_t>(std::vector<uint8_t>(bytes.begin(), bytes.end() - 1)),
            "of 552 bytes; expected 553 for 7 joints");
  std::vector<uint8_t> longer = bytes;
  longer.push_back(0);
  EXPECT_EQ(decode_checked<control_mode_t>(longer), "of 554 bytes; expected 553 for 7 joints");
  EXPECT_EQ(decode_checked<control_mode_t>(with_int32(bytes, 485, 0)), "of 553 bytes; expected 497 for 7 joints");
  const std::vector<uint8_t> no_joints = encode(make_mode(0, 0));
  ASSERT_EQ(no_joints.size(), 385u);
  EXPECT_EQ(decode_checked<control_mode_t>(with_int32(no_joints, 17, kJoints)), "truncated: 385 bytes")
      << "7 joints put num_posture at byte 485";

  // A non-finite number in each field, first field first; Finite::NotRequired takes them.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const auto refused = [&](void (*damage)(control_mode_t&, double), double bad, const std::string& field) {
    control_mode_t mode = make_mode(kJoints, kJoints);
    damage(mode, bad);
    const std::vector<uint8_t> damaged = encode(mode);
    EXPECT_EQ(decode_checked<control_mode_t>(damaged), "with non-finite " + field);
    EXPECT_EQ(decode_checked<control_mode_t>(damaged, kJoints, messages::Finite::NotRequired), "") << field;
  };
  refused([](control_mode_t& m, double x) { m.joint_stiffness[6] = x; }, nan, "joint_stiffness");
  refused([](control_mode_t& m, double x) { m.joint_damping[0] = x; }, -inf, "joint_damping");
  refused([](control_mode_t& m, double x) { m.damping_ratio = x; }, inf, "damping_ratio");
  refused([](control_mode_t& m, double x) { m.cartesian_stiffness[5][5] = x; }, nan, "cartesian_stiffness");
  refused([](control_mode_t& m, double x) { m.stiffness_frame_position[2] = x; }, inf, "stiffness_frame_position");
  refused([](control_mode_t& m, double x) { m.stiffness_frame_quaternion[0] = x; }, nan, "stiffness_frame_quaternion");
  refused([](control_mode_t& m, double x) { m.nullspace_posture[3] = x; }, -inf, "nullspace_posture");
  refused([](control_mode_t& m, double x) { m.nullspace_stiffness = x; }, nan, "nullspace_stiffness");
  refused(
      [](control_mode_t& m, double x) {
        m.nullspace_stiffness = x;
        m.joint_damping[2] = x;
      },
      nan, "joint_damping");
}

// payload_t's checked decoder: no count, so one exact size; the arm does not matter; with
// Finite::Required every number must be finite.
TEST(lcmtypes, PayloadCheckedDecoderRefusesWhatIsNotAPayload) {
  const std::vector<uint8_t> bytes = encode(make_payload());
  ASSERT_EQ(bytes.size(), 120u);
  EXPECT_EQ(decode_checked<payload_t>(bytes), "");
  for (const int arm : {messages::kAnyArm, 0, 1, 6}) EXPECT_EQ(decode_checked<payload_t>(bytes, arm), "") << arm;

  EXPECT_EQ(decode_checked<payload_t>(encode(make_mode(0, 0))), "not a payload_t (wrong fingerprint)");
  EXPECT_EQ(decode_checked<payload_t>(std::vector<uint8_t>(bytes.begin(), bytes.begin() + 7)),
            "not a payload_t (wrong fingerprint)");
  // Truncated or too long: there is no count to read, only the one size.
  EXPECT_EQ(decode_checked<payload_t>(std::vector<uint8_t>(bytes.begin(), bytes.begin() + 8)),
            "of 8 bytes; expected 120");
  EXPECT_EQ(decode_checked<payload_t>(std::vector<uint8_t>(bytes.begin(), bytes.end() - 1)),
            "of 119 bytes; expected 120");
  std::vector<uint8_t> longer = bytes;
  longer.push_back(0);
  EXPECT_EQ(decode_checked<payload_t>(longer), "of 121 bytes; expected 120");

  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const auto refused = [&](void (*damage)(payload_t&, double), double bad, const std::string& field) {
    payload_t payload = make_payload();
    damage(payload, bad);
    const std::vector<uint8_t> damaged = encode(payload);
    EXPECT_EQ(decode_checked<payload_t>(damaged), "with non-finite " + field);
    EXPECT_EQ(decode_checked<payload_t>(damaged, kJoints, messages::Finite::NotRequired), "") << field;
  };
  refused([](payload_t& p, double x) { p.mass = x; }, nan, "mass");
  refused([](payload_t& p, double x) { p.centre_of_mass[1] = x; }, -inf, "centre_of_mass");
  refused([](payload_t& p, double x) { p.inertia[2][1] = x; }, inf, "inertia");
  refused(
      [](payload_t& p, double x) {
        p.inertia[0][0] = x;
        p.mass = x;
      },
      nan, "mass");
}

// A message of one type is never read as another: each type has its own fingerprint, and it is
// checked before any field is read.
TEST(lcmtypes, TypesAreNotInterchangeable) {
  const std::set<int64_t> hashes = {robot_state_t::getHash(),  joint_torque_command_t::getHash(),
                                    arm_target_t::getHash(),   controller_status_t::getHash(),
                                    control_mode_t::getHash(), payload_t::getHash(),
                                    joint_trajectory_t::getHash(), joint_setpoint_t::getHash(),
                                    jog_command_t::getHash(), tip_setpoint_t::getHash()};
  EXPECT_EQ(hashes.size(), 10u);

  const std::vector<uint8_t> state = encode(make_state(kJoints));
  joint_torque_command_t command;
  EXPECT_LT(command.decode(state.data(), 0, static_cast<int>(state.size())), 0);
  const std::vector<uint8_t> target = encode(make_target());
  robot_state_t not_a_state;
  EXPECT_LT(not_a_state.decode(target.data(), 0, static_cast<int>(target.size())), 0);
}

// The fingerprints pin the contracts: a change to a field's name, type or order changes them
// and fails here. Changing a meaning needs a new type name, so that no reader takes the new
// meaning for the old, not a new number in this test.
TEST(lcmtypes, FingerprintsArePinned) {
  EXPECT_EQ(static_cast<uint64_t>(robot_state_t::getHash()), 0xc003a166c618d7eeu);
  EXPECT_EQ(static_cast<uint64_t>(joint_torque_command_t::getHash()), 0xd037d1c904e0e80fu);
  EXPECT_EQ(static_cast<uint64_t>(arm_target_t::getHash()), 0x309277be8aae6666u);
  // controller_status_t gained the contact fields at its end ([K]), then the law and the payload's
  // mass, then the state period ([M]), then the trajectory's progress, the stream's and the jog's ([N]), then the
  // clearance ([T]), then the located contact ([U]) at its end; no field changed meaning, and a
  // reader built on an older contract refuses the new one by its fingerprint.
  EXPECT_EQ(static_cast<uint64_t>(controller_status_t::getHash()), 0xb133d685a5d937abu);
  // sim_truth_t gained every contact at its end ([U]); contact_estimate_t is [U]'s.
  EXPECT_EQ(static_cast<uint64_t>(sim_truth_t::getHash()), 0xed86a42eaf5c1d82u);
  EXPECT_EQ(static_cast<uint64_t>(contact_estimate_t::getHash()), 0xe51ead88b77a4293u);
  EXPECT_EQ(static_cast<uint64_t>(control_mode_t::getHash()), 0xe4a15f556715af84u);
  EXPECT_EQ(static_cast<uint64_t>(payload_t::getHash()), 0x38b055cd3dfdfa1fu);
  EXPECT_EQ(static_cast<uint64_t>(joint_trajectory_t::getHash()), 0xd964c2fb834f2258u);
  EXPECT_EQ(static_cast<uint64_t>(joint_setpoint_t::getHash()), 0x5c7e81c8a461c11au);
  EXPECT_EQ(static_cast<uint64_t>(jog_command_t::getHash()), 0xbcbed304703b833cu);
  EXPECT_EQ(static_cast<uint64_t>(tip_setpoint_t::getHash()), 0x75e241a73d4f516du);
}

}  // namespace
}  // namespace chasles::testing
