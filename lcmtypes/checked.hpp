// One checked decoder for every chasles message type, and for the Drake iiwa and Panda messages
// chasles speaks (lcmtypes/drake_*.lcm), beside the contracts it reads, used by every reader (the
// controller, the plant, the CLI, the fuzzers).
//
// lcm-gen's decoders trust the counts they read: a negative or huge num_joints makes them resize to
// gigabytes, a zero-length string makes them throw, and they check the buffer's size only field by
// field. So the fingerprint, the string length and num_joints are read from the raw bytes and
// checked first, the exact encoded size is compared with the bytes there are, and only then does
// the generated decoder run. The message's arrays are sized for the count the bytes give, so a
// message reused for messages of one arm is decoded without allocating.
#pragma once

#include <lcm/lcm_coretypes.h>

#include <chasles/arm_target_t.hpp>
#include <chasles/contact_estimate_t.hpp>
#include <chasles/control_mode_t.hpp>
#include <chasles/controller_status_t.hpp>
#include <chasles/jog_command_t.hpp>
#include <chasles/joint_torque_command_t.hpp>
#include <chasles/joint_setpoint_t.hpp>
#include <chasles/joint_trajectory_t.hpp>
#include <chasles/payload_t.hpp>
#include <chasles/robot_state_t.hpp>
#include <chasles/scene_t.hpp>
#include <chasles/sim_truth_t.hpp>
#include <chasles/tip_setpoint_t.hpp>
#include <drake/lcmt_iiwa_command.hpp>
#include <drake/lcmt_iiwa_status.hpp>
#include <drake/lcmt_panda_command.hpp>
#include <drake/lcmt_panda_status.hpp>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <type_traits>
#include <vector>

