#include "tools/cli/messages.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <type_traits>
#include <cmath>

namespace chasles::cli {
namespace {

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
  /// A wrench (m, f): columns name[mx] … name[fz].
  void wrench(const char* name, const double* values) { sextuple(name, values, {"mx", "my", "mz", "fx", "fy", "fz"}); }
  /// A twist (ω, v): columns name[wx] … name[vz].
  void twist(const char* name, const double* values) { sextuple(name, values, {"wx", "wy", "wz", "vx", "vy", "vz"}); }

 private:
  void sextuple(const char* name, const double* values, const std::array<const char*, 6>& labels) {
    for (size_t i = 0; i < 6; ++i) {
      cells_.names.push_back(std::string(name) + "[" + labels[i] + "]");
      cells_.values.push_back(number_text(values[i]));
    }
  }

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
  row.joints("tau_ext", m.tau_ext);
  row.wrench("tip_wrench_ext", m.tip_wrench_ext);
  row.add("contact", int64_t{m.contact ? 1 : 0});
  row.add("collision", int64_t{m.collision ? 1 : 0});
  row.add("contacts", m.contacts);
  row.add("reflexes", m.reflexes);
  row.add("law", int64_t{m.law});
  row.add("payload_mass", m.payload_mass);
  row.add("state_period", m.state_period);
  row.add("trajectory_id", m.trajectory_id);
  row.add("trajectory_outcome", int64_t{m.trajectory_outcome});
  row.add("trajectory_elapsed", m.trajectory_elapsed);
  row.add("trajectory_duration", m.trajectory_duration);
  row.add("trajectory_time_scale", m.trajectory_time_scale);
  row.add("trajectory_waypoint", int64_t{m.trajectory_waypoint});
  row.add("trajectory_message", m.trajectory_message);
  row.add("streaming", int64_t{m.streaming ? 1 : 0});
  row.add("setpoints", m.setpoints);
  row.add("setpoints_dropped", m.setpoints_dropped);
  row.add("jogging", int64_t{m.jogging ? 1 : 0});
  row.add("jogs", m.jogs);
  row.add("jogs_dropped", m.jogs_dropped);
  row.add("jog_condition", m.jog_condition);
  row.add("jog_scale", m.jog_scale);
  row.add("jog_limited_by", int64_t{m.jog_limited_by});
  row.add("jog_joint", int64_t{m.jog_joint});
  row.add("contact_link", m.contact_link);
  row.add("contact_located_flag", int64_t{m.contact_located_flag ? 1 : 0});
  row.components("contact_point", m.contact_point, "xyz");
  row.components("contact_force", m.contact_force, "xyz");
}

void lay_out(const joint_setpoint_t& m, Row& row) {
  row.add("utime", m.utime);
  row.add("num_joints", int64_t{m.num_joints});
  row.joints("position", m.position);
  row.joints("velocity", m.velocity);
}

void lay_out(const tip_setpoint_t& m, Row& row) {
  row.add("utime", m.utime);
  row.components("position", m.position, "xyz");
  row.components("quaternion", m.quaternion, "wxyz");
  row.twist("twist", m.twist);
}

void lay_out(const contact_estimate_t& m, Row& row) {
  row.add("utime", m.utime);
  row.add("seq", m.seq);
  row.add("state", int64_t{m.state});
  row.add("contact", int64_t{m.contact ? 1 : 0});
  row.add("link", m.link);
  row.add("body", int64_t{m.body});
  row.components("point", m.point, "xyz");
  row.components("normal", m.normal, "xyz");
  row.components("force", m.force, "xyz");
  row.add("residual", m.residual);
  row.add("tau_ext_norm", m.tau_ext_norm);
  row.add("compute_us", m.compute_us);
}

void lay_out(const jog_command_t& m, Row& row) {
  row.add("utime", m.utime);
  row.add("kind", int64_t{m.kind});
  row.add("frame", int64_t{m.frame});
  row.add("num_joints", int64_t{m.num_joints});
  row.joints("joint_velocity", m.joint_velocity);
  row.twist("twist", m.twist);
}

void lay_out(const control_mode_t& m, Row& row) {
  row.add("utime", m.utime);
  row.add("law", int64_t{m.law});
  row.add("num_joints", int64_t{m.num_joints});
  row.joints("joint_stiffness", m.joint_stiffness);
  row.joints("joint_damping", m.joint_damping);
  row.add("damping_ratio", m.damping_ratio);
  for (int r = 0; r < 6; ++r) {
    const std::string name = "cartesian_stiffness[" + std::to_string(r) + "]";
    row.components(name.c_str(), m.cartesian_stiffness[r], "012345");
  }
  row.components("stiffness_frame_position", m.stiffness_frame_position, "xyz");
  row.components("stiffness_frame_quaternion", m.stiffness_frame_quaternion, "wxyz");
  row.add("num_posture", int64_t{m.num_posture});
  row.joints("nullspace_posture", m.nullspace_posture);
  row.add("nullspace_stiffness", m.nullspace_stiffness);
}

void lay_out(const payload_t& m, Row& row) {
  row.add("utime", m.utime);
  row.add("mass", m.mass);
  row.components("centre_of_mass", m.centre_of_mass, "xyz");
  for (int r = 0; r < 3; ++r) {
    const std::string name = std::string("inertia[") + "xyz"[r] + "]";
    row.components(name.c_str(), m.inertia[r], "xyz");
  }
}

void lay_out(const sim_truth_t& m, Row& row) {
  row.add("utime", m.utime);
  row.add("seq", m.seq);
  row.add("num_joints", int64_t{m.num_joints});
  row.joints("tau_ext", m.tau_ext);
  row.wrench("tip_wrench_ext", m.tip_wrench_ext);
  row.add("contact", int64_t{m.contact ? 1 : 0});
  // A table has a fixed set of columns: the count, and the contact with the largest force
  // (empty cells when there is none).
  row.add("num_contacts", int64_t{m.num_contacts});
  size_t largest = 0;
  const auto force = [&m](size_t k) { return std::hypot(m.contact_force[k][0], m.contact_force[k][1], m.contact_force[k][2]); };
  for (size_t k = 1; k < size_t(m.num_contacts); ++k)
    if (force(k) > force(largest)) largest = k;
  const bool any = m.num_contacts > 0;
  row.add("largest_contact_link", any ? m.contact_link[largest] : std::string());
  row.add("largest_contact_other", any ? m.contact_other[largest] : std::string());
  for (const auto& [name, rows] : {std::pair{"largest_contact_point", &m.contact_point},
                                   std::pair{"largest_contact_normal", &m.contact_normal},
                                   std::pair{"largest_contact_force", &m.contact_force}}) {
    for (int i = 0; i < 3; ++i) {
      row.add((std::string(name) + "[" + "xyz"[i] + "]").c_str(), any ? number_text((*rows)[largest][size_t(i)]) : std::string());
    }
  }
}

void lay_out(const drake::lcmt_iiwa_status& m, Row& row) {
  row.add("utime", m.utime);
  row.add("num_joints", int64_t{m.num_joints});
  row.joints("joint_position_measured", m.joint_position_measured);
  row.joints("joint_velocity_estimated", m.joint_velocity_estimated);
  row.joints("joint_position_commanded", m.joint_position_commanded);
  row.joints("joint_position_ipo", m.joint_position_ipo);
  row.joints("joint_torque_measured", m.joint_torque_measured);
  row.joints("joint_torque_commanded", m.joint_torque_commanded);
  row.joints("joint_torque_external", m.joint_torque_external);
}

void lay_out(const drake::lcmt_iiwa_command& m, Row& row) {
  row.add("utime", m.utime);
  row.add("num_joints", int64_t{m.num_joints});
  row.joints("joint_position", m.joint_position);
  row.add("num_torques", int64_t{m.num_torques});
  row.joints("joint_torque", m.joint_torque);
}

void lay_out(const drake::lcmt_panda_status& m, Row& row) {
  row.add("utime", m.utime);
  row.add("num_joints", int64_t{m.num_joints});
  row.joints("joint_position", m.joint_position);
  row.joints("joint_position_desired", m.joint_position_desired);
  row.joints("joint_velocity", m.joint_velocity);
  row.joints("joint_velocity_desired", m.joint_velocity_desired);
  row.joints("joint_acceleration_desired", m.joint_acceleration_desired);
  row.joints("joint_torque", m.joint_torque);
  row.joints("joint_torque_desired", m.joint_torque_desired);
  row.joints("joint_torque_external", m.joint_torque_external);
  row.add("control_command_success_rate", m.control_command_success_rate);
  row.add("robot_mode", int64_t{m.robot_mode});
  row.add("robot_utime", m.robot_utime);
  row.add("control_mode", int64_t{m.control_mode});
}

void lay_out(const drake::lcmt_panda_command& m, Row& row) {
  row.add("utime", m.utime);
  row.add("num_joint_position", int64_t{m.num_joint_position});
  row.joints("joint_position", m.joint_position);
  row.add("num_joint_velocity", int64_t{m.num_joint_velocity});
  row.joints("joint_velocity", m.joint_velocity);
  row.add("num_joint_torque", int64_t{m.num_joint_torque});
  row.joints("joint_torque", m.joint_torque);
  row.add("control_mode_expected", int64_t{m.control_mode_expected});
}

// The widest joint array of a message: its num_joints (a control mode's posture may be the wider;
// a payload has none).
template <typename Message>
int joints_of(const Message& m) {
  if constexpr (messages::detail::kCountless<Message>) {
    return 0;
  } else if constexpr (std::is_same_v<Message, control_mode_t>) {
    return std::max(m.num_joints, m.num_posture);
  } else if constexpr (std::is_same_v<Message, drake::lcmt_iiwa_command>) {
    return std::max(m.num_joints, m.num_torques);
  } else if constexpr (std::is_same_v<Message, drake::lcmt_panda_command>) {
    return std::max({m.num_joint_position, m.num_joint_velocity, m.num_joint_torque});
  } else {
    return m.num_joints;
  }
}

template <typename Message>
int count_of(const void* data, size_t size) {
  Message message;
  return messages::decode_checked(data, size, message).empty() ? joints_of(message) : -1;
}

template <typename Message>
std::string cells_of(const void* data, size_t size, const std::vector<std::string>& joints, Cells& cells) {
  Message message;
  if (std::string why = messages::decode_checked(data, size, message); !why.empty()) return why;
  if (size_t(joints_of(message)) > joints.size()) {
    return "num_joints " + std::to_string(joints_of(message)) + ", more than the " + std::to_string(joints.size()) +
           " joint columns";
  }
  Row row(cells, joints);
  lay_out(message, row);
  return {};
}

}  // namespace

