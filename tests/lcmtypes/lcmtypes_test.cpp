// The LCM message contracts on the wire: every field survives an encode/decode round trip
// bit for bit, the encoded size is the contract's, and a damaged buffer (truncated, or of another
// type) is refused rather than half-read.
#include <gtest/gtest.h>

#include <chasles/arm_target_t.hpp>
#include <chasles/controller_status_t.hpp>
#include <chasles/joint_torque_command_t.hpp>
#include <chasles/robot_state_t.hpp>
#include <cstdint>
#include <limits>
#include <set>
#include <vector>

namespace chasles::testing {
namespace {

constexpr int kJoints = 7;
constexpr int kHash = 8;  // every message starts with its type's 64-bit fingerprint

// n values that differ from each other and from 0, with a sign change and awkward magnitudes.
std::vector<double> values(int n, double scale) {
  std::vector<double> v;
  for (int i = 0; i < n; ++i) v.push_back(scale * (i % 2 == 0 ? 1.0 : -1.0) * (0.1 + i) / 3.0);
  return v;
}

template <class Message>
std::vector<uint8_t> encode(const Message& message) {
  std::vector<uint8_t> buffer(static_cast<size_t>(message.getEncodedSize()));
  EXPECT_EQ(message.encode(buffer.data(), 0, static_cast<int>(buffer.size())), static_cast<int>(buffer.size()));
  return buffer;
}

template <class Message>
Message decode(const std::vector<uint8_t>& buffer) {
  Message message;
  EXPECT_EQ(message.decode(buffer.data(), 0, static_cast<int>(buffer.size())), static_cast<int>(buffer.size()));
  return message;
}

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
  for (int i = 0; i < 6; ++i) status.tip_wrench_ext[i] = 0.25 * (i - 2);
  status.contact = true;
  status.collision = false;
  status.contacts = 4;
  status.reflexes = 1;
  return status;
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
  // tau_ext, the tip wrench, contact and collision, two counters
  EXPECT_EQ(buffer.size(), kHash + 8 + 1 + string_size + 4 + 3 * 8 * kJoints + 8 * 3 + 8 * 4 + 8 * kJoints +
                               (4 + 8 + 1) + 9 * 8 + 5 * 8 + 8 * kJoints + 6 * 8 + 2 + 2 * 8);
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
  for (int i = 0; i < 6; ++i) EXPECT_EQ(back.tip_wrench_ext[i], status.tip_wrench_ext[i]);
  EXPECT_TRUE(back.contact);
  EXPECT_FALSE(back.collision);
  EXPECT_EQ(back.contacts, 4);
  EXPECT_EQ(back.reflexes, 1);
  expect_damage_refused<controller_status_t>(buffer);
}

// A message of one type is never read as another: each type has its own fingerprint, and it is
// checked before any field is read.
TEST(lcmtypes, TypesAreNotInterchangeable) {
  const std::set<int64_t> hashes = {robot_state_t::getHash(), joint_torque_command_t::getHash(),
                                    arm_target_t::getHash(), controller_status_t::getHash()};
  EXPECT_EQ(hashes.size(), 4u);

  const std::vector<uint8_t> state = encode(make_state(kJoints));
  joint_torque_command_t command;
  EXPECT_LT(command.decode(state.data(), 0, static_cast<int>(state.size())), 0);
  const std::vector<uint8_t> target = encode(make_target());
  robot_state_t not_a_state;
  EXPECT_LT(not_a_state.decode(target.data(), 0, static_cast<int>(target.size())), 0);
}

// The fingerprints pin the contracts: a change to a field's name, type or order changes them
// and fails here. Changing a meaning needs a new type name (DESIGN.md, Messages), not a new
// number in this test.
TEST(lcmtypes, FingerprintsArePinned) {
  EXPECT_EQ(static_cast<uint64_t>(robot_state_t::getHash()), 0xc003a166c618d7eeu);
  EXPECT_EQ(static_cast<uint64_t>(joint_torque_command_t::getHash()), 0xd037d1c904e0e80fu);
  EXPECT_EQ(static_cast<uint64_t>(arm_target_t::getHash()), 0x309277be8aae6666u);
  // controller_status_t gained the contact fields at its end ([K]); no field changed meaning, and a
  // reader built on the old contract refuses the new one by its fingerprint.
  EXPECT_EQ(static_cast<uint64_t>(controller_status_t::getHash()), 0x12dcd8ff618718ceu);
}

}  // namespace
}  // namespace chasles::testing
