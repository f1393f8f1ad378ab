// chasles_loop_bench: the reference figures a real-time loop on this machine is judged against,
// measured with nothing of chasles in the way.
//
//   sleep     a bare periodic loop: clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME) on an absolute
//             schedule, timer slack 1 ns; wake-up jitter = actual − scheduled wake-up time.
//   pingpong  an LCM round trip at the same rate: this process publishes a robot_state_t for 7
//             joints (the plant's message) on LOOPBENCH_PING each period; a forked echo process
//             decodes it and publishes it back on LOOPBENCH_PONG; round trip = publish → echo
//             decoded here. With --realtime both ends run SCHED_FIFO, so the figure is what the
//             machine can do at best, not how long a busy machine keeps the echo waiting.
//
// Prints one JSON object on stdout; warnings on stderr. Errors: one line "chasles_loop_bench: ..."
// on stderr, exit 2 for a usage error, 1 when LCM cannot start or nothing echoes.
#include <poll.h>
#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cerrno>
#include <chasles/robot_state_t.hpp>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <lcm/lcm-cpp.hpp>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

using chasles::robot_state_t;

constexpr char kPing[] = "LOOPBENCH_PING";
constexpr char kPong[] = "LOOPBENCH_PONG";
constexpr int kJoints = 7;
constexpr int64_t kLateNs = 500'000;  // "late": a wake-up more than 500 µs after schedule
constexpr int64_t kStallNs = 10'000'000;  // a stall: longer than the controller's default --stale-ms

struct Options {
  std::string mode = "both";
  double seconds = 3.0;
  double rate_hz = 1000.0;
  bool realtime = false;
  std::string lcm_url;
  std::string echo_netns;  // the echo's network namespace (a /proc/PID/ns/net or /run/netns path)
};

class Failure : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

int64_t monotonic_ns() {
  timespec t{};
  clock_gettime(CLOCK_MONOTONIC, &t);
  return int64_t{t.tv_sec} * 1'000'000'000 + t.tv_nsec;
}

timespec to_timespec(int64_t ns) {
  return {static_cast<time_t>(ns / 1'000'000'000), static_cast<long>(ns % 1'000'000'000)};
}

void sleep_until(int64_t ns) {
  const timespec wake = to_timespec(ns);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &wake, nullptr) == EINTR) {
  }
}

// p50, p99 and max of samples in ns, as µs: nearest-rank percentiles.
struct Summary {
  double p50 = 0.0, p99 = 0.0, max = 0.0;
};

Summary summarise(std::vector<int64_t> samples_ns) {
  Summary s;
  if (samples_ns.empty()) return s;
  std::sort(samples_ns.begin(), samples_ns.end());
  const auto rank = [&](double q) {
    const auto k = static_cast<size_t>(std::ceil(q * static_cast<double>(samples_ns.size())));
    return static_cast<double>(samples_ns[std::max<size_t>(k, 1) - 1]) * 1e-3;
  };
  s.p50 = rank(0.50);
  s.p99 = rank(0.99);
  s.max = static_cast<double>(samples_ns.back()) * 1e-3;
  return s;
}

// SCHED_FIFO 80 and locked memory, as the controller asks for with --realtime; a warning, not a
// failure, when refused. Returns what was applied.
struct Scheduling {
  bool fifo = false;
  bool locked = false;
};

Scheduling go_realtime() {
  Scheduling applied;
  sched_param param{};
  param.sched_priority = 80;
  if (sched_setscheduler(0, SCHED_FIFO, &param) == 0) {
    applied.fifo = true;
  } else {
    std::fprintf(stderr, "chasles_loop_bench: warning: SCHED_FIFO 80 refused (%s); measuring under SCHED_OTHER\n",
                 std::strerror(errno));
  }
  if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) {
    applied.locked = true;
  } else {
    std::fprintf(stderr, "chasles_loop_bench: warning: mlockall refused (%s); memory may page\n", std::strerror(errno));
  }
  return applied;
}

int64_t period_ns(const Options& o) { return static_cast<int64_t>(std::llround(1e9 / o.rate_hz)); }

size_t tick_count(const Options& o) { return static_cast<size_t>(std::ceil(o.seconds * o.rate_hz)) + 1; }

