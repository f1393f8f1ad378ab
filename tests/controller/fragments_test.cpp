// LCM's fragments put back together, from datagrams laid out as LCM's udpm.c lays them out: in
// order, out of order, from two senders at once; and every way a message is lost — a fragment that
// never came (found by the next message of its sender, or by the timeout), one over the size
// limit, fragments that do not add up — named with its channel and size. bus_test checks the
// layout against LCM's own sender over real UDP.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "controller/transport/realtime/fragments.hpp"
#include "support/lcm_wire.hpp"

namespace chasles::controller {
namespace {

std::vector<uint8_t> payload_of(size_t n, uint8_t seed) {
  std::vector<uint8_t> b(n);
  for (size_t i = 0; i < n; ++i) b[i] = static_cast<uint8_t>(seed + 13 * i + i / 251);
  return b;
}

using testing::lcm_fragments;

struct Fed {
  std::vector<FragmentAssembler::Message> messages;
  std::vector<FragmentAssembler::Loss> losses;
};

void feed(FragmentAssembler& a, uint64_t sender, const std::vector<uint8_t>& d, int64_t now_ns, Fed& fed) {
  FragmentAssembler::Message m;
  if (a.add(sender, d.data(), d.size(), now_ns, m, fed.losses)) fed.messages.push_back(std::move(m));
}

TEST(Fragments, ParsesLcmsLayout) {
  const auto payload = payload_of(200'000, 3);
  const auto datagrams = lcm_fragments("CHASLES_TRAJECTORY", payload, 77);
  ASSERT_EQ(datagrams.size(), 4u);  // 200,000 bytes in fragments of 65,423
  LcmFragment f;
  ASSERT_TRUE(parse_lcm_fragment(datagrams[0].data(), datagrams[0].size(), f));
  EXPECT_EQ(f.seqno, 77u);
  EXPECT_EQ(f.message_size, 200'000u);
  EXPECT_EQ(f.offset, 0u);
  EXPECT_EQ(f.number, 0);
  EXPECT_EQ(f.count, 4);
  EXPECT_STREQ(f.channel, "CHASLES_TRAJECTORY");
  EXPECT_EQ(f.size, 65423u - 19u);
  ASSERT_TRUE(parse_lcm_fragment(datagrams[3].data(), datagrams[3].size(), f));
  EXPECT_EQ(f.channel, nullptr);
  EXPECT_EQ(f.number, 3);
  EXPECT_EQ(f.offset + f.size, 200'000u);
}

TEST(Fragments, RefusesWhatIsNotOne) {
  auto d = lcm_fragments("A", payload_of(100'000, 1), 1)[0];
  LcmFragment f;
  auto broken = d;
  broken[3] = 0x32;  // 'LC02'
  EXPECT_FALSE(parse_lcm_fragment(broken.data(), broken.size(), f));
  EXPECT_FALSE(parse_lcm_fragment(d.data(), 19, f));  // a header cut short
  broken = d;
  broken[17] = 2, broken[19] = 2;  // number 2 of 2
  EXPECT_FALSE(parse_lcm_fragment(broken.data(), broken.size(), f));
  broken = d;
  broken[10] = 0, broken[11] = 1;  // a message of 1 byte, longer fragment
  broken[8] = 0, broken[9] = 0;
  EXPECT_FALSE(parse_lcm_fragment(broken.data(), broken.size(), f));
  broken = d;
  broken[20] = 0;  // an empty channel
  EXPECT_FALSE(parse_lcm_fragment(broken.data(), broken.size(), f));
  broken.assign(d.begin(), d.begin() + 20);
  broken.insert(broken.end(), 64, 'C');  // 64 characters and no NUL
  EXPECT_FALSE(parse_lcm_fragment(broken.data(), broken.size(), f));
  const auto last = lcm_fragments("A", payload_of(100'000, 1), 1)[1];
  broken.assign(last.begin(), last.begin() + 20);  // a later fragment carrying nothing
  EXPECT_FALSE(parse_lcm_fragment(broken.data(), broken.size(), f));
  broken.assign(d.begin(), d.begin() + 22);  // the first, with its channel "A" and nothing after
  EXPECT_FALSE(parse_lcm_fragment(broken.data(), broken.size(), f));
}

TEST(Fragments, PutsMessagesBackTogetherInAnyOrderFromSeveralSenders) {
  FragmentAssembler a;
  const auto p1 = payload_of(176'432, 5), p2 = payload_of(70'000, 9);
  const auto d1 = lcm_fragments("CHASLES_TRAJECTORY", p1, 4), d2 = lcm_fragments("OTHER", p2, 900);
  ASSERT_EQ(d1.size(), 3u);
  ASSERT_EQ(d2.size(), 2u);
  Fed fed;
  // Sender 1 out of order, interleaved with sender 2.
  feed(a, 1, d1[2], 0, fed);
  feed(a, 2, d2[1], 0, fed);
  feed(a, 1, d1[0], 0, fed);
  feed(a, 1, d1[0], 0, fed);  // a repeat is ignored
  EXPECT_EQ(a.pending(), 2u);
  feed(a, 2, d2[0], 0, fed);
  ASSERT_EQ(fed.messages.size(), 1u);
  EXPECT_EQ(fed.messages[0].channel, "OTHER");
  EXPECT_EQ(fed.messages[0].payload, p2);
  feed(a, 1, d1[1], 0, fed);
  ASSERT_EQ(fed.messages.size(), 2u);
  EXPECT_EQ(fed.messages[1].channel, "CHASLES_TRAJECTORY");
  EXPECT_EQ(fed.messages[1].payload, p1);
  EXPECT_TRUE(fed.losses.empty());
  EXPECT_EQ(a.pending(), 0u);
}

TEST(Fragments, AMessageLeftIncompleteByItsSendersNextIsLostAndNamed) {
  FragmentAssembler a;
  const auto first = lcm_fragments("CHASLES_TRAJECTORY", payload_of(176'432, 5), 4);
  const auto second = lcm_fragments("CHASLES_TRAJECTORY", payload_of(150'000, 6), 5);
  Fed fed;
  feed(a, 1, first[0], 0, fed);
  feed(a, 1, first[2], 0, fed);  // fragment 2 of 3 lost on the way
  for (const auto& d : second) feed(a, 1, d, 0, fed);
  ASSERT_EQ(fed.losses.size(), 1u);
  EXPECT_EQ(fed.losses[0].channel, "CHASLES_TRAJECTORY");
  EXPECT_EQ(fed.losses[0].size, 176'432u);
  EXPECT_EQ(fed.losses[0].why, "fragment 2 of 3 never came (1 missing)");
  ASSERT_EQ(fed.messages.size(), 1u);
  EXPECT_EQ(fed.messages[0].payload, payload_of(150'000, 6));
}

TEST(Fragments, AMessageWhoseFragmentsStopIsLostAfterTheTimeout) {
  FragmentAssembler a(kLcmMaxMessageSize, 500'000'000);
  const auto d = lcm_fragments("CHASLES_TRAJECTORY", payload_of(176'432, 5), 4);
  Fed fed;
  feed(a, 1, d[1], 1'000'000'000, fed);  // the first fragment, with the channel, never comes
  feed(a, 1, d[2], 1'100'000'000, fed);
  a.expire(1'600'000'000, fed.losses);  // 0.5 s after the last: not yet
  EXPECT_TRUE(fed.losses.empty());
  a.expire(1'600'000'001, fed.losses);
  ASSERT_EQ(fed.losses.size(), 1u);
  EXPECT_EQ(fed.losses[0].channel, "");
  EXPECT_EQ(fed.losses[0].size, 176'432u);
  EXPECT_EQ(fed.losses[0].why, "fragment 1 of 3 never came (1 missing)");
  EXPECT_EQ(a.pending(), 0u);
}

TEST(Fragments, AMessageOverTheLimitIsLostOnceAndNothingHeld) {
  FragmentAssembler a(100'000);
  const auto d = lcm_fragments("BIG", payload_of(176'432, 5), 8);
  Fed fed;
  for (const auto& f : d) feed(a, 3, f, 0, fed);
  ASSERT_EQ(fed.losses.size(), 1u);
  EXPECT_EQ(fed.losses[0].channel, "BIG");
  EXPECT_EQ(fed.losses[0].size, 176'432u);
  EXPECT_EQ(fed.losses[0].why, "longer than the 100000 bytes taken");
  EXPECT_TRUE(fed.messages.empty());
  EXPECT_EQ(a.pending(), 0u);
}

TEST(Fragments, FragmentsThatDoNotAddUpAreLost) {
  FragmentAssembler a;
  auto d = lcm_fragments("X", payload_of(100'000, 5), 8);
  ASSERT_EQ(d.size(), 2u);
  // The second fragment claims the first's place: every number came, the bytes do not cover it.
  d[1][12] = 0, d[1][13] = 0, d[1][14] = 0, d[1][15] = 0;
  Fed fed;
  for (const auto& f : d) feed(a, 3, f, 0, fed);
  ASSERT_EQ(fed.losses.size(), 1u);
  EXPECT_EQ(fed.losses[0].why, "its fragments do not add up to its size");
  EXPECT_TRUE(fed.messages.empty());
}

}  // namespace
}  // namespace chasles::controller
