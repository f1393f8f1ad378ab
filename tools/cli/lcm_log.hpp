// Reading LCM log files (what lcm-logger writes), with every length checked against the file.
//
// The format is a sequence of events, each a 28-byte big-endian header — sync word 0xEDA1DA01,
// event number (int64), timestamp (int64, µs since the epoch, the logger's clock), channel length
// (int32), data length (int32) — then the channel name and the message bytes. A log can be cut
// short (the logger was killed, the disk filled, a copy was interrupted) or damaged in the middle;
// the reader hands out every event it can frame and says, for each stretch it could not, where in
// the file it was and why, then looks for the next sync word rather than give up on the rest.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace chasles::cli {

struct LogEvent {
  int64_t number = 0;       ///< the logger's event counter
  int64_t utime = 0;        ///< when the logger received it, µs since the epoch
  std::string channel;
  std::vector<uint8_t> data;
  uint64_t offset = 0;      ///< byte offset of the event's sync word in the file
};

class LogReader {
 public:
  /// Opens `path`; throws InputError if it cannot be read.
  explicit LogReader(const std::string& path);
  ~LogReader();
  LogReader(const LogReader&) = delete;
  LogReader& operator=(const LogReader&) = delete;

  /// The next well-framed event, or false at the end of the file. Damage met on the way is
  /// skipped and described in problems().
  bool next(LogEvent& event);

  /// What could not be read, in file order, each naming its byte offset ("byte 1234: ...").
  const std::vector<std::string>& problems() const { return problems_; }

  const std::string& path() const { return path_; }
  uint64_t size() const { return size_; }

 private:
  /// Reads the 28-byte header at `offset`; an empty string if it frames an event that fits in the
  /// file, else why not.
  std::string read_header(uint64_t offset, int64_t& number, int64_t& utime, int32_t& channel_length,
                          int32_t& data_length);
  /// The offset of the next sync word after `from` that starts a plausible event, or size_.
  uint64_t resync(uint64_t from);
  bool read_at(uint64_t offset, void* buffer, size_t count);

  std::string path_;
  std::FILE* file_ = nullptr;
  uint64_t size_ = 0;
  uint64_t position_ = 0;
  std::vector<std::string> problems_;
};

}  // namespace chasles::cli
