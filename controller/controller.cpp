#include "controller/controller.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>

#include "core/dynamics/dynamics.hpp"
#include "core/lie/so3.hpp"

namespace chasles::controller {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The largest factor a trajectory's times are scaled by to fit the limits.
constexpr double kMaxTimeScale = 1000.0;

// The longest quintic the search for a feasible duration tries, s, and its precision: the
// duration it suggests is at most this fraction longer than the shortest.
constexpr double kLongestMotion = 3600.0;
constexpr double kDurationPrecision = 1e-3;

// The largest step of the equilibrium an impedance law takes at once (a target of duration 0):
// per joint, rad or m, and of the tip, m and rad. Beyond it the law would pull with K times a
// distance the operator did not mean to be sudden; a duration makes it a motion instead.
constexpr double kMaxJointStep = 0.2;
constexpr double kMaxTipStep = 0.05, kMaxTipRotationStep = 0.3;

bool is_impedance(Law law) { return law == Law::kJointImpedance || law == Law::kCartesianImpedance; }

// A gap between states longer than this many periods restarts the observer: the torque held over
// it is not known.
constexpr double kMaxGapPeriods = 10.5;

// The relative change of the measured period that formats the warning anew, about its 3 digits'
// resolution: a jittery stream's running mean moves by less than this most states.
constexpr double kPeriodQuoteStep = 1e-3;

// The least x in (infeasible, largest], to kDurationPrecision, for which fits(x) holds, fits(infeasible)
// being false: by doubling up to largest, then bisection (fits is taken to hold from some x on); 0
// when it holds nowhere up to largest. fits(x) is called last with the x returned.
template <typename Fits>
double least_fitting(double infeasible, double largest, Fits fits) {
  double feasible = 0.0;
  for (double x = std::min(2.0 * infeasible, largest); feasible == 0.0; x = std::min(2.0 * x, largest)) {
    if (fits(x)) {
      feasible = x;
    } else if (x == largest) {
      return 0.0;
    } else {
      infeasible = x;
    }
  }
  while (feasible - infeasible > kDurationPrecision * feasible) {
    const double x = 0.5 * (infeasible + feasible);
    (fits(x) ? feasible : infeasible) = x;
  }
  fits(feasible);
  return feasible;
}

// The share of each joint's torque-rate limit a generated reference's jerk may take (through M):
// the rest is the feedback's, which must correct what the arm did not follow.
constexpr double kTorqueRateShare = 0.5;

// The generator needs finite limits; a joint without one (a URDF without a velocity limit, and so
// no default acceleration or jerk) is given these, far beyond what an arm does.
constexpr double kUnlimitedVelocity = 1e3, kUnlimitedAcceleration = 1e5, kUnlimitedJerk = 1e7;

double finite_or(double x, double fallback) { return std::isfinite(x) ? x : fallback; }

// d s with three significant digits and at least two decimals (6.24, 40.43, 0.0123), rounded up
// or to nearest.
void format_duration(char (&out)[24], double d, bool up) {
  const int decimals = std::clamp(2 - static_cast<int>(std::floor(std::log10(d))), 2, 9);
  const double unit = std::pow(10.0, -decimals);
  std::snprintf(out, sizeof(out), "%.*f", decimals, up ? std::ceil(d / unit) * unit : d);
}

void format_into(char (&buffer)[192], const char* format, va_list args) {
  std::vsnprintf(buffer, sizeof(buffer), format, args);
}

Config validated(const Config& config, int dof) {
  config.validate(dof);
  return config;
}

}  // namespace

Config Config::critically_damped(int dof, double omega) {
  Config config;
  config.kp = Eigen::VectorXd::Constant(dof, omega * omega);
  config.kd = Eigen::VectorXd::Constant(dof, 2.0 * omega);
  return config;
}

void Config::validate(int dof) const {
  auto check_gains = [dof](const Eigen::VectorXd& k, const char* name) {
    if (k.size() != dof) {
      throw ArgumentError(std::string(name) + " has " + std::to_string(k.size()) + " entries, the arm has " +
                                  std::to_string(dof) + " joints");
    }
    if (!k.allFinite() || (k.array() < 0.0).any()) {
      throw ArgumentError(std::string(name) + " must be finite and non-negative");
    }
  };
  check_gains(kp, "kp");
  check_gains(kd, "kd");
  if (!(period > 0.0) || !std::isfinite(period)) throw ArgumentError("the period must be positive");
  if (stale_ns <= 0) throw ArgumentError("the stale-state timeout must be positive");
  if (!(torque_ramp > 0.0)) throw ArgumentError("the torque ramp time must be positive");
  if (!(stream_timeout > 0.0) || !std::isfinite(stream_timeout)) {
    throw ArgumentError("the stream timeout must be positive and finite");
  }
  limits.validate(dof);
  jog.validate();
  if (damping.size() != 0) check_gains(damping, "damping");
  if (coulomb.size() != 0) check_gains(coulomb, "Coulomb friction");
}

