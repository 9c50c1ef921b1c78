#include "daemon/peer_exchange.h"

#include <gtest/gtest.h>

#include <limits>
#include <random>

#include "test/support/random_memory.h"

namespace tsc {
namespace {

using std::chrono::milliseconds;
using Clock = PeerExchange::Clock;

MemorySnapshot MakeSnapshot(int32_t robot, int places, int64_t version) {
  const auto m = testing_support::MakeRandomMemory(static_cast<uint32_t>(robot), places, 48,
                                                   static_cast<unsigned>(robot * 100 + places));
  return BuildSnapshot(m.memory, TopologicalMap{}, {robot, 5, version, 1}, 5000);
}

announce_t Announce(int32_t robot, int64_t sequence, const MemorySnapshot& s) {
  announce_t a{};
  a.robot = robot;
  a.boot_id = 5;
  a.sequence = sequence;
  a.memory_version = s.version;
  a.memory_digest = s.digest;
  a.portions = static_cast<int32_t>(s.portions.size());
  a.hmac_size = 0;
  return a;
}

TEST(PeerExchange, FetchesOnePeerAtATimeAndAsksAgainForLostPortions) {
  const MemorySnapshot two = MakeSnapshot(2, 20, 3);
  const MemorySnapshot three = MakeSnapshot(3, 5, 1);
  ASSERT_GE(two.portions.size(), 3u);
  PeerExchange dut(1, PeerExchangeOptions{});
  Clock::time_point t{};
  EXPECT_TRUE(dut.OnAnnounce(Announce(2, 1, two), t));
  EXPECT_TRUE(dut.OnAnnounce(Announce(3, 1, three), t));

  auto requests = dut.Tick(t);
  ASSERT_EQ(requests.size(), 1u);
  EXPECT_EQ(requests[0].robot, 2);
  EXPECT_EQ(requests[0].requester, 1);
  EXPECT_TRUE(requests[0].missing.empty());  // everything
  EXPECT_EQ(dut.fetching(), 2);

  // Everything arrives but portion 1 (lost on the way), and a portion of robot 3 (ignored).
  for (const memory_portion_t& p : two.portions) {
    if (p.index != 1) {
      EXPECT_FALSE(dut.OnPortion(p, t).has_value());
    }
  }
  EXPECT_FALSE(dut.OnPortion(three.portions[0], t).has_value());
  EXPECT_TRUE(dut.Tick(t + milliseconds(100)).empty());  // not yet time to ask again
  requests = dut.Tick(t + milliseconds(600));
  ASSERT_EQ(requests.size(), 1u);
  EXPECT_EQ(requests[0].robot, 2);  // still robot 2, not 3: one peer at a time
  EXPECT_EQ(requests[0].missing, std::vector<int32_t>{1});
  EXPECT_EQ(requests[0].num_missing, 1);

  auto complete = dut.OnPortion(two.portions[1], t + milliseconds(700));
  ASSERT_TRUE(complete.has_value());
  std::string reason;
  const auto snap = complete->Take(&reason);
  ASSERT_TRUE(snap.has_value()) << reason;
  EXPECT_EQ(snap->places.size(), 20u);
  EXPECT_FALSE(dut.fetching().has_value());
  dut.MarkMerged(2, {snap->version, snap->digest});

  requests = dut.Tick(t + milliseconds(800));
  ASSERT_EQ(requests.size(), 1u);
  EXPECT_EQ(requests[0].robot, 3);
}

TEST(PeerExchange, ReplayedAnnounceIsRefusedAndMergedDigestIsNotFetchedAgain) {
  const MemorySnapshot two = MakeSnapshot(2, 4, 1);
  PeerExchange dut(1, PeerExchangeOptions{}, {{2, {1, two.digest}}});
  Clock::time_point t{};
  EXPECT_TRUE(dut.OnAnnounce(Announce(2, 7, two), t));
  EXPECT_FALSE(dut.OnAnnounce(Announce(2, 7, two), t));  // same boot, same sequence
  EXPECT_FALSE(dut.OnAnnounce(Announce(2, 6, two), t));
  EXPECT_EQ(dut.replays(), 2);
  EXPECT_TRUE(dut.Tick(t).empty());  // already merged this content

  const MemorySnapshot newer = MakeSnapshot(2, 5, 2);
  EXPECT_TRUE(dut.OnAnnounce(Announce(2, 8, newer), t));
  const auto requests = dut.Tick(t);
  ASSERT_EQ(requests.size(), 1u);
  EXPECT_EQ(requests[0].version, 2);
}

TEST(PeerExchange, GivesUpOnASilentPeerAndForgetsIt) {
  const MemorySnapshot two = MakeSnapshot(2, 4, 1);
  PeerExchangeOptions o;
  o.max_retries = 3;
  PeerExchange dut(1, o);
  Clock::time_point t{};
  dut.OnAnnounce(Announce(2, 1, two), t);
  ASSERT_EQ(dut.Tick(t).size(), 1u);
  int asked = 0;
  for (int i = 1; i <= 5; ++i)
    asked += static_cast<int>(dut.Tick(t + milliseconds(600 * i)).size());
  EXPECT_EQ(asked, 3);
  EXPECT_EQ(dut.given_up(), 1);
  EXPECT_FALSE(dut.fetching().has_value());
  // Silent for longer than peer_timeout: forgotten, nothing more is asked.
  dut.Tick(t + milliseconds(20000));
  EXPECT_TRUE(dut.Tick(t + milliseconds(21000)).empty());
}

TEST(PeerExchange, ForgedPortionIsCountedNotKept) {
  const MemorySnapshot two = MakeSnapshot(2, 4, 1);
  PeerExchange dut(1, PeerExchangeOptions{});
  Clock::time_point t{};
  dut.OnAnnounce(Announce(2, 1, two), t);
  dut.Tick(t);
  memory_portion_t forged = two.portions[0];
  forged.places[0].mean[0] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_FALSE(dut.OnPortion(forged, t).has_value());
  EXPECT_EQ(dut.rejected_portions(), 1);
  EXPECT_EQ(dut.last_rejection(), "non-finite mean");
}

}  // namespace
}  // namespace tsc
