// The control logic of one tick, free of threads, clocks and transport so that it can be tested
// directly: validated state, targets and laws in, joint torques out. A tick is a short sequence of
// parts, each with one job and a file of its own:
//
//   the state: age, size, finiteness (else FAULT); the model's terms at it, once (data())
//   → the state monitor (monitor.hpp): the contact observer, the states' period, the torque's
//     semantics; a collision or a limit crossed starts the reflex (REFLEX)
//   → the reference, moved on by the source in force (reference/: a quintic to a goal, a
//     Cartesian path, a waypoint trajectory, a joint or tip stream, a jog, a brake to rest)
//   → the law in force (control_law.hpp, law.hpp) [+ D q̇_d + friction]
//   → the safety pipeline (safety.hpp): a switch's offset, fading → non-finite refused → effort
//     limits → torque-rate limit → command
//
// Two Data serve every part: the one at the measured state, computed once per tick, and the one at
// the reference (ReferenceKinematics), computed at most once per tick, where a jog or the
// Cartesian law reads it.
#pragma once

#include <Eigen/Core>
#include <cstdint>

#include "controller/cartesian.hpp"
#include "controller/clearance.hpp"
#include "controller/config.hpp"
#include "controller/control_law.hpp"
#include "controller/monitor.hpp"
#include "controller/reference/goal.hpp"
#include "controller/reference/jogging.hpp"
#include "controller/reference/path.hpp"
#include "controller/reference/source.hpp"
#include "controller/reference/stream.hpp"
#include "controller/reference/trajectory.hpp"
#include "controller/safety.hpp"
#include "controller/signals.hpp"
#include "core/model/model.hpp"
#include "core/motion/limits.hpp"
#include "core/motion/waypoints.hpp"

namespace chasles::controller {

class Controller {
 public:
  /// Keeps a reference to `model`. Throws ArgumentError for a bad config.
  Controller(const RobotModel& model, const Config& config);

  /// Takes a new control law (blended in from the next tick) or refuses it (returns false, counts
  /// it in rejected_modes(), says why in mode_rejection()) and keeps the law in force. A law is
  /// refused before the first state and in FAULT, like a target. Taking one ends a REFLEX (the arm
  /// holds where it is); free drive also ends a motion, since it follows no reference.
  /// Allocates nothing.
  bool set_law(const LawSettings& settings, int64_t now_ns);
  const LawSettings& law() const { return law_.settings(); }
  /// Controls with `model` from the next tick: the same chain with another payload. Refused
  /// (false) for a model that does not fit every workspace (RobotModel::check: another chain).
  /// Keeps a reference; the caller keeps it alive until the next set_model. The contact observer
  /// starts again with it. Allocates nothing.
  bool set_model(const RobotModel& model);
  const RobotModel& model() const { return *model_; }

  /// Keeps the arm clear of itself and the scene with `world` from the next tick (nullptr: no
  /// geometry). Refused (false) for a world built for another chain. The caller keeps it alive
  /// while it is in force. Allocates nothing.
  bool set_clearance_world(ClearanceWorld* world);
  /// The closest pair at the latest state and what last slowed the reference.
  const ClearanceStatus& clearance() const { return clearance_.status(); }

  /// Takes a new goal, or refuses it (returns false, counts it, says why in last_rejection()) and
  /// keeps the current one. A goal arriving before the first state is refused too. A JOINT goal
  /// is reached by a quintic from the current reference that must stay within limits() all the
  /// way (position range, velocity, acceleration, jerk); one that would not is refused, naming
  /// the joint, the quantity and the shortest duration that would do. A CARTESIAN
  /// goal that passes the checks becomes a request for the IK worker (take_request()); the arm
  /// keeps holding until its joint path comes back (follow()).
  bool set_target(const Target& target, int64_t now_ns);

  /// Takes a waypoint trajectory, started from the current reference (C², no jump), or refuses
  /// it (returns false, counts it as a refused target, says why in last_rejection() and in
  /// trajectory() as REJECTED). Checked first: counts, finite values, times increasing from > 0,
  /// every waypoint within the position limits less the margin, a last waypoint at rest, then
  /// the whole interpolated path against every limit — and, if the sender allows it, slowed by
  /// the least factor that fits; if not, refused naming the largest excess and the duration it
  /// would fit in. While it runs, a joint off the reference by more than its path
  /// tolerance ABORTS it (the arm holds where it is); at its end each joint must come within its
  /// goal tolerance within goal_time. A new target, law or trajectory PREEMPTS it; a reflex or a
  /// FAULT ABORTS it. Allocates nothing.
  bool set_trajectory(const motion::Waypoints& waypoints, int64_t now_ns);
  const TrajectoryProgress& trajectory() const { return trajectory_.progress(); }