Controller::Controller(const RobotModel& model, const Config& config)
    : model_(&model),
      config_(validated(config, model.dof())),
      data_(model),
      data_ref_(model),
      law_(model.dof()),
      work_(model.dof()),
      switch_offset_(Eigen::VectorXd::Zero(model.dof())),
      allowance_(Eigen::VectorXd::Zero(model.dof())),
      effort_limit_(model.dof()),
      rate_limit_per_tick_(model.dof()),
      torque_rate_(model.dof()),
      q_(Eigen::VectorXd::Zero(model.dof())),
      qd_(Eigen::VectorXd::Zero(model.dof())),
      qdd_ref_(Eigen::VectorXd::Zero(model.dof())),
      error_(Eigen::VectorXd::Zero(model.dof())),
      tau_(Eigen::VectorXd::Zero(model.dof())),
      tau_prev_(Eigen::VectorXd::Zero(model.dof())),
      limits_(model, config_.limits),
      q_guarded_(Eigen::VectorXd::Zero(model.dof())),
      ref_(model.dof()),
      trajectory_(model.dof()),
      candidate_(model.dof()),
      path_(model.dof()),
      spline_(model.dof()),
      spline_candidate_(model.dof()),
      path_tolerance_(Eigen::VectorXd::Zero(model.dof())),
      goal_tolerance_(Eigen::VectorXd::Zero(model.dof())),
      otg_(model.dof()),
      jogger_(model, config_.jog),
      jog_(model.dof()),
      contact_(model, config_.contact, config_.damping, config_.period, config_.coulomb),
      retract_goal_(Eigen::VectorXd::Zero(model.dof())),
      request_(model.dof()),
      state_period_(config_.period),
      sent_torque_(Eigen::MatrixXd::Zero(model.dof(), kSentCommands)),
      sent_ns_(kSentCommands, std::numeric_limits<int64_t>::min()),
      gap_torque_(Eigen::VectorXd::Zero(model.dof())) {
  otg_limits_.velocity = limits_.velocity.unaryExpr([](double x) { return finite_or(x, kUnlimitedVelocity); });
  otg_limits_.acceleration =
      limits_.acceleration.unaryExpr([](double x) { return finite_or(x, kUnlimitedAcceleration); });
  otg_limits_.jerk = limits_.jerk.unaryExpr([](double x) { return finite_or(x, kUnlimitedJerk); });
  jerk_limit_ = otg_limits_.jerk;
  for (motion::KinematicState* state : {&otg_from_, &otg_target_, &otg_out_}) {
    state->p = state->v = state->a = Eigen::VectorXd::Zero(model.dof());
  }
  for (int i = 0; i < model.dof(); ++i) {
    const double effort = model.joint(i).limits.effort;
    effort_limit_(i) = effort > 0.0 ? effort : kInf;
    torque_rate_(i) = effort_limit_(i) / config_.torque_ramp;
    rate_limit_per_tick_(i) = torque_rate_(i) * config_.period;
  }
  work_.period = config_.period;
}

bool Controller::refuse(const char* format, ...) {
  va_list args;
  va_start(args, format);
  format_into(rejection_, format, args);
  va_end(args);
  ++rejected_targets_;
  return false;
}

void Controller::fault(const char* format, ...) {
  va_list args;
  va_start(args, format);
  format_into(fault_reason_, format, args);
  va_end(args);
  if (mode_ != Mode::kFault) ++faults_;
  mode_ = Mode::kFault;
  end_trajectory(TrajectoryProgress::kAborted, "FAULT: %.160s", fault_reason_);
}

void Controller::stand_down(const char* format, ...) {
  if (stood_down_) return;
  va_list args;
  va_start(args, format);
  format_into(fault_reason_, format, args);
  va_end(args);
  ++faults_;  // a fault of its own, even while another is on
  mode_ = Mode::kFault;
  stood_down_ = true;
  end_trajectory(TrajectoryProgress::kAborted, "FAULT: %.160s", fault_reason_);
}

bool Controller::set_law(const LawSettings& settings, int64_t now_ns) {
  auto refuse_mode = [this](const char* why) {
    std::snprintf(mode_rejection_, sizeof(mode_rejection_), "%s", why);
    ++rejected_modes_;
    return false;
  };
  if (mode_ == Mode::kWaiting) return refuse_mode("no robot state has arrived yet");
  if (mode_ == Mode::kFault) return refuse_mode("the controller is in FAULT");
  char why[192];
  if (const char* problem = law_problem(*model_, settings, why)) return refuse_mode(problem);
  law_ = settings;
  end_trajectory(TrajectoryProgress::kPreempted, "a new control law");
  switch_pending_ = true;
  switch_start_ns_ = now_ns;
  // A new law ends a reflex where the arm is; free drive follows no reference, so a motion ends.
  // It ends a trajectory, a stream (of joint or tip setpoints) or a jog too: the reference brakes
  // to rest from its motion. A JOINT goal's quintic and a Cartesian path go on under the new law.
  if (mode_ == Mode::kReflex || law_.law == Law::kFreeDrive) {
    hold_at(q_);
  } else if (mode_ == Mode::kRunning && drive_ != Drive::kGoal && drive_ != Drive::kPath && drive_ != Drive::kStop) {
    stop_motion(now_ns);
  }
  return true;
}

void Controller::set_model(const RobotModel& model) {
  if (model.dof() != model_->dof() || &model == model_) return;
  model_ = &model;
  contact_.set_model(model);  // restarts the observer at the next state
}

void Controller::hold_at(const Eigen::VectorXd& q) {
  ref_.hold(q);
  mode_ = Mode::kHolding;
  compliant_ = retracting_ = false;
}

void Controller::start_drive(Drive drive, int64_t now_ns) {
  drive_ = drive;
  mode_ = Mode::kRunning;
  motion_start_ns_ = stream_tick_ns_ = now_ns;
}

void Controller::stop_motion(int64_t now_ns) {
  aim_at_stop();
  start_drive(Drive::kStop, now_ns);
}

// Every new state, whatever the mode: the observer needs each sample and the torque the arm had
// over the step before it, ours or the plant's brake. data_ holds the terms at this state.
void Controller::observe(const JointState& state) {
  if (observed_any_ && state.seq == observed_seq_) return;
  // The time since the last state observed, from the states' own clock: utime, or where a sender
  // leaves it standing, their arrival. A first state, a sender that restarted its count, a seq that
  // does not fit (it comes off the wire) or a gap over kMaxGapPeriods restarts the observer (dt = 0).
  int64_t steps = 0;
  double dt = 0.0;
  if (observed_any_ && !__builtin_sub_overflow(state.seq, observed_seq_, &steps) && steps > 0) {
    int64_t elapsed_us = 0;
    if (!__builtin_sub_overflow(state.utime, observed_utime_, &elapsed_us) && elapsed_us > 0) {
      dt = 1e-6 * static_cast<double>(elapsed_us);
    } else {
      dt = 1e-9 * static_cast<double>(state.arrival_ns - observed_arrival_ns_);
    }
    if (dt > 0.0 && steps == 1) track_period(dt);
    if (!(dt <= kMaxGapPeriods * std::max(config_.period, state_period_))) dt = 0.0;
  }
  const Eigen::VectorXd& tau = dt > 0.0 ? torque_across(state, dt) : state.effort;
  observed_seq_ = state.seq;
  observed_utime_ = state.utime;
  observed_arrival_ns_ = state.arrival_ns;
  observed_any_ = true;
  contact_.set_allowance(allowance_);
  contact_.update(data_, state.q, state.qd, tau, dt);
  const ContactEstimate& e = contact_.estimate();
  if (e.contact && !in_contact_) ++contacts_;
  in_contact_ = e.contact;
  peak_tip_force_ = std::max(peak_tip_force_, e.wrench_base.tail<3>().norm());
  check_semantics(state, dt);
}

