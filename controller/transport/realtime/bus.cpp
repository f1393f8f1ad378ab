#include "controller/transport/realtime/bus.hpp"

#include <arpa/inet.h>
#include <lcm/lcm.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <thread>
#include <vector>

#include "controller/transport/realtime/clock.hpp"
#include "controller/transport/realtime/fragments.hpp"
#include "controller/transport/realtime/mailbox.hpp"
#include "controller/transport/realtime/realtime.hpp"
#include "core/error.hpp"

namespace chasles::controller {

namespace {

// The URL LCM will use: `url`, else $LCM_DEFAULT_URL, else its default.
std::string effective_url(const std::string& url) {
  const char* env = std::getenv("LCM_DEFAULT_URL");
  return !url.empty() ? url : env != nullptr && *env != '\0' ? env : "udpm://";
}

// LCM's defaults for udpm:// (lcm/udpm.c).
constexpr const char* kDefaultGroup = "239.255.76.67";
constexpr int kDefaultPort = 7667;
// LCM's small-message header: magic 'LC02', then a sequence number, both big-endian; then the
// channel, NUL-terminated, and the payload. A fragment of a larger message starts with 'LC03'.
constexpr uint32_t kShortMagic = 0x4c433032;
constexpr size_t kShortHeader = 8;
constexpr size_t kMaxDatagram = 65536;         // more than UDP's 65,507-byte payload
constexpr int kReceiveBuffer = 2 * 1024 * 1024;  // bytes asked for; the kernel caps it at rmem_max
// Fragments on their way to the assembler (64 kB each): a 1000-waypoint trajectory of a 7-joint
// arm is 3, so 64 hold several such messages arriving at once.
constexpr int kFragmentSlots = 64;
// Reassembled messages waiting for the reading thread, which takes them at its next turn.
constexpr int kMessageSlots = 8;
// How often the assembler looks for messages whose fragments stopped coming.
constexpr int64_t kExpiryCheckNs = 100'000'000;

}  // namespace

bool parse_lcm_datagram(const uint8_t* data, size_t size, LcmDatagram& out) {
  if (size < kShortHeader + 1 || big_endian_u32(data) != kShortMagic) return false;
  size_t length = 0;
  if (!read_lcm_channel(data + kShortHeader, size - kShortHeader, length)) return false;
  out.channel = reinterpret_cast<const char*>(data + kShortHeader);
  out.payload = data + kShortHeader + length + 1;
  out.payload_size = size - kShortHeader - length - 1;
  return true;
}

// The multicast socket of a Bus that receives directly, its exact-name subscriptions, and the
// assembler of large messages. The reading thread (the one that calls handle) hands each fragment
// to the assembler's thread through a ring of preallocated datagram slots and takes whole messages
// back through a second ring: reassembly allocates, the reading thread never does.
struct Bus::Direct {
  struct Entry {
    std::string channel;
    Subscription::Slot* slot;
  };
  struct Datagram {  // a fragment on its way to the assembler
    uint64_t sender = 0;
    int64_t stamp_us = -1;
    size_t size = 0;
    std::vector<uint8_t> bytes = std::vector<uint8_t>(kMaxDatagram);
  };
  struct Reassembled {  // a whole message on its way back
    FragmentAssembler::Message message;
    int64_t stamp_us = -1;
  };
  using Note = std::array<char, 192>;