namespace chasles::messages {

/// The reader knows no arm (a log, a monitor): any joint count the bytes can hold.
inline constexpr int kAnyArm = -1;

/// Whether non-finite numbers refuse a message: a controller or a plant acts on them; a log
/// reader should show what was sent.
enum class Finite { Required, NotRequired };

namespace detail {

inline bool read_int32(const void* data, size_t size, size_t offset, int32_t& value) {
  // LCM's decode functions take the bytes left after the offset, not the buffer's size.
  return offset + 4 <= size &&
         __int32_t_decode_array(data, static_cast<int>(offset), static_cast<int>(size - offset), &value, 1) == 4;
}

inline bool fingerprint_is(const void* data, size_t size, int64_t hash) {
  int64_t fingerprint = 0;
  return size >= 8 && __int64_t_decode_array(data, 0, static_cast<int>(size), &fingerprint, 1) == 8 &&
         fingerprint == hash;
}

// Where num_joints sits: after the 8-byte fingerprint and the fields the .lcm contract puts first.
// controller_status_t has a string before it, whose length is read first.
inline constexpr size_t kStateCount = 8 + 8 + 8;             // utime, seq
inline constexpr size_t kCommandCount = 8 + 8 + 8 + 8;       // utime, seq, state_seq
inline constexpr size_t kTargetCount = 8 + 8 + 1;            // utime, mode
inline constexpr size_t kStatusStringLength = 8 + 8 + 1;     // utime, state
inline constexpr size_t kTruthCount = 8 + 8 + 8;             // utime, seq
inline constexpr size_t kModeCount = 8 + 8 + 1;              // utime, law
inline constexpr size_t kSetpointCount = 8 + 8;               // utime
inline constexpr size_t kJogCount = 8 + 8 + 1 + 1;            // utime, kind, frame
inline constexpr size_t kTrajectoryCounts = 8 + 8 + 8;       // utime, id: then four counts
// controller_status_t's trajectory_message follows its joint arrays (5 per joint) and 301 bytes of
// fixed-size fields, counted from the end of num_joints.
inline constexpr size_t kStatusTrajectoryStringAfterCount = 301;
// Its clearance_pair follows the trajectory_message, 55 bytes of the stream's and the jog's fields
// and the generator's three joint arrays; clearance_slowed_by follows it, a double and the two
// witness points.
inline constexpr size_t kStatusClearanceAfterTrajectory = 55;
// control_mode_t's num_posture follows its two joint arrays and 8 + 36 + 3 + 4 doubles.
inline constexpr size_t kModePostureAfterJoints = 8 * (1 + 36 + 3 + 4);
// Drake's messages: the first count follows the fingerprint and utime; a command's next count
// follows the array the one before it sizes.
inline constexpr size_t kDrakeFirstCount = 8 + 8;  // utime

inline std::string truncated(size_t size) { return "truncated: " + std::to_string(size) + " bytes"; }

// A count that cannot be right for a message of `size` bytes, whatever its other fields: each
// entry is at least one 8-byte double.
inline std::string impossible_count(int32_t count, size_t size, const char* name = "num_joints") {
  if (count < 0 || uint64_t(count) * 8 > size) {
    return std::string(name) + " " + std::to_string(count) + " in a message of " + std::to_string(size) + " bytes";
  }
  return {};
}

// Reads num_joints (and the status string's length), and sizes every array for it, so that
// getEncodedSize() is what the bytes must be.
inline std::string prepare(const void* data, size_t size, robot_state_t& m) {
  if (!read_int32(data, size, kStateCount, m.num_joints)) return truncated(size);
  if (std::string why = impossible_count(m.num_joints, size); !why.empty()) return why;
  for (auto* v : {&m.position, &m.velocity, &m.effort}) v->assign(size_t(m.num_joints), 0.0);
  return {};
}

inline std::string prepare(const void* data, size_t size, joint_torque_command_t& m) {
  if (!read_int32(data, size, kCommandCount, m.num_joints)) return truncated(size);
  if (std::string why = impossible_count(m.num_joints, size); !why.empty()) return why;
  m.torque.assign(size_t(m.num_joints), 0.0);
  return {};
}

inline std::string prepare(const void* data, size_t size, arm_target_t& m) {
  if (!read_int32(data, size, kTargetCount, m.num_joints)) return truncated(size);
  if (std::string why = impossible_count(m.num_joints, size); !why.empty()) return why;
  m.joint_position.assign(size_t(m.num_joints), 0.0);
  return {};
}

inline std::string prepare(const void* data, size_t size, controller_status_t& m) {
  int32_t length = 0;  // of the message string, with its terminating NUL
  if (!read_int32(data, size, kStatusStringLength, length)) return truncated(size);
  if (length < 1 || uint64_t(length) > size) {
    return "message string of " + std::to_string(length) + " bytes in a message of " + std::to_string(size) + " bytes";
  }
  m.message.assign(size_t(length - 1), ' ');
  const size_t count_at = kStatusStringLength + 4 + size_t(length);
  if (!read_int32(data, size, count_at, m.num_joints)) return truncated(size);
  if (std::string why = impossible_count(m.num_joints, size); !why.empty()) return why;
  for (auto* v : {&m.q, &m.q_desired, &m.tracking_error, &m.torque}) v->assign(size_t(m.num_joints), 0.0);
  int32_t trajectory_length = 0;
  const size_t trajectory_at = count_at + 4 + 40 * size_t(m.num_joints) + kStatusTrajectoryStringAfterCount;
  if (!read_int32(data, size, trajectory_at, trajectory_length)) return truncated(size);
  if (trajectory_length < 1 || uint64_t(trajectory_length) > size) {
    return "trajectory_message string of " + std::to_string(trajectory_length) + " bytes in a message of " +
           std::to_string(size) + " bytes";
  }
  m.trajectory_message.assign(size_t(trajectory_length - 1), ' ');
  size_t at = trajectory_at + 4 + size_t(trajectory_length) + kStatusClearanceAfterTrajectory + 24 * size_t(m.num_joints);
  // Each string, then the fixed-size fields up to the next: clearance_distance and
  // clearance_points after the pair, clearance_kept after slowed_by; contact_link's followers
  // need no walk.
  struct Walked {
    std::string* text;
    const char* name;
    size_t after;
  };
  for (auto [text, name, after] : {Walked{&m.clearance_pair, "clearance_pair", 8 + 6 * 8},
                                   Walked{&m.clearance_slowed_by, "clearance_slowed_by", 8},
                                   Walked{&m.contact_link, "contact_link", 0}}) {
    int32_t length_of = 0;
    if (!read_int32(data, size, at, length_of)) return truncated(size);
    if (length_of < 1 || uint64_t(length_of) > size) {
      return std::string(name) + " string of " + std::to_string(length_of) + " bytes in a message of " + std::to_string(size) + " bytes";
    }
    text->assign(size_t(length_of - 1), ' ');
    at += 4 + size_t(length_of) + after;
  }
  return {};
}

// The four counts, then each joint name's length (walking the strings), so that getEncodedSize()
// is what the bytes must be. The sender's counts bound what is allocated: each waypoint takes
// at least 8 bytes per joint, each name 5.
inline std::string prepare(const void* data, size_t size, joint_trajectory_t& m) {
  int32_t counts[4] = {};
  for (int k = 0; k < 4; ++k) {
    if (!read_int32(data, size, kTrajectoryCounts + 4 * size_t(k), counts[k])) return truncated(size);
  }
  m.num_joints = counts[0], m.num_points = counts[1], m.num_velocities = counts[2], m.num_accelerations = counts[3];
  if (std::string why = impossible_count(m.num_joints, size); !why.empty()) return why;
  for (int k = 1; k < 4; ++k) {
    if (counts[k] < 0 || uint64_t(counts[k]) * 8 * uint64_t(std::max(m.num_joints, 1)) > size) {
      static const char* const names[] = {"", "num_points", "num_velocities", "num_accelerations"};
      return std::string(names[k]) + " " + std::to_string(counts[k]) + " for " + std::to_string(m.num_joints) +
             " joints in a message of " + std::to_string(size) + " bytes";
    }
  }
  m.joint_names.resize(size_t(m.num_joints));
  size_t at = kTrajectoryCounts + 16;
  for (std::string& name : m.joint_names) {
    int32_t length = 0;
    if (!read_int32(data, size, at, length)) return truncated(size);
    if (length < 1 || uint64_t(length) > size - at) {
      return "a joint name of " + std::to_string(length) + " bytes in a message of " + std::to_string(size) + " bytes";
    }
    name.assign(size_t(length - 1), ' ');
    at += 4 + size_t(length);
  }
  return {};
}

inline std::string prepare(const void* data, size_t size, joint_setpoint_t& m) {
  if (!read_int32(data, size, kSetpointCount, m.num_joints)) return truncated(size);
  if (std::string why = impossible_count(m.num_joints, size); !why.empty()) return why;
  m.position.assign(size_t(m.num_joints), 0.0);
  m.velocity.assign(size_t(m.num_joints), 0.0);
  return {};
}

inline std::string prepare(const void* data, size_t size, jog_command_t& m) {
  if (!read_int32(data, size, kJogCount, m.num_joints)) return truncated(size);
  if (std::string why = impossible_count(m.num_joints, size); !why.empty()) return why;
  m.joint_velocity.assign(size_t(m.num_joints), 0.0);
  return {};
}

inline std::string prepare(const void* data, size_t size, control_mode_t& m) {
  if (!read_int32(data, size, kModeCount, m.num_joints)) return truncated(size);
  if (std::string why = impossible_count(m.num_joints, size); !why.empty()) return why;
  const size_t posture = kModeCount + 4 + 16 * size_t(m.num_joints) + kModePostureAfterJoints;
  if (!read_int32(data, size, posture, m.num_posture)) return truncated(size);
  if (m.num_posture < 0 || uint64_t(m.num_posture) * 8 > size) {
    return "num_posture " + std::to_string(m.num_posture) + " in a message of " + std::to_string(size) + " bytes";
  }
  m.joint_stiffness.assign(size_t(m.num_joints), 0.0);
  m.joint_damping.assign(size_t(m.num_joints), 0.0);
  m.nullspace_posture.assign(size_t(m.num_posture), 0.0);
  return {};
}

inline std::string prepare(const void* data, size_t size, drake::lcmt_iiwa_status& m) {
  if (!read_int32(data, size, kDrakeFirstCount, m.num_joints)) return truncated(size);
  if (std::string why = impossible_count(m.num_joints, size); !why.empty()) return why;
  for (auto* v : {&m.joint_position_measured, &m.joint_velocity_estimated, &m.joint_position_commanded,
                  &m.joint_position_ipo, &m.joint_torque_measured, &m.joint_torque_commanded,
                  &m.joint_torque_external}) {
    v->assign(size_t(m.num_joints), 0.0);
  }
  return {};
}

// num_joints (positions), then num_torques after the positions.
inline std::string prepare(const void* data, size_t size, drake::lcmt_iiwa_command& m) {
  if (!read_int32(data, size, kDrakeFirstCount, m.num_joints)) return truncated(size);
  if (std::string why = impossible_count(m.num_joints, size); !why.empty()) return why;
  if (!read_int32(data, size, kDrakeFirstCount + 4 + 8 * size_t(m.num_joints), m.num_torques)) return truncated(size);
  if (std::string why = impossible_count(m.num_torques, size, "num_torques"); !why.empty()) return why;
  m.joint_position.assign(size_t(m.num_joints), 0.0);
  m.joint_torque.assign(size_t(m.num_torques), 0.0);
  return {};
}

inline std::string prepare(const void* data, size_t size, drake::lcmt_panda_status& m) {
  if (!read_int32(data, size, kDrakeFirstCount, m.num_joints)) return truncated(size);
  if (std::string why = impossible_count(m.num_joints, size); !why.empty()) return why;
  for (auto* v : {&m.joint_position, &m.joint_position_desired, &m.joint_velocity, &m.joint_velocity_desired,
                  &m.joint_acceleration_desired, &m.joint_torque, &m.joint_torque_desired,
                  &m.joint_torque_external}) {
    v->assign(size_t(m.num_joints), 0.0);
  }
  return {};
}

// Three counts, each after the array the one before it sizes.
inline std::string prepare(const void* data, size_t size, drake::lcmt_panda_command& m) {
  struct Field {
    int32_t* count;
    std::vector<double>* values;
    const char* name;
  };
  const Field fields[3] = {{&m.num_joint_position, &m.joint_position, "num_joint_position"},
                           {&m.num_joint_velocity, &m.joint_velocity, "num_joint_velocity"},
                           {&m.num_joint_torque, &m.joint_torque, "num_joint_torque"}};
  size_t at = kDrakeFirstCount;
  for (const Field& field : fields) {
    if (!read_int32(data, size, at, *field.count)) return truncated(size);
    if (std::string why = impossible_count(*field.count, size, field.name); !why.empty()) return why;
    at += 4 + 8 * size_t(*field.count);
  }
  for (const Field& field : fields) field.values->assign(size_t(*field.count), 0.0);
  return {};
}

// scene_t (lcmtypes/chasles_scene_t.lcm) is walked field by field: each count is read from the
// bytes and checked against the bytes left (each entry takes at least its fixed part, each string
// 5 bytes) before anything is sized for it, each string's length read, so that the arrays sized
// here make getEncodedSize() what the bytes must be. What the counts mean — the caps, the hull
// vertices adding up — is the receiver's to judge (controller/transport/scene_message.hpp): a log
// reader shows what was sent.
class ByteWalk {
 public:
  ByteWalk(const void* data, size_t size, size_t at) : data_(data), size_(size), at_(at) {}
  const std::string& why() const { return why_; }

