// What the message tests share: sample values, and encoding and decoding through lcm-gen's own
// functions, each checked to use exactly the bytes the message says it needs.
#pragma once

#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>
#include <vector>

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

}  // namespace chasles::testing