  int fd = -1;
  int readable = -1;  // epoll over the socket and the assembler's doorbell: Bus::fileno()
  std::vector<Entry> entries;  // changed only while nothing is handled (construction, teardown)
  std::vector<uint8_t> buffer = std::vector<uint8_t>(kMaxDatagram);
  std::atomic<int64_t> dropped{0};
  // Fragments: the reading thread takes a free slot, fills it, queues it; the assembler returns it.
  std::vector<Datagram> datagrams = std::vector<Datagram>(kFragmentSlots);
  SpscRing<int> fragments{kFragmentSlots, -1}, free_datagrams{kFragmentSlots, -1};
  std::atomic<int64_t> fragments_refused{0};  // no free slot: the assembler fell behind
  // Whole messages: the assembler fills a slot and queues it; the reading thread hands it back.
  std::vector<Reassembled> reassembled = std::vector<Reassembled>(kMessageSlots);
  SpscRing<int> ready{kMessageSlots, -1}, spent{kMessageSlots, -1};
  std::atomic<bool> ready_rung{false};
  Doorbell to_assembler, to_reader;
  // Messages lost whole, and the newest loss described (the assembler writes, the reporter reads).
  std::atomic<int64_t> lost{0};
  Mailbox<Note> loss{Note{}};
  Note last_loss{};
  std::atomic<bool> stopping{false};
  std::thread assembling;

