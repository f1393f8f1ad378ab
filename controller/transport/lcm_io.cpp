#include "controller/transport/lcm_io.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstring>

#include "core/lie/so3.hpp"
#include "lcmtypes/checked.hpp"

namespace chasles::controller {

void Rejections::add(const std::string& reason) {
  Reason& slot = latest_.back();
  const size_t n = std::min(reason.size(), slot.size() - 1);
  std::copy_n(reason.begin(), n, slot.begin());
  slot[n] = '\0';
  latest_.publish();
  count_.fetch_add(1, std::memory_order_relaxed);
}

const char* Rejections::last() {
  latest_.read(last_);
  return last_.data();
}

StateReceiver::StateReceiver(int num_joints, Mailbox<JointState>& mailbox, Protocol protocol)
    : reader_(protocol, num_joints), mailbox_(mailbox) {}

std::string StateReceiver::receive(const void* data, size_t size, int64_t arrival_ns) {
  if (std::string why = reader_.read(data, size, arrival_ns, mailbox_.back()); !why.empty()) return why;
  mailbox_.publish();
  return {};
}

TargetReceiver::TargetReceiver(int num_joints, SpscRing<Target>& queue)
    : num_joints_(num_joints), target_(num_joints), queue_(queue) {
  message_.joint_position.reserve(size_t(num_joints));
}

std::string TargetReceiver::receive(const void* data, size_t size) {
  // 0 entries (HOLD, CARTESIAN) or the arm's count; the controller says which the mode needs.
  if (std::string why = messages::decode_checked(data, size, message_, num_joints_); !why.empty()) return why;
  target_.mode = message_.mode;  // as it came (wire_is_value<Target::Mode>): the controller names an unknown one
  target_.num_joints = message_.num_joints;
  target_.q.setZero();
  for (int i = 0; i < message_.num_joints; ++i) target_.q(i) = message_.joint_position[size_t(i)];
  target_.position = Eigen::Map<const Eigen::Vector3d>(message_.tip_position);
  target_.quaternion = Eigen::Map<const Eigen::Vector4d>(message_.tip_quaternion);
  target_.duration = message_.duration;
  if (!queue_.push(target_)) return "not taken: the controller has not caught up with the targets before it";
  return {};
}

SetpointReceiver::SetpointReceiver(int num_joints, SpscRing<Setpoint>& queue)
    : num_joints_(num_joints), setpoint_(num_joints), queue_(queue) {
  message_.position.reserve(size_t(num_joints));
  message_.velocity.reserve(size_t(num_joints));
}

std::string SetpointReceiver::receive(const void* data, size_t size) {
  if (std::string why = messages::decode_checked(data, size, message_, num_joints_, messages::Finite::Required);
      !why.empty()) {
    return why;
  }
  setpoint_.utime = message_.utime;
  setpoint_.q = Eigen::Map<const Eigen::VectorXd>(message_.position.data(), num_joints_);
  setpoint_.qd = Eigen::Map<const Eigen::VectorXd>(message_.velocity.data(), num_joints_);
  if (!queue_.push(setpoint_)) return "not taken: the controller has not caught up with the setpoints before it";
  return {};
}

std::string TipSetpointReceiver::receive(const void* data, size_t size) {
  if (std::string why = messages::decode_checked(data, size, message_, messages::kAnyArm, messages::Finite::Required);
      !why.empty()) {
    return why;
  }
  setpoint_.utime = message_.utime;
  setpoint_.position = Eigen::Map<const Eigen::Vector3d>(message_.position);
  setpoint_.quaternion = Eigen::Map<const Eigen::Vector4d>(message_.quaternion);
  setpoint_.twist = Eigen::Map<const Vector6d>(message_.twist);
  if (!queue_.push(setpoint_)) return "not taken: the controller has not caught up with the setpoints before it";
  return {};
}

JogReceiver::JogReceiver(int num_joints, SpscRing<Jog>& queue) : num_joints_(num_joints), jog_(num_joints), queue_(queue) {
  message_.joint_velocity.reserve(size_t(num_joints));
}

std::string JogReceiver::receive(const void* data, size_t size) {
  if (std::string why = messages::decode_checked(data, size, message_, num_joints_, messages::Finite::Required);
      !why.empty()) {
    return why;
  }
  if (message_.kind == to_wire(Jog::kJointVelocity) && message_.num_joints != num_joints_) {
    return "JOINT_VELOCITY for " + std::to_string(message_.num_joints) + " joints; the arm has " +
           std::to_string(num_joints_);
  }
  jog_.utime = message_.utime;
  // As they came (wire_is_value<Jog::Kind>, <Jog::Frame>): the controller names an unknown one.
  jog_.kind = message_.kind;
  jog_.frame = message_.frame;
  if (message_.num_joints == num_joints_) {
    jog_.joint_velocity = Eigen::Map<const Eigen::VectorXd>(message_.joint_velocity.data(), num_joints_);
  } else {
    jog_.joint_velocity.setZero();
  }
  jog_.twist = Eigen::Map<const Vector6d>(message_.twist);
  if (!queue_.push(jog_)) return "not taken: the controller has not caught up with the jog commands before it";
  return {};
}

TrajectoryReceiver::TrajectoryReceiver(const RobotModel& model, SpscRing<motion::Waypoints>& queue)
    : waypoints_(model.dof()), column_(size_t(model.dof()), -1), queue_(queue) {
  for (const Joint& joint : model.joints()) names_.push_back(joint.name);
  message_.joint_names.resize(names_.size());
  for (std::string& name : message_.joint_names) name.reserve(64);
}

std::string TrajectoryReceiver::receive(const void* data, size_t size) {
  const int n = static_cast<int>(names_.size());
  if (std::string why = messages::decode_checked(data, size, message_, n, messages::Finite::Required); !why.empty()) {
    return why;
  }
  const joint_trajectory_t& m = message_;
  // Built only for a refusal (after the node's "trajectory "): a trajectory taken costs no string.
  const auto id = [&m] { return std::to_string(m.id) + ": "; };
  if (m.num_points < 1 || m.num_points > motion::Waypoints::kMaxPoints) {
    return id() + std::to_string(m.num_points) + " waypoints; 1 to " + std::to_string(motion::Waypoints::kMaxPoints) + " are taken";
  }
  if ((m.num_velocities != 0 && m.num_velocities != m.num_points) ||
      (m.num_accelerations != 0 && m.num_accelerations != m.num_points)) {
    return id() + "velocities and accelerations come for every waypoint or none (" + std::to_string(m.num_points) +
           " waypoints, " + std::to_string(m.num_velocities) + " velocities, " + std::to_string(m.num_accelerations) +
           " accelerations)";
  }
  if (m.num_accelerations != 0 && m.num_velocities == 0) return id() + "accelerations without velocities";
  std::fill(column_.begin(), column_.end(), -1);
  for (int c = 0; c < n; ++c) {
    const auto it = std::find(names_.begin(), names_.end(), m.joint_names[size_t(c)]);
    if (it == names_.end()) return id() + "joint '" + m.joint_names[size_t(c)] + "' is not one of the arm's";
    int& column = column_[size_t(it - names_.begin())];
    if (column >= 0) return id() + "joint '" + m.joint_names[size_t(c)] + "' is named twice";
    column = c;
  }
  motion::Waypoints& w = waypoints_;
  w.id = m.id;
  w.count = m.num_points;
  w.has_velocities = m.num_velocities != 0;
  w.has_accelerations = m.num_accelerations != 0;
  for (int k = 0; k < m.num_points; ++k) {
    w.time(k) = m.time_from_start[size_t(k)];
    for (int i = 0; i < n; ++i) {
      const size_t c = size_t(column_[size_t(i)]);
      w.q(i, k) = m.positions[size_t(k)][c];
      w.qd(i, k) = w.has_velocities ? m.velocities[size_t(k)][c] : 0.0;
      w.qdd(i, k) = w.has_accelerations ? m.accelerations[size_t(k)][c] : 0.0;
    }
  }
  for (int i = 0; i < n; ++i) {
    w.path_tolerance(i) = m.path_tolerance[size_t(column_[size_t(i)])];
    w.goal_tolerance(i) = m.goal_tolerance[size_t(column_[size_t(i)])];
  }
  w.goal_time = m.goal_time_tolerance;
  w.time_scaling = m.time_scaling;
  if (!queue_.push(w)) return id() + "not taken: the controller has not caught up with the trajectories before it";
  return {};
}

std::string law_from_message(const control_mode_t& m, int n, LawSettings& s) {
  if (!from_wire(m.law, s.law)) {
    std::string known;
    for (const auto& [l, w] : WireTable<Law>::kPairs) {
      known += (known.empty() ? "" : ", ") + std::to_string(w) + " " + to_string(l);
    }
    return "unknown law " + std::to_string(m.law) + " (" + known + ")";
  }
  if (s.law == Law::kJointImpedance && m.num_joints != n) {
    return "a joint impedance needs joint_stiffness for each of the " + std::to_string(n) + " joints";
  }
  s.joint_stiffness.setZero();
  s.joint_damping.setZero();
  for (int i = 0; i < m.num_joints; ++i) {
    s.joint_stiffness(i) = m.joint_stiffness[size_t(i)];
    s.joint_damping(i) = m.joint_damping[size_t(i)];
  }
  s.damping_from_ratio = m.num_joints == 0 || s.joint_damping.isZero(0.0);
  s.damping_ratio = m.damping_ratio;
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) s.cartesian_stiffness(r, c) = m.cartesian_stiffness[r][c];
  }
  const Eigen::Vector4d wxyz = Eigen::Map<const Eigen::Vector4d>(m.stiffness_frame_quaternion);
  if (s.law == Law::kCartesianImpedance && std::abs(wxyz.norm() - 1.0) > kQuaternionNormTolerance) {
    return "stiffness_frame_quaternion (w, x, y, z) has norm " + std::to_string(wxyz.norm()) + ", not 1";
  }
  const Eigen::Quaterniond q(wxyz(0), wxyz(1), wxyz(2), wxyz(3));
  s.T_tip_frame = Transform(wxyz.norm() > 0.0 ? q.normalized().toRotationMatrix() : Matrix3d::Identity(),
                            Eigen::Map<const Eigen::Vector3d>(m.stiffness_frame_position));
  s.fixed_posture = m.num_posture == n && n > 0;
  s.nullspace_posture.setZero();
  for (int i = 0; i < m.num_posture; ++i) s.nullspace_posture(i) = m.nullspace_posture[size_t(i)];
  s.nullspace_stiffness = m.nullspace_stiffness;
  return {};
}