  /// Takes one setpoint of a stream: the reference moves toward it (and on at its velocity) along
  /// the time-optimal jerk-limited motion the online generator plans from the current reference at
  /// every tick, so it stays C² and within every limit whatever the stream does. Returns false for
  /// a setpoint dropped (not newer than the last taken: late or duplicated; counted in
  /// dropped_setpoints()) or refused (before the first state, in FAULT or REFLEX, under free
  /// drive; counted as a refused target, with its reason). The position is clamped into the
  /// limits less the margin and the velocity toward a limit to what can stop before it. No
  /// setpoint for Config::stream_timeout: the arm decelerates to rest and holds. A target, a
  /// trajectory or a law ends the stream. Allocates nothing.
  bool set_setpoint(const Setpoint& setpoint, int64_t now_ns);
  bool streaming() const { return driven_by(stream_) || driven_by(tip_stream_); }
  int64_t setpoints() const { return stream_.clock().taken() + tip_stream_.clock().taken(); }
  int64_t dropped_setpoints() const { return stream_.clock().dropped() + tip_stream_.clock().dropped(); }

  /// Takes one setpoint of a Cartesian stream: a tip pose moving on with its twist until the next.
  /// The reference follows it as a twist jog does (jog.hpp): the pose's twist plus the error to it
  /// over JogConfig::pose_time_constant, resolved by J_b⁺ at the reference, within every limit and
  /// short of a singularity (jog_progress() says how). Ordered, counted, refused and timed out as
  /// joint setpoints are; a quaternion whose norm is over 1e-3 from 1 is refused. Allocates nothing.
  bool set_tip_setpoint(const TipSetpoint& setpoint, int64_t now_ns);

  /// Takes one jog command: joint velocities or a tip twist, held until the next (jog.hpp says how
  /// they become the reference: within every limit, short of a singularity). Ordered by utime like
  /// setpoints (late or duplicated ones dropped, counted in dropped_jogs()); refused in the same
  /// cases, and for a kind or frame it does not know. No command for Config::stream_timeout: the
  /// arm decelerates to rest and holds. A target, a trajectory, a stream or a law ends the jog.
  /// Allocates nothing.
  bool set_jog(const Jog& jog, int64_t now_ns);
  bool jogging() const { return driven_by(jog_); }
  /// How the latest jog tick went: the condition number, the speed's scale and what cut it.
  const JogProgress& jog_progress() const { return jog_progress_; }
  /// The condition numbers in force.
  const JogConfig& jog_config() const { return jog_.config(); }
  int64_t jogs() const { return jog_.clock().taken(); }
  int64_t dropped_jogs() const { return jog_.clock().dropped(); }

  /// The Cartesian request set_target() made, once: true and `request` filled, else false.
  bool take_request(CartesianRequest& request) { return path_.take_request(request); }
  /// Starts the joint path planned for the latest request, or refuses it (a failed plan, or a
  /// plan for a request since superseded by another target, which is dropped silently).
  bool follow(const JointPath& path, int64_t now_ns);

  /// One tick at time now_ns with the latest state (nullptr: none has arrived yet). Returns true
  /// when a command is to be sent: torque() then holds it. Allocates nothing.
  bool tick(int64_t now_ns, const JointState* state);

  /// Stops commanding for good: FAULT, latched against every state and target that follows, and
  /// counted once. For what only an operator can resolve, such as another sender commanding the
  /// same arm. Allocates nothing.
  void stand_down(const char* format, ...) __attribute__((format(printf, 2, 3)));
  bool stood_down() const { return stood_down_; }

  Mode mode() const { return mode_; }
  /// Why the controller is in FAULT (or was, last).
  const char* fault_reason() const { return fault_reason_; }
  /// Why the last refused target was refused.
  const char* last_rejection() const { return rejection_; }
  /// Why the last refused control law was refused.
  const char* mode_rejection() const { return mode_rejection_; }
  int64_t rejected_modes() const { return counts_.rejected_modes; }
  /// What tripped the latest reflex, naming the joint or the force.
  const char* reflex_reason() const { return reflex_reason_; }
  /// Where on the arm the locator found the newest contact (off the loop, milliseconds after the
  /// state it was found at): at the next tick, a collision if its link's policy says so
  /// (LinkPolicy). Allocates nothing.
  void take_location(const LocatedContact& located) { monitor_.take_location(located); }
  /// The contact monitor's estimate at the latest state.
  const ContactEstimate& contact() const { return monitor_.contact().estimate(); }
  /// The period of the robot states, s, measured from their own clock (StateMonitor).
  double state_period() const { return monitor_.state_period(); }
  /// Why the measured period is not the configured one, or "" when it is (StateMonitor).
  const char* period_warning() const { return monitor_.period_warning(); }
  /// The model's terms at the latest state (compute_tick_terms), and the count of their passes.
  const Data& data() const { return data_; }
  /// The tip pose and J_b at the reference, where a jog or the Cartesian law last needed them,
  /// and the count of their passes.
  const Data& reference_data() const { return kinematics_.data(); }
  /// The limits every reference keeps to and the measured state is guarded by.
  const motion::MotionLimits& limits() const { return limits_; }
  /// The limits the online generator plans streams, jogs and stops with now: limits_' velocity (∞
  /// as a large finite value), its acceleration and jerk capped by the effort and the torque rate
  /// at the state of the latest goal taken (GeneratorLimits::fit_to_arm).
  const motion::Limits& generator_limits() const { return generator_.limits(); }
  /// The thresholds and reflex in force (the defaults filled in from the model).
  const ContactConfig& contact_config() const { return monitor_.contact().config(); }
  /// Contacts (each time the contact flag rose) and reflexes since start; the largest estimated
  /// tip force, N.
  int64_t contacts() const { return monitor_.contacts(); }
  int64_t reflexes() const { return counts_.reflexes; }
  double peak_tip_force() const { return monitor_.peak_tip_force(); }
  const Eigen::VectorXd& torque() const { return tau_; }
  const motion::Reference& reference() const { return ref_; }
  /// e = q_d − q at the last commanding tick.
  const Eigen::VectorXd& error() const { return error_; }

