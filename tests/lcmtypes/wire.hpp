// What the message tests share: sample values, encoding and decoding through lcm-gen's own
// functions (each checked to use exactly the bytes the message says it needs), the checked
// decoder as the controller runs it, and a count rewritten in the bytes.
#pragma once

#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "lcmtypes/checked.hpp"

namespace chasles::testing {

inline constexpr int kJoints = 7;
inline constexpr size_t kHash = 8;  // every message starts with its type's 64-bit fingerprint

// n values that differ from each other and from 0, with a sign change and awkward magnitudes;
// `scale` tells fields apart.
inline std::vector<double> values(int n, double scale) {
  std::vector<double> v;
  for (int i = 0; i < n; ++i) v.push_back(scale * (i % 2 == 0 ? 1.0 : -1.0) * (0.1 + i) / 3.0);
  return v;
}

template <class Message>
std::vector<uint8_t> encode(const Message& message) {
  std::vector<uint8_t> buffer(static_cast<size_t>(message.getEncodedSize()));
  EXPECT_EQ(message.encode(buffer.data(), 0, static_cast<int>(buffer.size())), static_cast<int>(buffer.size()));
  return buffer;
}

template <class Message>
Message decode(const std::vector<uint8_t>& buffer) {
  Message message;
  EXPECT_EQ(message.decode(buffer.data(), 0, static_cast<int>(buffer.size())), static_cast<int>(buffer.size()));
  return message;
}

// The checked decoder as the controller runs it (an arm of kJoints, finite numbers required): ""
// or why the bytes were refused.
template <class Message>
std::string decode_checked(const std::vector<uint8_t>& bytes, int arm = kJoints,
                           messages::Finite finite = messages::Finite::Required) {
  Message message;
  return messages::decode_checked(bytes.data(), bytes.size(), message, arm, finite);
}

// The bytes with the big-endian int32 at `offset` replaced by `count`.
inline std::vector<uint8_t> with_int32(std::vector<uint8_t> bytes, size_t offset, uint32_t count) {
  for (int i = 0; i < 4; ++i) bytes[offset + size_t(i)] = uint8_t(count >> (24 - 8 * i));
  return bytes;
}

}  // namespace chasles::testing
