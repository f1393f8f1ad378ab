// The control logic of one tick, free of threads, clocks and transport so that it can be tested
// directly: validated state, targets and laws in, joint torques out, through one safety pipeline.
//
//   state age / size / finiteness → reference (hold | quintic joint motion | planned Cartesian path)
//   → the law in force (law.hpp: computed torque, joint impedance, Cartesian impedance, free
//     drive) [+ D q̇_d] → a switch's offset, fading → non-finite refused → effort limits →
//     torque-rate limit → command
//
// Beside it, every new state feeds the contact monitor (contact.hpp): a collision while the arm
// runs or holds starts the reflex (REFLEX), in every law, which a new target or law ends.
//
// A new law takes over without a torque jump: at its first tick the difference between the torque
// last commanded and the new law's is kept as an offset that fades linearly to zero over the
// torque-ramp time, the time the rate limit allows to cross the effort range, so a switch between
// laws whose torques differ by less than that range never meets the rate limit.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "controller/cartesian.hpp"
#include "controller/contact.hpp"
#include "controller/jog.hpp"
#include "controller/law.hpp"
#include "controller/semantics_check.hpp"
#include "controller/signals.hpp"
#include "core/motion/limits.hpp"
#include "core/motion/quintic.hpp"
#include "core/motion/waypoints.hpp"
#include "core/model/model.hpp"
#include "core/motion/online_generator.hpp"

namespace chasles::controller {

struct Config {
  Eigen::VectorXd kp;  ///< position gains K_p, 1/s², one per joint
  Eigen::VectorXd kd;  ///< velocity gains K_d, 1/s
  double period = 1e-3;           ///< tick period, s
  int64_t stale_ns = 10'000'000;  ///< a state older than this stops the commands: FAULT
  /// Time to ramp through a joint's full effort range, s: the torque-rate limit is
  /// effort_limit / torque_ramp per joint (infinite where the URDF gives no effort limit).
  /// The same time is the fade of a switch between laws.
  double torque_ramp = 0.05;
  /// The joints' viscous damping D (N·m·s/rad or N·s/m), if known: the law adds D q̇_d, the
  /// torque that feeds it forward, and the contact observer counts it as the model's.
  /// Empty or zero: none.
  Eigen::VectorXd damping;
  /// The joints' Coulomb friction f_c (N·m or N), if known (chasles_calibrate dynamics identifies
  /// it): the law adds f_c tanh(q̇_d / v_c) — the reference's velocity, so the feedforward never
  /// chatters — and the observer counts f_c tanh(q̇ / v_c) as the model's (v_c = kCoulombVelocity,
  /// contact/observer.hpp). Empty: none.
  Eigen::VectorXd coulomb;
  /// Contact and collision thresholds, the observer's gains and the reflex.
  ContactConfig contact;
  /// Acceleration and jerk limits (the URDF gives position and velocity), the position margin
  /// and the measured velocity's tolerance.
  motion::LimitConfig limits;
  /// A stream or a jog with no message for this long, s, is taken as stopped: the arm decelerates
  /// to rest.
  double stream_timeout = 0.1;
  /// The condition numbers where a twist jog toward a singularity slows and stops.
  JogConfig jog;
  /// FAULT when the arm applies the command ± g(q), a driver's gravity compensation added to a
  /// whole torque or missing from τ − g(q) (semantics_check.hpp): off only for a driver whose
  /// reported torque is not the torque it applies.
  bool check_torque_semantics = true;