  explicit Direct(const std::string& url) {
    // udpm://GROUP:PORT?options; LCM's defaults fill in what is left out.
    std::string rest = url.substr(std::strlen("udpm://"));
    rest = rest.substr(0, rest.find('?'));
    std::string group = kDefaultGroup;
    int port = kDefaultPort;
    if (!rest.empty()) {
      const size_t colon = rest.find(':');
      group = rest.substr(0, colon);
      if (colon != std::string::npos) {
        char* end = nullptr;
        const long p = std::strtol(rest.c_str() + colon + 1, &end, 10);
        if (*end != '\0' || p <= 0 || p > 65535) throw Error("LCM URL " + url + ": the port is not a number in 1..65535");
        port = static_cast<int>(p);
      }
    }
    in_addr address{};
    if (inet_pton(AF_INET, group.c_str(), &address) != 1 || !IN_MULTICAST(ntohl(address.s_addr))) {
      throw Error("LCM URL " + url + ": '" + group + "' is not an IPv4 multicast group");
    }
    fd = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0) throw Error(std::string("cannot open a UDP socket: ") + std::strerror(errno));
    const int one = 1, zero = 0;
    sockaddr_in bound{};
    bound.sin_family = AF_INET;
    bound.sin_addr.s_addr = htonl(INADDR_ANY);
    bound.sin_port = htons(static_cast<uint16_t>(port));
    ip_mreq membership{};
    membership.imr_multiaddr = address;
    membership.imr_interface.s_addr = htonl(INADDR_ANY);
    const char* failed = nullptr;
    // As LCM's own socket: the port shared with every LCM process on the host (SO_REUSEADDR).
    if (setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one)) != 0) failed = "SO_REUSEADDR";
    else if (bind(fd, reinterpret_cast<const sockaddr*>(&bound), sizeof(bound)) != 0) failed = "bind";
    else if (setsockopt(fd, IPPROTO_IP, IP_MULTICAST_ALL, &zero, sizeof(zero)) != 0) failed = "IP_MULTICAST_ALL";
    else if (setsockopt(fd, IPPROTO_IP, IP_ADD_MEMBERSHIP, &membership, sizeof(membership)) != 0) failed = "join";
    else if (setsockopt(fd, SOL_SOCKET, SO_TIMESTAMP, &one, sizeof(one)) != 0) failed = "SO_TIMESTAMP";
    if (failed != nullptr) {
      const int err = errno;
      close(fd);
      throw Error("cannot receive " + url + " directly (" + failed + ": " + std::strerror(err) +
                  "; no multicast route? inside a network namespace run tools/netns.sh)");
    }
    setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &kReceiveBuffer, sizeof(kReceiveBuffer));  // best effort
    readable = epoll_create1(EPOLL_CLOEXEC);
    epoll_event on_socket{EPOLLIN, {}}, on_bell{EPOLLIN, {}};
    on_socket.data.fd = fd;
    on_bell.data.fd = to_reader.fileno();
    if (readable < 0 || epoll_ctl(readable, EPOLL_CTL_ADD, fd, &on_socket) != 0 ||
        epoll_ctl(readable, EPOLL_CTL_ADD, to_reader.fileno(), &on_bell) != 0) {
      const int err = errno;
      if (readable >= 0) close(readable);
      close(fd);
      throw Error(std::string("cannot wait on the bus's socket (epoll: ") + std::strerror(err) + ")");
    }
    for (int i = 0; i < kFragmentSlots; ++i) free_datagrams.push(i);
    assembling = std::thread([this] { assemble(); });
  }
  ~Direct() {
    stopping = true;
    to_assembler.ring();
    assembling.join();
    close(readable);
    close(fd);
  }
  Direct(const Direct&) = delete;
  Direct& operator=(const Direct&) = delete;

  // The assembler's thread: fragments into messages, messages handed to the reading thread,
  // losses counted and described.
  void assemble() {
    FragmentAssembler assembler;
    std::vector<int> free_messages;
    for (int i = 0; i < kMessageSlots; ++i) free_messages.push_back(i);
    std::vector<FragmentAssembler::Loss> losses;
    FragmentAssembler::Message message;
    int64_t refused_seen = 0;
    while (!stopping.load(std::memory_order_relaxed)) {
      // Idle, it sleeps until rung (a fragment, or the Bus ending): a fleet's processes cost nothing.
      to_assembler.wait_until(assembler.pending() > 0 ? monotonic_ns() + kExpiryCheckNs : INT64_MAX);
      for (int i = 0; spent.pop(i);) free_messages.push_back(i);
      for (int i = 0; fragments.pop(i);) {
        Datagram& d = datagrams[static_cast<size_t>(i)];
        if (assembler.add(d.sender, d.bytes.data(), d.size, monotonic_ns(), message, losses)) {
          if (free_messages.empty()) {
            losses.push_back({message.channel, message.payload.size(),
                              "whole, but " + std::to_string(kMessageSlots) +
                                  " reassembled messages already waited to be handled (the receiving thread fell behind)"});
          } else {
            const int slot = free_messages.back();
            free_messages.pop_back();
            reassembled[static_cast<size_t>(slot)] = {std::move(message), d.stamp_us};
            ready.push(slot);
            ready_rung.store(true, std::memory_order_release);
            to_reader.ring();
          }
        }
        free_datagrams.push(i);
      }
      assembler.expire(monotonic_ns(), losses);
      if (const int64_t refused = fragments_refused.load(std::memory_order_relaxed); refused != refused_seen) {
        for (auto& l : losses) l.why += "; " + std::to_string(refused - refused_seen) + " fragment(s) found no room on the way to the assembler";
        refused_seen = refused;
      }
      for (const auto& l : losses) {
        Note& note = loss.back();
        std::snprintf(note.data(), note.size(), "a %zu-byte message on %s: %s", l.size,
                      l.channel.empty() ? "a channel unknown (its first fragment never came)" : l.channel.c_str(),
                      l.why.c_str());
        loss.publish();
        lost.fetch_add(1, std::memory_order_release);
      }
      losses.clear();
    }
  }

  // Hands the message to the subscribers of its channel; whether any was.
  bool deliver(Bus& bus, const char* channel, const uint8_t* payload, size_t size, int64_t stamp_us) {
    bool heard = false;
    for (const Entry& entry : entries) {
      if (std::strcmp(entry.channel.c_str(), channel) != 0) continue;
      bus.arrival_utime_ = stamp_us;
      entry.slot->handler(payload, size);
      bus.arrival_utime_ = -1;
      heard = true;
    }
    if (!heard) dropped.fetch_add(1, std::memory_order_relaxed);
    return heard;
  }

  // Reads one datagram and hands it on: a small message to its subscribers, a fragment to the
  // assembler. 1 if one was read (delivered, handed on or dropped), 0 if none waits, −1 on a
  // socket error. Allocates nothing.
  int receive_one(Bus& bus) {
    iovec io{buffer.data(), buffer.size()};
    alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timeval))];
    sockaddr_in from{};
    msghdr message{};
    message.msg_name = &from;
    message.msg_namelen = sizeof(from);
    message.msg_iov = &io;
    message.msg_iovlen = 1;
    message.msg_control = control;
    message.msg_controllen = sizeof(control);
    ssize_t n = 0;
    do {
      n = recvmsg(fd, &message, MSG_DONTWAIT);
    } while (n < 0 && errno == EINTR);
    if (n < 0) return errno == EAGAIN || errno == EWOULDBLOCK ? 0 : -1;
    const size_t size = static_cast<size_t>(n);
    int64_t stamp_us = -1;
    for (cmsghdr* c = CMSG_FIRSTHDR(&message); c != nullptr; c = CMSG_NXTHDR(&message, c)) {
      if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMP) {
        timeval tv{};
        std::memcpy(&tv, CMSG_DATA(c), sizeof(tv));
        stamp_us = int64_t{tv.tv_sec} * 1'000'000 + tv.tv_usec;
      }
    }
    if ((message.msg_flags & MSG_TRUNC) != 0) {
      dropped.fetch_add(1, std::memory_order_relaxed);
      return 1;
    }
    LcmDatagram datagram;
    if (parse_lcm_datagram(buffer.data(), size, datagram)) {
      deliver(bus, datagram.channel, datagram.payload, datagram.payload_size, stamp_us);
      return 1;
    }
    if (size < 4 || big_endian_u32(buffer.data()) != kLcmFragmentMagic) {
      dropped.fetch_add(1, std::memory_order_relaxed);  // not LCM's
      return 1;
    }
    int slot = -1;
    if (!free_datagrams.pop(slot)) {
      fragments_refused.fetch_add(1, std::memory_order_relaxed);  // its message is reported lost
      return 1;
    }
    Datagram& d = datagrams[static_cast<size_t>(slot)];
    d.sender = uint64_t{ntohl(from.sin_addr.s_addr)} << 16 | ntohs(from.sin_port);
    d.stamp_us = stamp_us;
    d.size = size;
    std::memcpy(d.bytes.data(), buffer.data(), size);
    fragments.push(slot);
    to_assembler.ring();
    return 1;
  }

  // Hands every reassembled message waiting to its subscribers; how many. One atomic load when
  // none waits.
  int deliver_reassembled(Bus& bus) {
    if (!ready_rung.exchange(false, std::memory_order_acquire)) return 0;
    to_reader.clear();
    int count = 0;
    for (int i = 0; ready.pop(i); ++count) {
      const Reassembled& r = reassembled[static_cast<size_t>(i)];
      deliver(bus, r.message.channel.c_str(), r.message.payload.data(), r.message.payload.size(), r.stamp_us);
      spent.push(i);
    }
    if (count > 0) to_assembler.ring();  // its slots are free again
    return count;
  }
};

