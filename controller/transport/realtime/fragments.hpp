// LCM's large messages, put back together. LCM sends a message that does not fit one datagram as
// fragments ('LC03'): each carries the sender's sequence number, the message's size, its own
// offset, number and the count; the first also carries the channel. FragmentAssembler reassembles
// them per sender, as LCM's own receive thread does, and says what it could not: a message whose
// fragments stopped coming, one longer than LCM allows. It allocates, so the Bus runs it on a
// thread of its own, never on the thread that reads the socket for the real-time loop.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace chasles::controller {

/// LCM's limit on a message's payload (lcm.h: LCM_MAX_MESSAGE_SIZE), and on a channel's length.
constexpr size_t kLcmMaxMessageSize = size_t{1} << 28;
constexpr size_t kLcmMaxChannel = 63;
/// The magic that starts a fragment of a large message ('LC03'; a whole one's is 'LC02').
constexpr uint32_t kLcmFragmentMagic = 0x4c433033;

/// LCM's header fields are big-endian.
inline uint32_t big_endian_u32(const uint8_t* p) {
  return uint32_t{p[0]} << 24 | uint32_t{p[1]} << 16 | uint32_t{p[2]} << 8 | uint32_t{p[3]};
}
/// Whether `size` bytes at `text` begin with a channel name LCM sends — at most 63 characters, then
/// its NUL — and then its `length` without the NUL. Both datagram formats carry the channel so.
bool read_lcm_channel(const uint8_t* text, size_t size, size_t& length);

/// One fragment datagram read: its header, and its part of the payload (pointing into the
/// datagram). The channel is set in fragment 0 only.
struct LcmFragment {
  uint32_t seqno = 0;
  uint32_t message_size = 0;  ///< the whole payload, bytes
  uint32_t offset = 0;        ///< where this fragment's bytes go in the payload
  uint16_t number = 0, count = 0;
  const char* channel = nullptr;
  const uint8_t* data = nullptr;
  size_t size = 0;
};
/// Whether `data` is one LCM fragment consistent with itself (number < count, its bytes inside
/// the message, fragment 0 with a NUL-terminated channel of at most 63 characters), then `out`.
bool parse_lcm_fragment(const uint8_t* data, size_t size, LcmFragment& out);

class FragmentAssembler {
 public:
  struct Message {
    std::string channel;
    std::vector<uint8_t> payload;
  };
  /// A message given up: its channel (empty when its first fragment never came), its size as
  /// announced, and why.
  struct Loss {
    std::string channel;
    size_t size = 0;
    std::string why;
  };

  /// `max_size`: the longest payload taken (LCM's own limit by default); `timeout_ns`: how long a
  /// message may wait for its next fragment before it is given up.
  explicit FragmentAssembler(size_t max_size = kLcmMaxMessageSize, int64_t timeout_ns = 500'000'000);

  /// One fragment datagram from `sender` (any key naming the sending socket) received at now_ns:
  /// true when it completes a message, then moved into `out`. Messages given up on the way — one
  /// from the same sender left incomplete by a newer one, one over max_size — go to `losses`. A
  /// datagram that is not a fragment, or repeats one already held, is ignored (false).
  bool add(uint64_t sender, const uint8_t* data, size_t size, int64_t now_ns, Message& out, std::vector<Loss>& losses);
  /// Gives up the messages whose last fragment came more than the timeout before now_ns.
  void expire(int64_t now_ns, std::vector<Loss>& losses);
  /// Messages being put together.
  size_t pending() const { return partial_.size(); }

 private:
  struct Partial {
    uint32_t seqno = 0;
    uint32_t size = 0;
    std::string channel;
    std::vector<uint8_t> payload;
    std::vector<bool> received;
    int missing = 0;
    size_t bytes = 0;
    int64_t last_ns = 0;
  };
  static Loss loss_of(const Partial& p, const char* why);

  size_t max_size_;
  int64_t timeout_ns_;
  std::map<uint64_t, Partial> partial_;           // by sender: LCM interleaves no messages of one sender
  std::map<uint64_t, uint32_t> refused_seqno_;    // by sender: the over-long message already reported
};

}  // namespace chasles::controller
