// The Bus that reads its multicast socket itself (Receive::kDirect) against LCM's own sender, over
// real UDP multicast on loopback in a network namespace of this binary's own (tools/netns.sh): it
// hears exactly what LCM publishes, large messages put back together from their fragments, stamps
// it with the kernel's receive time, shares the port with LCM's own receivers, takes only its own
// group, drops what is not LCM's and counts and names a message that lost a fragment.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "controller/transport/realtime/bus.hpp"
#include "core/error.hpp"
#include "support/allocation_counter.hpp"
#include "support/lcm_wire.hpp"

namespace chasles::controller {
namespace {

constexpr const char* kUrl = "udpm://239.255.76.67:7667?ttl=0";
constexpr const char* kOtherGroup = "udpm://239.255.76.68:7667?ttl=0";  // same port, another group

int64_t wall_us() {
  timeval tv{};
  gettimeofday(&tv, nullptr);
  return int64_t{tv.tv_sec} * 1'000'000 + tv.tv_usec;
}

std::vector<uint8_t> bytes(size_t n, uint8_t seed) {
  std::vector<uint8_t> b(n);
  for (size_t i = 0; i < n; ++i) b[i] = static_cast<uint8_t>(seed + 7 * i);
  return b;
}

struct Heard {
  std::vector<std::vector<uint8_t>> messages;
  std::vector<int64_t> stamps;
  std::vector<int64_t> handled;  // the wall clock when the handler ran, µs
};

Bus::Handler recorder(Heard& heard, const Bus& bus) {
  return [&heard, &bus](const uint8_t* data, size_t size) {
    heard.messages.emplace_back(data, data + size);
    heard.stamps.push_back(bus.arrival_utime());
    heard.handled.push_back(wall_us());
  };
}

// Handles what the socket holds until `count` messages were heard or 2 s passed (loopback
// multicast is delivered within the send call; the bound only keeps a broken build from hanging).
void handle_until(Bus& bus, const Heard& heard, size_t count) {
  for (int i = 0; i < 200 && heard.messages.size() < count; ++i) bus.handle(10);
}

TEST(DirectBus, HearsWhatLcmPublishesStampedByTheKernel) {
  Bus sender(kUrl);
  Bus receiver(kUrl, Bus::Receive::kDirect);
  ASSERT_TRUE(receiver.direct());
  EXPECT_FALSE(sender.direct());
  Heard heard;
  auto subscription = receiver.subscribe("ARM_STATE", recorder(heard, receiver));
  const std::vector<uint8_t> a = bytes(196, 1), b = bytes(1, 9), c = bytes(60000, 3);
  // Linux turns receive stamps on for the whole stack lazily, from a work queue, once a socket
  // asks; until that has run a datagram is stamped when it is read. Wait for it (a loaded machine
  // runs it late): until a datagram on another channel shows a stamp taken before it was read.
  Heard primer;
  auto priming = receiver.subscribe("PRIME", recorder(primer, receiver));
  for (int i = 0; i < 200 && (primer.stamps.empty() || primer.stamps.back() > primer.handled.back() - 2'000); ++i) {
    ASSERT_TRUE(sender.publish("PRIME", bytes(8, 5)));
    pollfd readable{receiver.fileno(), POLLIN, 0};
    ASSERT_EQ(::poll(&readable, 1, 5000), 1);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    handle_until(receiver, primer, primer.messages.size() + 1);
  }
  ASSERT_FALSE(primer.stamps.empty());
  ASSERT_LT(primer.stamps.back(), primer.handled.back() - 2'000) << "no datagram stamped before it was read";
  const int64_t before = wall_us();
  // One datagram at a time, read 20 ms after the socket is readable, so its kernel stamp and its
  // handling time lie clearly apart however late a loaded machine queues it after the send (all
  // three sent at once, the last could be queued well after the first made the socket readable).
  for (const std::vector<uint8_t>* message : {&a, &b, &c}) {  // c large, still one datagram
    ASSERT_TRUE(sender.publish("ARM_STATE", *message));
    pollfd readable{receiver.fileno(), POLLIN, 0};
    ASSERT_EQ(::poll(&readable, 1, 5000), 1);
    const int64_t queued = wall_us();
    while (wall_us() < queued + 20'000) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    handle_until(receiver, heard, heard.messages.size() + 1);
  }
  ASSERT_EQ(heard.messages.size(), 3u);
  EXPECT_EQ(heard.messages[0], a);
  EXPECT_EQ(heard.messages[1], b);
  EXPECT_EQ(heard.messages[2], c);
  // The kernel stamps a datagram when it queues it: after the send began, and long before it is read
  // (not always before the send call returns: on a loaded machine the softirq work is deferred).
  for (size_t k = 0; k < heard.stamps.size(); ++k) {
    EXPECT_GE(heard.stamps[k], before - 1);  // µs resolution on both sides
    EXPECT_LT(heard.stamps[k], heard.handled[k] - 10'000) << "a stamp taken when handled, not when received: message " << k;
  }
  EXPECT_EQ(receiver.arrival_utime(), -1);  // outside a handler
  EXPECT_EQ(receiver.dropped(), 0);
}

TEST(DirectBus, OnlyTheSubscribedChannelsAndItsOwnGroupAreDelivered) {
  Bus sender(kUrl), other_group(kOtherGroup);
  Bus receiver(kUrl, Bus::Receive::kDirect);
  Heard state, target;
  auto s1 = receiver.subscribe("ARM_STATE", recorder(state, receiver));
  auto s2 = receiver.subscribe("ARM_TARGET", recorder(target, receiver));
  ASSERT_TRUE(other_group.publish("ARM_STATE", bytes(10, 2)));  // same port: not for this socket
  ASSERT_TRUE(sender.publish("ARM_STATUS", bytes(10, 3)));      // nobody here listens
  ASSERT_TRUE(sender.publish("ARM_STATE_X", bytes(10, 4)));     // a longer name is another channel
  ASSERT_TRUE(sender.publish("ARM_TARGET", bytes(12, 5)));
  ASSERT_TRUE(sender.publish("ARM_STATE", bytes(11, 6)));
  handle_until(receiver, state, 1);
  receiver.handle_pending();
  ASSERT_EQ(state.messages.size(), 1u);
  EXPECT_EQ(state.messages[0], bytes(11, 6));
  ASSERT_EQ(target.messages.size(), 1u);
  EXPECT_EQ(target.messages[0], bytes(12, 5));
  EXPECT_EQ(receiver.dropped(), 2);  // ARM_STATUS and ARM_STATE_X; the other group never arrived
}

TEST(DirectBus, SharesThePortWithLcmsOwnReceivers) {
  Bus sender(kUrl), lcm_receiver(kUrl);
  Bus direct_a(kUrl, Bus::Receive::kDirect), direct_b(kUrl, Bus::Receive::kDirect);
  Heard via_lcm, via_a, via_b;
  auto s1 = lcm_receiver.subscribe("ARM_STATE", recorder(via_lcm, lcm_receiver));
  auto s2 = direct_a.subscribe("ARM_STATE", recorder(via_a, direct_a));
  auto s3 = direct_b.subscribe("ARM_STATE", recorder(via_b, direct_b));
  ASSERT_TRUE(sender.publish("ARM_STATE", bytes(100, 8)));
  handle_until(lcm_receiver, via_lcm, 1);
  handle_until(direct_a, via_a, 1);
  handle_until(direct_b, via_b, 1);
  for (const Heard* h : {&via_lcm, &via_a, &via_b}) {
    ASSERT_EQ(h->messages.size(), 1u);
    EXPECT_EQ(h->messages[0], bytes(100, 8));
  }
}

void send_raw(const std::vector<std::vector<uint8_t>>& datagrams) {
  testing::send_datagrams("239.255.76.67", 7667, datagrams);
}

TEST(DirectBus, PutsLcmsLargeMessagesBackTogetherAndDropsForeignDatagrams) {
  Bus sender(kUrl);
  Bus receiver(kUrl, Bus::Receive::kDirect);
  Heard heard;
  auto subscription = receiver.subscribe("ARM_TRAJECTORY", recorder(heard, receiver));
  // LCM sends a message this large as 4 fragments ('LC03' datagrams, lcm/udpm.c).
  ASSERT_TRUE(sender.publish("ARM_TRAJECTORY", bytes(200'000, 1)));
  // Datagrams on the group that are not LCM's: junk, a short header, a channel without its NUL.
  std::vector<std::vector<uint8_t>> foreign = {
      {1, 2, 3, 4, 5, 6, 7, 8, 9, 10}, {0x4c, 0x43, 0x30, 0x32, 0, 0}, {0x4c, 0x43, 0x30, 0x32, 0, 0, 0, 1}};
  std::vector<uint8_t> unterminated = {0x4c, 0x43, 0x30, 0x32, 0, 0, 0, 2};
  unterminated.insert(unterminated.end(), 64, 'A');  // 64 characters and no NUL: over LCM's 63
  foreign.push_back(unterminated);
  send_raw(foreign);
  ASSERT_TRUE(sender.publish("ARM_TRAJECTORY", bytes(20, 4)));
  // The large message, 1,000 waypoints of a 12-joint arm's size, at LCM's 64 kB per fragment.
  ASSERT_TRUE(sender.publish("ARM_TRAJECTORY", bytes(1'000'000, 2)));
  handle_until(receiver, heard, 3);
  ASSERT_EQ(heard.messages.size(), 3u);
  // The small message is delivered as it is read; the large ones once put together.
  EXPECT_EQ(heard.messages[0], bytes(20, 4));
  EXPECT_EQ(heard.messages[1], bytes(200'000, 1));
  EXPECT_EQ(heard.messages[2], bytes(1'000'000, 2));
  EXPECT_GT(heard.stamps[1], 0);  // the kernel's stamp of its last fragment
  EXPECT_EQ(receiver.dropped(), 4);
  EXPECT_EQ(receiver.lost(), 0);
  EXPECT_STREQ(receiver.last_loss(), "");
}

TEST(DirectBus, AMessageMissingAFragmentIsCountedAndNamed) {
  Bus receiver(kUrl, Bus::Receive::kDirect);
  Heard heard;
  auto subscription = receiver.subscribe("ARM_TRAJECTORY", recorder(heard, receiver));
  auto sent = testing::lcm_fragments("ARM_TRAJECTORY", bytes(176'432, 3), 41, 60'000);
  ASSERT_EQ(sent.size(), 3u);
  sent.erase(sent.begin() + 1);
  send_raw(sent);
  // Then a whole one from another sender (another socket): it is not held up by the lost one.
  send_raw(testing::lcm_fragments("ARM_TRAJECTORY", bytes(70'000, 4), 7, 60'000));
  for (int i = 0; i < 300 && (heard.messages.empty() || receiver.lost() == 0); ++i) receiver.handle(10);
  ASSERT_EQ(heard.messages.size(), 1u);
  EXPECT_EQ(heard.messages[0], bytes(70'000, 4));
  EXPECT_EQ(receiver.lost(), 1);
  EXPECT_STREQ(receiver.last_loss(), "a 176432-byte message on ARM_TRAJECTORY: fragment 2 of 3 never came (1 missing)");
  EXPECT_EQ(receiver.dropped(), 0);
}

TEST(DirectBus, RefusesChannelPatternsAndHandlesWithoutAllocating) {
  Bus sender(kUrl);
  Bus receiver(kUrl, Bus::Receive::kDirect);
  EXPECT_THROW((void)receiver.subscribe("ARM_.*", [](const uint8_t*, size_t) {}), Error);
  EXPECT_THROW((void)receiver.subscribe(std::string(64, 'A'), [](const uint8_t*, size_t) {}), Error);
  size_t heard = 0, bytes_heard = 0;
  auto subscription = receiver.subscribe("ARM_STATE", [&](const uint8_t*, size_t size) {
    ++heard;
    bytes_heard += size;
  });
  const std::vector<uint8_t> message = bytes(196, 5);
  for (int i = 0; i < 100; ++i) ASSERT_TRUE(sender.publish("ARM_STATE", message));
  // And a large message: its fragments are read and handed on, and it comes back whole, on this
  // thread without an allocation (the assembler's thread allocates).
  ASSERT_TRUE(sender.publish("ARM_STATE", bytes(300'000, 6)));
  testing::AllocationCounter counter;
  int handled = 0;
  for (int i = 0; i < 200 && heard < 101; ++i) handled += receiver.handle(10);
  const int64_t allocations = counter.count();
  EXPECT_EQ(heard, 101u);
  EXPECT_EQ(handled, 100 + 5 + 1);  // the small ones, the fragments read, the large one delivered
  EXPECT_EQ(bytes_heard, 100 * message.size() + 300'000);
  EXPECT_EQ(allocations, 0);
}

// A Bus on memq:// has no socket: Receive::kDirect is LCM's path there, as the in-process tests use.
TEST(DirectBus, MemqKeepsLcmsDispatch) {
  Bus bus("memq://", Bus::Receive::kDirect);
  EXPECT_FALSE(bus.direct());
  int heard = 0;
  auto subscription = bus.subscribe("ARM_.*", [&](const uint8_t*, size_t) { ++heard; });
  ASSERT_TRUE(bus.publish("ARM_STATE", bytes(4, 1)));
  bus.handle_pending();
  EXPECT_EQ(heard, 1);
}

}  // namespace
}  // namespace chasles::controller
