// Drake's iiwa and Panda messages (lcmtypes/drake_*.lcm) on the wire. Their fingerprints are pinned
// to the values Drake's own generated classes give (../shared/drake-lcm.md, checked against Drake
// 1.58): the .lcm files here are written from Drake's definitions, and a field of the wrong name,
// type or order would change the fingerprint and make a real driver's messages unreadable. Then
// every field survives a round trip, and the encoded size is the layout's. Last, what the checked
// decoders (lcmtypes/checked.hpp) refuse, and the reason each gives.
#include <gtest/gtest.h>

#include <chasles/robot_state_t.hpp>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <drake/lcmt_iiwa_command.hpp>
#include <drake/lcmt_iiwa_status.hpp>
#include <drake/lcmt_panda_command.hpp>
#include <drake/lcmt_panda_status.hpp>
#include <limits>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "lcmtypes/checked.hpp"
#include "support/allocation_counter.hpp"
#include "wire.hpp"

namespace chasles::testing {
namespace {

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
  for (const auto& [p, v, t] :
       {std::tuple{0, 0, kJoints}, std::tuple{kJoints, 0, 0}, std::tuple{kJoints, kJoints, kJoints}}) {
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

// ---- The checked decoders ----

std::vector<uint8_t> prefix(const std::vector<uint8_t>& bytes, size_t length) {
  return std::vector<uint8_t>(bytes.begin(), bytes.begin() + std::ptrdiff_t(length));
}

// Every proper prefix of a valid encoding is refused by the checked decoder, for any arm, and so
// is the encoding with one more byte.
template <class Message>
void expect_drake_damage_refused(const std::vector<uint8_t>& bytes) {
  for (size_t length = 0; length < bytes.size(); ++length) {
    EXPECT_NE(decode_checked<Message>(prefix(bytes, length), messages::kAnyArm), "") << "truncated to " << length;
  }
  std::vector<uint8_t> longer = bytes;
  longer.push_back(0);
  EXPECT_NE(decode_checked<Message>(longer, messages::kAnyArm), "");
}

// Checked decoding into a message reused for one arm allocates nothing after the first.
template <class Message>
void expect_reuse_allocates_nothing(const std::vector<uint8_t>& bytes) {
  Message message;
  ASSERT_EQ(messages::decode_checked(bytes.data(), bytes.size(), message, kJoints, messages::Finite::Required), "");
  AllocationCounter counter;
  std::string why;
  for (int k = 0; k < 10; ++k) {
    why = messages::decode_checked(bytes.data(), bytes.size(), message, kJoints, messages::Finite::Required);
  }
  const long allocations = counter.count();
  EXPECT_EQ(why, "");
  EXPECT_EQ(allocations, 0);
}

TEST(DrakeLcmtypes, IiwaStatusCheckedDecoderReadsWhatItShouldAndRefusesTheRest) {
  const drake::lcmt_iiwa_status m = make_iiwa_status();
  const std::vector<uint8_t> bytes = encode(m);
  ASSERT_EQ(bytes.size(), 412u);  // 20 + 56 per joint
  drake::lcmt_iiwa_status checked;
  ASSERT_EQ(messages::decode_checked(bytes.data(), bytes.size(), checked, kJoints, messages::Finite::Required), "");
  EXPECT_EQ(checked.utime, m.utime);
  EXPECT_EQ(checked.joint_position_measured, m.joint_position_measured);
  EXPECT_EQ(checked.joint_velocity_estimated, m.joint_velocity_estimated);
  EXPECT_EQ(checked.joint_torque_measured, m.joint_torque_measured);
  EXPECT_EQ(checked.joint_torque_external, m.joint_torque_external);
  expect_drake_damage_refused<drake::lcmt_iiwa_status>(bytes);
  expect_reuse_allocates_nothing<drake::lcmt_iiwa_status>(bytes);

  // Another type (Drake's command, chasles's state) or too few bytes for a fingerprint.
  EXPECT_EQ(decode_checked<drake::lcmt_iiwa_status>(encode(make_iiwa_command(kJoints, kJoints))),
            "not a lcmt_iiwa_status (wrong fingerprint)");
  robot_state_t state;
  state.num_joints = 0;
  EXPECT_EQ(decode_checked<drake::lcmt_iiwa_status>(encode(state)), "not a lcmt_iiwa_status (wrong fingerprint)");
  EXPECT_EQ(decode_checked<drake::lcmt_iiwa_status>(prefix(bytes, 7)), "not a lcmt_iiwa_status (wrong fingerprint)");
  // num_joints sits at byte 16, after the fingerprint and utime.
  EXPECT_EQ(decode_checked<drake::lcmt_iiwa_status>(prefix(bytes, 19)), "truncated: 19 bytes");
  EXPECT_EQ(decode_checked<drake::lcmt_iiwa_status>(with_int32(bytes, 16, 0xffffffffu)),
            "num_joints -1 in a message of 412 bytes");
  EXPECT_EQ(decode_checked<drake::lcmt_iiwa_status>(with_int32(bytes, 16, 0x7fffffffu), messages::kAnyArm),
            "num_joints 2147483647 in a message of 412 bytes");
  EXPECT_EQ(decode_checked<drake::lcmt_iiwa_status>(with_int32(bytes, 16, 6)), "for 6 joints; the arm has 7");
  EXPECT_EQ(decode_checked<drake::lcmt_iiwa_status>(bytes, 14), "for 7 joints; the arm has 14");
  EXPECT_EQ(decode_checked<drake::lcmt_iiwa_status>(with_int32(bytes, 16, 6), messages::kAnyArm),
            "of 412 bytes; expected 356 for 6 joints");

  // Non-finite numbers, first field first; joint_position_ipo may be NaN (the driver sends NaN
  // there whenever FRI has no interpolator positions).
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const auto refused = [&](void (*damage)(drake::lcmt_iiwa_status&, double), double bad, const std::string& field) {
    drake::lcmt_iiwa_status damaged = make_iiwa_status();
    damage(damaged, bad);
    const std::vector<uint8_t> b = encode(damaged);
    EXPECT_EQ(decode_checked<drake::lcmt_iiwa_status>(b), "with non-finite " + field);
    EXPECT_EQ(decode_checked<drake::lcmt_iiwa_status>(b, kJoints, messages::Finite::NotRequired), "") << field;
  };
  using Iiwa = drake::lcmt_iiwa_status;
  refused([](Iiwa& s, double x) { s.joint_position_measured[6] = x; }, nan, "joint_position_measured");
  refused([](Iiwa& s, double x) { s.joint_velocity_estimated[0] = x; }, inf, "joint_velocity_estimated");
  refused([](Iiwa& s, double x) { s.joint_position_commanded[3] = x; }, -inf, "joint_position_commanded");
  refused([](drake::lcmt_iiwa_status& s, double x) { s.joint_torque_measured[2] = x; }, nan, "joint_torque_measured");
  refused([](drake::lcmt_iiwa_status& s, double x) { s.joint_torque_commanded[5] = x; }, nan, "joint_torque_commanded");
  refused([](drake::lcmt_iiwa_status& s, double x) { s.joint_torque_external[1] = x; }, inf, "joint_torque_external");
  drake::lcmt_iiwa_status no_ipo = make_iiwa_status();
  for (double& x : no_ipo.joint_position_ipo) x = nan;
  EXPECT_EQ(decode_checked<drake::lcmt_iiwa_status>(encode(no_ipo)), "");
}

TEST(DrakeLcmtypes, IiwaCommandCheckedDecoderReadsBothCounts) {
  // Each count 0 or the arm's, in any combination: which a driver needs is its mode's.
  for (const auto& [positions, torques] :
       {std::pair{kJoints, kJoints}, std::pair{0, kJoints}, std::pair{kJoints, 0}, std::pair{0, 0}}) {
    SCOPED_TRACE(std::to_string(positions) + " positions, " + std::to_string(torques) + " torques");
    const drake::lcmt_iiwa_command m = make_iiwa_command(positions, torques);
    const std::vector<uint8_t> bytes = encode(m);
    drake::lcmt_iiwa_command checked;
    ASSERT_EQ(messages::decode_checked(bytes.data(), bytes.size(), checked, kJoints, messages::Finite::Required), "");
    EXPECT_EQ(checked.utime, m.utime);
    EXPECT_EQ(checked.joint_position, m.joint_position);
    EXPECT_EQ(checked.joint_torque, m.joint_torque);
    expect_drake_damage_refused<drake::lcmt_iiwa_command>(bytes);
    expect_reuse_allocates_nothing<drake::lcmt_iiwa_command>(bytes);
  }
  const std::vector<uint8_t> bytes = encode(make_iiwa_command(kJoints, kJoints));
  ASSERT_EQ(bytes.size(), 136u);  // 24 + 8 per position + 8 per torque; num_torques at byte 76
  EXPECT_EQ(decode_checked<drake::lcmt_iiwa_command>(encode(make_iiwa_status())),
            "not a lcmt_iiwa_command (wrong fingerprint)");
  EXPECT_EQ(decode_checked<drake::lcmt_iiwa_command>(prefix(bytes, 18)), "truncated: 18 bytes");
  EXPECT_EQ(decode_checked<drake::lcmt_iiwa_command>(prefix(bytes, 78)), "truncated: 78 bytes");
  EXPECT_EQ(decode_checked<drake::lcmt_iiwa_command>(with_int32(bytes, 16, 0x80000000u)),
            "num_joints -2147483648 in a message of 136 bytes");
  EXPECT_EQ(decode_checked<drake::lcmt_iiwa_command>(with_int32(bytes, 76, 0xfffffff9u)),
            "num_torques -7 in a message of 136 bytes");
  EXPECT_EQ(decode_checked<drake::lcmt_iiwa_command>(with_int32(bytes, 76, 1'000'000), messages::kAnyArm),
            "num_torques 1000000 in a message of 136 bytes");
  // 15 positions move num_torques to byte 140, past the end.
  EXPECT_EQ(decode_checked<drake::lcmt_iiwa_command>(with_int32(bytes, 16, 15), messages::kAnyArm),
            "truncated: 136 bytes");
  EXPECT_EQ(decode_checked<drake::lcmt_iiwa_command>(encode(make_iiwa_command(6, kJoints))),
            "for 6 positions and 7 torques; the arm has 7 (give 0 or 7 in each)");
  EXPECT_EQ(decode_checked<drake::lcmt_iiwa_command>(encode(make_iiwa_command(kJoints, 8))),
            "for 7 positions and 8 torques; the arm has 7 (give 0 or 7 in each)");
  EXPECT_EQ(decode_checked<drake::lcmt_iiwa_command>(encode(make_iiwa_command(6, 8)), messages::kAnyArm), "");
  EXPECT_EQ(decode_checked<drake::lcmt_iiwa_command>(with_int32(bytes, 76, 0)),
            "of 136 bytes; expected 80 for 7 positions and 0 torques");
  drake::lcmt_iiwa_command nan = make_iiwa_command(kJoints, kJoints);
  nan.joint_torque[4] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(decode_checked<drake::lcmt_iiwa_command>(encode(nan)), "with non-finite joint_torque");
  EXPECT_EQ(decode_checked<drake::lcmt_iiwa_command>(encode(nan), kJoints, messages::Finite::NotRequired), "");
  nan.joint_position[0] = -std::numeric_limits<double>::infinity();
  EXPECT_EQ(decode_checked<drake::lcmt_iiwa_command>(encode(nan)), "with non-finite joint_position");
}

TEST(DrakeLcmtypes, PandaStatusCheckedDecoderReadsWhatItShouldAndRefusesTheRest) {
  const drake::lcmt_panda_status m = make_panda_status();
  const std::vector<uint8_t> bytes = encode(m);
  ASSERT_EQ(bytes.size(), 486u);  // 38 + 64 per joint
  drake::lcmt_panda_status checked;
  ASSERT_EQ(messages::decode_checked(bytes.data(), bytes.size(), checked, kJoints, messages::Finite::Required), "");
  EXPECT_EQ(checked.joint_position, m.joint_position);
  EXPECT_EQ(checked.joint_velocity, m.joint_velocity);
  EXPECT_EQ(checked.joint_torque, m.joint_torque);
  EXPECT_EQ(checked.joint_torque_external, m.joint_torque_external);
  EXPECT_EQ(checked.robot_mode, drake::lcmt_panda_status::kMove);
  EXPECT_EQ(checked.robot_utime, m.robot_utime);
  expect_drake_damage_refused<drake::lcmt_panda_status>(bytes);
  expect_reuse_allocates_nothing<drake::lcmt_panda_status>(bytes);

  EXPECT_EQ(decode_checked<drake::lcmt_panda_status>(encode(make_iiwa_status())),
            "not a lcmt_panda_status (wrong fingerprint)");
  EXPECT_EQ(decode_checked<drake::lcmt_panda_status>(prefix(bytes, 16)), "truncated: 16 bytes");
  EXPECT_EQ(decode_checked<drake::lcmt_panda_status>(with_int32(bytes, 16, 0xfffffffeu)),
            "num_joints -2 in a message of 486 bytes");
  EXPECT_EQ(decode_checked<drake::lcmt_panda_status>(with_int32(bytes, 16, 61)),
            "num_joints 61 in a message of 486 bytes");
  EXPECT_EQ(decode_checked<drake::lcmt_panda_status>(with_int32(bytes, 16, 60), messages::kAnyArm),
            "of 486 bytes; expected 3878 for 60 joints");
  EXPECT_EQ(decode_checked<drake::lcmt_panda_status>(bytes, 6), "for 7 joints; the arm has 6");

  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const auto refused = [&](void (*damage)(drake::lcmt_panda_status&, double), double bad, const std::string& field) {
    drake::lcmt_panda_status damaged = make_panda_status();
    damage(damaged, bad);
    const std::vector<uint8_t> b = encode(damaged);
    EXPECT_EQ(decode_checked<drake::lcmt_panda_status>(b), "with non-finite " + field);
    EXPECT_EQ(decode_checked<drake::lcmt_panda_status>(b, kJoints, messages::Finite::NotRequired), "") << field;
  };
  refused([](drake::lcmt_panda_status& s, double x) { s.joint_position[0] = x; }, nan, "joint_position");
  using Panda = drake::lcmt_panda_status;
  refused([](Panda& s, double x) { s.joint_position_desired[1] = x; }, inf, "joint_position_desired");
  refused([](Panda& s, double x) { s.joint_velocity[2] = x; }, nan, "joint_velocity");
  refused([](Panda& s, double x) { s.joint_velocity_desired[3] = x; }, -inf, "joint_velocity_desired");
  refused([](drake::lcmt_panda_status& s, double x) { s.joint_acceleration_desired[4] = x; }, nan,
          "joint_acceleration_desired");
  refused([](drake::lcmt_panda_status& s, double x) { s.joint_torque[5] = x; }, inf, "joint_torque");
  refused([](drake::lcmt_panda_status& s, double x) { s.joint_torque_desired[6] = x; }, nan, "joint_torque_desired");
  refused([](drake::lcmt_panda_status& s, double x) { s.joint_torque_external[0] = x; }, nan, "joint_torque_external");
  refused([](drake::lcmt_panda_status& s, double x) { s.control_command_success_rate = x; }, nan,
          "control_command_success_rate");
}

TEST(DrakeLcmtypes, PandaCommandCheckedDecoderReadsAllThreeCounts) {
  for (const auto& [p, v, t] : {std::tuple{0, 0, kJoints}, std::tuple{kJoints, 0, 0}, std::tuple{0, kJoints, 0},
                                std::tuple{kJoints, kJoints, kJoints}}) {
    SCOPED_TRACE(std::to_string(p) + " " + std::to_string(v) + " " + std::to_string(t));
    const drake::lcmt_panda_command m = make_panda_command(p, v, t);
    const std::vector<uint8_t> bytes = encode(m);
    drake::lcmt_panda_command checked;
    ASSERT_EQ(messages::decode_checked(bytes.data(), bytes.size(), checked, kJoints, messages::Finite::Required), "");
    EXPECT_EQ(checked.joint_position, m.joint_position);
    EXPECT_EQ(checked.joint_velocity, m.joint_velocity);
    EXPECT_EQ(checked.joint_torque, m.joint_torque);
    EXPECT_EQ(checked.control_mode_expected, m.control_mode_expected);
    expect_drake_damage_refused<drake::lcmt_panda_command>(bytes);
    expect_reuse_allocates_nothing<drake::lcmt_panda_command>(bytes);
  }
  // Torque mode: counts at bytes 16, 20 and 24, then 56 bytes of torques and the mode.
  const std::vector<uint8_t> bytes = encode(make_panda_command(0, 0, kJoints));
  ASSERT_EQ(bytes.size(), 85u);
  EXPECT_EQ(decode_checked<drake::lcmt_panda_command>(encode(make_panda_status())),
            "not a lcmt_panda_command (wrong fingerprint)");
  EXPECT_EQ(decode_checked<drake::lcmt_panda_command>(prefix(bytes, 23)), "truncated: 23 bytes");
  EXPECT_EQ(decode_checked<drake::lcmt_panda_command>(with_int32(bytes, 16, 0xffffffffu)),
            "num_joint_position -1 in a message of 85 bytes");
  EXPECT_EQ(decode_checked<drake::lcmt_panda_command>(with_int32(bytes, 20, 0x7fffffffu)),
            "num_joint_velocity 2147483647 in a message of 85 bytes");
  EXPECT_EQ(decode_checked<drake::lcmt_panda_command>(with_int32(bytes, 24, 0x80000001u)),
            "num_joint_torque -2147483647 in a message of 85 bytes");
  // 8 velocities move num_joint_torque to byte 88, past the end.
  EXPECT_EQ(decode_checked<drake::lcmt_panda_command>(with_int32(bytes, 20, 8), messages::kAnyArm),
            "truncated: 85 bytes");
  EXPECT_EQ(decode_checked<drake::lcmt_panda_command>(encode(make_panda_command(0, 0, 6))),
            "for 0 positions, 0 velocities and 6 torques; the arm has 7 (give 0 or 7 in each)");
  EXPECT_EQ(decode_checked<drake::lcmt_panda_command>(encode(make_panda_command(kJoints, 1, kJoints))),
            "for 7 positions, 1 velocities and 7 torques; the arm has 7 (give 0 or 7 in each)");
  EXPECT_EQ(decode_checked<drake::lcmt_panda_command>(with_int32(bytes, 24, 6), messages::kAnyArm),
            "of 85 bytes; expected 77 for 0 positions, 0 velocities and 6 torques");
  const auto refused = [&](void (*damage)(drake::lcmt_panda_command&), const std::string& field) {
    drake::lcmt_panda_command damaged = make_panda_command(kJoints, kJoints, kJoints);
    damage(damaged);
    const std::vector<uint8_t> b = encode(damaged);
    EXPECT_EQ(decode_checked<drake::lcmt_panda_command>(b), "with non-finite " + field);
    EXPECT_EQ(decode_checked<drake::lcmt_panda_command>(b, kJoints, messages::Finite::NotRequired), "") << field;
  };
  refused([](drake::lcmt_panda_command& c) { c.joint_position[3] = std::nan(""); }, "joint_position");
  refused([](drake::lcmt_panda_command& c) { c.joint_velocity[6] = HUGE_VAL; }, "joint_velocity");
  refused([](drake::lcmt_panda_command& c) { c.joint_torque[0] = -HUGE_VAL; }, "joint_torque");
}

}  // namespace
}  // namespace chasles::testing