  /// The IK figures of the last Cartesian plan: summed iterations, worst position error (m),
  /// whether every waypoint converged.
  int ik_iterations() const { return path_.ik_iterations(); }
  double ik_residual() const { return path_.ik_residual(); }
  bool ik_converged() const { return path_.ik_converged(); }

  int64_t faults() const { return counts_.faults; }
  int64_t stale_ticks() const { return counts_.stale_ticks; }
  int64_t rejected_targets() const { return counts_.rejected_targets; }

 private:
  bool driven_by(const ReferenceSource& source) const { return mode_ == Mode::kRunning && source_ == &source; }
  /// Starts driving the reference by `source` (RUNNING): the one place the source in force changes.
  void start_drive(ReferenceSource& source);
  /// Brakes the reference to rest from its motion, moving on from from_ns.
  void stop_motion(int64_t from_ns);
  /// Refuses (counted, with why) a stream's setpoint or a jog (`what`) that the controller's state
  /// does not take, and returns true; false when it may go on.
  bool refuse_stream(const char* what);
  /// The first message of a stream (setpoint, tip setpoint, jog: `what`) ends what drove the
  /// reference and starts `source` at now_ns; a later one goes on with it.
  template <typename Source>
  void enter_stream(Source& source, const char* what, int64_t now_ns);

  bool refuse(const char* format, ...) __attribute__((format(printf, 2, 3)));
  void fault(const char* format, ...) __attribute__((format(printf, 2, 3)));
  /// The state's age, size and finiteness, else FAULT; q_ and q̇_ from it.
  bool take_state(int64_t now_ns, const JointState& state);
  void observe(const JointState& state);
  /// A joint past its limits, or a collision, while RUNNING or HOLDING: the reflex.
  void guard(int64_t now_ns);
  void hold_at(const Eigen::VectorXd& q);
  /// Starts `reflex`, tripped by what `reason` says.
  void start_reflex(int64_t now_ns, const char* reason, Reflex reflex);
  bool set_joint_target(const Target& target, int64_t now_ns);
  bool request_cartesian(const Target& target);
  /// Whether the path planned for a goal (or a trajectory) keeps clear; if not, why into `why`.
  bool path_clear(bool trajectory, char (&why)[192]);
  /// The reference at now_ns; finishing a motion turns RUNNING into HOLDING.
  void update_reference(int64_t now_ns);
  /// The reference the source moved from ref_from_ cut to keep clear (clearance.hpp): a motion laid
  /// out in time waits along its path; one stalled against what cut it is over.
  void keep_clear();

  const RobotModel* model_;
  Config config_;
  Data data_;                       // the terms at the latest state, computed once per tick
  ReferenceKinematics kinematics_;  // the tip pose and J_b at the reference, at most once per tick
  motion::MotionLimits limits_;
  TorqueGuard guard_;
  CommandHistory history_;
  StateMonitor monitor_;
  Clearance clearance_;
  ControlLaw law_;
  GeneratorLimits generator_;
  JogProgress jog_progress_;
  // The reference sources, and the one in force while RUNNING.
  GoalMotion goal_;
  PathMotion path_;
  TrajectoryMotion trajectory_;
  StreamMotion stream_;
  TipStreamMotion tip_stream_;
  JogMotion jog_;
  StopMotion stop_;
  ReferenceSource* source_;
  motion::Reference ref_;
  motion::Reference ref_from_;  // the reference before the source moved it this tick
  PlannedPath planned_;  // a goal's or a trajectory's path, checked before it moves (path_clear)
  Eigen::VectorXd q_, qd_, error_, tau_;
  Eigen::VectorXd q_guarded_;  // the state the limit guard last saw, for a crossing
  Eigen::VectorXd retract_goal_;
  Mode mode_ = Mode::kWaiting;
  bool stood_down_ = false;
  bool compliant_ = false;
  ReferenceSource* reflex_motion_ = nullptr;  // what moves the reference in REFLEX: a stop or a retract
  // Fixed buffers: the reasons are formatted on the real-time thread, which must not allocate.
  char fault_reason_[192] = {};
  char rejection_[192] = {};
  char reflex_reason_[192] = {};
  char mode_rejection_[192] = {};
  char limit_reason_[160] = {};  // room for "; reflex stop" in reflex_reason_
  struct Counts {
    int64_t faults = 0, stale_ticks = 0, rejected_targets = 0, rejected_modes = 0, reflexes = 0;
  } counts_;
};

}  // namespace chasles::controller
