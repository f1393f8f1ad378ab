// The protocols' conventions table (controller/transport/conventions.hpp) against Drake's facts
// written out here a second time (docs/protocols.md, Drake's lcmtypes and drivers), and the
// protocol functions that read it. The table is what both ends of the wire encode and decode by —
// the controller's StatusReader and CommandWriter, the plant's StatePublisher and CommandInbox — so
// a row wrong here would be wrong the same way on both and pass their round trips: this is where it
// is caught.
#include <gtest/gtest.h>

#include <drake/lcmt_panda_status.hpp>
#include <string>

#include "controller/transport/conventions.hpp"
#include "controller/transport/protocol.hpp"

namespace chasles::controller {
namespace {

TEST(Conventions, ChaslesProtocolIsNumberedFullTorqueAndUnsigned) {
  const ProtocolConventions& row = conventions(Protocol::kChasles);
  EXPECT_STREQ(row.name, "chasles");
  EXPECT_STREQ(row.status_type, "chasles.robot_state_t");
  EXPECT_STREQ(row.command_type, "chasles.joint_torque_command_t");
  EXPECT_TRUE(row.numbered_status);
  EXPECT_EQ(row.torque_semantics, TorqueSemantics::kFull);
  EXPECT_EQ(row.arm_joints, 0);
  EXPECT_EQ(row.status_period, 0.0);
  EXPECT_EQ(row.effort, Sign::kSame);
  EXPECT_EQ(row.command_torque, Sign::kSame);
  EXPECT_EQ(row.command_control_mode, 0);
  EXPECT_EQ(default_channels(Protocol::kChasles, "ARM2_").status, "ARM2_STATE");
  EXPECT_EQ(default_channels(Protocol::kChasles, "ARM2_").command, "ARM2_COMMAND");
}

// Drake's iiwa: joint_torque_measured and joint_torque_commanded negated relative to Drake's
// manipulation convention, joint_torque_external not; FRI's 5 ms; the drivers add g(q).
TEST(Conventions, IiwaNegatesItsMeasuredAndCommandedTorqueNotItsExternalOne) {
  const ProtocolConventions& row = conventions(Protocol::kDrakeIiwa);
  EXPECT_STREQ(row.name, "drake-iiwa");
  EXPECT_STREQ(row.status_type, "drake.lcmt_iiwa_status");
  EXPECT_STREQ(row.command_type, "drake.lcmt_iiwa_command");
  EXPECT_EQ(row.effort, Sign::kNegated);
  EXPECT_EQ(row.torque_commanded, Sign::kNegated);
  EXPECT_EQ(row.tau_ext, Sign::kSame);
  EXPECT_EQ(row.command_torque, Sign::kSame);
  EXPECT_FALSE(row.numbered_status);
  EXPECT_EQ(row.torque_semantics, TorqueSemantics::kOverlay);
  EXPECT_EQ(row.arm_joints, 7);
  EXPECT_EQ(row.status_period, 0.005);
  EXPECT_EQ(row.command_control_mode, 0);
  EXPECT_EQ(default_channels(Protocol::kDrakeIiwa, "ARM2_").status, "IIWA_STATUS");
  EXPECT_EQ(default_channels(Protocol::kDrakeIiwa, "ARM2_").command, "IIWA_COMMAND");
}

// Drake's Panda (libfranka's RobotState): tau_ext_hat_filtered negated, tau_J and tau_J_d not;
// 1 kHz; torques exclude gravity; a command says CONTROL_MODE_TORQUE (4).
TEST(Conventions, PandaNegatesItsExternalTorqueOnly) {
  const ProtocolConventions& row = conventions(Protocol::kDrakePanda);
  EXPECT_STREQ(row.name, "drake-panda");
  EXPECT_STREQ(row.status_type, "drake.lcmt_panda_status");
  EXPECT_STREQ(row.command_type, "drake.lcmt_panda_command");
  EXPECT_EQ(row.effort, Sign::kSame);
  EXPECT_EQ(row.torque_commanded, Sign::kSame);
  EXPECT_EQ(row.tau_ext, Sign::kNegated);
  EXPECT_EQ(row.command_torque, Sign::kSame);
  EXPECT_FALSE(row.numbered_status);
  EXPECT_EQ(row.torque_semantics, TorqueSemantics::kOverlay);
  EXPECT_EQ(row.arm_joints, 7);
  EXPECT_EQ(row.status_period, 0.001);
  EXPECT_EQ(row.command_control_mode, 4);
  EXPECT_EQ(row.command_control_mode, drake::lcmt_panda_status::CONTROL_MODE_TORQUE);
  EXPECT_EQ(default_channels(Protocol::kDrakePanda, "ARM2_").status, "PANDA_STATUS");
  EXPECT_EQ(default_channels(Protocol::kDrakePanda, "ARM2_").command, "PANDA_COMMAND");
}

// What --protocol takes, the default semantics and the rate come from the rows, each protocol once.
TEST(Conventions, TheProtocolFunctionsReadTheTable) {
  for (const ProtocolConventions& row : kProtocolConventions) {
    EXPECT_STREQ(to_string(row.protocol), row.name);
    Protocol parsed = row.protocol == Protocol::kChasles ? Protocol::kDrakeIiwa : Protocol::kChasles;
    ASSERT_TRUE(parse_protocol(row.name, parsed)) << row.name;
    EXPECT_EQ(parsed, row.protocol);
    EXPECT_EQ(default_torque_semantics(row.protocol), row.torque_semantics) << row.name;
    EXPECT_EQ(nominal_status_period(row.protocol), row.status_period) << row.name;
  }
  EXPECT_EQ(factor(Sign::kSame) * 2.5, 2.5);
  EXPECT_EQ(factor(Sign::kNegated) * 2.5, -2.5);
}

}  // namespace
}  // namespace chasles::controller
