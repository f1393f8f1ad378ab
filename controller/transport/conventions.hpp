// The conventions of each protocol chasles speaks with an arm's driver, as one table: the facts
// both ends of the wire need. The controller's side (protocol.cpp: StatusReader, CommandWriter)
// decodes statuses and encodes commands by it; the simulated plant (tools/simulation/messaging.cpp)
// encodes statuses and decodes commands by the same rows, so the mirror image is not written twice.
// docs/protocols.md is the account, field by field, with Drake's sources for each fact.
//
// Units are the same on every protocol and so have no column: rad (m), rad/s (m/s), N·m (N), utime
// in µs. What differs is below: names and channels, the driver's rate and arm, whether a status is
// numbered, what the torque sent means, the sign of each torque field, and the control mode a
// command must say.
#pragma once

#include <cstdint>
#include <drake/lcmt_panda_status.hpp>
#include <iterator>

#include "controller/transport/enumerators.hpp"

namespace chasles::controller {

enum class Protocol { kChasles, kDrakeIiwa, kDrakePanda };

/// What the torque in a command means to its receiver.
enum class TorqueSemantics {
  kFull,     ///< the whole joint torque τ: the receiver adds nothing (chasles's plant)
  kOverlay,  ///< τ − g(q): the receiver adds its own gravity compensation (Drake's iiwa and Panda drivers)
};

/// A torque field's sign on the wire against chasles's convention, which is Drake's manipulation
/// convention: a positive joint torque accelerates the joint the positive way along its axis; an
/// external torque is positive when it pushes the joint the positive way. The wire carries
/// sign × chasles's value, and chasles reads sign × the wire's (the sign is its own inverse).
enum class Sign : int8_t { kSame = 1, kNegated = -1 };

/// The factor a Sign multiplies by: exact either way (±1 × x is x or −x, bit for bit).
constexpr double factor(Sign sign) { return sign == Sign::kNegated ? -1.0 : 1.0; }

/// One protocol's row.
struct ProtocolConventions {
  Protocol protocol;
  const char* name;          ///< what --protocol takes
  const char* status_type;   ///< the status's LCM type, with its package
  const char* command_type;  ///< the command's
  /// The default channels: chasles's are suffixes of the channel prefix (<prefix>STATE); Drake's are
  /// its drivers' own names, which no prefix changes.
  const char* status_channel;
  const char* command_channel;
  bool prefixed_channels;
  /// The period the driver publishes its status at, s: FRI's 5 ms, libfranka's 1 ms; 0 for chasles,
  /// whose plant's period the controller learns from the states.
  double status_period;
  /// The joints of the arm the driver runs (the iiwa's and the Panda's 7); 0: any arm. chasles reads
  /// and writes the messages for the arm of its model, which must match the status's count.
  int arm_joints;
  /// Whether a status carries a sequence number (chasles's seq); Drake's carry none and are
  /// numbered by arrival and judged by their utime (StatusSequence).
  bool numbered_status;
  /// What the driver expects a command's torque to be: kOverlay where it adds gravity compensation
  /// itself (Drake's iiwa drivers, libfranka under drake-franka-driver), kFull where nothing is
  /// added (chasles's plant). The default of --torque-semantics on both sides.
  TorqueSemantics torque_semantics;
  /// The joint torque measured, gravity included: robot_state_t.effort, the iiwa's
  /// joint_torque_measured (negated: Drake's simulated driver matches the hardware), the Panda's
  /// joint_torque (tau_J).
  Sign effort;
  /// The commanded torque a status reports back: the iiwa's joint_torque_commanded (what the driver
  /// handed the joints, negated as joint_torque_measured is), the Panda's joint_torque_desired
  /// (tau_J_d, the command as received). chasles's status has none.
  Sign torque_commanded;
  /// The external joint torque: the iiwa's joint_torque_external (not negated), the Panda's
  /// joint_torque_external (libfranka's tau_ext_hat_filtered, negated). chasles's status has none.
  Sign tau_ext;
  /// The command's torque: in chasles's convention on every protocol.
  Sign command_torque;
  /// The control mode a command declares (the Panda's control_mode_expected: its torque bit,
  /// which the driver's torque mode requires and the status's control_mode reports once
  /// commanded); 0 where a command declares none.
  int8_t command_control_mode;
};

/// The protocols, in the order of Protocol's enumerators.
inline constexpr ProtocolConventions kProtocolConventions[] = {
    {Protocol::kChasles, "chasles", "chasles.robot_state_t", "chasles.joint_torque_command_t", "STATE", "COMMAND",
     true, 0.0, 0, true, TorqueSemantics::kFull, Sign::kSame, Sign::kSame, Sign::kSame, Sign::kSame, 0},
    {Protocol::kDrakeIiwa, "drake-iiwa", "drake.lcmt_iiwa_status", "drake.lcmt_iiwa_command", "IIWA_STATUS",
     "IIWA_COMMAND", false, 0.005, 7, false, TorqueSemantics::kOverlay, Sign::kNegated, Sign::kNegated, Sign::kSame,
     Sign::kSame, 0},
    {Protocol::kDrakePanda, "drake-panda", "drake.lcmt_panda_status", "drake.lcmt_panda_command", "PANDA_STATUS",
     "PANDA_COMMAND", false, 0.001, 7, false, TorqueSemantics::kOverlay, Sign::kSame, Sign::kSame, Sign::kNegated,
     Sign::kSame, drake::lcmt_panda_status::CONTROL_MODE_TORQUE},
};

/// Whether the table has one row per protocol, each at its enumerator's place.
constexpr bool conventions_cover_every_protocol() {
  if (static_cast<int>(std::size(kProtocolConventions)) != enumerators::count<Protocol>()) return false;
  for (std::size_t i = 0; i < std::size(kProtocolConventions); ++i) {
    if (kProtocolConventions[i].protocol != static_cast<Protocol>(i)) return false;
  }
  return true;
}
static_assert(conventions_cover_every_protocol(), "kProtocolConventions: one row per Protocol, in its order");

/// The row of a protocol.
constexpr const ProtocolConventions& conventions(Protocol protocol) {
  return kProtocolConventions[static_cast<std::size_t>(protocol)];
}

}  // namespace chasles::controller