ModeReceiver::ModeReceiver(int num_joints, SpscRing<LawSettings>& queue)
    : num_joints_(num_joints), settings_(num_joints), queue_(queue) {
  for (auto* v : {&message_.joint_stiffness, &message_.joint_damping, &message_.nullspace_posture}) {
    v->reserve(size_t(num_joints));
  }
}

std::string ModeReceiver::receive(const void* data, size_t size) {
  if (std::string why = messages::decode_checked(data, size, message_, num_joints_, messages::Finite::Required);
      !why.empty()) {
    return why;
  }
  if (std::string why = law_from_message(message_, num_joints_, settings_); !why.empty()) return why;
  if (!queue_.push(settings_)) return "not taken: the controller has not caught up with the modes before it";
  return {};
}

PayloadReceiver::PayloadReceiver(Mailbox<Payload>& mailbox, Doorbell& bell) : mailbox_(mailbox), bell_(bell) {}

std::string SceneReceiver::receive(const void* data, size_t size) {
  if (size > SceneBytes::kMax) {
    return "of " + std::to_string(size) + " bytes, more than a scene may take (" + std::to_string(SceneBytes::kMax) + ")";
  }
  SceneBytes& slot = mailbox_.back();
  std::memcpy(slot.bytes.data(), data, size);
  slot.size = size;
  mailbox_.publish();
  bell_.ring();
  return {};
}

