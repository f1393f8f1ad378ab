#include "controller/transport/realtime/realtime.hpp"

#include <fcntl.h>
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <sys/eventfd.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <system_error>

#include "controller/transport/realtime/clock.hpp"

namespace chasles::controller {

void minimise_timer_slack() { prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL); }

int request_fifo(int priority) {
  sched_param param{};
  param.sched_priority = priority;
  return pthread_setschedparam(pthread_self(), SCHED_FIFO, &param);
}

std::vector<std::string> make_realtime(int priority, int cpu) {
  std::vector<std::string> warnings;
  // Locked memory keeps page faults out of the tick; MCL_FUTURE covers later stacks and buffers.
  if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0) {
    warnings.push_back(std::string("mlockall refused (") + std::strerror(errno) +
                       "): page faults may stall ticks; raise RLIMIT_MEMLOCK or run as root");
  }
  if (const int err = request_fifo(priority); err != 0) {
    warnings.push_back(std::string("SCHED_FIFO refused (") + std::strerror(err) +
                       "): the loop runs under SCHED_OTHER; grant CAP_SYS_NICE or an rtprio limit");
  }
  if (cpu >= 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(cpu, &set);
    if (const int err = pthread_setaffinity_np(pthread_self(), sizeof(set), &set); err != 0) {
      warnings.push_back("pinning to CPU " + std::to_string(cpu) + " refused (" + std::strerror(err) + ")");
    }
  }
  return warnings;
}

CpuWakeLatency::CpuWakeLatency(int32_t max_wake_us) {
  fd_ = open("/dev/cpu_dma_latency", O_WRONLY | O_CLOEXEC);
  if (fd_ < 0) {
    warning_ = std::string("/dev/cpu_dma_latency refused (") + std::strerror(errno) +
               "): idle cores may halt between states and start each tick cold; run as root";
    return;
  }
  // The kernel reads a binary 32-bit value (or text), once per open file.
  if (write(fd_, &max_wake_us, sizeof(max_wake_us)) != static_cast<ssize_t>(sizeof(max_wake_us))) {
    warning_ = std::string("/dev/cpu_dma_latency took no value (") + std::strerror(errno) + ")";
    close(fd_);
    fd_ = -1;
  }
}

CpuWakeLatency::~CpuWakeLatency() {
  if (fd_ >= 0) close(fd_);
}

bool wait_readable(int fd, int64_t until_ns) {
  const int64_t left = std::max<int64_t>(0, until_ns - monotonic_ns());
  const timespec timeout{static_cast<time_t>(left / 1'000'000'000), static_cast<long>(left % 1'000'000'000)};
  pollfd p{fd, POLLIN, 0};
  return ppoll(&p, 1, &timeout, nullptr) > 0 && (p.revents & POLLIN) != 0;
}

Doorbell::Doorbell() : fd_(eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC)) {
  if (fd_ < 0) throw std::system_error(errno, std::generic_category(), "eventfd");
}

Doorbell::~Doorbell() { close(fd_); }

void Doorbell::ring() {
  const uint64_t one = 1;
  [[maybe_unused]] const ssize_t written = write(fd_, &one, sizeof(one));  // fails only when 2^64 − 2 rings wait
}

bool Doorbell::wait_until(int64_t until_ns) {
  if (!wait_readable(fd_, until_ns)) return false;
  uint64_t rings = 0;
  return read(fd_, &rings, sizeof(rings)) == static_cast<ssize_t>(sizeof(rings));
}

void Doorbell::clear() {
  uint64_t rings = 0;
  [[maybe_unused]] const ssize_t n = read(fd_, &rings, sizeof(rings));  // EAGAIN: not rung
}

}  // namespace chasles::controller
