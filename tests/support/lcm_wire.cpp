#include "support/lcm_wire.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace chasles::testing {

namespace {
void put_big_endian(std::vector<uint8_t>& out, uint64_t value, int bytes) {
  for (int k = bytes - 1; k >= 0; --k) out.push_back(static_cast<uint8_t>(value >> (8 * k)));
}
}  // namespace

std::vector<std::vector<uint8_t>> lcm_fragments(const std::string& channel, const std::vector<uint8_t>& payload,
                                                uint32_t seqno, size_t room) {
  const size_t count = (payload.size() + channel.size() + 1 + room - 1) / room;
  std::vector<std::vector<uint8_t>> out;
  size_t offset = 0;
  for (size_t k = 0; k < count; ++k) {
    std::vector<uint8_t> d;
    put_big_endian(d, 0x4c433033, 4);  // 'LC03'
    put_big_endian(d, seqno, 4);
    put_big_endian(d, payload.size(), 4);
    put_big_endian(d, offset, 4);
    put_big_endian(d, k, 2);
    put_big_endian(d, count, 2);
    size_t n = room;
    if (k == 0) {
      d.insert(d.end(), channel.c_str(), channel.c_str() + channel.size() + 1);
      n -= channel.size() + 1;
    }
    n = std::min(n, payload.size() - offset);
    d.insert(d.end(), payload.begin() + static_cast<long>(offset), payload.begin() + static_cast<long>(offset + n));
    offset += n;
    out.push_back(std::move(d));
  }
  return out;
}

void send_datagrams(const char* group, int port, const std::vector<std::vector<uint8_t>>& datagrams) {
  const int fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw std::runtime_error(std::string("socket: ") + std::strerror(errno));
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<uint16_t>(port));
  inet_pton(AF_INET, group, &to.sin_addr);
  const unsigned char ttl = 0;
  setsockopt(fd, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof(ttl));
  for (const auto& d : datagrams) {
    if (sendto(fd, d.data(), d.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof(to)) !=
        static_cast<ssize_t>(d.size())) {
      const int err = errno;
      close(fd);
      throw std::runtime_error(std::string("sendto: ") + std::strerror(err));
    }
  }
  close(fd);
}

}  // namespace chasles::testing