// (a) The bare loop. A wake-up more than a period late is an overrun and the schedule restarts
// from it, as the controller's and the plant's loops do, rather than racing to catch up.
struct SleepResult {
  Summary jitter;
  size_t samples = 0;
  int64_t late = 0, overruns = 0;
  int64_t stalls = 0;  // wake-ups later than a controller's default stale limit
};

SleepResult run_sleep(const Options& o) {
  const int64_t period = period_ns(o);
  std::vector<int64_t> lateness_ns(tick_count(o), 0);  // touched now: no page fault in the loop
  SleepResult result;
  const int64_t start = monotonic_ns();
  const auto end = start + static_cast<int64_t>(o.seconds * 1e9);
  int64_t next = start;
  while (result.samples < lateness_ns.size()) {
    next += period;
    sleep_until(next);
    const int64_t now = monotonic_ns();
    if (now >= end) break;
    const int64_t late = now - next;
    lateness_ns[result.samples++] = late;
    if (late > kLateNs) ++result.late;
    if (late > kStallNs) ++result.stalls;
    if (late > period) {
      ++result.overruns;
      next = now;
    }
  }
  lateness_ns.resize(result.samples);
  result.jitter = summarise(std::move(lateness_ns));
  return result;
}

// The echo side of (b), in its own process: every ping back as a pong, decoded and encoded again
// as a plant or controller would.
volatile sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

void echo_received(const lcm_recv_buf_t* rbuf, const char*, void* user) {
  robot_state_t state;
  const int size = static_cast<int>(rbuf->data_size);
  if (state.decode(rbuf->data, 0, size) != size) return;
  static_cast<lcm::LCM*>(user)->publish(kPong, &state);
}

[[noreturn]] void run_echo(const Options& o) {
  prctl(PR_SET_PDEATHSIG, SIGTERM);  // never outlive the measuring process
  struct sigaction action {};
  action.sa_handler = on_signal;
  sigaction(SIGTERM, &action, nullptr);
  if (o.realtime) mlockall(MCL_CURRENT | MCL_FUTURE);  // SCHED_FIFO is inherited, memory locks are not
  if (!o.echo_netns.empty()) {  // the other "host" of tools/netns2.sh
    const int ns = open(o.echo_netns.c_str(), O_RDONLY | O_CLOEXEC);
    if (ns < 0 || setns(ns, CLONE_NEWNET) != 0) ::_exit(1);
    close(ns);
  }
  lcm::LCM lcm(o.lcm_url);
  if (!lcm.good()) ::_exit(1);
  // LCM's C interface: GCC 12's -fsanitize=vptr miscompiles its typed C++ subscription.
  lcm_subscribe(lcm.getUnderlyingLCM(), kPing, echo_received, &lcm);
  while (!g_stop) lcm.handleTimeout(100);
  ::_exit(0);
}

// The measuring side of (b).
class PingPong {
 public:
  PingPong(const Options& o, pid_t echo)
      : o_(o), echo_(echo), lcm_(o.lcm_url), sent_ns_(tick_count(o), -1), rtt_ns_(tick_count(o), -1) {
    if (!lcm_.good()) {
      throw Failure("cannot start LCM" + (o.lcm_url.empty() ? std::string() : " on " + o.lcm_url) +
                    ": is there a multicast route? Run inside tools/netns.sh with --lcm-url "
                    "'udpm://239.255.76.67:7667?ttl=0'");
    }
    lcm_subscribe(lcm_.getUnderlyingLCM(), kPong, &PingPong::on_pong, this);
    ping_.num_joints = kJoints;
    for (int i = 0; i < kJoints; ++i) {
      ping_.position.push_back(0.1 * i);
      ping_.velocity.push_back(-0.2 * i);
      ping_.effort.push_back(3.0 * i);
    }
  }

  struct Result {
    Summary round_trip;
    size_t sent = 0, answered = 0;
    size_t beyond_period = 0;  // answered after a period, or never: what a plant would count late
    int message_bytes = 0;
  };

