#include "lcm_start.hpp"

#include <unistd.h>

#include <cstdio>

#include "tools/cli/json_io.hpp"

namespace chasles::cli {

lcm_t* start_lcm(const std::string& url) {
  // While LCM starts, stderr goes to a temporary file; what it said is passed on if it starts.
  std::FILE* captured = std::tmpfile();
  const int saved = captured != nullptr ? ::dup(STDERR_FILENO) : -1;
  if (saved >= 0) {
    std::fflush(stderr);
    ::dup2(::fileno(captured), STDERR_FILENO);
  }
  lcm_t* lcm = lcm_create(url.empty() ? nullptr : url.c_str());
  std::string said;
  if (saved >= 0) {
    std::fflush(stderr);
    ::dup2(saved, STDERR_FILENO);
    ::close(saved);
    std::rewind(captured);
    char buffer[512];
    size_t count = 0;
    while ((count = std::fread(buffer, 1, sizeof(buffer), captured)) > 0) said.append(buffer, count);
  }
  if (captured != nullptr) std::fclose(captured);
  if (lcm != nullptr) {
    std::fputs(said.c_str(), stderr);
    return lcm;
  }
  const size_t start = said.find_first_not_of(" \t\r\n");
  const std::string reason = start == std::string::npos ? "" : said.substr(start, said.find('\n', start) - start);
  const bool multicast = url.empty() || url.rfind("udpm://", 0) == 0;
  throw InputError("cannot start LCM" + (url.empty() ? std::string() : " on " + url) +
                   (reason.empty() ? "" : " (" + reason + ")") +
                   (multicast ? ": is there a multicast route? (inside tools/netns.sh use --lcm-url "
                                "'udpm://239.255.76.67:7667?ttl=0')"
                              : ""));
}

}  // namespace chasles::cli