  bool skip(uint64_t bytes) {
    if (bytes > size_ - at_) return fail(truncated(size_));
    at_ += size_t(bytes);
    return true;
  }
  // A count whose entries take at least `entry` bytes each.
  bool count(int32_t& n, size_t entry, const char* name) {
    if (!read_int32(data_, size_, at_, n)) return fail(truncated(size_));
    at_ += 4;
    if (n < 0 || uint64_t(n) * entry > size_ - at_) {
      return fail(std::string(name) + " " + std::to_string(n) + " in a message of " + std::to_string(size_) + " bytes");
    }
    return true;
  }
  bool strings(std::vector<std::string>& out, int32_t n, const char* name) {
    out.resize(size_t(n));
    for (std::string& s : out) {
      int32_t length = 0;  // with its terminating NUL
      if (!read_int32(data_, size_, at_, length)) return fail(truncated(size_));
      at_ += 4;
      if (length < 1 || uint64_t(length) > size_ - at_) {
        return fail(std::string("a string of ") + name + " of " + std::to_string(length) + " bytes in a message of " +
                    std::to_string(size_) + " bytes");
      }
      s.assign(size_t(length - 1), ' ');
      at_ += size_t(length);
    }
    return true;
  }

 private:
  bool fail(std::string why) {
    why_ = std::move(why);
    return false;
  }
  const void* data_;
  size_t size_;
  size_t at_;
  std::string why_;
};

inline void size_rows(std::vector<std::vector<double>>& rows, int32_t n, size_t columns) {
  rows.resize(size_t(n));
  for (auto& row : rows) row.assign(columns, 0.0);
}

inline std::string prepare(const void* data, size_t size, sim_truth_t& m) {
  // After tau_ext: tip_wrench_ext and contact; a contact's two strings take 5 bytes at least, its
  // point, normal and force 72.
  constexpr size_t kAfterTorques = 48 + 1, kContact = 5 + 5 + 72;
  if (!read_int32(data, size, kTruthCount, m.num_joints)) return truncated(size);
  if (std::string why = impossible_count(m.num_joints, size); !why.empty()) return why;
  ByteWalk walk(data, size, kTruthCount + 4);
  const bool ok = walk.skip(uint64_t(m.num_joints) * 8 + kAfterTorques) &&
                  walk.count(m.num_contacts, kContact, "num_contacts") &&
                  walk.strings(m.contact_link, m.num_contacts, "contact_link") &&
                  walk.strings(m.contact_other, m.num_contacts, "contact_other");
  if (!ok) return walk.why();
  m.tau_ext.assign(size_t(m.num_joints), 0.0);
  size_rows(m.contact_point, m.num_contacts, 3);
  size_rows(m.contact_normal, m.num_contacts, 3);
  size_rows(m.contact_force, m.num_contacts, 3);
  return {};
}

inline std::string prepare(const void* data, size_t size, scene_t& m) {
  // The fixed part of each entry: an object's kind, size, position, quaternion, clearance and
  // vertex count; a plane's normal, offset, link count and clearance; a box's position,
  // quaternion, size, link count and clearance.
  constexpr size_t kObject = 1 + 24 + 24 + 32 + 16 + 4, kPlane = 24 + 8 + 4 + 16, kBox = 24 + 32 + 24 + 4 + 16;
  ByteWalk walk(data, size, 8);
  const bool ok = walk.skip(4 + 8) &&  // version, utime
                  walk.count(m.num_objects, 5 + kObject, "num_objects") &&
                  walk.strings(m.object_name, m.num_objects, "object_name") &&
                  walk.skip(uint64_t(m.num_objects) * kObject) && walk.count(m.num_vertices, 24, "num_vertices") &&
                  walk.skip(uint64_t(m.num_vertices) * 24) && walk.count(m.num_planes, 5 + kPlane, "num_planes") &&
                  walk.strings(m.plane_name, m.num_planes, "plane_name") &&
                  walk.skip(uint64_t(m.num_planes) * kPlane) && walk.count(m.num_plane_links, 5, "num_plane_links") &&
                  walk.strings(m.plane_links, m.num_plane_links, "plane_links") &&
                  walk.count(m.num_boxes, 5 + kBox, "num_boxes") && walk.strings(m.box_name, m.num_boxes, "box_name") &&
                  walk.skip(uint64_t(m.num_boxes) * kBox) && walk.count(m.num_box_links, 5, "num_box_links") &&
                  walk.strings(m.box_links, m.num_box_links, "box_links");
  if (!ok) return walk.why();
  m.object_kind.assign(size_t(m.num_objects), 0);
  size_rows(m.object_size, m.num_objects, 3);
  size_rows(m.object_position, m.num_objects, 3);
  size_rows(m.object_quaternion, m.num_objects, 4);
  size_rows(m.object_clearance, m.num_objects, 2);
  m.object_num_vertices.assign(size_t(m.num_objects), 0);
  size_rows(m.vertices, m.num_vertices, 3);
  size_rows(m.plane_normal, m.num_planes, 3);
  m.plane_offset.assign(size_t(m.num_planes), 0.0);
  m.plane_num_links.assign(size_t(m.num_planes), 0);
  size_rows(m.plane_clearance, m.num_planes, 2);
  size_rows(m.box_position, m.num_boxes, 3);
  size_rows(m.box_quaternion, m.num_boxes, 4);
  size_rows(m.box_size, m.num_boxes, 3);
  m.box_num_links.assign(size_t(m.num_boxes), 0);
  size_rows(m.box_clearance, m.num_boxes, 2);
  return {};
}

// Types with no joint count: fixed size, or sized by a string.
template <typename Message>
inline constexpr bool kCountless = std::is_same_v<Message, payload_t> || std::is_same_v<Message, tip_setpoint_t> ||
                                   std::is_same_v<Message, contact_estimate_t>;
inline std::string prepare(const void*, size_t, payload_t&) { return {}; }
inline std::string prepare(const void*, size_t, tip_setpoint_t&) { return {}; }
// The link's name, after utime, seq, state and contact.
inline std::string prepare(const void* data, size_t size, contact_estimate_t& m) {
  std::vector<std::string> link;
  ByteWalk walk(data, size, 8 + 8 + 8 + 1 + 1);
  if (!walk.strings(link, 1, "link")) return walk.why();
  m.link = std::move(link[0]);
  return {};
}

inline bool finite(const std::vector<double>& values) {
  for (double x : values) {
    if (!std::isfinite(x)) return false;
  }
  return true;
}
inline bool finite(const double* values, size_t n) {
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(values[i])) return false;
  }
  return true;
}
inline bool finite(const std::vector<std::vector<double>>& rows) {
  for (const auto& row : rows) {
    if (!finite(row)) return false;
  }
  return true;
}

