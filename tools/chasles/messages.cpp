#include "messages.hpp"

#include <charconv>
#include <cmath>
#include <lcm/lcm_coretypes.h>

namespace chasles::cli {
namespace {

// Byte offsets in the encoded messages, after the 8-byte fingerprint and the fields the .lcm
// contract puts first: robot_state_t utime, seq | joint_torque_command_t utime, seq, state_seq |
// arm_target_t utime, mode | controller_status_t utime, state, then the message string's length.
constexpr int kStateCount = 8 + 8 + 8;
constexpr int kCommandCount = 8 + 8 + 8 + 8;
constexpr int kTargetCount = 8 + 8 + 1;
constexpr int kStatusStringLength = 8 + 8 + 1;

bool read_int32(const void* data, size_t size, size_t offset, int32_t& value) {
  if (offset + 4 > size) return false;
  return __int32_t_decode_array(data, static_cast<int>(offset), static_cast<int>(size - offset), &value, 1) == 4;
}

bool fingerprint_is(const void* data, size_t size, int64_t hash) {
  int64_t fingerprint = 0;
  return size >= 8 && __int64_t_decode_array(data, 0, static_cast<int>(size), &fingerprint, 1) == 8 &&
         fingerprint == hash;
}

// A count that cannot be right for a message of `size` bytes, whatever its other fields: each
// entry is at least one 8-byte double.
std::string check_count(int32_t count, size_t size) {
  if (count < 0 || uint64_t(count) * 8 > size) {
    return "num_joints " + std::to_string(count) + " in a message of " + std::to_string(size) + " bytes";
  }
  return {};
}

// Sizes every joint array of `message` for `count` joints (so getEncodedSize() is what the bytes
// should be) and reads the message's string length where there is one.
std::string prepare(const void* data, size_t size, robot_state_t& m) {
  if (!read_int32(data, size, kStateCount, m.num_joints)) return "truncated: " + std::to_string(size) + " bytes";
  if (std::string why = check_count(m.num_joints, size); !why.empty()) return why;
  for (auto* v : {&m.position, &m.velocity, &m.effort}) v->assign(size_t(m.num_joints), 0.0);
  return {};
}

std::string prepare(const void* data, size_t size, joint_torque_command_t& m) {
  if (!read_int32(data, size, kCommandCount, m.num_joints)) return "truncated: " + std::to_string(size) + " bytes";
  if (std::string why = check_count(m.num_joints, size); !why.empty()) return why;
  m.torque.assign(size_t(m.num_joints), 0.0);
  return {};
}

std::string prepare(const void* data, size_t size, arm_target_t& m) {
  if (!read_int32(data, size, kTargetCount, m.num_joints)) return "truncated: " + std::to_string(size) + " bytes";
  if (std::string why = check_count(m.num_joints, size); !why.empty()) return why;
  m.joint_position.assign(size_t(m.num_joints), 0.0);
  return {};
}

std::string prepare(const void* data, size_t size, controller_status_t& m) {
  int32_t length = 0;  // of the message string, with its terminating NUL
  if (!read_int32(data, size, kStatusStringLength, length)) return "truncated: " + std::to_string(size) + " bytes";
  if (length < 1 || uint64_t(length) > size) {
    return "message string of " + std::to_string(length) + " bytes in a message of " + std::to_string(size) + " bytes";
  }
  m.message.assign(size_t(length - 1), ' ');
  if (!read_int32(data, size, size_t(kStatusStringLength) + 4 + size_t(length), m.num_joints)) {
    return "truncated: " + std::to_string(size) + " bytes";
  }
  if (std::string why = check_count(m.num_joints, size); !why.empty()) return why;
  for (auto* v : {&m.q, &m.q_desired, &m.tracking_error, &m.torque}) v->assign(size_t(m.num_joints), 0.0);
  return {};
}

// Appends cells; the joint arrays take `width` columns, empty where a message has fewer entries
// (a HOLD target has none).
class Row {
 public:
  Row(Cells& cells, const std::vector<std::string>& joints) : cells_(cells), joints_(joints) {
    cells_.names.clear();
    cells_.values.clear();
  }
  void add(const char* name, std::string value) {
    cells_.names.emplace_back(name);
    cells_.values.push_back(std::move(value));
  }
  void add(const char* name, int64_t value) { add(name, std::to_string(value)); }
  void add(const char* name, double value) { add(name, number_text(value)); }
  void joints(const char* name, const std::vector<double>& values) {
    for (size_t i = 0; i < joints_.size(); ++i) {
      cells_.names.push_back(std::string(name) + "[" + joints_[i] + "]");
      cells_.values.push_back(i < values.size() ? number_text(values[i]) : std::string());
    }
  }
  void components(const char* name, const double* values, const char* labels) {
    for (size_t i = 0; labels[i] != '\0'; ++i) {
      cells_.names.push_back(std::string(name) + "[" + labels[i] + "]");
      cells_.values.push_back(number_text(values[i]));
    }
  }

