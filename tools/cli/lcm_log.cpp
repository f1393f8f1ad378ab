#include "tools/cli/lcm_log.hpp"

#include <lcm/lcm.h>
#include <sys/stat.h>

#include <array>
#include <cerrno>
#include <cstring>

#include "tools/cli/json_io.hpp"

namespace chasles::cli {
namespace {

constexpr uint32_t kSync = 0xEDA1DA01;
constexpr uint64_t kHeaderBytes = 4 + 8 + 8 + 4 + 4;

uint64_t big_endian(const uint8_t* bytes, int count) {
  uint64_t value = 0;
  for (int i = 0; i < count; ++i) value = (value << 8) | bytes[i];
  return value;
}

std::string hex32(uint32_t value) {
  char text[16];
  std::snprintf(text, sizeof(text), "0x%08X", value);
  return text;
}

}  // namespace

LogReader::LogReader(const std::string& path) : path_(path) {
  file_ = std::fopen(path.c_str(), "rb");
  if (file_ == nullptr) throw InputError(path + ": cannot open the log (" + std::strerror(errno) + ")");
  struct stat info {};
  if (::fstat(::fileno(file_), &info) != 0 || !S_ISREG(info.st_mode)) {
    std::fclose(file_);
    throw InputError(path + ": not a regular file");
  }
  // A log still being written grows; what is read is what was there when it was opened.
  size_ = static_cast<uint64_t>(info.st_size);
}

LogReader::~LogReader() { std::fclose(file_); }

bool LogReader::read_at(uint64_t offset, void* buffer, size_t count) {
  if (offset + count > size_) return false;
  if (::fseeko(file_, static_cast<off_t>(offset), SEEK_SET) != 0) return false;
  return std::fread(buffer, 1, count, file_) == count;
}

std::string LogReader::read_header(uint64_t offset, int64_t& number, int64_t& utime, int32_t& channel_length,
                                   int32_t& data_length) {
  std::array<uint8_t, kHeaderBytes> header{};
  if (!read_at(offset, header.data(), header.size())) {
    return "the last " + std::to_string(size_ - offset) + " bytes are too few for an event header (" +
           std::to_string(kHeaderBytes) + " bytes): the log is cut short";
  }
  const auto sync = static_cast<uint32_t>(big_endian(&header[0], 4));
  number = static_cast<int64_t>(big_endian(&header[4], 8));
  utime = static_cast<int64_t>(big_endian(&header[12], 8));
  channel_length = static_cast<int32_t>(static_cast<uint32_t>(big_endian(&header[20], 4)));
  data_length = static_cast<int32_t>(static_cast<uint32_t>(big_endian(&header[24], 4)));
  if (sync != kSync) return "no event starts here (" + hex32(sync) + " where the sync word " + hex32(kSync) + " should be)";
  const std::string event = "event #" + std::to_string(number);
  if (channel_length < 1 || channel_length > LCM_MAX_CHANNEL_NAME_LENGTH) {
    return event + " announces a channel name of " + std::to_string(channel_length) + " bytes (LCM allows 1 to " +
           std::to_string(LCM_MAX_CHANNEL_NAME_LENGTH) + ")";
  }
  if (data_length < 0) return event + " announces a negative message size, " + std::to_string(data_length) + " bytes";
  const uint64_t needed = kHeaderBytes + uint64_t(channel_length) + uint64_t(data_length);
  if (needed > size_ - offset) {
    return event + " is cut short: it needs " + std::to_string(needed) + " bytes and the file ends " +
           std::to_string(size_ - offset) + " bytes after its start";
  }
  return {};
}

uint64_t LogReader::resync(uint64_t from) {
  std::array<uint8_t, 65536> chunk{};
  for (uint64_t start = from; start + 4 <= size_;) {
    const size_t count = static_cast<size_t>(std::min<uint64_t>(chunk.size(), size_ - start));
    if (!read_at(start, chunk.data(), count)) return size_;
    for (size_t i = 0; i + 4 <= count; ++i) {
      if (big_endian(&chunk[i], 4) != kSync) continue;
      int64_t number = 0, utime = 0;
      int32_t channel_length = 0, data_length = 0;
      if (read_header(start + i, number, utime, channel_length, data_length).empty()) return start + i;
    }
    start += count - 3;  // a sync word may straddle two chunks
    if (count < 4) break;
  }
  return size_;
}

bool LogReader::next(LogEvent& event) {
  while (position_ < size_) {
    int64_t number = 0, utime = 0;
    int32_t channel_length = 0, data_length = 0;
    std::string why = read_header(position_, number, utime, channel_length, data_length);
    if (why.empty()) {
      event.channel.resize(size_t(channel_length));
      event.data.resize(size_t(data_length));
      if (!read_at(position_ + kHeaderBytes, event.channel.data(), event.channel.size()) ||
          !read_at(position_ + kHeaderBytes + uint64_t(channel_length), event.data.data(), event.data.size())) {
        why = "cannot read event #" + std::to_string(number) + " (" + std::strerror(errno) + ")";
      } else {
        for (const char c : event.channel) {
          if (c < 0x20 || c > 0x7e) {
            why = "event #" + std::to_string(number) + " has a channel name with unprintable bytes";
            break;
          }
        }
      }
    }
    if (!why.empty()) {
      const uint64_t next = resync(position_ + 1);
      problems_.push_back("byte " + std::to_string(position_) + ": " + why +
                          (next < size_ ? "; skipped " + std::to_string(next - position_) +
                                              " bytes to the next event, at byte " + std::to_string(next)
                                        : ""));
      position_ = next;
      continue;
    }
    event.number = number;
    event.utime = utime;
    event.offset = position_;
    position_ += kHeaderBytes + uint64_t(channel_length) + uint64_t(data_length);
    return true;
  }
  return false;
}

}  // namespace chasles::cli
