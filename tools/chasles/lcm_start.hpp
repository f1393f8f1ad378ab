// Starting LCM for a subcommand, with a failure reported as one line.
#pragma once

#include <lcm/lcm.h>

#include <cstdint>
#include <string>
#include <vector>

#include "tools/cli/json_io.hpp"

namespace chasles::cli {

/// lcm_create(url) ("" for $LCM_DEFAULT_URL, else LCM's default). LCM explains a failure to start
/// over a dozen lines of stderr; they are kept back and the first becomes part of the InputError
/// thrown, with a hint about multicast routes for udpm URLs. The caller lcm_destroy()s the result.
lcm_t* start_lcm(const std::string& url);

/// Encodes `message` (an lcm-gen type) and publishes it on `channel`; throws InputError if LCM
/// refuses it.
template <typename Message>
void publish_message(lcm_t* lcm, const std::string& channel, const Message& message) {
  std::vector<uint8_t> bytes(size_t(message.getEncodedSize()));
  message.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  if (lcm_publish(lcm, channel.c_str(), bytes.data(), static_cast<unsigned int>(bytes.size())) != 0) {
    throw InputError("cannot publish on " + channel);
  }
}

}  // namespace chasles::cli