// The torque the arm reports applying over its last step against the one commanded for it: the
// latest sent before the state arrived. Judged only while this controller commands. A mismatch is
// the configuration's, not the moment's: this controller stops commanding for good, as when
// another sender is heard, and the message says the flag that fixes it.
void Controller::check_semantics(const JointState& state, double dt) {
  const int j = mode_ == Mode::kWaiting || mode_ == Mode::kFault ? -1 : command_in_force(state.arrival_ns);
  if (!config_.check_torque_semantics || j < 0 || !(dt > 0.0)) {
    semantics_.restart();
    return;
  }
  switch (semantics_.update(state.effort, sent_torque_.col(j), data_.g, dt)) {
    case TorqueSemanticsCheck::Verdict::kDriverAddsGravity:
      stand_down("the arm applied the torque commanded + %.0f %% of g(q) over %g s: its driver adds gravity "
                 "compensation to the whole torque sent; run with --torque-semantics overlay",
                 100.0 * semantics_.share(), TorqueSemanticsCheck::kWindow);
      break;
    case TorqueSemanticsCheck::Verdict::kDriverAddsNothing:
      stand_down("the arm applied the torque commanded - %.0f %% of g(q) over %g s: its driver adds no gravity "
                 "compensation to the tau - g(q) sent; run with --torque-semantics full",
                 -100.0 * semantics_.share(), TorqueSemanticsCheck::kWindow);
      break;
    default:
      break;
  }
}

// The mean torque the arm applied across the dt since the last state observed. A state's effort is
// the torque of its own last step; when states between were lost, each earlier step ran under the
// command in force as it began — this controller's, which it keeps — so the mean is taken over
// those and the effort reported for the last. Taking the effort for the whole gap instead read the
// torque's change over the gap as external: at 200 Hz with half the states lost, 18 N at the tip
// and a false collision. A quarter step's grace lets the command answering a state be sent a
// little after the state arrived. Allocates nothing.
const Eigen::VectorXd& Controller::torque_across(const JointState& state, double dt) {
  const int64_t steps = std::llround(dt / state_period_);
  if (steps <= 1) return state.effort;
  const double step_ns = static_cast<double>(state.arrival_ns - observed_arrival_ns_) / static_cast<double>(steps);
  gap_torque_ = state.effort;
  for (int64_t k = 0; k + 1 < steps; ++k) {
    const int j = command_in_force(observed_arrival_ns_ + std::llround((static_cast<double>(k) + 0.25) * step_ns));
    gap_torque_ += j >= 0 ? sent_torque_.col(j) : state.effort;
  }
  gap_torque_ /= static_cast<double>(steps);
  return gap_torque_;
}

// The latest command sent at or before at_ns, among those kept; −1 when there is none.
int Controller::command_in_force(int64_t at_ns) const {
  constexpr int64_t kNone = std::numeric_limits<int64_t>::min();  // a slot not written yet
  int latest = -1;
  for (int j = 0; j < kSentCommands; ++j) {
    const int64_t sent = sent_ns_[size_t(j)];
    if (sent != kNone && sent <= at_ns && (latest < 0 || sent > sent_ns_[size_t(latest)])) latest = j;
  }
  return latest;
}

// A running mean over the first kPeriodWindow intervals, then an exponential one of that length.
void Controller::track_period(double dt) {
  period_intervals_ = std::min<int64_t>(period_intervals_ + 1, kPeriodWindow);
  state_period_ += (dt - state_period_) / static_cast<double>(period_intervals_);
  const double ratio = state_period_ / config_.period;
  const bool was_mismatched = period_mismatch_;
  period_mismatch_ = period_intervals_ == kPeriodWindow && std::abs(ratio - 1.0) > kPeriodTolerance;
  // Formatted on the tick only when the figure it quotes may have moved, not at every state.
  if (period_mismatch_ &&
      (!was_mismatched || std::abs(state_period_ - quoted_period_) > kPeriodQuoteStep * quoted_period_)) {
    quoted_period_ = state_period_;
    std::snprintf(period_warning_, sizeof(period_warning_),
                  "the robot states come every %.3g ms (%.4g Hz), the configured period is %.3g ms", 1e3 * state_period_,
                  1.0 / state_period_, 1e3 * config_.period);
  }
}

void Controller::start_reflex(int64_t now_ns, const char* limit_reason) {
  hold_at(q_);  // stop: hold here, braked by the position loop and the torque-rate limit
  const Reflex reflex = limit_reason != nullptr ? Reflex::kStop : contact_.config().reflex;
  switch (reflex) {
    case Reflex::kStop:
      break;
    case Reflex::kCompliant:
      compliant_ = true;
      break;
    case Reflex::kRetract: {
      // From where the arm is and how it moves now, so the reference does not jump; slower than
      // configured where the limits ask it.
      contact_.retract_goal(contact_.config().retract_distance, retract_goal_);
      ref_.qd = qd_;
      motion::LimitExcess excess;
      if (shortest_duration(retract_goal_, contact_.config().retract_duration, excess) > 0.0) {
        trajectory_.swap(candidate_);
        motion_start_ns_ = now_ns;
        retracting_ = true;
      } else {
        ref_.qd.setZero();  // no retract within the limits from this motion: a stop
      }
      break;
    }
  }
  mode_ = Mode::kReflex;
  pending_request_ = -1;  // a Cartesian plan in the works is dropped
  end_trajectory(TrajectoryProgress::kAborted, "REFLEX: %.160s", limit_reason != nullptr ? limit_reason : contact_.reason());
  if (limit_reason != nullptr) {
    std::snprintf(reflex_reason_, sizeof(reflex_reason_), "%s; reflex stop", limit_reason);
  } else {
    std::snprintf(reflex_reason_, sizeof(reflex_reason_), "%s; reflex %s", contact_.reason(), to_string(reflex));
  }
  ++reflexes_;
}