  Result run() {
    wait_for_echo();
    const int64_t period = period_ns(o_);
    const int64_t start = monotonic_ns();
    const auto end = start + static_cast<int64_t>(o_.seconds * 1e9);
    int64_t next = start;
    size_t k = 0;
    while (k < sent_ns_.size()) {
      next += period;
      sleep_until(next);
      int64_t now = monotonic_ns();
      if (now >= end) break;
      if (now - next > period) next = now;
      ping_.seq = static_cast<int64_t>(k);
      ping_.utime = now / 1000;
      sent_ns_[k] = monotonic_ns();
      lcm_.publish(kPing, &ping_);
      // Wait for the answer until the next tick at most; a later one is still timed when it comes.
      while (rtt_ns_[k] < 0 && (now = monotonic_ns()) < next + period) handle_for(next + period - now);
      ++k;
    }
    const int64_t drain_end = monotonic_ns() + 50'000'000;
    for (int64_t now = monotonic_ns(); now < drain_end; now = monotonic_ns()) handle_for(drain_end - now);

    Result result;
    result.sent = k;
    std::vector<int64_t> answered;
    answered.reserve(k);
    for (size_t i = 0; i < k; ++i) {
      if (rtt_ns_[i] >= 0) answered.push_back(rtt_ns_[i]);
      if (rtt_ns_[i] < 0 || rtt_ns_[i] > period) ++result.beyond_period;
    }
    result.answered = answered.size();
    result.round_trip = summarise(std::move(answered));
    result.message_bytes = ping_.getEncodedSize();
    return result;
  }

 private:
  // The echo process needs a moment to start; ping (seq −1) until it answers.
  void wait_for_echo() {
    const int64_t give_up = monotonic_ns() + 5'000'000'000;
    ping_.seq = -1;
    while (!echo_ready_) {
      int status = 0;
      if (waitpid(echo_, &status, WNOHANG) == echo_) throw Failure("the echo process could not start LCM (or enter --echo-netns)");
      if (monotonic_ns() > give_up) {
        throw Failure(std::string("no answer on ") + kPong + " within 5 s: is multicast looped back?" +
                      " Run inside tools/netns.sh");
      }
      lcm_.publish(kPing, &ping_);
      const int64_t wait_end = monotonic_ns() + 10'000'000;
      for (int64_t now = monotonic_ns(); !echo_ready_ && now < wait_end; now = monotonic_ns()) {
        handle_for(wait_end - now);
      }
    }
  }

  void handle_for(int64_t ns) {
    pollfd fd{lcm_.getFileno(), POLLIN, 0};
    const timespec timeout = to_timespec(std::max<int64_t>(ns, 0));
    if (ppoll(&fd, 1, &timeout, nullptr) > 0) lcm_.handle();
  }

  // The round trip ends once the echo is decoded here, as a controller's would end with a state.
  static void on_pong(const lcm_recv_buf_t* rbuf, const char*, void* user) {
    auto& self = *static_cast<PingPong*>(user);
    robot_state_t pong;
    const int size = static_cast<int>(rbuf->data_size);
    if (pong.decode(rbuf->data, 0, size) != size) return;
    if (pong.seq < 0) {
      self.echo_ready_ = true;
      return;
    }
    const auto k = static_cast<size_t>(pong.seq);
    if (k < self.sent_ns_.size() && self.sent_ns_[k] >= 0 && self.rtt_ns_[k] < 0) {
      self.rtt_ns_[k] = monotonic_ns() - self.sent_ns_[k];
    }
  }

  const Options& o_;
  pid_t echo_;
  lcm::LCM lcm_;
  robot_state_t ping_{};
  std::vector<int64_t> sent_ns_, rtt_ns_;
  bool echo_ready_ = false;
};

std::string summary_json(const Summary& s) {
  char text[160];
  std::snprintf(text, sizeof(text), "\"p50\":%.1f,\"p99\":%.1f,\"max\":%.1f", s.p50, s.p99, s.max);
  return text;
}