// The first field holding a non-finite number, or nullptr.
inline const char* non_finite(const robot_state_t& m) {
  return !finite(m.position) ? "position" : !finite(m.velocity) ? "velocity" : !finite(m.effort) ? "effort" : nullptr;
}
inline const char* non_finite(const joint_torque_command_t& m) { return finite(m.torque) ? nullptr : "torque"; }
inline const char* non_finite(const sim_truth_t& m) {
  return !finite(m.tau_ext)                ? "tau_ext"
         : !finite(m.tip_wrench_ext, 6)    ? "tip_wrench_ext"
         : !finite(m.contact_point)        ? "contact_point"
         : !finite(m.contact_normal)       ? "contact_normal"
         : !finite(m.contact_force)        ? "contact_force"
                                           : nullptr;
}
inline const char* non_finite(const control_mode_t& m) {
  return !finite(m.joint_stiffness)                                   ? "joint_stiffness"
         : !finite(m.joint_damping)                                   ? "joint_damping"
         : !std::isfinite(m.damping_ratio)                            ? "damping_ratio"
         : !finite(&m.cartesian_stiffness[0][0], 36)                  ? "cartesian_stiffness"
         : !finite(m.stiffness_frame_position, 3)                     ? "stiffness_frame_position"
         : !finite(m.stiffness_frame_quaternion, 4)                   ? "stiffness_frame_quaternion"
         : !finite(m.nullspace_posture)                               ? "nullspace_posture"
         : !std::isfinite(m.nullspace_stiffness)                      ? "nullspace_stiffness"
                                                                      : nullptr;
}
inline const char* non_finite(const payload_t& m) {
  return !std::isfinite(m.mass)                  ? "mass"
         : !finite(m.centre_of_mass, 3)          ? "centre_of_mass"
         : !finite(&m.inertia[0][0], 9)          ? "inertia"
                                                 : nullptr;
}
inline const char* non_finite(const joint_trajectory_t& m) {
  return !finite(m.time_from_start)                 ? "time_from_start"
         : !finite(m.positions)                     ? "positions"
         : !finite(m.velocities)                    ? "velocities"
         : !finite(m.accelerations)                 ? "accelerations"
         : !finite(m.path_tolerance)                ? "path_tolerance"
         : !finite(m.goal_tolerance)                ? "goal_tolerance"
         : !std::isfinite(m.goal_time_tolerance)    ? "goal_time_tolerance"
                                                    : nullptr;
}
inline const char* non_finite(const scene_t& m) {
  return !finite(m.object_size)         ? "object_size"
         : !finite(m.object_position)   ? "object_position"
         : !finite(m.object_quaternion) ? "object_quaternion"
         : !finite(m.object_clearance)  ? "object_clearance"
         : !finite(m.vertices)          ? "vertices"
         : !finite(m.plane_normal)      ? "plane_normal"
         : !finite(m.plane_offset)      ? "plane_offset"
         : !finite(m.plane_clearance)   ? "plane_clearance"
         : !finite(m.box_position)      ? "box_position"
         : !finite(m.box_quaternion)    ? "box_quaternion"
         : !finite(m.box_size)          ? "box_size"
         : !finite(m.box_clearance)     ? "box_clearance"
                                        : nullptr;
}
inline const char* non_finite(const joint_setpoint_t& m) {
  return !finite(m.position) ? "position" : !finite(m.velocity) ? "velocity" : nullptr;
}
inline const char* non_finite(const jog_command_t& m) {
  return !finite(m.joint_velocity) ? "joint_velocity" : !finite(m.twist, 6) ? "twist" : nullptr;
}
inline const char* non_finite(const contact_estimate_t& m) {
  return !finite(m.point, 3)                                         ? "point"
         : !finite(m.normal, 3)                                      ? "normal"
         : !finite(m.force, 3)                                       ? "force"
         : !std::isfinite(m.residual) || !std::isfinite(m.tau_ext_norm) ? "residual"
                                                                     : nullptr;
}
inline const char* non_finite(const tip_setpoint_t& m) {
  return !finite(m.position, 3) ? "position" : !finite(m.quaternion, 4) ? "quaternion" : !finite(m.twist, 6) ? "twist" : nullptr;
}
// joint_position_ipo is left out: the real driver sends NaN there whenever FRI gives no interpolator
// positions (outside its commanding state), and nothing in chasles reads it.
inline const char* non_finite(const drake::lcmt_iiwa_status& m) {
  return !finite(m.joint_position_measured)    ? "joint_position_measured"
         : !finite(m.joint_velocity_estimated) ? "joint_velocity_estimated"
         : !finite(m.joint_position_commanded) ? "joint_position_commanded"
         : !finite(m.joint_torque_measured)    ? "joint_torque_measured"
         : !finite(m.joint_torque_commanded)   ? "joint_torque_commanded"
         : !finite(m.joint_torque_external)    ? "joint_torque_external"
                                               : nullptr;
}
inline const char* non_finite(const drake::lcmt_iiwa_command& m) {
  return !finite(m.joint_position) ? "joint_position" : !finite(m.joint_torque) ? "joint_torque" : nullptr;
}
inline const char* non_finite(const drake::lcmt_panda_status& m) {
  return !finite(m.joint_position)                          ? "joint_position"
         : !finite(m.joint_position_desired)                ? "joint_position_desired"
         : !finite(m.joint_velocity)                        ? "joint_velocity"
         : !finite(m.joint_velocity_desired)                ? "joint_velocity_desired"
         : !finite(m.joint_acceleration_desired)            ? "joint_acceleration_desired"
         : !finite(m.joint_torque)                          ? "joint_torque"
         : !finite(m.joint_torque_desired)                  ? "joint_torque_desired"
         : !finite(m.joint_torque_external)                 ? "joint_torque_external"
         : !std::isfinite(m.control_command_success_rate)   ? "control_command_success_rate"
                                                            : nullptr;
}
inline const char* non_finite(const drake::lcmt_panda_command& m) {
  return !finite(m.joint_position)   ? "joint_position"
         : !finite(m.joint_velocity) ? "joint_velocity"
         : !finite(m.joint_torque)   ? "joint_torque"
                                     : nullptr;
}
inline const char* non_finite(const arm_target_t& m) {
  return !finite(m.joint_position)      ? "joint_position"
         : !finite(m.tip_position, 3)   ? "tip_position"
         : !finite(m.tip_quaternion, 4) ? "tip_quaternion"
         : !std::isfinite(m.duration)   ? "duration"
                                        : nullptr;
}