std::string PayloadReceiver::receive(const void* data, size_t size) {
  if (std::string why = messages::decode_checked(data, size, message_, messages::kAnyArm, messages::Finite::Required);
      !why.empty()) {
    return why;
  }
  Payload payload;
  payload.mass = message_.mass;
  payload.centre = Eigen::Map<const Eigen::Vector3d>(message_.centre_of_mass);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) payload.inertia(r, c) = message_.inertia[r][c];
  }
  if (std::string why = payload_problem(payload); !why.empty()) return why;
  mailbox_.write(payload);
  bell_.ring();
  return {};
}

SentCommands::SentCommands() {
  for (auto& slot : utime_) slot.store(INT64_MIN, std::memory_order_relaxed);
}

void SentCommands::record(int64_t seq, int64_t utime) {
  utime_[static_cast<size_t>(seq % kWindow)].store(utime, std::memory_order_release);
  latest_.store(seq, std::memory_order_release);
}

bool SentCommands::take(int64_t seq, int64_t utime) {
  const int64_t latest = latest_.load(std::memory_order_acquire);
  if (seq <= 0 || seq > latest || seq <= latest - kWindow || utime == INT64_MIN) return false;
  int64_t expected = utime;
  return utime_[static_cast<size_t>(seq % kWindow)].compare_exchange_strong(expected, INT64_MIN,
                                                                            std::memory_order_acq_rel);
}

CommandWatch::CommandWatch(SentCommands& sent) : sent_(sent) {}

bool CommandWatch::receive(const void* data, size_t size) {
  const bool command = messages::decode_checked(data, size, message_).empty();
  if (command && sent_.take(message_.seq, message_.utime)) return false;
  if (foreign_.load(std::memory_order_relaxed) == 0) {
    first_seq_.store(command ? message_.seq : -1, std::memory_order_relaxed);
    first_state_seq_.store(command ? message_.state_seq : -1, std::memory_order_relaxed);
  }
  foreign_.fetch_add(1, std::memory_order_release);
  return true;
}

}  // namespace chasles::controller
