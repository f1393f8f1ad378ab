// The LCM log reader of `chasles log` on arbitrary files: it frames what it can, skips damage
// with a problem naming the byte offset, and every event it hands out lies within the file, in
// file order. The bytes go through a memfd, so nothing touches the disk.
#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <string>

#include "tools/cli/json_io.hpp"
#include "tools/cli/lcm_log.hpp"
#include "fuzz/check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const int fd = memfd_create("fuzz.lcm", 0);
  FUZZ_CHECK(fd >= 0);
  FUZZ_CHECK(write(fd, data, size) == static_cast<ssize_t>(size));
  try {
    chasles::cli::LogReader reader("/proc/self/fd/" + std::to_string(fd));
    FUZZ_CHECK(reader.size() == size);
    chasles::cli::LogEvent event;
    uint64_t end = 0;
    while (reader.next(event)) {
      FUZZ_CHECK(event.offset >= end);
      end = event.offset + 28 + event.channel.size() + event.data.size();
      FUZZ_CHECK(end <= size);
    }
    for (const std::string& problem : reader.problems()) FUZZ_CHECK(problem.rfind("byte ", 0) == 0);
  } catch (const chasles::cli::InputError&) {
  }
  close(fd);
  return 0;
}
