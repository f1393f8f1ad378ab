// The enums' wire values (controller/transport/wire.hpp): every enumerator through real bytes — put
// in its message by to_wire, encoded by lcm-gen, decoded, read back by from_wire — against the
// constants the .lcm files give it, written out here a second time; every other int8_t refused;
// and the enumerator count the tables are checked against at compile time, on this compiler.
#include <gtest/gtest.h>

#include <chasles/arm_target_t.hpp>
#include <chasles/control_mode_t.hpp>
#include <chasles/controller_status_t.hpp>
#include <chasles/jog_command_t.hpp>
#include <cstdint>
#include <utility>
#include <vector>

#include "controller/law_settings.hpp"
#include "controller/signals.hpp"
#include "controller/transport/conventions.hpp"
#include "controller/transport/lcm_io.hpp"
#include "controller/transport/wire.hpp"

namespace chasles::controller {
namespace {

// A message with `set` applied, through its bytes and back.
template <typename Message, typename Set>
Message through_bytes(Set set) {
  Message out{};
  set(out);
  std::vector<uint8_t> bytes(size_t(out.getEncodedSize()));
  EXPECT_EQ(out.encode(bytes.data(), 0, int(bytes.size())), int(bytes.size()));
  Message in{};
  EXPECT_EQ(in.decode(bytes.data(), 0, int(bytes.size())), int(bytes.size()));
  return in;
}

// Each expected pair both ways, through `field` of Message's bytes, and every other int8_t is none.
template <typename Message, typename Enum>
void expect_wire(const std::vector<std::pair<Enum, int8_t>>& expected, int8_t Message::*field) {
  ASSERT_EQ(int(expected.size()), enumerators::count<Enum>());
  for (const auto& [value, wire] : expected) {
    EXPECT_EQ(to_wire(value), wire) << int(value);
    const int8_t sent = to_wire(value);  // C++17 lambdas capture no structured binding
    const Message m = through_bytes<Message>([&](Message& out) { out.*field = sent; });
    Enum back{};
    ASSERT_TRUE(from_wire(m.*field, back)) << int(wire);
    EXPECT_EQ(back, value) << int(wire);
  }
  for (int w = -128; w < 128; ++w) {
    bool listed = false;
    for (const auto& pair : expected) listed = listed || pair.second == w;
    Enum back = expected.front().first;
    EXPECT_EQ(from_wire(static_cast<int8_t>(w), back), listed) << w;
    if (!listed) {
      EXPECT_EQ(back, expected.front().first) << "untouched on a refusal";
    }
  }
}

TEST(WireTables, TheStatusStateIsTheMode) {
  expect_wire<controller_status_t, Mode>({{Mode::kWaiting, controller_status_t::WAITING},
                                          {Mode::kRunning, controller_status_t::RUNNING},
                                          {Mode::kHolding, controller_status_t::HOLDING},
                                          {Mode::kFault, controller_status_t::FAULT},
                                          {Mode::kReflex, controller_status_t::REFLEX}},
                                         &controller_status_t::state);
}

TEST(WireTables, TheStatusTrajectoryOutcomeIsTrajectoryProgress) {
  expect_wire<controller_status_t, TrajectoryProgress::Outcome>(
      {{TrajectoryProgress::kNone, controller_status_t::TRAJECTORY_NONE},
       {TrajectoryProgress::kActive, controller_status_t::TRAJECTORY_ACTIVE},
       {TrajectoryProgress::kSucceeded, controller_status_t::TRAJECTORY_SUCCEEDED},
       {TrajectoryProgress::kAborted, controller_status_t::TRAJECTORY_ABORTED},
       {TrajectoryProgress::kPreempted, controller_status_t::TRAJECTORY_PREEMPTED},
       {TrajectoryProgress::kRejected, controller_status_t::TRAJECTORY_REJECTED}},
      &controller_status_t::trajectory_outcome);
}

TEST(WireTables, TheStatusJogLimitIsJogProgress) {
  expect_wire<controller_status_t, JogProgress::Limit>({{JogProgress::kNone, controller_status_t::JOG_NONE},
                                                        {JogProgress::kVelocity, controller_status_t::JOG_VELOCITY_LIMIT},
                                                        {JogProgress::kPosition, controller_status_t::JOG_POSITION_LIMIT},
                                                        {JogProgress::kSingularity, controller_status_t::JOG_SINGULARITY}},
                                                       &controller_status_t::jog_limited_by);
}

TEST(WireTables, ATargetsModeAndAJogsKindAndFrameAreTheirOwnValues) {
  expect_wire<arm_target_t, Target::Mode>(
      {{Target::kHold, arm_target_t::HOLD}, {Target::kJoint, arm_target_t::JOINT}, {Target::kCartesian, arm_target_t::CARTESIAN}},
      &arm_target_t::mode);
  expect_wire<jog_command_t, Jog::Kind>(
      {{Jog::kJointVelocity, jog_command_t::JOINT_VELOCITY}, {Jog::kTwist, jog_command_t::TWIST}}, &jog_command_t::kind);
  expect_wire<jog_command_t, Jog::Frame>({{Jog::kBase, jog_command_t::BASE}, {Jog::kTool, jog_command_t::TOOL}},
                                         &jog_command_t::frame);
}

TEST(WireTables, EnumeratorsAreCountedAsDeclared) {
  EXPECT_EQ(enumerators::count<Mode>(), 5);
  EXPECT_EQ(enumerators::count<TrajectoryProgress::Outcome>(), 6);
  EXPECT_EQ(enumerators::count<JogProgress::Limit>(), 4);
  EXPECT_EQ(enumerators::count<Law>(), 4);
  EXPECT_EQ(enumerators::count<Target::Mode>(), 3);
  EXPECT_EQ(enumerators::count<Jog::Kind>(), 2);
  EXPECT_EQ(enumerators::count<Jog::Frame>(), 2);
  EXPECT_EQ(enumerators::count<Protocol>(), 3);
  EXPECT_EQ(to_wire(static_cast<Mode>(9)), kNoWire) << "a value that is no enumerator has no wire value";
}

// The laws on the wire are control_mode_t's constants, one each, and nothing else reads as a law;
// the status reports the law in force in the same values.
TEST(LawWire, EveryLawHasItsConstantAndNothingElseIsALaw) {
  const std::vector<std::pair<Law, int8_t>> expected = {{Law::kComputedTorque, control_mode_t::COMPUTED_TORQUE},
                                                        {Law::kJointImpedance, control_mode_t::JOINT_IMPEDANCE},
                                                        {Law::kCartesianImpedance, control_mode_t::CARTESIAN_IMPEDANCE},
                                                        {Law::kFreeDrive, control_mode_t::FREE_DRIVE}};
  expect_wire<control_mode_t, Law>(expected, &control_mode_t::law);
  expect_wire<controller_status_t, Law>(expected, &controller_status_t::law);
  control_mode_t message{};
  message.law = 7;
  LawSettings settings(7);
  EXPECT_EQ(law_from_message(message, 7, settings),
            "unknown law 7 (0 computed-torque, 1 joint-impedance, 2 cartesian-impedance, 3 free-drive)");
}

}  // namespace
}  // namespace chasles::controller
