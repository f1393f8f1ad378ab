#include "controller/safety.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace chasles::controller {
namespace {

constexpr int64_t kNeverSent = std::numeric_limits<int64_t>::min();

}  // namespace

CommandHistory::CommandHistory(int dof) : torque_(Eigen::MatrixXd::Zero(dof, kSize)), sent_ns_(kSize, kNeverSent) {}

void CommandHistory::record(const Eigen::VectorXd& tau, int64_t sent_ns) {
  torque_.col(next_) = tau;
  sent_ns_[size_t(next_)] = sent_ns;
  next_ = (next_ + 1) % kSize;
}

int CommandHistory::in_force(int64_t at_ns) const {
  int latest = -1;
  for (int j = 0; j < kSize; ++j) {
    const int64_t sent = sent_ns_[size_t(j)];
    if (sent != kNeverSent && sent <= at_ns && (latest < 0 || sent > sent_ns_[size_t(latest)])) latest = j;
  }
  return latest;
}

TorqueGuard::TorqueGuard(const RobotModel& model, double torque_ramp, double period)
    : torque_ramp_(torque_ramp),
      effort_limit_(model.dof()),
      rate_limit_per_tick_(model.dof()),
      torque_rate_(model.dof()),
      previous_(Eigen::VectorXd::Zero(model.dof())),
      switch_offset_(Eigen::VectorXd::Zero(model.dof())) {
  for (int i = 0; i < model.dof(); ++i) {
    const double effort = model.joint(i).limits.effort;
    effort_limit_(i) = effort > 0.0 ? effort : std::numeric_limits<double>::infinity();
    torque_rate_(i) = effort_limit_(i) / torque_ramp;
    rate_limit_per_tick_(i) = torque_rate_(i) * period;
  }
}

void TorqueGuard::restart(const Eigen::VectorXd& tau) {
  // Within the effort limits: the rate limit keeps every command between this and the law's.
  previous_ = tau.cwiseMax(-effort_limit_).cwiseMin(effort_limit_);
  switch_offset_.setZero();
}

bool TorqueGuard::apply(Eigen::VectorXd& tau, int64_t now_ns) {
  if (switch_pending_) {
    switch_offset_ = previous_ - tau;
    switch_pending_ = false;
    switch_start_ns_ = now_ns;
  }
  const double fade = 1.0 - 1e-9 * static_cast<double>(now_ns - switch_start_ns_) / torque_ramp_;
  if (fade > 0.0) tau += fade * switch_offset_;
  if (!tau.allFinite()) return false;
  tau = tau.cwiseMax(-effort_limit_).cwiseMin(effort_limit_);
  limit_rate(tau);
  previous_ = tau;
  return true;
}

// One factor for the whole change, so that a limited command keeps the law's direction. Clamping
// each joint on its own turns the law's torque, an M-coupled combination, into another one: after
// a FAULT on a Panda moving at 0.8 rad/s, the hold's braking torque met the limit on joints 1 and 3
// at once, and equal steps on both drove joint 1 faster (0.8 to 2.6 rad/s in 20 ms at 200 Hz)
// instead of stopping it. The step is the same fraction of the law's change on every joint.
void TorqueGuard::limit_rate(Eigen::VectorXd& tau) const {
  double scale = 1.0;
  for (int i = 0; i < tau.size(); ++i) {
    const double step = std::abs(tau(i) - previous_(i));
    if (step > rate_limit_per_tick_(i)) scale = std::min(scale, rate_limit_per_tick_(i) / step);
  }
  if (scale < 1.0) tau = previous_ + scale * (tau - previous_);
  // Exact to the last bit: the product may round past the limit it was scaled to.
  tau = tau.cwiseMax(previous_ - rate_limit_per_tick_).cwiseMin(previous_ + rate_limit_per_tick_);
}

}  // namespace chasles::controller
