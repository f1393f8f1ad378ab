#include "controller/controller.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>

#include "core/dynamics/dynamics.hpp"
#include "core/lie/so3.hpp"

namespace chasles::controller {
namespace {

// The largest step of the equilibrium an impedance law takes at once (a target of duration 0):
// per joint, rad or m, and of the tip, m and rad. Beyond it the law would pull with K times a
// distance the operator did not mean to be sudden; a duration makes it a motion instead.
constexpr double kMaxJointStep = 0.2;
// A brake the clearance has slowed below this joint speed (rad/s or m/s) is at rest.
constexpr double kClearStill = 1e-4;
constexpr double kMaxTipStep = 0.05, kMaxTipRotationStep = 0.3;

void format_into(char (&buffer)[192], const char* format, va_list args) {
  std::vsnprintf(buffer, sizeof(buffer), format, args);
}

Config validated(const Config& config, int dof) {
  config.validate(dof);
  return config;
}

}  // namespace

Controller::Controller(const RobotModel& model, const Config& config)
    : model_(&model),
      config_(validated(config, model.dof())),
      data_(model),
      kinematics_(model),
      limits_(model, config_.limits),
      guard_(model, config_.torque_ramp, config_.period),
      history_(model.dof()),
      monitor_(model, config_),
      clearance_(model, config_.clearance),
      law_(model.dof(), config_),
      generator_(limits_, guard_.effort_limit(), guard_.torque_rate(), config_.limits.acceleration_within_effort,
                 config_.limits.jerk_within_torque_rate),
      goal_(model.dof(), limits_),
      path_(model.dof()),
      trajectory_(model.dof(), limits_),
      stream_(model.dof(), limits_, generator_, config_.stream_timeout),
      tip_stream_(model.dof(), config_.jog, limits_, generator_, config_.stream_timeout, jog_progress_),
      jog_(model.dof(), config_.jog, limits_, generator_, config_.stream_timeout, jog_progress_),
      stop_(model.dof(), limits_, generator_),
      source_(&goal_),
      ref_(model.dof()),
      ref_from_(model.dof()),
      planned_(model),
      q_(Eigen::VectorXd::Zero(model.dof())),
      qd_(Eigen::VectorXd::Zero(model.dof())),
      error_(Eigen::VectorXd::Zero(model.dof())),
      tau_(Eigen::VectorXd::Zero(model.dof())),
      q_guarded_(Eigen::VectorXd::Zero(model.dof())),
      retract_goal_(Eigen::VectorXd::Zero(model.dof())) {
  planned_.path.position = [this](double t, Eigen::VectorXd& q) {
    if (planned_.trajectory) {
      trajectory_.planned().sample(t, planned_.sampled);
    } else {
      goal_.planned().sample(t, planned_.sampled);
    }
    q = planned_.sampled.q;
  };
  // The planned motions keep within the velocity limits: the path's speed bound, where they are
  // finite; else the check has none to prove with, and bounds by the model's (an error it says).
  planned_.path.speed = limits_.velocity;
  if (!planned_.path.speed.allFinite()) planned_.path.speed.resize(0);
}

bool Controller::path_clear(bool trajectory, char (&why)[192]) {
  planned_.trajectory = trajectory;
  planned_.path.duration = trajectory ? trajectory_.planned().duration() : goal_.planned().duration();
  try {
    return clearance_.path_clear(*model_, planned_.data, planned_.path, why, sizeof(why));
  } catch (const Error& e) {  // a joint without a velocity limit: nothing bounds the path's speed
    std::snprintf(why, sizeof(why), "%.180s", e.what());
    return false;
  }
}

bool Controller::refuse(const char* format, ...) {
  va_list args;
  va_start(args, format);
  format_into(rejection_, format, args);
  va_end(args);
  ++counts_.rejected_targets;
  return false;
}

void Controller::fault(const char* format, ...) {
  va_list args;
  va_start(args, format);
  format_into(fault_reason_, format, args);
  va_end(args);
  if (mode_ != Mode::kFault) ++counts_.faults;
  mode_ = Mode::kFault;
  trajectory_.end(TrajectoryProgress::kAborted, "FAULT: %.160s", fault_reason_);
}

void Controller::stand_down(const char* format, ...) {
  if (stood_down_) return;
  va_list args;
  va_start(args, format);
  format_into(fault_reason_, format, args);
  va_end(args);
  ++counts_.faults;  // a fault of its own, even while another is on
  mode_ = Mode::kFault;
  stood_down_ = true;
  trajectory_.end(TrajectoryProgress::kAborted, "FAULT: %.160s", fault_reason_);
}

bool Controller::set_law(const LawSettings& settings, int64_t now_ns) {
  auto refuse_mode = [this](const char* why) {
    std::snprintf(mode_rejection_, sizeof(mode_rejection_), "%s", why);
    ++counts_.rejected_modes;
    return false;
  };
  if (mode_ == Mode::kWaiting) return refuse_mode("no robot state has arrived yet");
  if (mode_ == Mode::kFault) return refuse_mode("the controller is in FAULT");
  char why[192];
  if (const char* problem = law_problem(*model_, settings, why)) return refuse_mode(problem);
  law_.set(settings);
  trajectory_.end(TrajectoryProgress::kPreempted, "a new control law");
  guard_.begin_switch();
  // A new law ends a reflex where the arm is; free drive follows no reference, so a motion ends.
  // It ends a trajectory, a stream (of joint or tip setpoints) or a jog too: the reference brakes
  // to rest from its motion. A JOINT goal's quintic and a Cartesian path go on under the new law.
  if (mode_ == Mode::kReflex || law_.law() == Law::kFreeDrive) {
    hold_at(q_);
  } else if (mode_ == Mode::kRunning && source_ != &goal_ && source_ != &path_ && source_ != &stop_) {
    stop_motion(now_ns);
  }
  return true;
}

bool Controller::set_clearance_world(ClearanceWorld* world) {
  if (world != nullptr && world->row.size() != model_->dof()) return false;
  clearance_.set_world(world);
  return true;
}

bool Controller::set_model(const RobotModel& model) {
  if (&model == model_) return true;
  if (model.dof() != model_->dof() || !model.check(data_) || !kinematics_.fits(model)) return false;
  model_ = &model;
  monitor_.set_model(model);  // restarts the observer at the next state
  return true;
}

void Controller::hold_at(const Eigen::VectorXd& q) {
  ref_.hold(q);
  mode_ = Mode::kHolding;
  compliant_ = false;
  reflex_motion_ = nullptr;
}

void Controller::start_drive(ReferenceSource& source) {
  source_ = &source;
  mode_ = Mode::kRunning;
}

void Controller::stop_motion(int64_t from_ns) {
  stop_.start(ref_, data_, from_ns);
  start_drive(stop_);
}

// Every new state, whatever the mode: the observer needs each sample and the torque the arm had
// over the step before it, ours or the plant's brake. data_ holds the terms at this state. A
// torque the arm applies otherwise than sent is the configuration's, not the moment's: this
// controller stops commanding for good, as when another sender is heard, naming the flag that
// fixes it.
void Controller::observe(const JointState& state) {
  const bool commanding = mode_ != Mode::kWaiting && mode_ != Mode::kFault;
  switch (monitor_.observe(state, data_, history_, commanding, law_.allowance())) {
    case TorqueSemanticsCheck::Verdict::kDriverAddsGravity:
      stand_down("the arm applied the torque commanded + %.0f %% of g(q) over %g s: its driver adds gravity "
                 "compensation to the whole torque sent; run with --torque-semantics overlay",
                 100.0 * monitor_.semantics_share(), TorqueSemanticsCheck::kWindow);
      break;
    case TorqueSemanticsCheck::Verdict::kDriverAddsNothing:
      stand_down("the arm applied the torque commanded - %.0f %% of g(q) over %g s: its driver adds no gravity "
                 "compensation to the tau - g(q) sent; run with --torque-semantics full",
                 -100.0 * monitor_.semantics_share(), TorqueSemanticsCheck::kWindow);
      break;
    default:
      break;
  }
}

void Controller::start_reflex(int64_t now_ns, const char* reason, Reflex reflex) {
  hold_at(q_);
  if (reflex == Reflex::kCompliant) {
    compliant_ = true;
  } else {
    ref_.qd = qd_;  // from how the arm moves now, so the reference does not jump
    const ContactMonitor& contact = monitor_.contact();
    if (reflex == Reflex::kRetract) {
      contact.retract_goal(contact.config().retract_distance, retract_goal_);
      motion::LimitExcess excess;
      if (goal_.plan(ref_, retract_goal_, contact.config().retract_duration, excess) > 0.0) {
        goal_.start(now_ns);  // slower than configured where the limits ask it
        reflex_motion_ = &goal_;
      }
    }
    if (reflex_motion_ == nullptr) {
      // A stop (or a retract the limits do not allow from this motion): the reference brakes from
      // the arm's own motion to rest, within the acceleration its effort leaves it here. A reference
      // held still while the arm moves fast asks a torque the arm may not have: saturated, the arm
      // swung on, up to 30 times its velocity limits (docs/controller.md, "Clearance").
      stop_.start(ref_, data_, now_ns);
      reflex_motion_ = &stop_;
    }
  }
  mode_ = Mode::kReflex;
  path_.drop();  // a Cartesian plan in the works is dropped
  trajectory_.end(TrajectoryProgress::kAborted, "REFLEX: %.160s", reason);
  std::snprintf(reflex_reason_, sizeof(reflex_reason_), "%.160s; reflex %s", reason, to_string(reflex));
  ++counts_.reflexes;
}

bool Controller::set_trajectory(const motion::Waypoints& w, int64_t now_ns) {
  char why[192];
  const auto reject = [&](const char* reason) {
    trajectory_.reject(w.id, reason);
    return refuse("trajectory %lld: %s", static_cast<long long>(w.id), reason);
  };
  if (mode_ == Mode::kWaiting) return reject("no robot state has arrived yet");
  if (mode_ == Mode::kFault) return reject("the controller is in FAULT");
  if (law_.law() == Law::kFreeDrive) return reject("free drive follows no trajectory (send a control mode first)");
  if (!trajectory_.check(*model_, w, why)) return reject(why);
  if (mode_ == Mode::kReflex) hold_at(q_);  // a new trajectory ends the reflex, from where the arm is
  if (!trajectory_.fit(*model_, ref_, w, why)) return reject(why);
  if (char clash[192]; !path_clear(true, clash)) return reject(clash);
  path_.drop();  // a Cartesian plan still in the works is superseded
  trajectory_.start(w, now_ns);
  start_drive(trajectory_);
  return true;
}

bool Controller::set_target(const Target& target, int64_t now_ns) {
  if (mode_ == Mode::kWaiting) return refuse("no robot state has arrived yet");
  if (mode_ == Mode::kFault) return refuse("the controller is in FAULT (%s)", fault_reason_);
  if (mode_ == Mode::kReflex) hold_at(q_);  // a new target ends the reflex, from where the arm is
  if (law_.law() == Law::kFreeDrive && target.mode != Target::kHold) {
    return refuse("free drive follows no target: the arm goes where it is moved (send a control mode first)");
  }
  switch (target.mode) {
    case Target::kHold:
      trajectory_.end(TrajectoryProgress::kPreempted, "a HOLD target");
      hold_at(q_);
      return true;
    case Target::kCartesian:
      return request_cartesian(target);
    case Target::kJoint:
      return set_joint_target(target, now_ns);
    default:
      return refuse("unknown target mode %d", target.mode);
  }
}

bool Controller::set_joint_target(const Target& target, int64_t now_ns) {
  const int n = model_->dof();
  if (target.num_joints != n) return refuse("a joint target for %d joints; the arm has %d", target.num_joints, n);
  // Under an impedance law a duration of 0 steps the equilibrium: the impedance shapes the motion.
  const bool step = target.duration == 0.0 && law_.is_impedance();
  if (!step && (!(target.duration > 0.0) || !std::isfinite(target.duration))) {
    return refuse("a joint target needs a positive, finite duration (got %g s; 0 steps the equilibrium of an "
                  "impedance law)", target.duration);
  }
  for (int i = 0; i < n; ++i) {
    const Joint& joint = model_->joint(i);
    const double goal = target.q(i);
    if (!std::isfinite(goal)) return refuse("joint %s: target %g is not finite", joint.name.c_str(), goal);
    // Continuous joints wrap, so any finite angle is a position they can take.
    if (goal < limits_.lower(i) || goal > limits_.upper(i)) {
      return refuse("joint %s: target %g is outside [%g, %g], its limits less the %g margin", joint.name.c_str(), goal,
                    limits_.lower(i), limits_.upper(i), config_.limits.position_margin);
    }
    if (step && std::abs(goal - ref_.q(i)) > kMaxJointStep) {
      return refuse("joint %s: a step of %g to %g is over %g; give a duration", joint.name.c_str(),
                    std::abs(goal - ref_.q(i)), goal, kMaxJointStep);
    }
  }
  if (!step) {
    motion::LimitExcess excess;
    const double shortest = goal_.plan(ref_, target.q, target.duration, excess);
    if (excess) {
      const char* name = model_->joint(excess.joint).name.c_str();
      const char* quantity = to_string(excess.quantity);
      const char* unit = unit_of(excess.quantity);
      if (shortest == 0.0) {
        return refuse("joint %s: from the current motion no quintic reaches the goal within its %s limit %g %s",
                      name, quantity, excess.limit, unit);
      }
      return refuse("joint %s: reaching the goal in %g s needs a %s of %g %s, over its limit %g %s; %.4g s would do",
                    name, target.duration, quantity, excess.value, unit, excess.limit, unit, shortest);
    }
    // Before anything moves: the quintic kept clear of the arm itself and the scene.
    if (char clash[192]; !path_clear(false, clash)) return refuse("the JOINT target's path: %s", clash);
  }
  path_.drop();  // a Cartesian plan still in the works is superseded
  trajectory_.end(TrajectoryProgress::kPreempted, "a JOINT target");
  if (step) {
    hold_at(target.q);
    return true;
  }
  goal_.start(now_ns);  // the quintic plan() checked
  start_drive(goal_);
  return true;
}

bool Controller::request_cartesian(const Target& target) {
  if (mode_ == Mode::kRunning) {
    return refuse("a Cartesian target while a motion runs: send it once the arm holds (the path starts at rest)");
  }
  if (!target.position.allFinite() || !target.quaternion.allFinite()) {
    return refuse("a Cartesian target with a non-finite position or quaternion");
  }
  const double norm = target.quaternion.norm();
  if (std::abs(norm - 1.0) > kQuaternionNormTolerance) {
    return refuse("a Cartesian target whose quaternion (w, x, y, z) has norm %g, not 1", norm);
  }
  const bool step = target.duration == 0.0 && law_.is_impedance();
  if (!step && (!(target.duration > 0.0) || !std::isfinite(target.duration))) {
    return refuse("a Cartesian target needs a positive, finite duration (got %g s; 0 steps the equilibrium of an "
                  "impedance law)", target.duration);
  }
  const Eigen::Matrix3d R_goal = Eigen::Quaterniond(target.quaternion(0), target.quaternion(1), target.quaternion(2),
                                                    target.quaternion(3))
                                     .normalized()
                                     .toRotationMatrix();
  if (step) {
    const Transform& T_sb = kinematics_.at(*model_, ref_.q).T_sb;
    const double distance = (target.position - T_sb.translation()).norm();
    const double angle = Eigen::AngleAxisd(R_goal * T_sb.linear().transpose()).angle();
    if (distance > kMaxTipStep || angle > kMaxTipRotationStep) {
      return refuse("a step of the tip by %g m and %g rad is over %g m or %g rad; give a duration", distance, angle,
                    kMaxTipStep, kMaxTipRotationStep);
    }
  }
  path_.request(ref_.q, Transform(R_goal, target.position), target.duration);
  return true;
}

bool Controller::follow(const JointPath& path, int64_t now_ns) {
  if (!path_.answers(path)) return false;
  if (!path.ok) return refuse("Cartesian target refused: %s", path.reason);
  if (mode_ != Mode::kHolding || (path.q.col(0) - ref_.q).cwiseAbs().maxCoeff() > 1e-12) {
    return refuse("Cartesian path dropped: the arm is no longer holding where the path starts");
  }
  trajectory_.end(TrajectoryProgress::kPreempted, "a CARTESIAN target");
  path_.start(path, now_ns);
  start_drive(path_);
  return true;
}

bool Controller::refuse_stream(const char* what) {
  if (mode_ == Mode::kWaiting) return !refuse("%s: no robot state has arrived yet", what);
  if (mode_ == Mode::kFault) return !refuse("%s: the controller is in FAULT", what);
  // A stream does not end a reflex by coming on: it would within a period. A target or law does.
  if (mode_ == Mode::kReflex) return !refuse("%s: the arm is in REFLEX (a target or control mode resumes)", what);
  if (law_.law() == Law::kFreeDrive) return !refuse("%s: free drive follows none (send a control mode first)", what);
  return false;
}

template <typename Source>
void Controller::enter_stream(Source& source, const char* what, int64_t now_ns) {
  if (driven_by(source)) return;
  trajectory_.end(TrajectoryProgress::kPreempted, "%s", what);
  path_.drop();  // a Cartesian plan in the works is dropped
  source.start(now_ns);
  start_drive(source);
}

bool Controller::set_setpoint(const Setpoint& setpoint, int64_t now_ns) {
  if (refuse_stream("setpoint")) return false;
  const int n = model_->dof();
  if (setpoint.q.size() != n || setpoint.qd.size() != n || !setpoint.q.allFinite() || !setpoint.qd.allFinite()) {
    return refuse("setpoint: of the wrong size or with non-finite values");
  }
  enter_stream(stream_, "a stream", now_ns);
  return stream_.take(setpoint, data_, now_ns);
}

bool Controller::set_tip_setpoint(const TipSetpoint& setpoint, int64_t now_ns) {
  if (refuse_stream("tip setpoint")) return false;
  if (!setpoint.position.allFinite() || !setpoint.quaternion.allFinite() || !setpoint.twist.allFinite()) {
    return refuse("tip setpoint: with non-finite values");
  }
  const double norm = setpoint.quaternion.norm();
  if (std::abs(norm - 1.0) > kQuaternionNormTolerance) {
    return refuse("tip setpoint: a quaternion of norm %g, not a unit one", norm);
  }
  enter_stream(tip_stream_, "a Cartesian stream", now_ns);
  return tip_stream_.take(setpoint, data_, now_ns);
}

bool Controller::set_jog(const Jog& jog, int64_t now_ns) {
  if (refuse_stream("jog")) return false;
  if (jog.kind != Jog::kJointVelocity && jog.kind != Jog::kTwist) return refuse("jog: unknown kind %d", jog.kind);
  if (jog.kind == Jog::kTwist && jog.frame != Jog::kBase && jog.frame != Jog::kTool) {
    return refuse("jog: unknown frame %d", jog.frame);
  }
  if (jog.joint_velocity.size() != model_->dof() || !jog.joint_velocity.allFinite() || !jog.twist.allFinite()) {
    return refuse("jog: of the wrong size or with non-finite values");
  }
  enter_stream(jog_, "a jog", now_ns);
  return jog_.take(jog, data_, now_ns);
}

void Controller::update_reference(int64_t now_ns) {
  if (law_.law() == Law::kFreeDrive) {
    ref_.hold(q_);  // the arm goes where it is moved; a law after this one starts from there
    return;
  }
  const Tick tick{now_ns, model_, &kinematics_};
  clearance_.hand_back(ref_);
  ref_from_ = ref_;
  if (mode_ == Mode::kReflex) {
    if (compliant_) ref_.hold(q_);  // the arm goes where it is pushed
    if (reflex_motion_ == nullptr) return;
    const ReferenceSource::Progress progress = reflex_motion_->advance(tick, ref_);
    keep_clear();
    if (progress == ReferenceSource::Progress::kFailed) ref_.hold(ref_from_.q);  // never seen in the tests
    if (progress != ReferenceSource::Progress::kMoving) reflex_motion_ = nullptr;  // at rest, held
    return;
  }
  if (mode_ != Mode::kRunning) return;
  const ReferenceSource::Progress progress = source_->advance(tick, ref_);
  keep_clear();
  switch (progress) {
    case ReferenceSource::Progress::kMoving:
      break;
    case ReferenceSource::Progress::kArrived:
      hold_at(ref_.q);
      break;
    case ReferenceSource::Progress::kStopping:  // a stream gone silent brakes from its last step on
      stop_motion(stream_.last_tick_ns());
      update_reference(now_ns);
      break;
    case ReferenceSource::Progress::kFailed:  // never seen in the tests and benchmarks
      refuse("stream ended: %.170s", source_->failure());
      hold_at(ref_.q);
      break;
  }
}

void Controller::keep_clear() {
  if (!clearance_.active() || (ref_.q.array() == ref_from_.q.array()).all()) return;
  if (!clearance_.shape(*model_, kinematics_.at(*model_, ref_from_.q), ref_from_, config_.period,
                        generator_.limits().acceleration, ref_)) {
    return;
  }
  if (mode_ == Mode::kReflex) {
    reflex_motion_ = nullptr;  // no retract or brake into something else: the reflex holds where it was cut
    ref_.hold(ref_.q);
    return;
  }
  // A motion laid out in time (a goal's quintic, a Cartesian path, a trajectory) waits along its
  // path: its clock is set back by the share of the tick it did not take. A stream, a jog and a
  // brake plan from the reference every tick, with their own acceleration handed back (Clearance::hand_back).
  source_->delay(std::llround((1.0 - clearance_.status().kept) * config_.period * 1e9));
  if (ref_.qd.norm() < kClearStill && source_ != &stream_ && source_ != &tip_stream_ && source_ != &jog_) {
    // Stalled against what cut it, with no room to come: the motion is over, at rest where it is.
    refuse("the motion stopped short: %.150s", clearance_.status().slowing_name);
    trajectory_.end(TrajectoryProgress::kAborted, "stopped short: %.160s", clearance_.status().slowing_name);
    path_.drop();
    hold_at(ref_.q);
  }
}

bool Controller::take_state(int64_t now_ns, const JointState& state) {
  if (now_ns - state.arrival_ns > config_.stale_ns) {
    ++counts_.stale_ticks;
    if (mode_ != Mode::kWaiting) {
      fault("no fresh robot state: the latest is %.1f ms old (limit %.1f ms)",
            1e-6 * static_cast<double>(now_ns - state.arrival_ns), 1e-6 * static_cast<double>(config_.stale_ns));
    }
    return false;
  }
  const int n = model_->dof();
  if (state.q.size() != n || state.qd.size() != n || state.effort.size() != n || !state.q.allFinite() ||
      !state.qd.allFinite() || !state.effort.allFinite()) {
    fault("a robot state of the wrong size or with non-finite values reached the control law");
    return false;
  }
  q_ = state.q;
  qd_ = state.qd;
  return true;
}

void Controller::guard(int64_t now_ns) {
  if (mode_ != Mode::kRunning && mode_ != Mode::kHolding) return;
  // Under free drive a person moves the arm: a collision on a link they may guide it by is theirs,
  // no reflex — and no reason to skip the checks after it.
  const ContactMonitor& contact = monitor_.contact();
  const LinkPolicy& policy = contact.policy(contact.estimate().body);
  const bool collided = contact.estimate().collision && !(law_.law() == Law::kFreeDrive && policy.guided);
  if (const motion::LimitExcess excess = measured_excess(limits_, q_guarded_, q_, qd_)) {
    std::snprintf(limit_reason_, sizeof(limit_reason_), "joint %s: %s %g %s past its limit %g %s",
                  model_->joint(excess.joint).name.c_str(), to_string(excess.quantity), excess.value,
                  unit_of(excess.quantity), excess.limit, unit_of(excess.quantity));
    start_reflex(now_ns, limit_reason_, Reflex::kStop);
  } else if (collided) {
    start_reflex(now_ns, contact.reason(), policy.reflex);
  } else if (clearance_.inside() >= 0) {  // pushed inside a stop distance: a contact, as the policy says
    start_reflex(now_ns, clearance_.inside_reason(clearance_.inside()), contact.config().reflex);
  }
}

bool Controller::tick(int64_t now_ns, const JointState* state) {
  if (state == nullptr || stood_down_ || !take_state(now_ns, *state)) return false;
  // The model's terms at this state, once: the law, the observer and the contact monitor read them.
  compute_tick_terms(*model_, data_, q_, qd_);
  observe(*state);
  if (stood_down_) return false;  // the observer found the torque semantics wrong
  clearance_.observe(data_);
  if (mode_ == Mode::kWaiting || mode_ == Mode::kFault) {
    // (Re-)entering HOLD where the arm is now, from g(q): what a plant applies while it brakes or
    // waits, so the first commands do not jump. A joint found outside its limits has crossed none.
    hold_at(q_);
    q_guarded_ = q_;
    guard_.restart(data_.g);
  }
  guard(now_ns);
  q_guarded_ = q_;
  update_reference(now_ns);
  error_ = ref_.q - q_;
  if (trajectory_.active() && !trajectory_.judge(*model_, error_, driven_by(trajectory_), now_ns)) hold_at(q_);
  const double compliant_damping = compliant_ ? contact_config().compliant_damping : -1.0;
  law_.torque(*model_, data_, kinematics_, ref_, q_, qd_, compliant_damping, tau_);
  if (law_.law() != Law::kComputedTorque) clearance_.repel(*model_, data_, tau_);  // felt where the arm yields
  if (!guard_.apply(tau_, now_ns)) {
    fault("the control law produced a non-finite torque");
    return false;
  }
  history_.record(tau_, now_ns);
  return true;
}

}  // namespace chasles::controller