double Controller::shortest_duration(const Eigen::VectorXd& goal, double requested, motion::LimitExcess& excess) {
  candidate_.start(ref_, goal, requested);
  excess = candidate_.excess(limits_);
  if (!excess) return requested;
  // From rest the peaks of a quintic over d in T are known, 1.875 d/T, (10/√3) d/T² and
  // 60 d/T³, so the shortest duration is too, and is tried first. From a motion, slower is within
  // the limits past some duration: found by doubling, then to kDurationPrecision by bisection.
  double from_rest = requested;
  for (int i = 0; i < candidate_.dof(); ++i) {
    const double d = std::abs(goal(i) - ref_.q(i));
    from_rest = std::max({from_rest, 1.875 * d / limits_.velocity(i),
                          std::sqrt(10.0 / std::sqrt(3.0) * d / limits_.acceleration(i)),
                          std::cbrt(60.0 * d / limits_.jerk(i))});
  }
  double infeasible = requested;
  if (const double T = from_rest * (1.0 + 1e-9); T > requested) {
    candidate_.start(ref_, goal, T);
    if (!candidate_.excess(limits_)) return T;
    infeasible = T;
  }
  return least_fitting(infeasible, kLongestMotion, [&](double T) {
    candidate_.start(ref_, goal, T);
    return !candidate_.excess(limits_);
  });
}

void Controller::end_trajectory(TrajectoryProgress::Outcome outcome, const char* format, ...) {
  if (progress_.outcome != TrajectoryProgress::kActive) return;
  progress_.outcome = outcome;
  va_list args;
  va_start(args, format);
  std::vsnprintf(progress_.message, sizeof(progress_.message), format, args);
  va_end(args);
}

double Controller::least_time_scale(const motion::Waypoints& waypoints) {
  return least_fitting(1.0, kMaxTimeScale, [&](double scale) {
    spline_candidate_.build(ref_, waypoints, limits_, scale);
    return spline_candidate_.fits(limits_);
  });
}

bool Controller::set_trajectory(const motion::Waypoints& w, int64_t now_ns) {
  const auto reject = [&](const char* why) {
    refuse("trajectory %lld: %s", static_cast<long long>(w.id), why);
    // The running trajectory, if any, goes on: the status says so once this one is reported.
    if (progress_.outcome != TrajectoryProgress::kActive) {
      progress_ = TrajectoryProgress{};
      progress_.id = w.id;
      progress_.outcome = TrajectoryProgress::kRejected;
      std::snprintf(progress_.message, sizeof(progress_.message), "%s", why);
    }
    return false;
  };
  char why[192];
  if (mode_ == Mode::kWaiting) return reject("no robot state has arrived yet");
  if (mode_ == Mode::kFault) return reject("the controller is in FAULT");
  if (law_.law == Law::kFreeDrive) return reject("free drive follows no trajectory (send a control mode first)");
  const int n = model_->dof();
  if (w.dof() != n) return reject("sized for another arm");
  if (w.count < 1 || w.count > motion::Waypoints::kMaxPoints) {
    std::snprintf(why, sizeof(why), "%d waypoints; 1 to %d are taken", w.count, motion::Waypoints::kMaxPoints);
    return reject(why);
  }
  for (int k = 0; k < w.count; ++k) {
    const double before = k == 0 ? 0.0 : w.time(k - 1);
    if (!std::isfinite(w.time(k)) || !(w.time(k) > before)) {
      std::snprintf(why, sizeof(why), "waypoint %d: time %g s is not after %g s (times increase from > 0)", k,
                    w.time(k), before);
      return reject(why);
    }
    for (int i = 0; i < n; ++i) {
      const char* name = model_->joint(i).name.c_str();
      if (!std::isfinite(w.q(i, k)) || (w.has_velocities && !std::isfinite(w.qd(i, k))) ||
          (w.has_accelerations && !std::isfinite(w.qdd(i, k)))) {
        std::snprintf(why, sizeof(why), "waypoint %d, joint %s: a value that is not finite", k, name);
        return reject(why);
      }
      if (w.q(i, k) < limits_.lower(i) || w.q(i, k) > limits_.upper(i)) {
        std::snprintf(why, sizeof(why), "waypoint %d, joint %s: position %g outside [%g, %g], its limits less the margin",
                      k, name, w.q(i, k), limits_.lower(i), limits_.upper(i));
        return reject(why);
      }
    }
  }
  const int last = w.count - 1;
  if ((w.has_velocities && w.qd.col(last).cwiseAbs().maxCoeff() > 0.0) ||
      (w.has_accelerations && w.qdd.col(last).cwiseAbs().maxCoeff() > 0.0)) {
    return reject("the last waypoint must be at rest (velocity and acceleration 0)");
  }
  if (!w.path_tolerance.allFinite() || !w.goal_tolerance.allFinite() || (w.path_tolerance.array() < 0.0).any() ||
      (w.goal_tolerance.array() < 0.0).any() || !(w.goal_time >= 0.0) || !std::isfinite(w.goal_time)) {
    return reject("tolerances must be finite and non-negative");
  }
  if (mode_ == Mode::kReflex) hold_at(q_);  // a new trajectory ends the reflex, from where the arm is
  double scale = 1.0;
  spline_candidate_.build(ref_, w, limits_, scale);
  if (const motion::WaypointExcess e = spline_candidate_.excess(limits_)) {
    scale = least_time_scale(w);
    if (!w.time_scaling || scale == 0.0) {
      motion::WaypointExcess worst = e;
      if (scale == 0.0) {
        // What stays when it is slowed all it may be: its shape leaves the limits, not its speed.
        spline_candidate_.build(ref_, w, limits_, kMaxTimeScale);
        worst = spline_candidate_.excess(limits_);
      }
      const motion::LimitExcess& x = worst.excess;
      const int length = std::snprintf(why, sizeof(why), "waypoint %d, joint %s: %s %s %.4g %s, over its limit %.4g",
                                       worst.waypoint, model_->joint(x.joint).name.c_str(), to_string(x.quantity),
                                       x.quantity == motion::LimitExcess::kPosition ? "reaches" : "peaks at", x.value,
                                       unit_of(x.quantity), x.limit);
      const size_t at = std::min(static_cast<size_t>(std::max(length, 0)), sizeof(why) - 1);
      if (scale == 0.0) {
        std::snprintf(why + at, sizeof(why) - at, ", even slowed %gx", kMaxTimeScale);
      } else {
        // Rounded up, so that the duration quoted fits.
        const double sent = w.time(w.count - 1);
        char fitting[24], as_sent[24];
        format_duration(fitting, scale * sent, true);
        format_duration(as_sent, sent, false);
        std::snprintf(why + at, sizeof(why) - at,
                      "; fits in %s s instead of %s s (allow time scaling, or send it slower)", fitting, as_sent);
      }
      return reject(why);
    }
  }
  end_trajectory(TrajectoryProgress::kPreempted, "trajectory %lld", static_cast<long long>(w.id));
  pending_request_ = -1;  // a Cartesian plan still in the works is superseded
  progress_ = TrajectoryProgress{};
  progress_.id = w.id;
  progress_.outcome = TrajectoryProgress::kActive;
  progress_.duration = spline_candidate_.duration();
  progress_.scale = scale;
  if (scale > 1.0) {
    std::snprintf(progress_.message, sizeof(progress_.message), "slowed %.4gx to fit the limits", scale);
  }
  spline_.swap(spline_candidate_);
  path_tolerance_ = w.path_tolerance;
  goal_tolerance_ = w.goal_tolerance;
  goal_time_ = w.goal_time;
  start_drive(Drive::kWaypoints, now_ns);
  return true;
}

