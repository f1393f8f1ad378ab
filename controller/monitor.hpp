// What every new state is watched for, whatever the mode (docs/controller.md, "Contact"): the
// contact observer's estimate (contact.hpp) from the torque the arm had over the step before it —
// ours, kept in the command history, or the plant's brake; the states' own period; and whether the
// arm applies the torque we send (semantics_check.hpp).
#pragma once

#include <Eigen/Core>
#include <cstdint>

#include "controller/config.hpp"
#include "controller/contact.hpp"
#include "controller/safety.hpp"
#include "controller/semantics_check.hpp"
#include "controller/signals.hpp"

namespace chasles::controller {

class StateMonitor {
 public:
  /// Keeps a reference to `model`. Throws ArgumentError for a bad contact configuration.
  StateMonitor(const RobotModel& model, const Config& config);
  /// Takes a state (once per seq) whose terms at (q, q̇) are in `data`. `commanding`: whether this
  /// controller commands, and so whether the arm's torque is judged against `sent`. `allowance`:
  /// the law's own pull, not a collision when it presses. Returns the torque-semantics check's
  /// verdict (kUndecided but at the end of a window that decided). Allocates nothing.
  TorqueSemanticsCheck::Verdict observe(const JointState& state, const Data& data, const CommandHistory& sent,
                                        bool commanding, const Eigen::VectorXd& allowance);
  /// Estimates with `model` from the next state (the same chain, another payload).
  void set_model(const RobotModel& model) { contact_.set_model(model); }
  const ContactMonitor& contact() const { return contact_; }
  /// The locator's newest contact, judged at the next state (ContactMonitor::take_location).
  void take_location(const LocatedContact& located) { contact_.take_location(located); }
  /// The share of g(q) the semantics check found in the difference (its last window).
  double semantics_share() const { return semantics_.share(); }

  /// The period of the robot states, s, measured from their utime (their arrival where a sender
  /// leaves utime standing): the mean over the last kPeriodWindow intervals between consecutive
  /// states; the configured period until one is measured. The observer steps by each interval.
  double state_period() const { return state_period_; }
  /// Why the measured period is not the configured one (over kPeriodTolerance apart, once
  /// kPeriodWindow intervals are in), or "" when it is.
  const char* period_warning() const { return period_mismatch_ ? period_warning_ : ""; }
  static constexpr int64_t kPeriodWindow = 100;
  static constexpr double kPeriodTolerance = 0.1;
  /// Contacts (each time the contact flag rose) since start; the largest estimated tip force, N.
  int64_t contacts() const { return contacts_; }
  double peak_tip_force() const { return peak_tip_force_; }

 private:
  void track_period(double dt);
  const Eigen::VectorXd& torque_across(const JointState& state, double dt, const CommandHistory& sent);

  double period_;
  bool check_semantics_;
  ContactMonitor contact_;
  TorqueSemanticsCheck semantics_;
  int64_t seq_ = 0;  // of the last state observed, once any_
  int64_t utime_ = 0, arrival_ns_ = 0;
  bool any_ = false;
  bool in_contact_ = false;
  int64_t contacts_ = 0;
  double peak_tip_force_ = 0.0;
  Eigen::VectorXd gap_torque_;
  double state_period_;
  double quoted_period_ = 0.0;  // the state period period_warning_ was formatted with
  int64_t period_intervals_ = 0;
  bool period_mismatch_ = false;
  char period_warning_[160] = {};
};

}  // namespace chasles::controller
