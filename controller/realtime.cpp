#include "chasles/controller/realtime.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/prctl.h>

#include <cerrno>
#include <cstring>

namespace chasles::controller {

void minimise_timer_slack() { prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL); }

std::vector<std::string> make_realtime(int priority, int cpu) {
  std::vector<std::string> warnings;
  // Locked memory keeps page faults out of the tick; MCL_FUTURE covers later stacks and buffers.
  if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0) {
    warnings.push_back(std::string("mlockall refused (") + std::strerror(errno) +
                       "): page faults may stall ticks; raise RLIMIT_MEMLOCK or run as root");
  }
  sched_param param{};
  param.sched_priority = priority;
  if (const int err = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param); err != 0) {
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

}  // namespace chasles::controller
