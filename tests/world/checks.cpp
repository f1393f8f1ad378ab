#include "checks.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "controller/controller.hpp"
#include "core/dynamics/dynamics.hpp"
#include "core/model/urdf.hpp"
#include "support/reference.hpp"

namespace chasles::faults {

CommandReport check_commands(const RobotModel& model, const std::vector<HeardCommand>& commands,
                             const std::vector<HeardStatus>& statuses, double ramp_s, double period_s) {
  const int n = model.dof();
  Data data(model);
  Eigen::VectorXd effort(n), rate(n);
  for (int i = 0; i < n; ++i) {
    effort(i) = model.joint(i).limits.effort;
    rate(i) = effort(i) / ramp_s * period_s;  // the controller's rate_limit_per_tick_, same formula
  }
  // Faults counted in the last status heard before arrival index i / the first heard after it.
  auto faults_before = [&](int64_t index) {
    int64_t f = 0;
    for (const auto& s : statuses) {
      if (s.index > index) break;
      f = s.message.faults;
    }
    return f;
  };
  auto faults_after = [&](int64_t index) {
    for (const auto& s : statuses) {
      if (s.index > index) return s.message.faults;
    }
    return statuses.empty() ? int64_t{0} : statuses.back().message.faults;
  };
  CommandReport r;
  std::vector<double> spacing;
  auto violation = [&](int64_t& counter, const std::string& what) {
    if (counter++ == 0 && r.first_violation.empty()) r.first_violation = what;
  };
  const HeardCommand* previous = nullptr;
  for (const HeardCommand& c : commands) {
    ++r.commands;
    const Eigen::VectorXd tau = vector_of(c.message.torque);
    const std::string where = "command seq " + std::to_string(c.message.seq) + ": ";
    if (tau.size() != n || !tau.allFinite()) {
      violation(r.non_finite, where + "non-finite or of the wrong size");
      previous = &c;
      continue;
    }
    for (int i = 0; i < n; ++i) {
      r.max_effort_ratio = std::max(r.max_effort_ratio, std::abs(tau(i)) / effort(i));
      if (std::abs(tau(i)) > effort(i) * (1.0 + 1e-12)) {
        violation(r.effort_violations, where + "|tau_" + std::to_string(i) + "| = " + std::to_string(tau(i)) +
                                           " over its effort limit " + std::to_string(effort(i)));
      }
    }
    if (previous != nullptr && c.message.seq != previous->message.seq + 1) {
      ++r.seq_gaps;  // a command the test did not hear: the next step is not judged
      previous = &c;
      continue;
    }
    auto within = [&](const Eigen::VectorXd& from, double& worst) {
      bool ok = true;
      for (int i = 0; i < n; ++i) {
        const double ratio = std::abs(tau(i) - from(i)) / rate(i);
        worst = std::max(worst, ratio);
        ok = ok && std::abs(tau(i) - from(i)) <= rate(i) + 1e-9 * (1.0 + std::abs(tau(i)));
      }
      return ok;
    };
    double step_ratio = 0.0;
    if (previous != nullptr && within(vector_of(previous->message.torque), step_ratio)) {
      r.max_rate_ratio = std::max(r.max_rate_ratio, step_ratio);
      spacing.push_back(static_cast<double>(c.message.utime - previous->message.utime));
    } else {
      // Allowed only where the law restarts its rate limiter: the first command, or the first
      // after a FAULT (the faults counter grew between the two commands), and then from g(q).
      const bool restart = previous == nullptr || faults_after(c.index) > faults_before(previous->index);
      double from_gravity = 0.0;
      if (restart && c.q_answered && within(gravity_torques(model, data, *c.q_answered), from_gravity)) {
        ++r.restarts_from_gravity;
        r.max_rate_ratio = std::max(r.max_rate_ratio, from_gravity);
      } else {
        std::ostringstream what;
        what << where << "a step of " << (tau - vector_of(previous->message.torque)).transpose()
             << " over the rate limit " << rate.transpose() << (restart ? " (nor within it of g(q))" : "");
        violation(r.rate_violations, what.str());
      }
    }
    previous = &c;
  }
  r.spacing_p50_us = percentile(spacing, 0.5);
  r.spacing_p99_us = percentile(spacing, 0.99);
  return r;
}

StatusReport summarise(const std::vector<HeardStatus>& statuses) {
  StatusReport r;
  std::vector<double> jitter, latency;
  int8_t last = -1;
  for (const auto& heard : statuses) {
    const controller_status_t& s = heard.message;
    if (s.state != last) {
      r.modes += (r.modes.empty() ? "" : ">") + std::string(controller::to_string(static_cast<controller::Mode>(s.state)));
      if (s.state == controller_status_t::FAULT) {
        ++r.fault_transitions;
        r.fault_messages.push_back(s.message);  // as first reported (the age in it grows later)
      }
      last = s.state;
    }
    if (s.ticks > 0) jitter.push_back(s.jitter_p99_us);
    if (s.latency_p99_us > 0.0) latency.push_back(s.latency_p99_us);
    r.jitter_max_us = std::max(r.jitter_max_us, s.jitter_max_us);
  }
  r.jitter_p99_median_us = percentile(jitter, 0.5);
  r.latency_p99_median_us = percentile(latency, 0.5);
  if (!statuses.empty()) {
    const controller_status_t& s = statuses.back().message;
    r.ticks = s.ticks, r.overruns = s.overruns, r.stale = s.stale_states, r.rejected = s.rejected_messages;
    r.faults = s.faults;
  }
  return r;
}

std::string table_row(const std::string& fault, const CommandReport& c, const StatusReport& s) {
  char row[1024];
  std::snprintf(row, sizeof(row),
                "FAULT TABLE | %s | modes %s | faults %lld, stale ticks %lld, rejected %lld | %lld commands, "
                "max |tau|/effort %.2f, max |dtau|/limit %.2f, %lld restarts from g(q), %lld bound violations | "
                "spacing p50 %.0f us p99 %.0f us, jitter p99 (median window) %.0f us max %.0f us, overruns %lld of %lld "
                "ticks",
                fault.c_str(), s.modes.c_str(), static_cast<long long>(s.faults), static_cast<long long>(s.stale),
                static_cast<long long>(s.rejected), static_cast<long long>(c.commands), c.max_effort_ratio,
                c.max_rate_ratio, static_cast<long long>(c.restarts_from_gravity),
                static_cast<long long>(c.non_finite + c.effort_violations + c.rate_violations), c.spacing_p50_us,
                c.spacing_p99_us, s.jitter_p99_median_us, s.jitter_max_us, static_cast<long long>(s.overruns),
                static_cast<long long>(s.ticks));
  std::string text = row;
  for (const auto& m : s.fault_messages) text += "\n    FAULT message: " + m;
  return text;
}


joint_torque_command_t command_of(int64_t seq, int64_t utime, int64_t state_seq, const Eigen::VectorXd& tau) {
  joint_torque_command_t command{};
  command.utime = utime;
  command.seq = seq;
  command.state_seq = state_seq;
  command.num_joints = static_cast<int32_t>(tau.size());
  command.torque.assign(tau.data(), tau.data() + tau.size());
  return command;
}

}  // namespace chasles::faults
