#include "support/process.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

namespace chasles::testing {
namespace {

int exit_code(int status) { return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status); }

}  // namespace

std::string read_file(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  std::ostringstream text;
  text << file.rdbuf();
  return text.str();
}

std::vector<std::string> concat(std::vector<std::string> a, const std::vector<std::string>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

std::string temp_path(const std::string& name) {
  return ::testing::TempDir() + "chasles_" + std::to_string(::getpid()) + "_" + name;
}

TempFile::TempFile(const std::string& name, const std::string& content) : path(temp_path(name)) {
  std::ofstream(path, std::ios::binary) << content;
}

TempFile::~TempFile() { std::remove(path.c_str()); }

RunResult run_to_completion(const std::vector<std::string>& argv_strings, const std::string& stdin_path,
                            const std::vector<std::string>& env) {
  static int runs = 0;
  const std::string base = ::testing::TempDir() + "run_" + std::to_string(::getpid()) + "_" + std::to_string(++runs);
  const std::string out_path = base + "_stdout", err_path = base + "_stderr";
  std::vector<std::string> args = argv_strings, env_strings = env;
  std::vector<char*> argv;
  for (auto& s : args) argv.push_back(s.data());
  argv.push_back(nullptr);
  std::fflush(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int in = ::open(stdin_path.c_str(), O_RDONLY);
    const int out = ::open(out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    const int err = ::open(err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    if (in < 0 || out < 0 || err < 0) ::_exit(126);
    ::dup2(in, 0);
    ::dup2(out, 1);
    ::dup2(err, 2);
    for (auto& entry : env_strings) {
      if (entry.find('=') == std::string::npos) {
        ::unsetenv(entry.c_str());
      } else {
        ::putenv(entry.data());
      }
    }
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  RunResult result;
  if (pid < 0) return result;
  int status = 0;
  ::waitpid(pid, &status, 0);
  result.exit_code = exit_code(status);
  result.out = read_file(out_path);
  result.err = read_file(err_path);
  std::remove(out_path.c_str());
  std::remove(err_path.c_str());
  return result;
}

ChildProcess::ChildProcess(std::vector<std::string> argv_strings)
    : stderr_path_(::testing::TempDir() + "child_" + std::to_string(::getpid()) + "_" + std::to_string(++count_) +
                   "_stderr"),
      stdout_path_(stderr_path_.substr(0, stderr_path_.size() - 6) + "stdout") {
  std::vector<char*> argv;
  for (auto& s : argv_strings) argv.push_back(s.data());
  argv.push_back(nullptr);
  std::fflush(nullptr);
  pid_ = ::fork();
  if (pid_ == 0) {
    const int null = ::open("/dev/null", O_RDWR);
    const int out = ::open(stdout_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    const int err = ::open(stderr_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    if (null < 0 || out < 0 || err < 0) ::_exit(126);
    ::dup2(null, 0);
    ::dup2(out, 1);
    ::dup2(err, 2);
    // A ChildProcess is a loop under test (plant, controller, logger). Nice −10 gives it the edge
    // over whatever CPU hogs share the test machine, as SCHED_FIFO does in a deployment, without
    // real-time scheduling's mlockall (which sanitizer builds cannot afford). Refused without
    // CAP_SYS_NICE, and then the test runs at the ordinary priority.
    ::setpriority(PRIO_PROCESS, 0, -10);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
}

ChildProcess::~ChildProcess() {
  if (pid_ > 0 && exit_code_ < 0) stop();
  std::remove(stderr_path_.c_str());
  std::remove(stdout_path_.c_str());
}

bool ChildProcess::running() {
  if (pid_ <= 0 || exit_code_ >= 0) return false;
  // A child that has ended is reaped here: keep its status, so that stop() and wait() report it
  // rather than signal or wait for a pid that is no longer ours.
  int status = 0;
  if (::waitpid(pid_, &status, WNOHANG) == 0) return true;
  exit_code_ = exit_code(status);
  return false;
}

int ChildProcess::stop(int signal) {
  if (exit_code_ >= 0) return exit_code_;
  ::kill(pid_, signal);
  return wait();
}

int ChildProcess::wait() {
  if (exit_code_ >= 0) return exit_code_;
  int status = 0;
  ::waitpid(pid_, &status, 0);
  exit_code_ = exit_code(status);
  return exit_code_;
}

std::string ChildProcess::stderr_text() const { return read_file(stderr_path_); }
std::string ChildProcess::stdout_text() const { return read_file(stdout_path_); }

bool ChildProcess::catches(int signal, double seconds) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  const std::string status_path = "/proc/" + std::to_string(pid_) + "/status";
  do {
    std::ifstream status(status_path);
    for (std::string line; std::getline(status, line);) {
      if (line.rfind("SigCgt:", 0) != 0) continue;
      const unsigned long long caught = std::stoull(line.substr(7), nullptr, 16);
      if ((caught >> (signal - 1)) & 1ULL) return true;
    }
    if (!running()) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  } while (std::chrono::steady_clock::now() < deadline);
  return false;
}

}  // namespace chasles::testing