// Whether a message for `count` joints fits an arm of `arm_joints`: states, commands and truths carry
// every joint; a target carries all of them (JOINT) or none (HOLD, CARTESIAN), and the controller says
// which its mode needs; a jog all of them or none (a TWIST).
template <typename Message>
bool fits_arm(int32_t count, int arm_joints) {
  if constexpr (std::is_same_v<Message, arm_target_t>) return count <= arm_joints;
  if constexpr (std::is_same_v<Message, jog_command_t>) return count == 0 || count == arm_joints;
  return count == arm_joints;
}
// A control mode carries all of the arm's joints or none, in each of its two counts; so do Drake's
// commands, in each of theirs (which counts a driver needs depends on its mode, and is the
// protocol's to judge: controller/transport/protocol.hpp).
inline bool all_or_none(int32_t count, int arm_joints) { return count == 0 || count == arm_joints; }
inline bool fits_arm(const control_mode_t& m, int arm_joints) {
  return all_or_none(m.num_joints, arm_joints) && all_or_none(m.num_posture, arm_joints);
}
inline bool fits_arm(const drake::lcmt_iiwa_command& m, int arm_joints) {
  return all_or_none(m.num_joints, arm_joints) && all_or_none(m.num_torques, arm_joints);
}
inline bool fits_arm(const drake::lcmt_panda_command& m, int arm_joints) {
  return all_or_none(m.num_joint_position, arm_joints) && all_or_none(m.num_joint_velocity, arm_joints) &&
         all_or_none(m.num_joint_torque, arm_joints);
}

