// A program run as a child process by a test: stdin and stdout on /dev/null, stderr kept in a
// file the test can read; stopped (SIGTERM) when the object goes away.
#pragma once

#include <sys/types.h>

#include <csignal>
#include <string>
#include <vector>

namespace chasles::testing {

class ChildProcess {
 public:
  /// argv[0] is the program's path.
  explicit ChildProcess(std::vector<std::string> argv);
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  bool running() const;
  /// Sends `signal` and waits; the exit code, 128 + signal if it died of one.
  int stop(int signal = SIGTERM);
  /// Waits for the process to end by itself.
  int wait();
  std::string stderr_text() const;
  pid_t pid() const { return pid_; }

 private:
  static inline int count_ = 0;
  std::string stderr_path_;
  pid_t pid_ = -1;
  int exit_code_ = -1;
};

}  // namespace chasles::testing