void Bus::Subscription::end() {
  if (subscription_ != nullptr) lcm_unsubscribe(lcm_, subscription_);
  if (direct_ != nullptr) {
    auto& entries = direct_->entries;
    for (auto it = entries.begin(); it != entries.end(); ++it) {
      if (it->slot == slot_.get()) {
        entries.erase(it);
        break;
      }
    }
  }
  subscription_ = nullptr;
  direct_ = nullptr;
}

Bus::Subscription::~Subscription() { end(); }

Bus::Subscription::Subscription(Subscription&& other) noexcept
    : lcm_(other.lcm_), subscription_(other.subscription_), direct_(other.direct_), slot_(std::move(other.slot_)) {
  other.subscription_ = nullptr;
  other.direct_ = nullptr;
}

Bus::Subscription& Bus::Subscription::operator=(Subscription&& other) noexcept {
  if (this != &other) {
    end();
    lcm_ = other.lcm_;
    subscription_ = other.subscription_;
    direct_ = other.direct_;
    slot_ = std::move(other.slot_);
    other.subscription_ = nullptr;
    other.direct_ = nullptr;
  }
  return *this;
}

Bus::Bus(const std::string& url, Receive receive)
    : lcm_(lcm_create(url.empty() ? nullptr : url.c_str())),
      kernel_stamps_(effective_url(url).rfind("udpm://", 0) == 0) {
  if (lcm_ == nullptr) {
    throw Error("LCM could not start on " + (url.empty() ? std::string("its default URL") : url) +
                " (no multicast route? inside a network namespace run tools/netns.sh)");
  }
  if (receive == Receive::kDirect && kernel_stamps_) {
    try {
      direct_ = std::make_unique<Direct>(effective_url(url));
    } catch (...) {
      lcm_destroy(lcm_);
      throw;
    }
  }
}