MessageType message_type(const void* data, size_t size) {
  if (messages::starts_as<robot_state_t>(data, size)) return MessageType::State;
  if (messages::starts_as<joint_torque_command_t>(data, size)) return MessageType::Command;
  if (messages::starts_as<arm_target_t>(data, size)) return MessageType::Target;
  if (messages::starts_as<controller_status_t>(data, size)) return MessageType::Status;
  if (messages::starts_as<control_mode_t>(data, size)) return MessageType::Mode;
  if (messages::starts_as<payload_t>(data, size)) return MessageType::Payload;
  if (messages::starts_as<sim_truth_t>(data, size)) return MessageType::Truth;
  if (messages::starts_as<joint_setpoint_t>(data, size)) return MessageType::Setpoint;
  if (messages::starts_as<jog_command_t>(data, size)) return MessageType::Jog;
  if (messages::starts_as<tip_setpoint_t>(data, size)) return MessageType::TipSetpoint;
  if (messages::starts_as<contact_estimate_t>(data, size)) return MessageType::Contact;
  if (messages::starts_as<drake::lcmt_iiwa_status>(data, size)) return MessageType::IiwaStatus;
  if (messages::starts_as<drake::lcmt_iiwa_command>(data, size)) return MessageType::IiwaCommand;
  if (messages::starts_as<drake::lcmt_panda_status>(data, size)) return MessageType::PandaStatus;
  if (messages::starts_as<drake::lcmt_panda_command>(data, size)) return MessageType::PandaCommand;
  return MessageType::Unknown;
}

