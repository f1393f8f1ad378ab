// What the fault tests judge, from what was heard on the bus: the controller's command stream
// against exactly what its safety pipeline promises (controller.cpp) — every torque finite and
// within the URDF effort limit, every step within effort / torque_ramp × period of the previous
// command, or, for the first command after WAITING or a FAULT, of g(q) at the state it answers,
// where the rate limiter restarts — and the status stream summarised.
#pragma once

#include <Eigen/Core>
#include <chasles/controller_status_t.hpp>
#include <chasles/joint_torque_command_t.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/model/model.hpp"
#include "support/arm.hpp"
#include "support/statistics.hpp"

namespace chasles::faults {

/// A command as heard, with what it answers.
struct HeardCommand {
  joint_torque_command_t message;
  int64_t index = 0;  ///< arrival order among everything the bus heard
  std::optional<Eigen::VectorXd> q_answered;  ///< position of the state with seq == state_seq, as last heard
  /// The test heard that state → the test heard this command, µs (−1: state not heard): the
  /// round trip through the controller, as a process beside the plant sees it.
  double round_trip_us = -1.0;
};

struct HeardStatus {
  controller_status_t message;
  int64_t index = 0;
};

/// What the command stream showed; every *_violations must be 0.
struct CommandReport {
  int64_t commands = 0;
  int64_t non_finite = 0, effort_violations = 0, rate_violations = 0;
  int64_t restarts_from_gravity = 0;  ///< first commands after WAITING / a FAULT, checked against g(q)
  int64_t seq_gaps = 0;               ///< commands the test did not hear (not judged)
  double max_effort_ratio = 0.0;      ///< max |τ_i| / effort_i
  double max_rate_ratio = 0.0;        ///< max |Δτ_i| / (effort_i / ramp × period), over judged steps
  double spacing_p50_us = 0.0, spacing_p99_us = 0.0;  ///< utime spacing of consecutive commands
  std::string first_violation;
};

/// Judges the controller's commands: `ramp_s` and `period_s` as configured.
CommandReport check_commands(const RobotModel& model, const std::vector<HeardCommand>& commands,
                             const std::vector<HeardStatus>& statuses, double ramp_s, double period_s);

/// What the status stream showed.
struct StatusReport {
  std::string modes;  ///< the sequence of states, repeats collapsed: "WAITING>HOLDING>RUNNING>..."
  int64_t fault_transitions = 0;
  std::vector<std::string> fault_messages;  ///< one per FAULT reported, as first reported
  double jitter_p99_median_us = 0.0;        ///< median over status windows of jitter_p99_us
  double latency_p99_median_us = 0.0;
  double jitter_max_us = 0.0;               ///< the controller's longest wake-up delay, any window
  int64_t ticks = 0, overruns = 0, stale = 0, rejected = 0, faults = 0;
};
StatusReport summarise(const std::vector<HeardStatus>& statuses);

/// One line for the fault table, printed by each test.
std::string table_row(const std::string& fault, const CommandReport& c, const StatusReport& s);

/// The arm's model as the tests run it (the Panda to its TCP).
using testing::panda;
using testing::ur5;
using testing::bent_pose;
using testing::joint_target;
using testing::list;
using testing::vector_of;
using testing::percentile;
joint_torque_command_t command_of(int64_t seq, int64_t utime, int64_t state_seq, const Eigen::VectorXd& tau);

}  // namespace chasles::faults