// What a message's counts say, for a refusal: "7 joints", or each count of a type with several.
template <typename Message>
std::string counts(const Message& m) {
  return std::to_string(m.num_joints) + " joints";
}
inline std::string counts(const control_mode_t& m) {
  return std::to_string(m.num_joints) + " joints and a posture of " + std::to_string(m.num_posture);
}
inline std::string counts(const drake::lcmt_iiwa_command& m) {
  return std::to_string(m.num_joints) + " positions and " + std::to_string(m.num_torques) + " torques";
}
inline std::string counts(const drake::lcmt_panda_command& m) {
  return std::to_string(m.num_joint_position) + " positions, " + std::to_string(m.num_joint_velocity) +
         " velocities and " + std::to_string(m.num_joint_torque) + " torques";
}
// The counts a size was computed for: num_joints, or every count of Drake's commands.
template <typename Message>
std::string size_counts(const Message& m) {
  if constexpr (std::is_same_v<Message, drake::lcmt_iiwa_command> ||
                std::is_same_v<Message, drake::lcmt_panda_command>) {
    return counts(m);
  } else {
    return std::to_string(m.num_joints) + " joints";
  }
}
// Types whose every count may be 0 or the arm's.
template <typename Message>
inline constexpr bool kAllOrNone = std::is_same_v<Message, control_mode_t> ||
                                   std::is_same_v<Message, drake::lcmt_iiwa_command> ||
                                   std::is_same_v<Message, drake::lcmt_panda_command>;
