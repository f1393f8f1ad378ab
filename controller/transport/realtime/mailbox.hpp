// Lock-free hand-over between one producer thread and one consumer thread, for the real-time
// tick: neither side ever waits for the other, and nothing allocates after construction.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace chasles::controller {

/// Latest-value mailbox (a triple buffer): write() publishes a value, read() fetches the newest
/// one published since the previous read; older unread values are overwritten (latest wins).
/// The three slots are copies of a prototype, so values holding vectors keep their capacity and
/// copying one of the same size into a slot does not allocate.
template <typename T>
class Mailbox {
 public:
  explicit Mailbox(const T& prototype) : slots_{prototype, prototype, prototype} {}

  /// Producer side: the slot to fill, then publish().
  T& back() { return slots_[back_]; }
  void publish() {
    back_ = middle_.exchange(back_ | kFresh, std::memory_order_acq_rel) & kIndex;
  }
  void write(const T& value) {
    back() = value;
    publish();
  }

  /// Consumer side: whether a value was published since the last read.
  bool fresh() const { return (middle_.load(std::memory_order_acquire) & kFresh) != 0; }
  /// Consumer side: true and `out` set to the newest value if one was published since the last
  /// read, else false and `out` untouched.
  bool read(T& out) {
    if (!take()) return false;
    out = slots_[front_];
    return true;
  }
  /// Consumer side, without a copy: whether a value was published since the last look, which
  /// front() then is. front() stays the consumer's, untouched by the producer, until the next
  /// take() or read().
  bool take() {
    if ((middle_.load(std::memory_order_relaxed) & kFresh) == 0) return false;
    front_ = middle_.exchange(front_, std::memory_order_acq_rel) & kIndex;
    return true;
  }
  const T& front() const { return slots_[front_]; }

 private:
  static constexpr uint8_t kIndex = 3, kFresh = 4;
  std::array<T, 3> slots_;
  uint8_t back_ = 0, front_ = 1;
  std::atomic<uint8_t> middle_{2};
};

/// Bounded single-producer single-consumer queue; push() fails (and the caller counts a loss)
/// rather than wait when the consumer has fallen behind.
template <typename T>
class SpscRing {
 public:
  /// Slots are copies of `prototype`, so values holding vectors keep their capacity.
  explicit SpscRing(size_t capacity, const T& prototype = T()) : items_(capacity + 1, prototype) {}

  bool push(const T& item) {
    const size_t head = head_.load(std::memory_order_relaxed);
    const size_t next = head + 1 == items_.size() ? 0 : head + 1;
    if (next == tail_.load(std::memory_order_acquire)) return false;
    items_[head] = item;
    head_.store(next, std::memory_order_release);
    return true;
  }

  bool pop(T& item) {
    const size_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_.load(std::memory_order_acquire)) return false;
    item = items_[tail];
    tail_.store(tail + 1 == items_.size() ? 0 : tail + 1, std::memory_order_release);
    return true;
  }

 private:
  std::vector<T> items_;
  alignas(64) std::atomic<size_t> head_{0};
  alignas(64) std::atomic<size_t> tail_{0};
};

}  // namespace chasles::controller
