// A program run as a child process by a test: stdin and stdout on /dev/null, stderr kept in a
// file the test can read; stopped (SIGTERM) when the object goes away. And what such runs are
// given: argument lists put together, files in the test's temporary directory, the LCM URL.
#pragma once

#include <sys/types.h>

#include <csignal>
#include <string>
#include <vector>

namespace chasles::testing {

/// What a program run to completion printed and how it ended.
struct RunResult {
  int exit_code = -1;  ///< the exit status, or 128 + signal if it was killed
  std::string out, err;
};

/// Runs argv (argv[0] the program's path) to completion: stdin from `stdin_path`, stdout and
/// stderr through files (no pipe to fill up). `env` entries "NAME=value" are set in the child's
/// environment, a bare "NAME" is removed from it.
RunResult run_to_completion(const std::vector<std::string>& argv, const std::string& stdin_path = "/dev/null",
                            const std::vector<std::string>& env = {});

/// The LCM URL the tests' processes talk on: loopback multicast, TTL 0 (the URL tools/netns.sh
/// documents).
inline constexpr char kLcmUrl[] = "udpm://239.255.76.67:7667?ttl=0";

/// `a` followed by `b`: a command line put together from its parts.
std::vector<std::string> concat(std::vector<std::string> a, const std::vector<std::string>& b);

/// A path in the test's temporary directory that no other test process uses:
/// TempDir()/chasles_<pid>_<name> (the file is neither made nor removed). `name` carries any
/// extension the file needs.
std::string temp_path(const std::string& name);

/// A file's whole content ("" if it cannot be read).
std::string read_file(const std::string& path);

/// A file in the test's temporary directory with the given content, removed with the object.
struct TempFile {
  TempFile(const std::string& name, const std::string& content);
  ~TempFile();
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  const std::string path;
};

class ChildProcess {
 public:
  /// argv[0] is the program's path.
  explicit ChildProcess(std::vector<std::string> argv);
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  /// Whether the process is still running; reaps it (and keeps its exit code) if not.
  bool running();
  /// Sends `signal` and waits; the exit code, 128 + signal if it died of one.
  int stop(int signal = SIGTERM);
  /// Waits for the process to end by itself.
  int wait();
  std::string stderr_text() const;
  std::string stdout_text() const;
  /// Waits up to `seconds` for the process to have a handler for `signal` (SigCgt in
  /// /proc/PID/status): the readiness of a program that installs its handlers once it is set up.
  bool catches(int signal, double seconds);
  pid_t pid() const { return pid_; }

 private:
  static inline int count_ = 0;
  std::string stderr_path_, stdout_path_;
  pid_t pid_ = -1;
  int exit_code_ = -1;
};

}  // namespace chasles::testing
