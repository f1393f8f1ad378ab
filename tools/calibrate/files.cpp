#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "core/model/model.hpp"
#include "commands.hpp"

namespace chasles::calibrate_cli {

namespace {

std::string directory_of(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  return slash == 0 ? "/" : path.substr(0, slash);
}

std::string system_error(const std::string& path, const std::string& what) {
  return path + ": " + what + ": " + std::strerror(errno);
}

void write_all(int fd, const std::string& content, const std::string& path) {
  const char* data = content.data();
  size_t left = content.size();
  while (left > 0) {
    const ssize_t written = ::write(fd, data, left);
    if (written < 0) {
      if (errno == EINTR) continue;
      throw InputError(system_error(path, "cannot write"));
    }
    data += written;
    left -= static_cast<size_t>(written);
  }
}

}  // namespace

void write_files_atomically(const std::vector<std::pair<std::string, std::string>>& files) {
  for (size_t a = 0; a < files.size(); ++a) {
    for (size_t b = a + 1; b < files.size(); ++b) {
      if (files[a].first == files[b].first) throw InputError(files[a].first + ": named for two outputs");
    }
  }
  std::vector<std::string> temporaries;
  try {
    for (const auto& [path, content] : files) {
      std::string name = path + ".tmp.XXXXXX";
      const int fd = ::mkstemp(name.data());
      if (fd < 0) throw InputError(system_error(path, "cannot create a temporary file beside it"));
      temporaries.push_back(name);
      try {
        write_all(fd, content, path);
        // mkstemp makes the file 0600; give it what a plain open would (0666 less the umask).
        const mode_t mask = ::umask(0);
        ::umask(mask);
        if (::fchmod(fd, 0666 & ~mask) != 0 || ::fsync(fd) != 0) throw InputError(system_error(path, "cannot write"));
      } catch (...) {
        ::close(fd);
        throw;
      }
      if (::close(fd) != 0) throw InputError(system_error(path, "cannot write"));
    }
    for (size_t k = 0; k < files.size(); ++k) {
      if (std::rename(temporaries[k].c_str(), files[k].first.c_str()) != 0) {
        throw InputError(system_error(files[k].first, "cannot replace"));
      }
      temporaries[k].clear();
    }
  } catch (...) {
    for (const std::string& name : temporaries) {
      if (!name.empty()) std::remove(name.c_str());
    }
    throw;
  }
  // The renames are durable once the directories are.
  for (const auto& file : files) {
    const int fd = ::open(directory_of(file.first).c_str(), O_RDONLY | O_DIRECTORY);
    if (fd >= 0) {
      ::fsync(fd);
      ::close(fd);
    }
  }
}

std::string read_text_file(const std::string& path, const std::string& what) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw InputError(path + ": cannot open the " + what + ": " + std::strerror(errno));
  std::ostringstream text;
  text << file.rdbuf();
  if (file.bad()) throw InputError(path + ": cannot read the " + what);
  return text.str();
}

Json report_header(const RobotModel& nominal, const std::string& urdf) {
  Json header;
  header["tool"] = std::string("chasles_calibrate ") + CHASLES_VERSION;
  header["robot"] = nominal.name();
  header["urdf"] = urdf;
  header["base_link"] = nominal.base_link();
  header["tip_link"] = nominal.tip_link();
  return header;
}

}  // namespace chasles::calibrate_cli