int fail(const std::string& message, int code) {
  std::fprintf(stderr, "chasles_loop_bench: %s\n", message.c_str());
  return code;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("chasles_loop_bench: reference timing of a bare 1 kHz loop and of an LCM round trip",
               "chasles_loop_bench");
  Options o;
  app.add_option("--mode", o.mode, "What to measure, each for --seconds")
      ->check(CLI::IsMember({"sleep", "pingpong", "both"}))
      ->capture_default_str();
  app.add_option("--seconds", o.seconds, "Length of each measurement")
      ->check(CLI::Range(0.01, 3600.0))
      ->type_name("N")
      ->capture_default_str();
  app.add_option("--rate", o.rate_hz, "Loop rate")
      ->check(CLI::Range(1.0, 20000.0))
      ->type_name("HZ")
      ->capture_default_str();
  app.add_flag("--realtime", o.realtime,
               "SCHED_FIFO 80 and mlockall, as the controller's --realtime (warns if refused)");
  app.add_option("--lcm-url", o.lcm_url, "LCM provider URL (default: $LCM_DEFAULT_URL, else LCM's default)")
      ->type_name("URL");
  app.add_option("--echo-netns", o.echo_netns,
                 "Run the ping-pong's echo in this network namespace (tools/netns2.sh's $CHASLES_NETNS_B): "
                 "the round trip then crosses the veth pair, as between two hosts")
      ->check(CLI::ExistingFile)
      ->type_name("PATH");
  app.footer(
      "Output: {\"rate_hz\", \"seconds\", \"sched\", \"mlockall\",\n"
      "         \"sleep_jitter_us\": {\"p50\", \"p99\", \"max\", \"late_500us\", \"late_10ms\", \"overruns\", \"samples\"},\n"
      "         \"lcm_round_trip_us\": {\"p50\", \"p99\", \"max\", \"sent\", \"answered\", \"beyond_period\", \"message_bytes\"}}\n"
      "Example (as root; tools/netns.sh keeps the multicast on a private loopback):\n"
      "  tools/netns.sh chasles_loop_bench --realtime --lcm-url 'udpm://239.255.76.67:7667?ttl=0'");
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    return fail(std::string(e.what()) + " (see 'chasles_loop_bench --help')", 2);
  }

  const bool sleep = o.mode != "pingpong", pingpong = o.mode != "sleep";
  prctl(PR_SET_TIMERSLACK, 1UL);  // the default 50 µs slack would dominate the jitter
  Scheduling scheduling;
  if (o.realtime) scheduling = go_realtime();
  // The echo process is forked while this process still has one thread; it inherits the policy.
  pid_t echo = -1;
  if (pingpong) {
    std::fflush(nullptr);
    echo = fork();
    if (echo < 0) return fail(std::string("fork: ") + std::strerror(errno), 1);
    if (echo == 0) run_echo(o);
  }
  const auto stop_echo = [&] {
    if (echo <= 0) return;
    kill(echo, SIGTERM);
    waitpid(echo, nullptr, 0);
    echo = -1;
  };

  char head[160];
  std::snprintf(head, sizeof(head), "{\"rate_hz\":%g,\"seconds\":%g,\"sched\":\"%s\",\"mlockall\":%s", o.rate_hz,
                o.seconds, scheduling.fifo ? "SCHED_FIFO 80" : "SCHED_OTHER", scheduling.locked ? "true" : "false");
  std::string out = head;
  try {
    if (sleep) {
      const SleepResult r = run_sleep(o);
      out += ",\"sleep_jitter_us\":{" + summary_json(r.jitter) + ",\"late_500us\":" + std::to_string(r.late) +
             ",\"late_10ms\":" + std::to_string(r.stalls) +
             ",\"overruns\":" + std::to_string(r.overruns) + ",\"samples\":" + std::to_string(r.samples) + "}";
    }
    if (pingpong) {
      PingPong bench(o, echo);
      const PingPong::Result r = bench.run();
      out += ",\"lcm_round_trip_us\":{" + summary_json(r.round_trip) + ",\"sent\":" + std::to_string(r.sent) +
             ",\"answered\":" + std::to_string(r.answered) + ",\"beyond_period\":" + std::to_string(r.beyond_period) +
             ",\"message_bytes\":" + std::to_string(r.message_bytes) + "}";
    }
  } catch (const Failure& e) {
    stop_echo();
    return fail(e.what(), 1);
  }
  stop_echo();
  std::printf("%s}\n", out.c_str());
  return 0;
}