  /// K_p = ω², K_d = 2ω (critically damped error dynamics at the natural frequency ω, rad/s).
  static Config critically_damped(int dof, double omega);
  /// Throws ArgumentError naming what is wrong (sizes, signs, non-finite values).
  void validate(int dof) const;
};

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
  const LawSettings& law() const { return law_; }
  /// Controls with `model` from the next tick: the same chain with another payload (a model of
  /// another size is ignored). Keeps a reference; the caller keeps it alive until the next
  /// set_model. The contact observer starts again with it. Allocates nothing.
  void set_model(const RobotModel& model);
  const RobotModel& model() const { return *model_; }

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
  const TrajectoryProgress& trajectory() const { return progress_; }

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
  bool streaming() const { return driven_by(Drive::kStream) || driven_by(Drive::kTipStream); }
  int64_t setpoints() const { return setpoints_; }
  int64_t dropped_setpoints() const { return dropped_setpoints_; }

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
  bool jogging() const { return driven_by(Drive::kJog); }
  /// How the latest jog tick went: the condition number, the speed's scale and what cut it.
  const JogProgress& jog_progress() const { return jog_progress_; }
  /// The condition numbers in force.
  const JogConfig& jog_config() const { return jogger_.config(); }
  int64_t jogs() const { return jogs_; }
  int64_t dropped_jogs() const { return dropped_jogs_; }

  /// The Cartesian request set_target() made, once: true and `request` filled, else false.
  bool take_request(CartesianRequest& request);
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
  int64_t rejected_modes() const { return rejected_modes_; }
  /// What tripped the latest reflex, naming the joint or the force.
  const char* reflex_reason() const { return reflex_reason_; }
  /// The contact monitor's estimate at the latest state.
  const ContactEstimate& contact() const { return contact_.estimate(); }
  /// The period of the robot states, s, measured from their utime (their arrival where a sender
  /// leaves utime standing): the mean over the last kPeriodWindow intervals between consecutive
  /// states; the configured period until one is measured. The observer steps by each interval.
  double state_period() const { return state_period_; }
  /// Why the measured period is not the configured one (over kPeriodTolerance apart, once
  /// kPeriodWindow intervals are in), or "" when it is.
  const char* period_warning() const { return period_mismatch_ ? period_warning_ : ""; }
  static constexpr int64_t kPeriodWindow = 100;
  static constexpr double kPeriodTolerance = 0.1;
  /// The model's terms at the latest state (compute_tick_terms), and the count of their passes.
  const Data& data() const { return data_; }
  /// The tip pose and J_b at the reference (computed under the Cartesian law only).
  const Data& reference_data() const { return data_ref_; }
  /// The limits every reference keeps to and the measured state is guarded by.
  const motion::MotionLimits& limits() const { return limits_; }
  /// The limits the online generator plans streams, jogs and stops with now: limits_' velocity and
  /// acceleration (∞ as large finite values) and the jerk capped by the torque rate at the pose of
  /// the latest goal taken (cap_jerk_to_torque_rate).
  const motion::Limits& generator_limits() const { return otg_limits_; }
  /// The thresholds and reflex in force (the defaults filled in from the model).
  const ContactConfig& contact_config() const { return contact_.config(); }
  /// Contacts (each time the contact flag rose) and reflexes since start; the largest estimated
  /// tip force, N.
  int64_t contacts() const { return contacts_; }
  int64_t reflexes() const { return reflexes_; }
  double peak_tip_force() const { return peak_tip_force_; }
  const Eigen::VectorXd& torque() const { return tau_; }
  const motion::Reference& reference() const { return ref_; }
  /// e = q_d − q at the last commanding tick.
  const Eigen::VectorXd& error() const { return error_; }

  /// The IK figures of the last Cartesian plan: summed iterations, worst position error (m),
  /// whether every waypoint converged.
  int ik_iterations() const { return ik_iterations_; }
  double ik_residual() const { return ik_residual_; }
  bool ik_converged() const { return ik_converged_; }

  int64_t faults() const { return faults_; }
  int64_t stale_ticks() const { return stale_ticks_; }
  int64_t rejected_targets() const { return rejected_targets_; }