void Controller::judge_trajectory(int64_t now_ns) {
  const double t = 1e-9 * static_cast<double>(now_ns - motion_start_ns_);
  progress_.elapsed = t;
  progress_.waypoint = spline_.waypoint_at(t);
  if (mode_ == Mode::kRunning && drive_ == Drive::kWaypoints) {
    for (int i = 0; i < error_.size(); ++i) {
      if (path_tolerance_(i) > 0.0 && std::abs(error_(i)) > path_tolerance_(i)) {
        end_trajectory(TrajectoryProgress::kAborted, "joint %s: %g rad off the path at %.3f s, over its tolerance %g",
                       model_->joint(i).name.c_str(), std::abs(error_(i)), t, path_tolerance_(i));
        hold_at(q_);
        return;
      }
    }
    return;
  }
  // Past the end: the reference holds the last waypoint; the arm must come within the goal
  // tolerance within goal_time.
  int off = -1;
  for (int i = 0; i < error_.size(); ++i) {
    if (goal_tolerance_(i) > 0.0 && std::abs(error_(i)) > goal_tolerance_(i)) off = i;
  }
  if (off < 0) {
    progress_.outcome = TrajectoryProgress::kSucceeded;  // its message, the scaling if any, stays
  } else if (t > progress_.duration + goal_time_) {
    end_trajectory(TrajectoryProgress::kAborted, "joint %s: %g rad from its goal %.3f s after the end, over its tolerance %g",
                   model_->joint(off).name.c_str(), std::abs(error_(off)), t - progress_.duration,
                   goal_tolerance_(off));
  }
}

bool Controller::set_target(const Target& target, int64_t now_ns) {
  if (mode_ == Mode::kWaiting) return refuse("no robot state has arrived yet");
  if (mode_ == Mode::kFault) return refuse("the controller is in FAULT (%s)", fault_reason_);
  if (mode_ == Mode::kReflex) hold_at(q_);  // a new target ends the reflex, from where the arm is
  const int n = model_->dof();
  if (law_.law == Law::kFreeDrive && target.mode != Target::kHold) {
    return refuse("free drive follows no target: the arm goes where it is moved (send a control mode first)");
  }
  switch (target.mode) {
    case Target::kHold:
      end_trajectory(TrajectoryProgress::kPreempted, "a HOLD target");
      hold_at(q_);
      return true;
    case Target::kCartesian:
      return request_cartesian(target);
    case Target::kJoint:
      break;
    default:
      return refuse("unknown target mode %d", target.mode);
  }
  if (target.num_joints != n) return refuse("a joint target for %d joints; the arm has %d", target.num_joints, n);
  // Under an impedance law a duration of 0 steps the equilibrium: the impedance shapes the motion.
  const bool step = target.duration == 0.0 && is_impedance(law_.law);
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
    const double shortest = shortest_duration(target.q, target.duration, excess);
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
  }
  pending_request_ = -1;  // a Cartesian plan still in the works is superseded
  end_trajectory(TrajectoryProgress::kPreempted, "a JOINT target");
  if (step) {
    hold_at(target.q);
    return true;
  }
  trajectory_.swap(candidate_);  // the quintic shortest_duration checked
  start_drive(Drive::kGoal, now_ns);
  return true;
}

bool Controller::refuse_stream(const char* what) {
  if (mode_ == Mode::kWaiting) return !refuse("%s: no robot state has arrived yet", what);
  if (mode_ == Mode::kFault) return !refuse("%s: the controller is in FAULT", what);
  // A stream does not end a reflex by coming on: it would within a period. A target or law does.
  if (mode_ == Mode::kReflex) return !refuse("%s: the arm is in REFLEX (a target or control mode resumes)", what);
  if (law_.law == Law::kFreeDrive) return !refuse("%s: free drive follows none (send a control mode first)", what);
  return false;
}

