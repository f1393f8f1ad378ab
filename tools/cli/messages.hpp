// The chasles message types read from untrusted bytes (a log file, the network), and laid out as
// table rows for export.
//
// Bytes are decoded by the one checked decoder of each type (lcmtypes/checked.hpp), as the
// controller and the plant decode them; non-finite numbers are kept, since a log should show
// what was sent.
#pragma once

#include "lcmtypes/checked.hpp"
#include <cstdint>
#include <string>
#include <vector>

namespace chasles::cli {

using messages::decode_checked;

/// chasles's types, and Drake's iiwa and Panda messages (the arm's driver may speak those).
enum class MessageType {
  Unknown, State, Command, Target, Status, Mode, Payload, Truth, Setpoint, Jog, TipSetpoint, Contact,
  IiwaStatus, IiwaCommand, PandaStatus, PandaCommand
};

/// The type whose fingerprint the bytes start with, or Unknown.
MessageType message_type(const void* data, size_t size);

/// "chasles.robot_state_t", ..., "drake.lcmt_iiwa_status", ...; "unknown" for Unknown.
std::string type_name(MessageType type);

/// The num_joints of a valid message of `type`, or -1 when the bytes do not decode as one.
int joint_count(MessageType type, const void* data, size_t size);

/// The names of the joints of an n-joint message: `names` when it has n entries, else j0..j(n-1).
std::vector<std::string> joint_labels(const std::vector<std::string>& names, int n);

/// One message as table cells, one per field, in the .lcm contract's order: arrays by joint name
/// ("position[panda_joint1]"), tip positions by axis ("tip_position[x]"), quaternions by component
/// ("tip_quaternion[w]"). Numbers in shortest round-trip form; booleans 0/1; strings as they are.
struct Cells {
  std::vector<std::string> names;
  std::vector<std::string> values;
};

/// Decodes and lays out one message of `type`; an empty string or why it could not be decoded.
/// `joints` labels the joint arrays (see joint_labels).
std::string message_cells(MessageType type, const void* data, size_t size, const std::vector<std::string>& joints,
                          Cells& cells);

/// A double in shortest round-trip form ("0.1", "-2.5e-07", "nan", "inf").
std::string number_text(double x);

}  // namespace chasles::cli
