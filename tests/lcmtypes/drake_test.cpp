// Drake's iiwa and Panda messages (lcmtypes/drake_*.lcm) on the wire. Their fingerprints are pinned
// to the values Drake's own generated classes give (../shared/drake-lcm.md, checked against Drake
// 1.58): the .lcm files here are written from Drake's definitions, and a field of the wrong name,
// type or order would change the fingerprint and make a real driver's messages unreadable. Then
// every field survives a round trip, and the encoded size is the layout's.
#include <gtest/gtest.h>

#include <cstdint>
#include <drake/lcmt_iiwa_command.hpp>
#include <drake/lcmt_iiwa_status.hpp>
#include <drake/lcmt_panda_command.hpp>
#include <drake/lcmt_panda_status.hpp>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace chasles::testing {
namespace {

constexpr int kJoints = 7;
constexpr size_t kHash = 8;  // every message starts with its type's 64-bit fingerprint

// n values that differ from each other and from 0, with a sign change; `scale` tells fields apart.
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

// The first 8 bytes on the wire, big-endian, as a number.
uint64_t wire_fingerprint(const std::vector<uint8_t>& bytes) {
  uint64_t value = 0;
  for (size_t i = 0; i < 8; ++i) value = (value << 8) | bytes[i];
  return value;
}

drake::lcmt_iiwa_status make_iiwa_status() {
  drake::lcmt_iiwa_status m;
  m.utime = 1'790'000'000'005'000;
  m.num_joints = kJoints;
  m.joint_position_measured = values(kJoints, 1.0);
  m.joint_velocity_estimated = values(kJoints, 2.0);
  m.joint_position_commanded = values(kJoints, 3.0);
  m.joint_position_ipo = values(kJoints, 4.0);
  m.joint_torque_measured = values(kJoints, 50.0);
  m.joint_torque_commanded = values(kJoints, 60.0);
  m.joint_torque_external = values(kJoints, 7.0);
  return m;
}

drake::lcmt_iiwa_command make_iiwa_command(int positions, int torques) {
  drake::lcmt_iiwa_command m;
  m.utime = 1'790'000'000'010'000;
  m.num_joints = positions;
  m.joint_position = values(positions, 0.5);
  m.num_torques = torques;
  m.joint_torque = values(torques, 20.0);
  return m;
}

drake::lcmt_panda_status make_panda_status() {
  drake::lcmt_panda_status m;
  m.utime = 1'790'000'000'001'000;
  m.num_joints = kJoints;
  m.joint_position = values(kJoints, 1.0);
  m.joint_position_desired = values(kJoints, 1.5);
  m.joint_velocity = values(kJoints, 2.0);
  m.joint_velocity_desired = values(kJoints, 2.5);
  m.joint_acceleration_desired = values(kJoints, 3.0);
  m.joint_torque = values(kJoints, 40.0);
  m.joint_torque_desired = values(kJoints, 45.0);
  m.joint_torque_external = values(kJoints, 5.0);
  m.control_command_success_rate = 0.97;
  m.robot_mode = drake::lcmt_panda_status::kMove;
  m.robot_utime = 123'456'000;
  m.control_mode = drake::lcmt_panda_status::CONTROL_MODE_TORQUE;
  return m;
}

drake::lcmt_panda_command make_panda_command(int positions, int velocities, int torques) {
  drake::lcmt_panda_command m;
  m.utime = 1'790'000'000'002'000;
  m.num_joint_position = positions;
  m.joint_position = values(positions, 0.25);
  m.num_joint_velocity = velocities;
  m.joint_velocity = values(velocities, -0.75);
  m.num_joint_torque = torques;
  m.joint_torque = values(torques, 12.0);
  m.control_mode_expected = drake::lcmt_panda_status::CONTROL_MODE_TORQUE;
  return m;
}

// Drake's fingerprints, from Drake's generated classes, not from these files: an independent check
// that name, type and order of every field are Drake's. On the wire they are the first 8 bytes.
TEST(DrakeLcmtypes, FingerprintsAreDrakes) {
  EXPECT_EQ(static_cast<uint64_t>(drake::lcmt_iiwa_status::getHash()), 0xf16fb804284abca3u);
  EXPECT_EQ(static_cast<uint64_t>(drake::lcmt_iiwa_command::getHash()), 0xddc7c7738c815334u);
  EXPECT_EQ(static_cast<uint64_t>(drake::lcmt_panda_status::getHash()), 0x19571cdf4d82fae6u);
  EXPECT_EQ(static_cast<uint64_t>(drake::lcmt_panda_command::getHash()), 0xe68df777004d59d0u);
  EXPECT_EQ(wire_fingerprint(encode(make_iiwa_status())), 0xf16fb804284abca3u);
  EXPECT_EQ(wire_fingerprint(encode(make_iiwa_command(kJoints, kJoints))), 0xddc7c7738c815334u);
  EXPECT_EQ(wire_fingerprint(encode(make_panda_status())), 0x19571cdf4d82fae6u);
  EXPECT_EQ(wire_fingerprint(encode(make_panda_command(0, 0, kJoints))), 0xe68df777004d59d0u);
  EXPECT_EQ(std::string(drake::lcmt_iiwa_status::getTypeName()), "lcmt_iiwa_status");
  EXPECT_EQ(std::string(drake::lcmt_panda_command::getTypeName()), "lcmt_panda_command");
}

// The constants libfranka's modes and the control-mode bits map to, as Drake gives them.
TEST(DrakeLcmtypes, PandaConstantsAreDrakes) {
  using S = drake::lcmt_panda_status;
  EXPECT_EQ(S::kOther, 0);
  EXPECT_EQ(S::kIdle, 1);
  EXPECT_EQ(S::kMove, 2);
  EXPECT_EQ(S::kGuiding, 3);
  EXPECT_EQ(S::kReflex, 4);
  EXPECT_EQ(S::kUserStopped, 5);
  EXPECT_EQ(S::kAutomaticErrorRecovery, 6);
  EXPECT_EQ(S::CONTROL_MODE_POSITION, 1);
  EXPECT_EQ(S::CONTROL_MODE_VELOCITY, 2);
  EXPECT_EQ(S::CONTROL_MODE_TORQUE, 4);
}

TEST(DrakeLcmtypes, IiwaStatusRoundTrips) {
  const drake::lcmt_iiwa_status m = make_iiwa_status();
  const std::vector<uint8_t> bytes = encode(m);
  // fingerprint, utime, num_joints, seven arrays of n doubles
  EXPECT_EQ(bytes.size(), kHash + 8 + 4 + 7 * 8 * kJoints);
  const auto back = decode<drake::lcmt_iiwa_status>(bytes);
  EXPECT_EQ(back.utime, m.utime);
  EXPECT_EQ(back.num_joints, kJoints);
  EXPECT_EQ(back.joint_position_measured, m.joint_position_measured);
  EXPECT_EQ(back.joint_velocity_estimated, m.joint_velocity_estimated);
  EXPECT_EQ(back.joint_position_commanded, m.joint_position_commanded);
  EXPECT_EQ(back.joint_position_ipo, m.joint_position_ipo);
  EXPECT_EQ(back.joint_torque_measured, m.joint_torque_measured);
  EXPECT_EQ(back.joint_torque_commanded, m.joint_torque_commanded);
  EXPECT_EQ(back.joint_torque_external, m.joint_torque_external);
  // The order on the wire is Drake's: the first measured position right after num_joints, the
  // first external torque 6 arrays later.
  EXPECT_EQ(bytes[kHash + 8 + 3], kJoints);
}

TEST(DrakeLcmtypes, IiwaCommandRoundTrips) {
  for (const auto& [positions, torques] : {std::pair{kJoints, kJoints}, std::pair{0, kJoints}, std::pair{kJoints, 0}}) {
    SCOPED_TRACE(std::to_string(positions) + " positions, " + std::to_string(torques) + " torques");
    const drake::lcmt_iiwa_command m = make_iiwa_command(positions, torques);
    const std::vector<uint8_t> bytes = encode(m);
    // fingerprint, utime, num_joints, joint_position[num_joints], num_torques, joint_torque[num_torques]
    EXPECT_EQ(bytes.size(), kHash + 8 + 4 + 8 * size_t(positions) + 4 + 8 * size_t(torques));
    const auto back = decode<drake::lcmt_iiwa_command>(bytes);
    EXPECT_EQ(back.utime, m.utime);
    EXPECT_EQ(back.num_joints, positions);
    EXPECT_EQ(back.joint_position, m.joint_position);
    EXPECT_EQ(back.num_torques, torques);
    EXPECT_EQ(back.joint_torque, m.joint_torque);
  }
}

TEST(DrakeLcmtypes, PandaStatusRoundTrips) {
  const drake::lcmt_panda_status m = make_panda_status();
  const std::vector<uint8_t> bytes = encode(m);
  // fingerprint, utime, num_joints, eight arrays of n doubles, success rate, robot_mode,
  // robot_utime, control_mode
  EXPECT_EQ(bytes.size(), kHash + 8 + 4 + 8 * 8 * kJoints + 8 + 1 + 8 + 1);
  const auto back = decode<drake::lcmt_panda_status>(bytes);
  EXPECT_EQ(back.utime, m.utime);
  EXPECT_EQ(back.num_joints, kJoints);
  EXPECT_EQ(back.joint_position, m.joint_position);
  EXPECT_EQ(back.joint_position_desired, m.joint_position_desired);
  EXPECT_EQ(back.joint_velocity, m.joint_velocity);
  EXPECT_EQ(back.joint_velocity_desired, m.joint_velocity_desired);
  EXPECT_EQ(back.joint_acceleration_desired, m.joint_acceleration_desired);
  EXPECT_EQ(back.joint_torque, m.joint_torque);
  EXPECT_EQ(back.joint_torque_desired, m.joint_torque_desired);
  EXPECT_EQ(back.joint_torque_external, m.joint_torque_external);
  EXPECT_EQ(back.control_command_success_rate, 0.97);
  EXPECT_EQ(back.robot_mode, drake::lcmt_panda_status::kMove);
  EXPECT_EQ(back.robot_utime, 123'456'000);
  EXPECT_EQ(back.control_mode, drake::lcmt_panda_status::CONTROL_MODE_TORQUE);
  // The last byte is control_mode, the 8 before it robot_utime.
  EXPECT_EQ(bytes.back(), 4);
}

TEST(DrakeLcmtypes, PandaCommandRoundTrips) {
  for (const auto& [p, v, t] : {std::tuple{0, 0, kJoints}, std::tuple{kJoints, 0, 0}, std::tuple{kJoints, kJoints, kJoints}}) {
    SCOPED_TRACE(std::to_string(p) + " " + std::to_string(v) + " " + std::to_string(t));
    const drake::lcmt_panda_command m = make_panda_command(p, v, t);
    const std::vector<uint8_t> bytes = encode(m);
    // fingerprint, utime, three counted arrays, control_mode_expected
    EXPECT_EQ(bytes.size(), kHash + 8 + 3 * 4 + 8 * size_t(p + v + t) + 1);
    const auto back = decode<drake::lcmt_panda_command>(bytes);
    EXPECT_EQ(back.utime, m.utime);
    EXPECT_EQ(back.num_joint_position, p);
    EXPECT_EQ(back.joint_position, m.joint_position);
    EXPECT_EQ(back.num_joint_velocity, v);
    EXPECT_EQ(back.joint_velocity, m.joint_velocity);
    EXPECT_EQ(back.num_joint_torque, t);
    EXPECT_EQ(back.joint_torque, m.joint_torque);
    EXPECT_EQ(back.control_mode_expected, drake::lcmt_panda_status::CONTROL_MODE_TORQUE);
  }
}

}  // namespace
}  // namespace chasles::testing
