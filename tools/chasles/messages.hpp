// The chasles message types read from untrusted bytes (a log file, the network), and laid out as
// table rows for export.
//
// lcm-gen's decoders trust the counts they read: a negative or huge num_joints makes them resize
// to gigabytes, a zero-length string makes them throw, and num_joints = 0 leaves the arrays of a
// reused message as they were. So, as the controller does (controller/lcm_io.cpp), the fingerprint,
// the string length and num_joints are read from the raw bytes and checked, the exact encoded size
// is compared with the bytes there are, and only then does the generated decoder run, into a
// fresh message.
#pragma once

#include <chasles/arm_target_t.hpp>
#include <chasles/controller_status_t.hpp>
#include <chasles/joint_torque_command_t.hpp>
#include <chasles/robot_state_t.hpp>
#include <cstdint>
#include <string>
#include <vector>

namespace chasles::cli {

enum class MessageType { Unknown, State, Command, Target, Status };

/// The chasles type whose fingerprint the bytes start with, or Unknown.
MessageType message_type(const void* data, size_t size);

/// "chasles.robot_state_t", ... ; "unknown" for Unknown.
std::string type_name(MessageType type);

/// Decodes `data` into `message`; an empty string, or why the bytes are not a valid Message
/// ("truncated: 12 bytes", "num_joints -3", "of 200 bytes; expected 196"). Non-finite numbers are
/// not refused here: a log should show what was sent.
template <typename Message>
std::string decode_checked(const void* data, size_t size, Message& message);

extern template std::string decode_checked(const void*, size_t, robot_state_t&);
extern template std::string decode_checked(const void*, size_t, joint_torque_command_t&);
extern template std::string decode_checked(const void*, size_t, arm_target_t&);
extern template std::string decode_checked(const void*, size_t, controller_status_t&);

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
