#include "controller/monitor.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace chasles::controller {
namespace {

// A gap between states longer than this many periods restarts the observer: the torque held over
// it is not known.
constexpr double kMaxGapPeriods = 10.5;

// The relative change of the measured period that formats the warning anew, about its 3 digits'
// resolution: a jittery stream's running mean moves by less than this most states.
constexpr double kPeriodQuoteStep = 1e-3;

}  // namespace

StateMonitor::StateMonitor(const RobotModel& model, const Config& config)
    : period_(config.period),
      check_semantics_(config.check_torque_semantics),
      contact_(model, config.contact, config.damping, config.period, config.coulomb),
      gap_torque_(Eigen::VectorXd::Zero(model.dof())),
      state_period_(config.period) {}

TorqueSemanticsCheck::Verdict StateMonitor::observe(const JointState& state, const Data& data,
                                                    const CommandHistory& sent, bool commanding,
                                                    const Eigen::VectorXd& allowance) {
  if (any_ && state.seq == seq_) return TorqueSemanticsCheck::Verdict::kUndecided;
  // The time since the last state observed, from the states' own clock: utime, or where a sender
  // leaves it standing, their arrival. A first state, a sender that restarted its count, a seq that
  // does not fit (it comes off the wire) or a gap over kMaxGapPeriods restarts the observer (dt = 0).
  int64_t steps = 0;
  double dt = 0.0;
  if (any_ && !__builtin_sub_overflow(state.seq, seq_, &steps) && steps > 0) {
    int64_t elapsed_us = 0;
    if (!__builtin_sub_overflow(state.utime, utime_, &elapsed_us) && elapsed_us > 0) {
      dt = 1e-6 * static_cast<double>(elapsed_us);
    } else {
      dt = 1e-9 * static_cast<double>(state.arrival_ns - arrival_ns_);
    }
    if (dt > 0.0 && steps == 1) track_period(dt);
    if (!(dt <= kMaxGapPeriods * std::max(period_, state_period_))) dt = 0.0;
  }
  const Eigen::VectorXd& tau = dt > 0.0 ? torque_across(state, dt, sent) : state.effort;
  seq_ = state.seq;
  utime_ = state.utime;
  arrival_ns_ = state.arrival_ns;
  any_ = true;
  contact_.set_allowance(allowance);
  contact_.update(data, state.q, state.qd, tau, dt);
  const ContactEstimate& e = contact_.estimate();
  if (e.contact && !in_contact_) ++contacts_;
  in_contact_ = e.contact;
  peak_tip_force_ = std::max(peak_tip_force_, e.wrench_base.tail<3>().norm());

  // The torque the arm reports applying over its last step against the one commanded for it: the
  // latest sent before the state arrived. Judged only while this controller commands.
  const int j = commanding ? sent.in_force(state.arrival_ns) : -1;
  if (!check_semantics_ || j < 0 || !(dt > 0.0)) {
    semantics_.restart();
    return TorqueSemanticsCheck::Verdict::kUndecided;
  }
  return semantics_.update(state.effort, sent.command(j), data.g, dt);
}

// The mean torque the arm applied across the dt since the last state observed. A state's effort is
// the torque of its own last step; when states between were lost, each earlier step ran under the
// command in force as it began — this controller's, which it keeps — so the mean is taken over
// those and the effort reported for the last. Taking the effort for the whole gap instead read the
// torque's change over the gap as external: at 200 Hz with half the states lost, 18 N at the tip
// and a false collision. A quarter step's grace lets the command answering a state be sent a
// little after the state arrived. Allocates nothing.
const Eigen::VectorXd& StateMonitor::torque_across(const JointState& state, double dt, const CommandHistory& sent) {
  const int64_t steps = std::llround(dt / state_period_);
  if (steps <= 1) return state.effort;
  const double step_ns = static_cast<double>(state.arrival_ns - arrival_ns_) / static_cast<double>(steps);
  gap_torque_ = state.effort;
  for (int64_t k = 0; k + 1 < steps; ++k) {
    const int j = sent.in_force(arrival_ns_ + std::llround((static_cast<double>(k) + 0.25) * step_ns));
    if (j >= 0) {
      gap_torque_ += sent.command(j);
    } else {
      gap_torque_ += state.effort;
    }
  }
  gap_torque_ /= static_cast<double>(steps);
  return gap_torque_;
}

// A running mean over the first kPeriodWindow intervals, then an exponential one of that length.
void StateMonitor::track_period(double dt) {
  period_intervals_ = std::min<int64_t>(period_intervals_ + 1, kPeriodWindow);
  state_period_ += (dt - state_period_) / static_cast<double>(period_intervals_);
  const double ratio = state_period_ / period_;
  const bool was_mismatched = period_mismatch_;
  period_mismatch_ = period_intervals_ == kPeriodWindow && std::abs(ratio - 1.0) > kPeriodTolerance;
  // Formatted on the tick only when the figure it quotes may have moved, not at every state.
  if (period_mismatch_ &&
      (!was_mismatched || std::abs(state_period_ - quoted_period_) > kPeriodQuoteStep * quoted_period_)) {
    quoted_period_ = state_period_;
    std::snprintf(period_warning_, sizeof(period_warning_),
                  "the robot states come every %.3g ms (%.4g Hz), the configured period is %.3g ms",
                  1e3 * state_period_, 1.0 / state_period_, 1e3 * period_);
  }
}

}  // namespace chasles::controller
