#include "harness.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "chasles/controller/clock.hpp"
#include "chasles/controller/controller.hpp"
#include "chasles/core/dynamics/dynamics.hpp"
#include "chasles/core/model/urdf.hpp"
#include "support/reference.hpp"

namespace chasles::faults {
namespace {

using controller::monotonic_ns;

// Room for about 8 s of states by seq, far more than any state a command can still answer.
constexpr size_t kPositions = 8192;

template <typename Message>
bool decode(const lcm_recv_buf_t* rbuf, Message& message) {
  return message.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) == static_cast<int>(rbuf->data_size);
}

}  // namespace

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * static_cast<double>(v.size())))];
}

Bus::Bus(const std::string& url, const std::string& prefix)
    : prefix_(prefix), rx_(lcm_create(url.c_str())), tx_(lcm_create(url.c_str())), positions_(kPositions) {
  if (rx_ == nullptr || tx_ == nullptr) throw std::runtime_error("LCM did not start on " + url + ": run under tools/netns.sh");
  // Bursts (the 10 kHz flood, a burst after a delay spike) must not be lost in the test's own
  // receive queue, or commands would go unjudged.
  for (auto* s : {lcm_subscribe(rx_, (prefix + "STATE").c_str(), &Bus::on_state, this),
                  lcm_subscribe(rx_, (prefix + "COMMAND").c_str(), &Bus::on_command, this),
                  lcm_subscribe(rx_, (prefix + "STATUS").c_str(), &Bus::on_status, this)}) {
    lcm_subscription_set_queue_capacity(s, 100'000);
  }
  thread_ = std::thread([this] {
    while (!done_.load()) lcm_handle_timeout(rx_, 20);
  });
}

Bus::~Bus() {
  done_ = true;
  thread_.join();
  lcm_destroy(rx_);
  lcm_destroy(tx_);
}

bool Bus::until(const std::function<bool(const Bus&)>& done, double seconds) const {
  const int64_t deadline = monotonic_ns() + static_cast<int64_t>(seconds * 1e9);
  while (true) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (done(*this)) return true;
    }
    if (monotonic_ns() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

void Bus::listen(double seconds) const {
  until([](const Bus&) { return false; }, seconds);
}

bool Bus::status_is(int8_t mode) const { return status_.has_value() && status_->state == mode; }

bool Bus::wait_for(int8_t mode, double seconds) const {
  return until([mode](const Bus& bus) { return bus.status_is(mode); }, seconds);
}

void Bus::publish(const std::string& channel, const std::vector<uint8_t>& bytes) {
  lcm_publish(tx_, (prefix_ + channel).c_str(), bytes.data(), static_cast<unsigned>(bytes.size()));
}

void Bus::publish_command(const joint_torque_command_t& command) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    own_commands_.insert({command.seq, command.utime});
  }
  publish("COMMAND", command);
}

std::vector<HeardCommand> Bus::commands() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return commands_;
}
std::vector<HeardStatus> Bus::statuses() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return statuses_;
}
std::optional<controller_status_t> Bus::status() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return status_;
}
std::optional<robot_state_t> Bus::state() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return state_;
}
int64_t Bus::state_count() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return state_count_;
}
Bus::StateGaps Bus::state_gaps() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return gaps_;
}
void Bus::clear_commands() {
  std::lock_guard<std::mutex> lock(mutex_);
  commands_.clear();
}

void Bus::on_state(const lcm_recv_buf_t* rbuf, const char*, void* self) {
  robot_state_t m{};
  if (!decode(rbuf, m) || m.seq < 0) return;
  for (double x : m.position) {
    if (!std::isfinite(x)) return;  // the test's own NaN bursts
  }
  for (double x : m.velocity) {
    if (!std::isfinite(x)) return;
  }
  auto* bus = static_cast<Bus*>(self);
  std::lock_guard<std::mutex> lock(bus->mutex_);
  ++bus->index_;
  ++bus->state_count_;
  auto& slot = bus->positions_[static_cast<size_t>(m.seq) % kPositions];
  slot.seq = m.seq;
  slot.arrival_ns = monotonic_ns();
  if (bus->last_seq_ >= 0 && m.seq > bus->last_seq_) {
    bus->gaps_.max_missing_run = std::max(bus->gaps_.max_missing_run, m.seq - bus->last_seq_ - 1);
    bus->gaps_.max_arrival_gap_ms =
        std::max(bus->gaps_.max_arrival_gap_ms, 1e-6 * static_cast<double>(slot.arrival_ns - bus->last_arrival_ns_));
  }
  if (m.seq > bus->last_seq_ || m.seq + 1000 < bus->last_seq_) {  // the latter: a plant restarted at 0
    bus->last_seq_ = m.seq;
    bus->last_arrival_ns_ = slot.arrival_ns;
  }
  slot.q = vector_of(m.position);
  bus->state_ = std::move(m);
}

void Bus::on_command(const lcm_recv_buf_t* rbuf, const char*, void* self) {
  HeardCommand c{};
  if (!decode(rbuf, c.message)) return;
  auto* bus = static_cast<Bus*>(self);
  std::lock_guard<std::mutex> lock(bus->mutex_);
  if (bus->own_commands_.count({c.message.seq, c.message.utime}) > 0) return;
  c.index = ++bus->index_;
  if (c.message.state_seq >= 0) {
    const auto& slot = bus->positions_[static_cast<size_t>(c.message.state_seq) % kPositions];
    if (slot.seq == c.message.state_seq) {
      c.q_answered = slot.q;
      c.round_trip_us = 1e-3 * static_cast<double>(monotonic_ns() - slot.arrival_ns);
    }
  }
  bus->commands_.push_back(std::move(c));
}

void Bus::on_status(const lcm_recv_buf_t* rbuf, const char*, void* self) {
  HeardStatus s{};
  if (!decode(rbuf, s.message)) return;
  auto* bus = static_cast<Bus*>(self);
  std::lock_guard<std::mutex> lock(bus->mutex_);
  s.index = ++bus->index_;
  bus->status_ = s.message;
  bus->statuses_.push_back(std::move(s));
}

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

std::string unexplained_faults(const Bus::StateGaps& gaps, const StatusReport& s, double stale_ms, double injected_ms) {
  if (s.faults == 0) return "";
  // 0.8: the bus and the controller stamp arrivals from different threads and processes.
  const double late_ms = 1e-3 * s.jitter_max_us;
  if (gaps.max_arrival_gap_ms >= 0.8 * stale_ms || late_ms + injected_ms >= 0.8 * stale_ms) return "";
  char why[320];
  std::snprintf(why, sizeof(why),
                "%lld FAULT(s) that no stall explains: longest wait for a state on the bus %.1f ms, the controller's "
                "worst wake-up %.1f ms late, injected gaps up to %.1f ms, stale limit %.1f ms",
                static_cast<long long>(s.faults), gaps.max_arrival_gap_ms, late_ms, injected_ms, stale_ms);
  return why;
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

const RobotModel& panda() {
  static const RobotModel model = [] {
    UrdfOptions options;
    options.tip_link = "panda_hand_tcp";
    return load_urdf_file(testing::data_path("panda.urdf"), options);
  }();
  return model;
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