bool Controller::set_setpoint(const Setpoint& setpoint, int64_t now_ns) {
  if (refuse_stream("setpoint")) return false;
  const int n = model_->dof();
  if (setpoint.q.size() != n || setpoint.qd.size() != n || !setpoint.q.allFinite() || !setpoint.qd.allFinite()) {
    return refuse("setpoint: of the wrong size or with non-finite values");
  }
  const bool first = !driven_by(Drive::kStream);
  if (!enter_stream(Drive::kStream, setpoint.utime, setpoint_utime_, dropped_setpoints_, "a stream", now_ns)) {
    return false;
  }
  const double age = take_setpoint(setpoint.utime, now_ns, first);
  // The same goal at rest again (a stream holding its last point) keeps the limits it is planned
  // with; any other goal is planned under the jerk capped at the pose it starts from.
  bool held = !first && otg_target_.v.isZero(0.0) && setpoint.qd.isZero(0.0);
  for (int i = 0; i < n; ++i) {
    const double p = std::clamp(setpoint.q(i) + setpoint.qd(i) * age, limits_.lower(i), limits_.upper(i));
    held = held && p == otg_target_.p(i);
    otg_target_.p(i) = p;
  }
  if (!held) cap_jerk_to_torque_rate();
  for (int i = 0; i < n; ++i) {
    otg_target_.v(i) = motion::velocity_that_stops_in_range(setpoint.qd(i), otg_target_.p(i), limits_.lower(i),
                                                    limits_.upper(i), otg_limits_.velocity(i),
                                                    otg_limits_.acceleration(i), otg_limits_.jerk(i));
    otg_target_.a(i) = 0.0;
  }
  return true;
}

bool Controller::enter_stream(Drive drive, int64_t utime, int64_t last_utime, int64_t& dropped, const char* what,
                              int64_t now_ns) {
  if (!driven_by(drive)) {
    end_trajectory(TrajectoryProgress::kPreempted, what);
    pending_request_ = -1;  // a Cartesian plan in the works is dropped
    start_drive(drive, now_ns);
  } else if (utime <= last_utime) {
    ++dropped;  // late or duplicated: the stream has moved past it
    return false;
  }
  return true;
}

double Controller::take_setpoint(int64_t utime, int64_t now_ns, bool first) {
  const int64_t offset_us = now_ns / 1000 - utime;
  if (first) {
    stream_offset_us_ = offset_us;
  } else {
    // The least offset so far, let up by 100 ppm of the time since the last setpoint: two clocks
    // drift apart by less, so the estimate never falls behind.
    stream_offset_us_ = std::min(stream_offset_us_ + (now_ns - setpoint_ns_) / 10'000'000, offset_us);
  }
  setpoint_utime_ = utime;
  setpoint_ns_ = now_ns;
  ++setpoints_;
  return std::clamp(1e-6 * static_cast<double>(offset_us - stream_offset_us_), 0.0, config_.stream_timeout);
}

void Controller::aim_at_stop() {
  cap_jerk_to_torque_rate();
  for (int i = 0; i < ref_.q.size(); ++i) {
    otg_target_.p(i) = std::clamp(motion::stop_position(ref_.q(i), ref_.qd(i), ref_.qdd(i), otg_limits_.velocity(i),
                                                        otg_limits_.acceleration(i), otg_limits_.jerk(i)),
                                  limits_.lower(i), limits_.upper(i));
  }
  otg_target_.v.setZero();
  otg_target_.a.setZero();
}

void Controller::update_stream(int64_t now_ns) {
  const double dt = std::clamp(1e-9 * static_cast<double>(now_ns - stream_tick_ns_), 0.0, 0.1);
  stream_tick_ns_ = now_ns;
  if (drive_ == Drive::kStream && now_ns - setpoint_ns_ > static_cast<int64_t>(config_.stream_timeout * 1e9)) {
    drive_ = Drive::kStop;
    aim_at_stop();
  }
  if (drive_ == Drive::kStream) {
    // The setpoint moves on at its velocity; at a limit it stops there.
    for (int i = 0; i < ref_.q.size(); ++i) {
      otg_target_.p(i) = std::clamp(otg_target_.p(i) + otg_target_.v(i) * dt, limits_.lower(i), limits_.upper(i));
      otg_target_.v(i) = motion::velocity_that_stops_in_range(otg_target_.v(i), otg_target_.p(i), limits_.lower(i),
                                                      limits_.upper(i), otg_limits_.velocity(i),
                                                      otg_limits_.acceleration(i), otg_limits_.jerk(i));
    }
  }
  otg_from_.p = ref_.q;
  otg_from_.v = ref_.qd;
  otg_from_.a = ref_.qdd;
  // Each joint on its own: a stream's target moves every period, so arriving together buys
  // nothing, and the fixed-duration search it needs costs far more per tick.
  if (!otg_.plan(otg_from_, otg_target_, otg_limits_, 0.0, motion::Synchronization::kNone)) {
    // Never seen in the tests and benchmarks: the stream ends where the reference is.
    refuse("stream ended: the trajectory generator found no motion (%.120s)", otg_.reason());
    hold_at(ref_.q);
    return;
  }
  otg_.at_time(dt, otg_out_);
  ref_.q = otg_out_.p;
  ref_.qd = otg_out_.v;
  ref_.qdd = otg_out_.a;
  if (drive_ == Drive::kStop && otg_.duration() <= dt) hold_at(otg_target_.p);
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
  const bool first = !driven_by(Drive::kTipStream);
  if (!enter_stream(Drive::kTipStream, setpoint.utime, setpoint_utime_, dropped_setpoints_, "a Cartesian stream",
                    now_ns)) {
    return false;
  }
  cap_jerk_to_torque_rate();
  const double age = take_setpoint(setpoint.utime, now_ns, first);
  const Eigen::Vector4d& w = setpoint.quaternion;
  tip_twist_ = setpoint.twist;
  tip_target_.linear() = exp3(tip_twist_.head<3>() * age) *
                         Eigen::Quaterniond(w(0), w(1), w(2), w(3)).normalized().toRotationMatrix();
  tip_target_.translation() = setpoint.position + tip_twist_.tail<3>() * age;
  return true;
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
  if (!enter_stream(Drive::kJog, jog.utime, jog_utime_, dropped_jogs_, "a jog", now_ns)) return false;
  cap_jerk_to_torque_rate();
  jog_.utime = jog.utime;
  jog_.kind = jog.kind;
  jog_.frame = jog.frame;
  jog_.joint_velocity = jog.joint_velocity;
  jog_.twist = jog.twist;
  jog_utime_ = jog.utime;
  jog_ns_ = now_ns;
  ++jogs_;
  return true;
}

