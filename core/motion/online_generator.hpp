// A jerk-limited, time-optimal online trajectory generator (OTG) for n independent axes, in the
// spirit of Ruckig (Berscheid & Kröger, "Jerk-limited Real-time Trajectory Generation with
// Arbitrary Target States", RSS 2021), written from scratch.
//
// Each axis moves along a profile of at most 7 phases of constant jerk (+j, 0 or −j), from any
// state (p, v, a) to any target state (p, v, a), within |v| ≤ v_max, |a| ≤ a_max, |j| ≤ j_max.
// plan() first finds each axis's minimal duration, then gives every axis a profile of the common
// duration of the slowest one, so that all of them arrive together. It is meant to be called at
// every control tick, replanning from the current reference toward a target that may move, as
// Ruckig's update() is; it allocates nothing. docs/motion.md explains the algorithm.
#pragma once

#include <Eigen/Core>
#include <array>
#include <vector>

namespace chasles::motion {

/// Per-axis limits, each > 0 and finite.
struct Limits {
  Eigen::VectorXd velocity, acceleration, jerk;
};

/// Position, velocity and acceleration per axis.
struct KinematicState {
  Eigen::VectorXd p, v, a;
};

/// One axis's motion: up to kMaxPhases phases of constant jerk, each starting at a known state, so
/// that a sample is one cubic evaluated in the phase it falls in (no accumulated integration).
struct AxisProfile {
  static constexpr int kMaxPhases = 10;  // a brake of 2 phases + a profile of up to 7
  int phases = 0;
  std::array<double, kMaxPhases> t{};        // phase durations
  std::array<double, kMaxPhases> j{};        // phase jerks
  std::array<double, kMaxPhases + 1> p{}, v{}, a{}, start{};  // the state and time at each phase's start; [phases]: the end
  double duration() const { return start[phases]; }
};

/// Whether the axes arrive together (kTime: a straight line in joint space from rest to rest; what
/// a planner's motion wants) or each as fast as it can (kNone: a moving target followed per axis,
/// as a stream or a teleoperated arm wants, at a fraction of the cost: no fixed-duration search).
enum class Synchronization { kTime, kNone };

/// Where an axis at (p, v, a) comes to rest when it brakes as fast as `V`, `A`, `J` allow (the end
/// of plan_velocity toward 0): the stop a limit or a singularity must stay clear of.
double stop_position(double p, double v, double a, double V, double A, double J);

class OnlineGenerator {
 public:
  /// Allocates everything the generator will use. Throws ArgumentError unless dof ≥ 1.
  explicit OnlineGenerator(int dof);

  int dof() const { return dof_; }

  /// Time-synchronised plan from `current` to `target` (all axes arrive together at the minimal
  /// common duration, at least min_duration), within `limits`. `target.v` within the velocity
  /// limit, `target.a` within the acceleration limit, and the target reachable from within the
  /// velocity limit (|v − a|a|/(2j)| ≤ v_max: with a ≠ 0 the velocity was still changing before
  /// it, as in Ruckig's check). `current` may be outside the limits (e.g. |v| > v_max after the limits were
  /// lowered): then the plan first brings it back within them with full jerk (Ruckig's brake
  /// pre-trajectory), and only the brake may exceed them. Returns false (and a reason()) for
  /// invalid input (sizes, non-finite values, non-positive limits, target out of limits, negative
  /// or non-finite min_duration), leaving the previous plan in place. With Synchronization::kNone
  /// each axis takes its own time-optimal profile (min_duration is then only a floor of
  /// duration(), the longest of them); or, in principle, when no
  /// profile is found (a numerical failure, never seen in the tests and benchmarks), after which
  /// the previous plan is not to be used. Allocates nothing.
  bool plan(const KinematicState& current, const KinematicState& target, const Limits& limits,
            double min_duration = 0.0, Synchronization synchronization = Synchronization::kTime);

  /// Ruckig's velocity interface: each axis from `current` to the velocity `target_velocity` at zero
  /// acceleration, as fast as it can (no synchronisation, no position target), within `limits`;
  /// past its end it moves on at that velocity. A jog's reference. `target_velocity` within the
  /// velocity limit; `current` may be outside the limits (braked back first, as in plan()).
  /// Returns false (and a reason()) for invalid input, leaving the previous plan in place.
  /// Allocates nothing.
  bool plan_velocity(const KinematicState& current, const Eigen::VectorXd& target_velocity, const Limits& limits);

  /// The plan's duration in seconds (0 before the first successful plan()).
  double duration() const { return duration_; }

  /// The state at t ∈ [0, duration] after the plan's start; before 0, the start; past the end, the
  /// target moving on with its velocity and acceleration (p + v t + a t²/2, v + a t, a). `out`'s
  /// vectors are resized to dof() if they are not that size already (which allocates, once);
  /// otherwise allocates nothing.
  void at_time(double t, KinematicState& out) const;

  /// Why the last plan() returned false; "" after a successful one.
  const char* reason() const { return reason_.data(); }

  /// One axis's profile of the last plan (for tests and diagnostics).
  const AxisProfile& axis(int i) const { return profiles_[static_cast<std::size_t>(i)]; }

  /// The minimal duration of each axis alone in the last plan (brake included).
  double minimal_duration(int i) const { return minimal_[static_cast<std::size_t>(i)]; }

 private:
  int dof_;
  double duration_ = 0.0;
  std::vector<AxisProfile> profiles_;  // the plan
  std::vector<AxisProfile> fastest_;   // each axis's time-optimal profile (work space)
  std::vector<double> minimal_;
  std::array<char, 160> reason_{};  // formatted in place: plan() allocates nothing

  /// Checks sizes, finiteness and positive limits of what every plan takes; false with reason_.
  bool valid_input(const KinematicState& current, const Limits& limits);
};

}  // namespace chasles::motion
