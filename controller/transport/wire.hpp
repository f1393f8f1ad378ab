// Every enum that crosses the wire as an int8_t constant of an LCM type, with its values there: one
// table per enum (WireTable<Enum>::kPairs, {enumerator, lcm-gen's constant} pairs), checked at
// compile time to name every enumerator once and every wire value once, and two lookups over it,
// to_wire and from_wire. The only mapping between an enum and its wire values: the receivers
// (lcm_io.hpp), the node's status and the plant use these, and the tables' test round-trips every
// enumerator through the bytes.
#pragma once

#include <chasles/arm_target_t.hpp>
#include <chasles/control_mode_t.hpp>
#include <chasles/controller_status_t.hpp>
#include <chasles/jog_command_t.hpp>
#include <chasles/scene_t.hpp>
#include <cstddef>
#include <cstdint>
#include <iterator>

#include "controller/law_settings.hpp"
#include "controller/signals.hpp"
#include "controller/transport/enumerators.hpp"
#include "core/geometry/shape.hpp"

namespace chasles::controller {

/// One enumerator and its value on the wire.
template <typename Enum>
struct WirePair {
  Enum value;
  int8_t wire;
};

/// The wire values of an enum: specialised below, one table each.
template <typename Enum>
struct WireTable;

/// controller_status_t.state.
template <>
struct WireTable<Mode> {
  static constexpr WirePair<Mode> kPairs[] = {
      {Mode::kWaiting, controller_status_t::WAITING}, {Mode::kRunning, controller_status_t::RUNNING},
      {Mode::kHolding, controller_status_t::HOLDING}, {Mode::kFault, controller_status_t::FAULT},
      {Mode::kReflex, controller_status_t::REFLEX},
  };
};

/// controller_status_t.trajectory_outcome.
template <>
struct WireTable<TrajectoryProgress::Outcome> {
  static constexpr WirePair<TrajectoryProgress::Outcome> kPairs[] = {
      {TrajectoryProgress::kNone, controller_status_t::TRAJECTORY_NONE},
      {TrajectoryProgress::kActive, controller_status_t::TRAJECTORY_ACTIVE},
      {TrajectoryProgress::kSucceeded, controller_status_t::TRAJECTORY_SUCCEEDED},
      {TrajectoryProgress::kAborted, controller_status_t::TRAJECTORY_ABORTED},
      {TrajectoryProgress::kPreempted, controller_status_t::TRAJECTORY_PREEMPTED},
      {TrajectoryProgress::kRejected, controller_status_t::TRAJECTORY_REJECTED},
  };
};

/// controller_status_t.jog_limited_by.
template <>
struct WireTable<JogProgress::Limit> {
  static constexpr WirePair<JogProgress::Limit> kPairs[] = {
      {JogProgress::kNone, controller_status_t::JOG_NONE},
      {JogProgress::kVelocity, controller_status_t::JOG_VELOCITY_LIMIT},
      {JogProgress::kPosition, controller_status_t::JOG_POSITION_LIMIT},
      {JogProgress::kSingularity, controller_status_t::JOG_SINGULARITY},
  };
};

/// control_mode_t.law and controller_status_t.law.
template <>
struct WireTable<Law> {
  static constexpr WirePair<Law> kPairs[] = {
      {Law::kComputedTorque, control_mode_t::COMPUTED_TORQUE},
      {Law::kJointImpedance, control_mode_t::JOINT_IMPEDANCE},
      {Law::kCartesianImpedance, control_mode_t::CARTESIAN_IMPEDANCE},
      {Law::kFreeDrive, control_mode_t::FREE_DRIVE},
  };
};

/// arm_target_t.mode.
template <>
struct WireTable<Target::Mode> {
  static constexpr WirePair<Target::Mode> kPairs[] = {
      {Target::kHold, arm_target_t::HOLD}, {Target::kJoint, arm_target_t::JOINT},
      {Target::kCartesian, arm_target_t::CARTESIAN},
  };
};

/// jog_command_t.kind.
template <>
struct WireTable<Jog::Kind> {
  static constexpr WirePair<Jog::Kind> kPairs[] = {
      {Jog::kJointVelocity, jog_command_t::JOINT_VELOCITY}, {Jog::kTwist, jog_command_t::TWIST},
  };
};

/// jog_command_t.frame.
template <>
struct WireTable<Jog::Frame> {
  static constexpr WirePair<Jog::Frame> kPairs[] = {
      {Jog::kBase, jog_command_t::BASE}, {Jog::kTool, jog_command_t::TOOL},
  };
};

/// scene_t.object_kind.
template <>
struct WireTable<geometry::ShapeKind> {
  static constexpr WirePair<geometry::ShapeKind> kPairs[] = {
      {geometry::ShapeKind::kSphere, scene_t::SPHERE},     {geometry::ShapeKind::kBox, scene_t::BOX},
      {geometry::ShapeKind::kCylinder, scene_t::CYLINDER}, {geometry::ShapeKind::kCapsule, scene_t::CAPSULE},
      {geometry::ShapeKind::kConvex, scene_t::CONVEX},
  };
};

/// The value to_wire gives a value that is no enumerator; no table uses it.
inline constexpr int8_t kNoWire = -1;

/// Whether Enum's table lists each of its enumerators once and gives each its own wire value
/// (never kNoWire).
template <typename Enum>
constexpr bool wire_table_is_complete() {
  const auto& pairs = WireTable<Enum>::kPairs;
  const std::size_t n = std::size(pairs);
  if (static_cast<int>(n) != enumerators::count<Enum>()) return false;
  for (std::size_t i = 0; i < n; ++i) {
    if (pairs[i].wire == kNoWire) return false;
    for (std::size_t j = i + 1; j < n; ++j) {
      if (pairs[i].value == pairs[j].value || pairs[i].wire == pairs[j].wire) return false;
    }
  }
  return true;
}

/// Whether each of Enum's enumerators has its wire value as its own value. The decoded targets and
/// jogs carry the wire's int8_t as it came (Target::mode, Jog::kind, Jog::frame), so that the
/// controller names a value no enumerator has when it refuses it: that is right only where this holds.
template <typename Enum>
constexpr bool wire_is_value() {
  for (const auto& pair : WireTable<Enum>::kPairs) {
    if (static_cast<int>(pair.value) != pair.wire) return false;
  }
  return true;
}

static_assert(wire_table_is_complete<Mode>(), "WireTable<Mode> must list every Mode once, each its own state");
static_assert(wire_table_is_complete<TrajectoryProgress::Outcome>(),
              "WireTable<TrajectoryProgress::Outcome> must list every outcome once, each its own value");
static_assert(wire_table_is_complete<JogProgress::Limit>(),
              "WireTable<JogProgress::Limit> must list every limit once, each its own value");
static_assert(wire_table_is_complete<Law>(), "WireTable<Law> must list every Law once, each its own value");
static_assert(wire_table_is_complete<Target::Mode>(), "WireTable<Target::Mode> must list every mode once");
static_assert(wire_table_is_complete<Jog::Kind>(), "WireTable<Jog::Kind> must list every kind once");
static_assert(wire_table_is_complete<Jog::Frame>(), "WireTable<Jog::Frame> must list every frame once");
static_assert(wire_table_is_complete<geometry::ShapeKind>(), "WireTable<ShapeKind> must list every shape kind once");
static_assert(wire_is_value<Target::Mode>() && wire_is_value<Jog::Kind>() && wire_is_value<Jog::Frame>(),
              "Target and Jog carry the wire's mode, kind and frame as they came: their enumerators must be "
              "the wire's values");

/// The wire value of an enumerator; kNoWire for a value that is none.
template <typename Enum>
constexpr int8_t to_wire(Enum value) {
  for (const auto& pair : WireTable<Enum>::kPairs) {
    if (pair.value == value) return pair.wire;
  }
  return kNoWire;
}

/// The enumerator a wire value stands for: true and `value` set, or false (`value` untouched) for a
/// wire value no enumerator has.
template <typename Enum>
constexpr bool from_wire(int8_t wire, Enum& value) {
  for (const auto& pair : WireTable<Enum>::kPairs) {
    if (pair.wire == wire) {
      value = pair.value;
      return true;
    }
  }
  return false;
}

}  // namespace chasles::controller