 private:
  /// What drives the reference while RUNNING: a quintic to a goal, a planned Cartesian path, a
  /// waypoint trajectory, a stream of setpoints, a jog, or the stop after one of them. From kStream
  /// on, the online generator makes the reference (follows_generator).
  enum class Drive : int8_t { kGoal, kPath, kWaypoints, kStream, kTipStream, kJog, kStop };
  bool driven_by(Drive drive) const { return mode_ == Mode::kRunning && drive_ == drive; }
  /// The drives whose reference the online generator makes, tick by tick (its jerk capped first).
  static bool follows_generator(Drive drive) { return drive >= Drive::kStream; }
  /// Takes a stream's message (setpoint, tip setpoint, jog: `what`) stamped `utime`: the first of
  /// a stream ends what drove the reference and starts `drive`; a later one older than the one in
  /// force (`last_utime`) is dropped and counted in `dropped`, and false returned.
  bool enter_stream(Drive drive, int64_t utime, int64_t last_utime, int64_t& dropped, const char* what,
                    int64_t now_ns);
  /// Refuses (counted, with why) a stream's setpoint or a jog (`what`) that the controller's state
  /// does not take, and returns true; false when it may go on.
  bool refuse_stream(const char* what);

  bool refuse(const char* format, ...) __attribute__((format(printf, 2, 3)));
  void fault(const char* format, ...) __attribute__((format(printf, 2, 3)));
  void check_semantics(const JointState& state, double dt);
  void hold_at(const Eigen::VectorXd& q);
  void observe(const JointState& state);
  void track_period(double dt);
  const Eigen::VectorXd& torque_across(const JointState& state, double dt);
  int command_in_force(int64_t at_ns) const;
  /// Starts the reflex: the configured one for a collision (contact_'s reason), else a stop.
  void start_reflex(int64_t now_ns, const char* limit_reason = nullptr);
  /// The shortest duration from `requested` up whose quintic from ref_ to goal stays within the
  /// limits, left in candidate_; 0 when none does. excess: what the requested duration broke.
  double shortest_duration(const Eigen::VectorXd& goal, double requested, motion::LimitExcess& excess);
  bool request_cartesian(const Target& target);
  /// The reference at now_ns; finishing a motion turns RUNNING into HOLDING.
  void update_reference(int64_t now_ns);
  /// The stream's reference one tick on (and a stop's): the generator's plan from ref_ toward the
  /// setpoint (the stop's end).
  void update_stream(int64_t now_ns);
  /// Counts a setpoint taken at now_ns and returns its age, s: how much later than the stream's
  /// quickest it arrived (sender's utime against arrival), by which it is moved on.
  double take_setpoint(int64_t utime, int64_t now_ns, bool first);
  /// A jog's reference one tick on, or a Cartesian stream's.
  void update_jog(int64_t now_ns);
  /// The generator's target for a stop: where the fastest brake from the reference ends (at rest,
  /// within the position limits).
  void aim_at_stop();
  /// Brakes the reference to rest along the generator's stop (Drive::kStop) from now_ns.
  void stop_motion(int64_t now_ns);
  /// Starts driving the reference by `drive` (RUNNING) from now_ns, ending what drove it before.
  void start_drive(Drive drive, int64_t now_ns);
  /// A waypoint trajectory's tolerances and outcome, after the reference is updated.
  void judge_trajectory(int64_t now_ns);
  /// Ends an active waypoint trajectory with `outcome`, saying why.
  void end_trajectory(TrajectoryProgress::Outcome outcome, const char* format, ...)
      __attribute__((format(printf, 3, 4)));
  /// The least factor (≥ 1, to 1e-3) by which waypoints' times scaled fit the limits, left built
  /// in spline_candidate_; 0 if none up to kMaxTimeScale.
  double least_time_scale(const motion::Waypoints& waypoints);

  /// The generator's jerk limits at this state: the configured ones, scaled down by one factor
  /// until M(q) times them asks at most kTorqueRateShare of each joint's torque-rate limit.
  void limit_torque_rate();
  void cap_jerk_to_torque_rate();
  /// The law's torque at this tick into tau_ (before the switch's offset and the safety pipeline).
  void apply_law(int64_t now_ns);