 private:
  Cells& cells_;
  const std::vector<std::string>& joints_;
};

void lay_out(const robot_state_t& m, Row& row) {
  row.add("utime", m.utime);
  row.add("seq", m.seq);
  row.add("num_joints", int64_t{m.num_joints});
  row.joints("position", m.position);
  row.joints("velocity", m.velocity);
  row.joints("effort", m.effort);
}

void lay_out(const joint_torque_command_t& m, Row& row) {
  row.add("utime", m.utime);
  row.add("seq", m.seq);
  row.add("state_seq", m.state_seq);
  row.add("num_joints", int64_t{m.num_joints});
  row.joints("torque", m.torque);
}

void lay_out(const arm_target_t& m, Row& row) {
  row.add("utime", m.utime);
  row.add("mode", int64_t{m.mode});
  row.add("num_joints", int64_t{m.num_joints});
  row.joints("joint_position", m.joint_position);
  row.components("tip_position", m.tip_position, "xyz");
  row.components("tip_quaternion", m.tip_quaternion, "wxyz");
  row.add("duration", m.duration);
}

void lay_out(const controller_status_t& m, Row& row) {
  row.add("utime", m.utime);
  row.add("state", int64_t{m.state});
  row.add("message", m.message);
  row.add("num_joints", int64_t{m.num_joints});
  row.joints("q", m.q);
  row.joints("q_desired", m.q_desired);
  row.joints("tracking_error", m.tracking_error);
  row.components("tip_position", m.tip_position, "xyz");
  row.components("tip_quaternion", m.tip_quaternion, "wxyz");
  row.joints("torque", m.torque);
  row.add("ik_iterations", int64_t{m.ik_iterations});
  row.add("ik_residual", m.ik_residual);
  row.add("ik_converged", int64_t{m.ik_converged ? 1 : 0});
  row.add("jitter_p50_us", m.jitter_p50_us);
  row.add("jitter_p99_us", m.jitter_p99_us);
  row.add("jitter_max_us", m.jitter_max_us);
  row.add("compute_p50_us", m.compute_p50_us);
  row.add("compute_p99_us", m.compute_p99_us);
  row.add("compute_max_us", m.compute_max_us);
  row.add("latency_p50_us", m.latency_p50_us);
  row.add("latency_p99_us", m.latency_p99_us);
  row.add("latency_max_us", m.latency_max_us);
  row.add("ticks", m.ticks);
  row.add("overruns", m.overruns);
  row.add("stale_states", m.stale_states);
  row.add("rejected_messages", m.rejected_messages);
  row.add("faults", m.faults);
}

template <typename Message>
int count_of(const void* data, size_t size) {
  Message message;
  return decode_checked(data, size, message).empty() ? message.num_joints : -1;
}

template <typename Message>
std::string cells_of(const void* data, size_t size, const std::vector<std::string>& joints, Cells& cells) {
  Message message;
  if (std::string why = decode_checked(data, size, message); !why.empty()) return why;
  if (size_t(message.num_joints) > joints.size()) {
    return "num_joints " + std::to_string(message.num_joints) + ", more than the " + std::to_string(joints.size()) +
           " joint columns";
  }
  Row row(cells, joints);
  lay_out(message, row);
  return {};
}

}  // namespace

template <typename Message>
std::string decode_checked(const void* data, size_t size, Message& message) {
  if (!fingerprint_is(data, size, Message::getHash())) {
    return std::string("not a ") + Message::getTypeName() + " (wrong fingerprint)";
  }
  if (size > size_t(INT32_MAX)) return "of " + std::to_string(size) + " bytes, too large";
  message = Message{};  // lcm-gen leaves the arrays of a reused message alone when num_joints is 0
  if (std::string why = prepare(data, size, message); !why.empty()) return why;
  const int expected = message.getEncodedSize();
  if (size_t(expected) != size) {
    return "of " + std::to_string(size) + " bytes; " + std::to_string(message.num_joints) + " joints need " +
           std::to_string(expected);
  }
  if (message.decode(data, 0, static_cast<int>(size)) != expected) return "does not decode";
  return {};
}

template std::string decode_checked(const void*, size_t, robot_state_t&);
template std::string decode_checked(const void*, size_t, joint_torque_command_t&);
template std::string decode_checked(const void*, size_t, arm_target_t&);
template std::string decode_checked(const void*, size_t, controller_status_t&);

MessageType message_type(const void* data, size_t size) {
  if (fingerprint_is(data, size, robot_state_t::getHash())) return MessageType::State;
  if (fingerprint_is(data, size, joint_torque_command_t::getHash())) return MessageType::Command;
  if (fingerprint_is(data, size, arm_target_t::getHash())) return MessageType::Target;
  if (fingerprint_is(data, size, controller_status_t::getHash())) return MessageType::Status;
  return MessageType::Unknown;
}

std::string type_name(MessageType type) {
  switch (type) {
    case MessageType::State: return std::string("chasles.") + robot_state_t::getTypeName();
    case MessageType::Command: return std::string("chasles.") + joint_torque_command_t::getTypeName();
    case MessageType::Target: return std::string("chasles.") + arm_target_t::getTypeName();
    case MessageType::Status: return std::string("chasles.") + controller_status_t::getTypeName();
    case MessageType::Unknown: break;
  }
  return "unknown";
}

std::vector<std::string> joint_labels(const std::vector<std::string>& names, int n) {
  if (n >= 0 && names.size() == size_t(n)) return names;
  std::vector<std::string> labels;
  for (int i = 0; i < n; ++i) labels.push_back("j" + std::to_string(i));
  return labels;
}

int joint_count(MessageType type, const void* data, size_t size) {
  switch (type) {
    case MessageType::State: return count_of<robot_state_t>(data, size);
    case MessageType::Command: return count_of<joint_torque_command_t>(data, size);
    case MessageType::Target: return count_of<arm_target_t>(data, size);
    case MessageType::Status: return count_of<controller_status_t>(data, size);
    case MessageType::Unknown: break;
  }
  return -1;
}

std::string message_cells(MessageType type, const void* data, size_t size, const std::vector<std::string>& joints,
                          Cells& cells) {
  switch (type) {
    case MessageType::State: return cells_of<robot_state_t>(data, size, joints, cells);
    case MessageType::Command: return cells_of<joint_torque_command_t>(data, size, joints, cells);
    case MessageType::Target: return cells_of<arm_target_t>(data, size, joints, cells);
    case MessageType::Status: return cells_of<controller_status_t>(data, size, joints, cells);
    case MessageType::Unknown: break;
  }
  return "not a chasles message (unknown fingerprint)";
}

std::string number_text(double x) {
  if (std::isnan(x)) return "nan";
  if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), x);
  return std::string(buffer, result.ptr);
}

}  // namespace chasles::cli
