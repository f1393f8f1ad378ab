#include "core/atomic_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "core/error.hpp"

namespace chasles {
namespace {

namespace fs = std::filesystem;

std::string directory_of(const std::string& path) {
  const std::string dir = fs::path(path).parent_path().string();
  return dir.empty() ? "." : dir;
}

std::string system_error(const std::string& path, const std::string& what) {
  return path + ": " + what + ": " + std::strerror(errno);
}

}  // namespace

// mkstemp: no other writer's name, not even another process of the same program.
void write_file_atomically(const std::string& path, const std::string& content) {
  std::string temporary = path + ".tmp.XXXXXX";
  const int fd = ::mkstemp(temporary.data());
  if (fd < 0) throw Error(system_error(path, "cannot create a temporary file beside it"));
  const auto give_up = [&](const std::string& what) {
    const std::string why = system_error(path, what);
    ::close(fd);
    std::remove(temporary.c_str());
    throw Error(why);
  };
  const char* data = content.data();
  size_t left = content.size();
  while (left > 0) {
    const ssize_t written = ::write(fd, data, left);
    if (written < 0) {
      if (errno == EINTR) continue;
      give_up("cannot write");
    }
    data += written;
    left -= static_cast<size_t>(written);
  }
  // mkstemp makes the file 0600; give it what a plain open would (0666 less the umask).
  const mode_t mask = ::umask(0);
  ::umask(mask);
  if (::fchmod(fd, 0666 & ~mask) != 0 || ::fsync(fd) != 0) give_up("cannot write");
  if (::close(fd) != 0) {
    const std::string why = system_error(path, "cannot write");
    std::remove(temporary.c_str());
    throw Error(why);
  }
  if (std::rename(temporary.c_str(), path.c_str()) != 0) {
    const std::string why = system_error(path, "cannot replace");
    std::remove(temporary.c_str());
    throw Error(why);
  }
  // The rename is durable once the directory is.
  const int dir = ::open(directory_of(path).c_str(), O_RDONLY | O_DIRECTORY);
  if (dir >= 0) {
    ::fsync(dir);
    ::close(dir);
  }
}

}  // namespace chasles
