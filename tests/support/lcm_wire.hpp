// LCM's UDP multicast wire, written by hand where a test needs what LCM's own sender never does:
// a large message with a fragment left out, or bytes that are not LCM's at all.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace chasles::testing {

/// The datagrams LCM's udpm.c sends for `payload` on `channel` as a fragmented message ('LC03',
/// lcm/udpm_util.h): the header (magic, sequence number, message size, fragment offset, number,
/// count; big-endian), then in fragment 0 the channel with its NUL, then at most `room` bytes after
/// the header in all (LCM's LCM_FRAGMENT_MAX_PAYLOAD, 65,423).
std::vector<std::vector<uint8_t>> lcm_fragments(const std::string& channel, const std::vector<uint8_t>& payload,
                                                uint32_t seqno, size_t room = 65423);

/// Sends each datagram to the multicast group and port from a socket of its own (a sender of its
/// own, as another process would be), loopback only (TTL 0). Throws if it cannot.
void send_datagrams(const char* group, int port, const std::vector<std::vector<uint8_t>>& datagrams);

}  // namespace chasles::testing