void Controller::update_jog(int64_t now_ns) {
  const double dt = std::clamp(1e-9 * static_cast<double>(now_ns - stream_tick_ns_), 0.0, 0.1);
  stream_tick_ns_ = now_ns;
  const int64_t timeout = static_cast<int64_t>(config_.stream_timeout * 1e9);
  bool at_rest = false;
  if (drive_ == Drive::kJog) {
    const bool halt = now_ns - jog_ns_ > timeout;
    at_rest = jogger_.step(*model_, jog_, halt, limits_, otg_limits_, dt, ref_, jog_progress_) && halt;
  } else {
    const bool halt = now_ns - setpoint_ns_ > timeout;
    if (!halt) {  // the pose moves on with its twist: the rotation in the base's axes, on the left
      tip_target_.linear() = exp3(tip_twist_.head<3>() * dt) * tip_target_.linear();
      tip_target_.translation() += tip_twist_.tail<3>() * dt;
    }
    at_rest = jogger_.follow_pose(*model_, tip_target_, tip_twist_, halt, limits_, otg_limits_, dt, ref_,
                                  jog_progress_) &&
              halt;
  }
  if (at_rest) hold_at(ref_.q);
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
  const bool step = target.duration == 0.0 && is_impedance(law_.law);
  if (!step && (!(target.duration > 0.0) || !std::isfinite(target.duration))) {
    return refuse("a Cartesian target needs a positive, finite duration (got %g s; 0 steps the equilibrium of an "
                  "impedance law)", target.duration);
  }
  const Eigen::Quaterniond rotation(target.quaternion(0), target.quaternion(1), target.quaternion(2),
                                    target.quaternion(3));
  if (step) {
    const Transform& T_sb = forward_kinematics(*model_, data_ref_, ref_.q);
    const double distance = (target.position - T_sb.translation()).norm();
    const double angle = Eigen::AngleAxisd(rotation.normalized().toRotationMatrix() * T_sb.linear().transpose()).angle();
    if (distance > kMaxTipStep || angle > kMaxTipRotationStep) {
      return refuse("a step of the tip by %g m and %g rad is over %g m or %g rad; give a duration", distance, angle,
                    kMaxTipStep, kMaxTipRotationStep);
    }
  }
  request_.id = ++next_request_id_;
  request_.q_start = ref_.q;
  request_.T_goal = Transform(rotation.normalized().toRotationMatrix(), target.position);
  request_.duration = target.duration;
  request_ready_ = true;
  pending_request_ = request_.id;
  return true;
}

bool Controller::take_request(CartesianRequest& request) {
  if (!request_ready_) return false;
  request = request_;
  request_ready_ = false;
  return true;
}

bool Controller::follow(const JointPath& path, int64_t now_ns) {
  if (path.request_id != pending_request_) return false;
  pending_request_ = -1;
  ik_iterations_ = path.ik_iterations;
  ik_residual_ = path.ik_residual;
  ik_converged_ = path.ok;
  if (!path.ok) return refuse("Cartesian target refused: %s", path.reason);
  if (mode_ != Mode::kHolding || (path.q.col(0) - ref_.q).cwiseAbs().maxCoeff() > 1e-12) {
    return refuse("Cartesian path dropped: the arm is no longer holding where the path starts");
  }
  end_trajectory(TrajectoryProgress::kPreempted, "a CARTESIAN target");
  path_.start(path);
  start_drive(Drive::kPath, now_ns);
  return true;
}

void Controller::update_reference(int64_t now_ns) {
  const double t = 1e-9 * static_cast<double>(now_ns - motion_start_ns_);
  if (law_.law == Law::kFreeDrive) {
    ref_.hold(q_);  // the arm goes where it is moved; a law after this one starts from there
    return;
  }
  if (mode_ == Mode::kReflex) {
    if (retracting_) trajectory_.sample(t, ref_);  // holds the goal once there
    if (compliant_) ref_.hold(q_);                 // the arm goes where it is pushed
    return;
  }
  if (mode_ != Mode::kRunning) return;
  // The samplers set the goal at rest once t is past the end.
  switch (drive_) {
    case Drive::kGoal:
      trajectory_.sample(t, ref_);
      if (t >= trajectory_.duration()) mode_ = Mode::kHolding;
      break;
    case Drive::kPath:
      path_.sample(t, ref_);
      if (t >= path_.duration()) mode_ = Mode::kHolding;
      break;
    case Drive::kWaypoints:
      spline_.sample(t, ref_);
      if (t >= spline_.duration()) mode_ = Mode::kHolding;
      break;
    case Drive::kStream:
    case Drive::kStop:
      update_stream(now_ns);
      break;
    case Drive::kTipStream:
    case Drive::kJog:
      update_jog(now_ns);
      break;
  }
}

