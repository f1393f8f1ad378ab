// The seam between the processes and the wire: one LCM instance, publish and subscribe, in the
// manner of Drake's DrakeLcmInterface. The provider URL chooses the wire: production runs on
// udpm:// (UDP multicast), the in-process tests on memq:// (LCM's own in-process queue), and
// every message takes the same path either way — lcm-gen's encoding, LCM's dispatch, and the
// checked decoder of its type (lcmtypes/checked.hpp) on the receiving side.
//
// Receiving directly (Receive::kDirect, on udpm://): LCM 1.3.1 reads every datagram on a thread of
// its own and hands it over through a pipe, two wake-ups per message before a handler runs. A
// direct Bus instead reads the multicast group itself, on the thread that calls handle(): its own
// socket, joined to the URL's group and port as LCM's is, and LCM's formats, so the messages are
// LCM's own, published by LCM. It takes only the group it joined (IP_MULTICAST_ALL off: another
// group on the same port is not delivered to it) and exact channel names. A message of one
// datagram (LCM's 'LC02', up to 64 kB: every state, command and setpoint) is handed to its
// subscribers at once; the fragments of a larger one ('LC03': a planner's long trajectory) go to a
// thread of the Bus's own that puts them together (fragments.hpp), and the whole message comes
// back to the handling thread, which delivers it at its next turn — so the reading thread never
// allocates, and a message of any size LCM allows arrives. One that cannot be put together (a
// fragment lost, the queues full) is counted and described: lost(), last_loss(). It sends
// through LCM.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

extern "C" {
typedef struct _lcm_t lcm_t;
typedef struct _lcm_subscription_t lcm_subscription_t;
}

namespace chasles::controller {

/// One UDP datagram read as an LCM small message (LCM's 'LC02' header, the channel NUL-terminated
/// in at most 63 characters, the payload): the channel and the payload point into `data`. Anything
/// else — a fragment of a larger message ('LC03'), a truncated header, a channel without its NUL,
/// bytes that are not LCM's — is not one.
struct LcmDatagram {
  const char* channel = nullptr;
  const uint8_t* payload = nullptr;
  size_t payload_size = 0;
};
/// Whether `data` is one whole LCM small message, then `out` filled. Allocates nothing.
bool parse_lcm_datagram(const uint8_t* data, size_t size, LcmDatagram& out);

class Bus {
  struct Direct;  // the socket of a Bus that receives directly

 public:
  /// Called on the thread that handles the bus, with the message's bytes as received.
  using Handler = std::function<void(const uint8_t* data, size_t size)>;

  /// Ends its subscription when destroyed; must not outlive the Bus.
  class Subscription {
   public:
    Subscription() = default;
    ~Subscription();
    Subscription(Subscription&& other) noexcept;
    Subscription& operator=(Subscription&& other) noexcept;

   private:
    friend class Bus;
    struct Slot {
      Handler handler;
      Bus* bus;
    };
    lcm_t* lcm_ = nullptr;
    lcm_subscription_t* subscription_ = nullptr;
    Direct* direct_ = nullptr;  // receiving directly: the table slot_ is entered in
    std::unique_ptr<Slot> slot_;
    void end();
  };

  /// Who reads what arrives: LCM's receive thread, or the handling thread itself (see above).
  enum class Receive { kLcm, kDirect };

  /// Starts LCM on `url` (empty: $LCM_DEFAULT_URL, else LCM's default). Throws chasles::Error if
  /// it cannot. Receive::kDirect takes effect on udpm:// only (memq:// has no socket to read).
  explicit Bus(const std::string& url, Receive receive = Receive::kLcm);
  ~Bus();
  Bus(const Bus&) = delete;
  Bus& operator=(const Bus&) = delete;

  /// Sends bytes on `channel`; false if LCM failed to (the message is lost, as on a network).
  /// Allocates nothing.
  bool publish(const std::string& channel, const void* data, size_t size);
  bool publish(const std::string& channel, const std::vector<uint8_t>& bytes) {
    return publish(channel, bytes.data(), bytes.size());
  }
  /// Encodes an lcm-gen message and sends it (allocates: not for the real-time loop).
  template <typename Message>
  bool publish_message(const std::string& channel, const Message& message) {
    std::vector<uint8_t> bytes(static_cast<size_t>(message.getEncodedSize()));
    message.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
    return publish(channel, bytes);
  }

  /// `channel` is a regular expression, as in LCM ("CHASLES_.*" hears every chasles channel);
  /// receiving directly, an exact name (a pattern is refused with chasles::Error).
  /// `queue_capacity` > 0: how many messages may wait for this subscriber before LCM drops the
  /// newest (LCM's default otherwise, 30); receiving directly, the socket's buffer is the queue.
  [[nodiscard]] Subscription subscribe(const std::string& channel, Handler handler, int queue_capacity = 0);

  /// Delivers one message to its subscribers, waiting up to timeout_ms for it: > 0 if one was
  /// delivered, 0 if none came, < 0 on an LCM error.
  int handle(int timeout_ms);
  /// Delivers every message already waiting, without blocking; returns how many.
  int handle_pending();
  /// A file descriptor that is readable when a message waits (for poll).
  int fileno() const;

  /// While a handler runs: when the kernel received its message, µs since the Unix epoch
  /// (CLOCK_REALTIME, the socket's SO_TIMESTAMP) — before LCM's receive thread and the hand-over
  /// to the handling thread, so a latency measured from it includes both. −1 when the provider
  /// stamps no arrival (memq:// stamps the wall clock, which a simulated clock does not follow).
  int64_t arrival_utime() const { return arrival_utime_; }

  /// Starts LCM's receive thread now, from a thread running SCHED_FIFO at `priority`, so that it
  /// inherits that policy: on udpm:// every message passes through that thread before any handler
  /// sees it, and under SCHED_OTHER it waits behind every busy process. Call before the first
  /// subscribe (which would start the thread under the caller's policy). Returns a warning when
  /// SCHED_FIFO is refused (the thread then starts under SCHED_OTHER); empty otherwise.
  std::string start_receiving(int priority);

  /// Whether this Bus reads its socket itself.
  bool direct() const { return direct_ != nullptr; }
  /// Receiving directly: datagrams dropped as not LCM's (truncated, foreign, a fragment that is
  /// not one), and messages on channels nobody here subscribed to.
  int64_t dropped() const;
  /// Receiving directly: messages lost before they could be delivered — a fragment that never
  /// came (within 0.5 s of the one before), one longer than LCM allows, the queues to and from the
  /// assembler full. Any thread.
  int64_t lost() const;
  /// The newest loss, described with its channel and size ("a 176432-byte message on
  /// CHASLES_TRAJECTORY: fragment 2 of 3 never came (1 missing)"); empty if none. One thread
  /// only (the reporter's).
  const char* last_loss();

 private:
  lcm_t* lcm_;
  bool kernel_stamps_;
  int64_t arrival_utime_ = -1;
  std::unique_ptr<Direct> direct_;
};

}  // namespace chasles::controller