// Types that carry no joint count at all: fixed-size ones, and the scene (its counts are of
// objects, planes and boxes, whatever the arm).
template <typename Message>
inline constexpr bool kArmless = kCountless<Message> || std::is_same_v<Message, scene_t>;
template <typename Message>
bool fits_arm(const Message& m, int arm_joints) {
  if constexpr (kArmless<Message>) return true;
  else return fits_arm<Message>(m.num_joints, arm_joints);
}

}  // namespace detail

/// Whether `data` starts with Message's fingerprint (what type it claims to be, not that it is valid).
template <typename Message>
bool starts_as(const void* data, size_t size) {
  return detail::fingerprint_is(data, size, Message::getHash());
}

/// Decodes `data` into `message`: an empty string, or why the bytes are not a valid Message for
/// this reader — "not a robot_state_t (wrong fingerprint)", "truncated: 12 bytes",
/// "for 6 joints; the arm has 7", "of 200 bytes; expected 196 for 7 joints", "with non-finite
/// velocity". `arm_joints` is the reader's arm (kAnyArm: any count); Finite::Required refuses
/// NaN and ±inf (controller_status_t, which only monitors read, has no such check). After a
/// refusal `message` holds nothing valid: decode into a scratch message and keep the last good one.
template <typename Message>
std::string decode_checked(const void* data, size_t size, Message& message, int arm_joints = kAnyArm,
                           Finite finite = Finite::NotRequired) {
  if (!detail::fingerprint_is(data, size, Message::getHash())) {
    return std::string("not a ") + Message::getTypeName() + " (wrong fingerprint)";
  }
  if (size > size_t(INT32_MAX)) return "of " + std::to_string(size) + " bytes, too large";
  if (std::string why = detail::prepare(data, size, message); !why.empty()) return why;
  if (arm_joints != kAnyArm && !detail::fits_arm(message, arm_joints)) {
    if constexpr (detail::kAllOrNone<Message>) {
      return "for " + detail::counts(message) + "; the arm has " + std::to_string(arm_joints) + " (give 0 or " +
             std::to_string(arm_joints) + " in each)";
    } else if constexpr (!detail::kArmless<Message>) {
      return "for " + std::to_string(message.num_joints) + " joints; the arm has " + std::to_string(arm_joints);
    }
  }
  const int expected = message.getEncodedSize();
  if (size_t(expected) != size) {
    if constexpr (detail::kArmless<Message>) {
      return "of " + std::to_string(size) + " bytes; expected " + std::to_string(expected);
    } else {
      return "of " + std::to_string(size) + " bytes; expected " + std::to_string(expected) + " for " +
             detail::size_counts(message);
    }
  }
  if (message.decode(data, 0, static_cast<int>(size)) != expected) return "does not decode";
  if constexpr (!std::is_same_v<Message, controller_status_t>) {
    if (finite == Finite::Required) {
      if (const char* field = detail::non_finite(message)) return std::string("with non-finite ") + field;
    }
  }
  return {};
}

}  // namespace chasles::messages