std::string type_name(MessageType type) {
  switch (type) {
    case MessageType::State: return std::string("chasles.") + robot_state_t::getTypeName();
    case MessageType::Command: return std::string("chasles.") + joint_torque_command_t::getTypeName();
    case MessageType::Target: return std::string("chasles.") + arm_target_t::getTypeName();
    case MessageType::Status: return std::string("chasles.") + controller_status_t::getTypeName();
    case MessageType::Mode: return std::string("chasles.") + control_mode_t::getTypeName();
    case MessageType::Payload: return std::string("chasles.") + payload_t::getTypeName();
    case MessageType::Truth: return std::string("chasles.") + sim_truth_t::getTypeName();
    case MessageType::Setpoint: return std::string("chasles.") + joint_setpoint_t::getTypeName();
    case MessageType::Jog: return std::string("chasles.") + jog_command_t::getTypeName();
    case MessageType::TipSetpoint: return std::string("chasles.") + tip_setpoint_t::getTypeName();
    case MessageType::Contact: return std::string("chasles.") + contact_estimate_t::getTypeName();
    case MessageType::IiwaStatus: return std::string("drake.") + drake::lcmt_iiwa_status::getTypeName();
    case MessageType::IiwaCommand: return std::string("drake.") + drake::lcmt_iiwa_command::getTypeName();
    case MessageType::PandaStatus: return std::string("drake.") + drake::lcmt_panda_status::getTypeName();
    case MessageType::PandaCommand: return std::string("drake.") + drake::lcmt_panda_command::getTypeName();
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
    case MessageType::Mode: return count_of<control_mode_t>(data, size);
    case MessageType::Payload: return count_of<payload_t>(data, size);
    case MessageType::Truth: return count_of<sim_truth_t>(data, size);
    case MessageType::Setpoint: return count_of<joint_setpoint_t>(data, size);
    case MessageType::Jog: return count_of<jog_command_t>(data, size);
    case MessageType::TipSetpoint: return count_of<tip_setpoint_t>(data, size);
    case MessageType::Contact: return count_of<contact_estimate_t>(data, size);
    case MessageType::IiwaStatus: return count_of<drake::lcmt_iiwa_status>(data, size);
    case MessageType::IiwaCommand: return count_of<drake::lcmt_iiwa_command>(data, size);
    case MessageType::PandaStatus: return count_of<drake::lcmt_panda_status>(data, size);
    case MessageType::PandaCommand: return count_of<drake::lcmt_panda_command>(data, size);
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
    case MessageType::Mode: return cells_of<control_mode_t>(data, size, joints, cells);
    case MessageType::Payload: return cells_of<payload_t>(data, size, joints, cells);
    case MessageType::Truth: return cells_of<sim_truth_t>(data, size, joints, cells);
    case MessageType::Setpoint: return cells_of<joint_setpoint_t>(data, size, joints, cells);
    case MessageType::Jog: return cells_of<jog_command_t>(data, size, joints, cells);
    case MessageType::TipSetpoint: return cells_of<tip_setpoint_t>(data, size, joints, cells);
    case MessageType::Contact: return cells_of<contact_estimate_t>(data, size, joints, cells);
    case MessageType::IiwaStatus: return cells_of<drake::lcmt_iiwa_status>(data, size, joints, cells);
    case MessageType::IiwaCommand: return cells_of<drake::lcmt_iiwa_command>(data, size, joints, cells);
    case MessageType::PandaStatus: return cells_of<drake::lcmt_panda_status>(data, size, joints, cells);
    case MessageType::PandaCommand: return cells_of<drake::lcmt_panda_command>(data, size, joints, cells);
    case MessageType::Unknown: break;
  }
  return "not a chasles or Drake message (unknown fingerprint)";
}

std::string number_text(double x) {
  if (std::isnan(x)) return "nan";
  if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), x);
  return std::string(buffer, result.ptr);
}

}  // namespace chasles::cli
