#include "controller/transport/realtime/fragments.hpp"

#include <algorithm>
#include <cstring>

namespace chasles::controller {

namespace {

// LCM's fragment header (lcm/udpm_util.h), big-endian: magic 'LC03', sequence number, message
// size, fragment offset (u32 each), fragment number, fragments in the message (u16 each).
constexpr size_t kLongHeader = 20;

uint16_t big_endian_u16(const uint8_t* p) { return static_cast<uint16_t>(p[0] << 8 | p[1]); }

}  // namespace

bool read_lcm_channel(const uint8_t* text, size_t size, size_t& length) {
  const size_t room = std::min(size, kLcmMaxChannel + 1);
  length = strnlen(reinterpret_cast<const char*>(text), room);
  return length < room;  // else no NUL where the channel must end
}

bool parse_lcm_fragment(const uint8_t* data, size_t size, LcmFragment& out) {
  if (size < kLongHeader || big_endian_u32(data) != kLcmFragmentMagic) return false;
  LcmFragment f;
  f.seqno = big_endian_u32(data + 4);
  f.message_size = big_endian_u32(data + 8);
  f.offset = big_endian_u32(data + 12);
  f.number = big_endian_u16(data + 16);
  f.count = big_endian_u16(data + 18);
  f.data = data + kLongHeader;
  f.size = size - kLongHeader;
  if (f.count == 0 || f.number >= f.count) return false;
  if (f.number == 0) {
    size_t length = 0;
    if (!read_lcm_channel(f.data, f.size, length) || length == 0) return false;
    f.channel = reinterpret_cast<const char*>(f.data);
    f.data += length + 1;
    f.size -= length + 1;
  }
  // LCM cuts a message into fragments that each carry part of it: one with nothing is not LCM's.
  if (f.size == 0 || uint64_t{f.offset} + f.size > f.message_size) return false;
  out = f;
  return true;
}

FragmentAssembler::FragmentAssembler(size_t max_size, int64_t timeout_ns) : max_size_(max_size), timeout_ns_(timeout_ns) {}

FragmentAssembler::Loss FragmentAssembler::loss_of(const Partial& p, const char* why) {
  Loss loss{p.channel, p.size, why};
  if (loss.why.empty()) {
    int first = 0;
    while (first < static_cast<int>(p.received.size()) && p.received[static_cast<size_t>(first)]) ++first;
    loss.why = "fragment " + std::to_string(first + 1) + " of " + std::to_string(p.received.size()) +
               " never came (" + std::to_string(p.missing) + " missing)";
  }
  return loss;
}

bool FragmentAssembler::add(uint64_t sender, const uint8_t* data, size_t size, int64_t now_ns, Message& out,
                            std::vector<Loss>& losses) {
  LcmFragment f;
  if (!parse_lcm_fragment(data, size, f)) return false;
  if (f.message_size > max_size_) {
    const auto refused = refused_seqno_.find(sender);
    if (refused == refused_seqno_.end() || refused->second != f.seqno) {
      refused_seqno_[sender] = f.seqno;
      losses.push_back({f.channel != nullptr ? f.channel : "", f.message_size,
                        "longer than the " + std::to_string(max_size_) + " bytes taken"});
    }
    return false;
  }
  auto it = partial_.find(sender);
  if (it != partial_.end() &&
      (it->second.seqno != f.seqno || it->second.size != f.message_size || it->second.received.size() != f.count)) {
    // LCM sends one message at a time: a sender that moved on will not finish the older one.
    losses.push_back(loss_of(it->second, ""));
    partial_.erase(it);
    it = partial_.end();
  }
  if (it == partial_.end()) {
    Partial p;
    p.seqno = f.seqno;
    p.size = f.message_size;
    p.received.assign(f.count, false);
    p.missing = f.count;
    it = partial_.emplace(sender, std::move(p)).first;
  }
  Partial& p = it->second;
  if (p.received[f.number]) return false;  // a repeat
  p.received[f.number] = true;
  --p.missing;
  p.last_ns = now_ns;
  if (f.channel != nullptr) p.channel = f.channel;
  // Grown as the fragments come, not to the size announced: a header that lies costs only what
  // was sent.
  if (p.payload.size() < f.offset + f.size) p.payload.resize(f.offset + f.size);
  std::memcpy(p.payload.data() + f.offset, f.data, f.size);
  p.bytes += f.size;
  if (p.missing > 0) return false;
  const bool whole = p.bytes == p.size && p.payload.size() == p.size;
  if (whole) {
    out.channel = std::move(p.channel);
    out.payload = std::move(p.payload);
  } else {
    losses.push_back(loss_of(p, "its fragments do not add up to its size"));
  }
  partial_.erase(it);
  return whole;
}

void FragmentAssembler::expire(int64_t now_ns, std::vector<Loss>& losses) {
  for (auto it = partial_.begin(); it != partial_.end();) {
    if (now_ns - it->second.last_ns > timeout_ns_) {
      losses.push_back(loss_of(it->second, ""));
      it = partial_.erase(it);
    } else {
      ++it;
    }
  }
}

}  // namespace chasles::controller