bool Controller::tick(int64_t now_ns, const JointState* state) {
  if (state == nullptr || stood_down_) return false;
  if (now_ns - state->arrival_ns > config_.stale_ns) {
    ++stale_ticks_;
    if (mode_ != Mode::kWaiting) {
      fault("no fresh robot state: the latest is %.1f ms old (limit %.1f ms)",
            1e-6 * static_cast<double>(now_ns - state->arrival_ns), 1e-6 * static_cast<double>(config_.stale_ns));
    }
    return false;
  }
  if (state->q.size() != model_->dof() || state->qd.size() != model_->dof() || state->effort.size() != model_->dof() ||
      !state->q.allFinite() || !state->qd.allFinite() || !state->effort.allFinite()) {
    fault("a robot state of the wrong size or with non-finite values reached the control law");
    return false;
  }
  q_ = state->q;
  qd_ = state->qd;
  // The model's terms at this state, once: the law, the observer and the contact monitor read them.
  compute_tick_terms(*model_, data_, q_, qd_);
  observe(*state);
  if (stood_down_) return false;  // the observer found the torque semantics wrong

  if (mode_ == Mode::kWaiting || mode_ == Mode::kFault) {
    // (Re-)entering HOLD where the arm is now. The torque-rate limit starts from g(q), which is
    // what a plant applies while it brakes or waits, so the first commands do not jump.
    hold_at(q_);
    q_guarded_ = q_;  // a joint found outside its limits has crossed none
    // Within the effort limits: the rate limit keeps every command between this and the law's.
    tau_prev_ = data_.g.cwiseMax(-effort_limit_).cwiseMin(effort_limit_);
    switch_offset_.setZero();
  }
  if (mode_ == Mode::kRunning || mode_ == Mode::kHolding) {
    if (const motion::LimitExcess excess = measured_excess(limits_, q_guarded_, q_, qd_)) {
      std::snprintf(limit_reason_, sizeof(limit_reason_), "joint %s: %s %g %s past its limit %g %s",
                    model_->joint(excess.joint).name.c_str(), to_string(excess.quantity), excess.value,
                    unit_of(excess.quantity), excess.limit, unit_of(excess.quantity));
      start_reflex(now_ns, limit_reason_);
    } else if (contact_.estimate().collision) {
      start_reflex(now_ns);
    }
  }
  q_guarded_ = q_;
  update_reference(now_ns);
  error_ = ref_.q - q_;
  if (progress_.outcome == TrajectoryProgress::kActive) judge_trajectory(now_ns);

  apply_law(now_ns);

  if (!tau_.allFinite()) {
    fault("the control law produced a non-finite torque");
    return false;
  }
  tau_ = tau_.cwiseMax(-effort_limit_).cwiseMin(effort_limit_);
  limit_torque_rate();
  tau_prev_ = tau_;
  sent_torque_.col(sent_next_) = tau_;
  sent_ns_[size_t(sent_next_)] = now_ns;
  sent_next_ = (sent_next_ + 1) % kSentCommands;
  return true;
}

// One factor for the whole change, so that a limited command keeps the law's direction. Clamping
// each joint on its own turns the law's torque, an M-coupled combination, into another one: after
// a FAULT on a Panda moving at 0.8 rad/s, the hold's braking torque met the limit on joints 1 and 3
// at once, and equal steps on both drove joint 1 faster (0.8 to 2.6 rad/s in 20 ms at 200 Hz)
// instead of stopping it. The step is the same fraction of the law's change on every joint.
void Controller::limit_torque_rate() {
  double scale = 1.0;
  for (int i = 0; i < tau_.size(); ++i) {
    const double step = std::abs(tau_(i) - tau_prev_(i));
    if (step > rate_limit_per_tick_(i)) scale = std::min(scale, rate_limit_per_tick_(i) / step);
  }
  if (scale < 1.0) tau_ = tau_prev_ + scale * (tau_ - tau_prev_);
  // Exact to the last bit: the product may round past the limit it was scaled to.
  tau_ = tau_.cwiseMax(tau_prev_ - rate_limit_per_tick_).cwiseMin(tau_prev_ + rate_limit_per_tick_);
}

// At the pose where the generator takes a new goal (a setpoint, a jog command, a stop), and held
// until the next: the plan is then time-optimal for limits that stay put, as Ruckig's is for the
// limits it is given. Capped anew every tick instead, a rest-to-rest move replanned under a jerk
// that changed with M(q) took up to 1.17 times the time-optimal duration at its limits.
void Controller::cap_jerk_to_torque_rate() {
  if (!config_.limits.jerk_within_torque_rate) return;
  // τ̇ ≈ M(q) q⃛ is what a reference's jerk asks of the torque; the rate limit allows
  // effort/torque_ramp per joint. One factor for every joint keeps the jerks' proportions (and a
  // twist's direction through a change); half the rate leaves room for M(q) to grow along the
  // way to the next goal.
  double scale = 1.0;
  for (int i = 0; i < torque_rate_.size(); ++i) {
    const double asked = data_.M.row(i).cwiseAbs().dot(jerk_limit_);
    if (asked > 0.0) scale = std::min(scale, kTorqueRateShare * torque_rate_(i) / asked);
  }
  otg_limits_.jerk = scale * jerk_limit_;
}

void Controller::apply_law(int64_t now_ns) {
  if (compliant_) {
    damped_float(*model_, data_, contact_.config().compliant_damping, qd_, qdd_ref_, tau_);
  } else {
    switch (law_.law) {
      case Law::kComputedTorque:
        computed_torque(*model_, data_, config_.kp, config_.kd, ref_, q_, qd_, qdd_ref_, tau_);
        break;
      case Law::kJointImpedance:
        joint_impedance(*model_, data_, work_, law_, ref_, q_, qd_, tau_);
        break;
      case Law::kCartesianImpedance:
        body_jacobian(*model_, data_ref_, ref_.q);  // frame c at the reference
        cartesian_impedance(*model_, data_, data_ref_, work_, law_, ref_, q_, qd_, tau_);
        break;
      case Law::kFreeDrive:
        free_drive(*model_, data_, law_, qd_, tau_);
        break;
    }
  }
  // What an impedance pulls with on purpose is not a collision when it presses on something.
  if (!compliant_ && is_impedance(law_.law)) {
    allowance_ = work_.spring;
  } else {
    allowance_.setZero();
  }
  if (config_.damping.size() != 0) tau_ += config_.damping.cwiseProduct(ref_.qd);
  add_coulomb_friction(config_.coulomb, ref_.qd, tau_);
  if (switch_pending_) {
    switch_offset_ = tau_prev_ - tau_;
    switch_pending_ = false;
    switch_start_ns_ = now_ns;
  }
  const double fade = 1.0 - 1e-9 * static_cast<double>(now_ns - switch_start_ns_) / config_.torque_ramp;
  if (fade > 0.0) tau_ += fade * switch_offset_;
}

}  // namespace chasles::controller