Bus::~Bus() {
  direct_.reset();
  lcm_destroy(lcm_);
}

int64_t Bus::dropped() const { return direct_ ? direct_->dropped.load(std::memory_order_relaxed) : 0; }

int64_t Bus::lost() const { return direct_ ? direct_->lost.load(std::memory_order_acquire) : 0; }

const char* Bus::last_loss() {
  if (!direct_) return "";
  direct_->loss.read(direct_->last_loss);
  return direct_->last_loss.data();
}

bool Bus::publish(const std::string& channel, const void* data, size_t size) {
  return lcm_publish(lcm_, channel.c_str(), data, static_cast<unsigned>(size)) == 0;
}

Bus::Subscription Bus::subscribe(const std::string& channel, Handler handler, int queue_capacity) {
  Subscription s;
  s.lcm_ = lcm_;
  s.slot_ = std::make_unique<Subscription::Slot>(Subscription::Slot{std::move(handler), this});
  if (direct_) {
    if (channel.find_first_of(".*+?[](){}|^$\\") != std::string::npos || channel.size() > kLcmMaxChannel) {
      throw Error("a Bus that receives directly takes exact channel names of at most 63 characters, not '" +
                  channel + "'");
    }
    direct_->entries.push_back({channel, s.slot_.get()});
    s.direct_ = direct_.get();
    return s;
  }
  // The C interface hands the channel over as a char*; the C++ one builds a std::string for every
  // message, which may allocate.
  s.subscription_ = lcm_subscribe(
      lcm_, channel.c_str(),
      [](const lcm_recv_buf_t* rbuf, const char*, void* context) {
        auto& slot = *static_cast<Subscription::Slot*>(context);
        slot.bus->arrival_utime_ = slot.bus->kernel_stamps_ ? rbuf->recv_utime : -1;
        slot.handler(static_cast<const uint8_t*>(rbuf->data), rbuf->data_size);
        slot.bus->arrival_utime_ = -1;
      },
      s.slot_.get());
  if (s.subscription_ == nullptr) throw Error("LCM could not subscribe to " + channel);
  if (queue_capacity > 0) lcm_subscription_set_queue_capacity(s.subscription_, queue_capacity);
  return s;
}

int Bus::handle(int timeout_ms) {
  if (!direct_) return lcm_handle_timeout(lcm_, timeout_ms);
  pollfd p{direct_->readable, POLLIN, 0};
  const int ready = poll(&p, 1, timeout_ms);
  if (ready <= 0) return ready;
  if (const int read = direct_->receive_one(*this); read != 0) return read;
  return direct_->deliver_reassembled(*this);
}

int Bus::handle_pending() {
  int count = 0;
  if (direct_) {
    while (direct_->receive_one(*this) > 0) ++count;
    return count + direct_->deliver_reassembled(*this);
  }
  while (lcm_handle_timeout(lcm_, 0) > 0) ++count;
  return count;
}

int Bus::fileno() const { return direct_ ? direct_->readable : lcm_get_fileno(lcm_); }

std::string Bus::start_receiving(int priority) {
  if (direct_) return {};  // no receive thread: the handling thread reads the socket
  std::string warning;
  std::thread starter([&] {
    if (const int err = request_fifo(priority); err != 0) {
      warning = std::string("SCHED_FIFO refused for LCM's receive thread (") + std::strerror(err) +
                "): it runs under SCHED_OTHER";
    }
    lcm_get_fileno(lcm_);  // udpm:// starts its receive thread here, which inherits this one's policy
  });
  starter.join();
  return warning;
}

}  // namespace chasles::controller