  const RobotModel* model_;
  Config config_;
  Data data_;      // the terms at the latest state, computed once per tick
  Data data_ref_;  // frame c at the reference, for the Cartesian law (and a Cartesian step's check)
  LawSettings law_;
  LawWorkspace work_;
  Eigen::VectorXd switch_offset_;  // what the torque last commanded differed from the new law's
  Eigen::VectorXd allowance_;      // the impedance's own pull at the last tick, for the contact monitor
  bool switch_pending_ = false;    // a new law: take the offset at the next commanding tick
  int64_t switch_start_ns_ = 0;
  Eigen::VectorXd effort_limit_, rate_limit_per_tick_, torque_rate_;  // N·m, N·m per tick, N·m/s
  Eigen::VectorXd q_, qd_, qdd_ref_, error_, tau_, tau_prev_;
  motion::MotionLimits limits_;
  Eigen::VectorXd q_guarded_;  // the state the limit guard last saw, for a crossing
  char limit_reason_[160] = {};  // room for "; reflex stop" in reflex_reason_
  motion::Reference ref_;
  motion::QuinticTrajectory trajectory_, candidate_;
  Drive drive_ = Drive::kGoal;
  JointPathSampler path_;
  motion::WaypointSpline spline_, spline_candidate_;  // the one followed; the one being checked
  Eigen::VectorXd path_tolerance_, goal_tolerance_;
  double goal_time_ = 0.0;
  TrajectoryProgress progress_;
  motion::OnlineGenerator otg_;
  motion::Limits otg_limits_;  // limits_, with ∞ replaced by large finite values (the generator needs them)
  Eigen::VectorXd jerk_limit_;  // the configured jerk, finite; otg_limits_.jerk is it capped by the torque rate
  motion::KinematicState otg_from_, otg_target_, otg_out_;
  int64_t setpoint_utime_ = 0, setpoint_ns_ = 0, stream_tick_ns_ = 0;
  int64_t stream_offset_us_ = 0;  // the least (arrival − sender's utime) of the stream, µs
  int64_t setpoints_ = 0, dropped_setpoints_ = 0;
  Jogger jogger_;
  Jog jog_;  // the latest command taken
  Transform tip_target_;   // a Cartesian stream's pose, moved on with tip_twist_ every tick
  Vector6d tip_twist_ = Vector6d::Zero();
  JogProgress jog_progress_;
  int64_t jog_utime_ = 0, jog_ns_ = 0, jogs_ = 0, dropped_jogs_ = 0;
  ContactMonitor contact_;
  TorqueSemanticsCheck semantics_;
  int64_t observed_seq_ = 0;  // of the last state the contact monitor took, once observed_any_
  int64_t observed_utime_ = 0, observed_arrival_ns_ = 0;
  bool observed_any_ = false;
  bool compliant_ = false, retracting_ = false, in_contact_ = false;
  Eigen::VectorXd retract_goal_;
  int64_t contacts_ = 0, reflexes_ = 0;
  double peak_tip_force_ = 0.0;
  CartesianRequest request_;
  bool request_ready_ = false;
  int64_t pending_request_ = -1;  // id of the request whose path is awaited; −1: none
  int64_t next_request_id_ = 0;
  int ik_iterations_ = 0;
  double ik_residual_ = 0.0;
  bool ik_converged_ = false;
  int64_t motion_start_ns_ = 0;
  Mode mode_ = Mode::kWaiting;
  bool stood_down_ = false;
  // Fixed buffers: the reasons are formatted on the real-time thread, which must not allocate.
  char fault_reason_[192] = {};
  char rejection_[192] = {};
  char reflex_reason_[192] = {};
  char mode_rejection_[192] = {};
  int64_t faults_ = 0, stale_ticks_ = 0, rejected_targets_ = 0, rejected_modes_ = 0;
  double state_period_;
  // The commands of the last kSentCommands ticks and when they were sent: the observer's torque
  // across states that were lost (torque_across).
  static constexpr int kSentCommands = 16;
  Eigen::MatrixXd sent_torque_;
  std::vector<int64_t> sent_ns_;
  int sent_next_ = 0;
  Eigen::VectorXd gap_torque_;
  double quoted_period_ = 0.0;  // the state period period_warning_ was formatted with
  int64_t period_intervals_ = 0;
  bool period_mismatch_ = false;
  char period_warning_[160] = {};
};

}  // namespace chasles::controller
