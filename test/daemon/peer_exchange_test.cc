#include "daemon/peer_exchange.h"

#include <gtest/gtest.h>

#include <limits>
#include <numeric>
#include <optional>
#include <random>

#include "test/support/random_memory.h"

namespace tsc {
namespace {

using std::chrono::milliseconds;
using Clock = PeerExchange::Clock;

constexpr int kDim = 48;

MemorySnapshot MakeSnapshot(int32_t robot, int places, int64_t version) {
  const auto m = testing_support::MakeRandomMemory(static_cast<uint32_t>(robot), places, kDim,
                                                   static_cast<unsigned>(robot * 100 + places));
  return BuildSnapshot(m.memory, TopologicalMap{}, {robot, 5, version, 1}, 5000);
}

announce_t Announce(int32_t robot, int64_t sequence, const MemorySnapshot& s) {
  announce_t a{};
  a.robot = robot;
  a.boot_id = 5;
  a.sequence = sequence;
  DescribeInAnnounce(s, a);
  a.hmac_size = 0;
  return a;
}

TEST(PeerExchange, FetchesOnePeerAtATimeAndAsksAgainForLostPortions) {
  const MemorySnapshot two = MakeSnapshot(2, 20, 3);
  const MemorySnapshot three = MakeSnapshot(3, 5, 1);
  ASSERT_GE(static_cast<size_t>(two.count()), 3u);
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
  for (const memory_portion_v2_t& p : AllPortions(two)) {
    if (p.index != 1) {
      EXPECT_FALSE(dut.OnPortion(p, t).has_value());
    }
  }
  EXPECT_FALSE(dut.OnPortion(three.Portion(0), t).has_value());
  EXPECT_TRUE(dut.Tick(t + milliseconds(100)).empty());  // not yet time to ask again
  requests = dut.Tick(t + milliseconds(600));
  ASSERT_EQ(requests.size(), 1u);
  EXPECT_EQ(requests[0].robot, 2);  // still robot 2, not 3: one peer at a time
  EXPECT_EQ(requests[0].missing, std::vector<int32_t>{1});
  EXPECT_EQ(requests[0].num_missing, 1);

  auto complete = dut.OnPortion(two.Portion(1), t + milliseconds(700));
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

// A peer whose member views are kept in another basis is heard but never fetched: its views
// would be measured against ours as if they were comparable.
TEST(PeerExchange, APeerOfAnotherViewBasisIsNotFetched) {
  const MemorySnapshot two = MakeSnapshot(2, 4, 1);
  const MemorySnapshot three = MakeSnapshot(3, 4, 1);
  PeerExchangeOptions options;
  options.view_basis = 77;  // ours; the random memories keep plain descriptors (0)
  PeerExchange dut(1, options);
  Clock::time_point t{};
  EXPECT_TRUE(dut.OnAnnounce(Announce(2, 1, two), t));
  EXPECT_EQ(dut.other_basis(), 1);
  EXPECT_NE(dut.last_rejection().find("robot 2"), std::string::npos) << dut.last_rejection();
  EXPECT_TRUE(dut.Tick(t).empty());
  announce_t same = Announce(3, 1, three);
  same.view_basis = 77;
  EXPECT_TRUE(dut.OnAnnounce(same, t));
  const auto requests = dut.Tick(t);
  ASSERT_EQ(requests.size(), 1u);
  EXPECT_EQ(requests[0].robot, 3);
  EXPECT_EQ(dut.other_basis(), 1);
}

// Issue 23: the second fetch of a peer asks for the structure, then only for the body of the
// place that changed; after a failed merge (Forget) the next fetch asks for everything again.
TEST(PeerExchange, SecondFetchAsksForTheStructureThenOnlyTheChangedBody) {
  auto peer = testing_support::MakeRandomMemory(2, 60, kDim, 60);
  const MemorySnapshot v1 = BuildSnapshot(peer.memory, peer.map, {2, 5, 1, 0}, 4096);
  PeerExchange dut(1, PeerExchangeOptions{});
  Clock::time_point t{};
  dut.OnAnnounce(Announce(2, 1, v1), t);
  ASSERT_TRUE(dut.Tick(t).at(0).missing.empty());  // nothing of robot 2 yet: everything
  std::optional<SnapshotAssembler> complete;
  for (const memory_portion_v2_t& p : AllPortions(v1)) complete = dut.OnPortion(p, t);
  ASSERT_TRUE(complete.has_value());
  dut.MarkMerged(2, {v1.version, v1.digest});
  EXPECT_EQ(dut.known_bodies(), 60u);

  DetectedPlace revisit;
  revisit.index = 61;
  revisit.descriptors = Eigen::MatrixXf::Constant(kDim, 2, 0.75f);
  revisit.members = {6100, 6101};
  peer.memory.Update(33, revisit);
  const MemorySnapshot v2 = BuildSnapshot(peer.memory, peer.map, {2, 5, 2, 0}, 4096);
  ASSERT_GE(v2.structure_portions, 2);
  t += milliseconds(1000);
  dut.OnAnnounce(Announce(2, 2, v2), t);
  auto requests = dut.Tick(t);
  ASSERT_EQ(requests.size(), 1u);
  std::vector<int32_t> structure(static_cast<size_t>(v2.structure_portions));
  std::iota(structure.begin(), structure.end(), 0);
  EXPECT_EQ(requests[0].missing, structure);
  for (int32_t i : structure) {
    EXPECT_FALSE(dut.OnPortion(v2.Portion(i), t).has_value());
  }
  requests = dut.Tick(t + milliseconds(100));  // at once, not after the retry period
  ASSERT_EQ(requests.size(), 1u);
  EXPECT_EQ(requests[0].missing, std::vector<int32_t>{v2.structure_portions + 33});
  complete = dut.OnPortion(v2.Portion(v2.structure_portions + 33), t + milliseconds(150));
  ASSERT_TRUE(complete.has_value());
  std::string reason;
  PlaceBodies kept;  // what the merge of v1 kept (tscd: in its store)
  for (size_t i = 0; i < v1.bodies.size(); ++i) kept.emplace(v1.body_digests[i], v1.bodies[i]);
  const auto snap = complete->Take(&reason, [&](const KnownDigests&) { return kept; });
  ASSERT_TRUE(snap.has_value()) << reason;
  EXPECT_EQ(snap->digest, v2.digest);
  EXPECT_EQ(snap->places.size(), 60u);

  dut.Forget(2);  // say the merge failed
  EXPECT_EQ(dut.known_bodies(), 0u);
  dut.OnAnnounce(Announce(2, 3, v2), t + milliseconds(2000));
  requests = dut.Tick(t + milliseconds(2000));
  ASSERT_EQ(requests.size(), 1u);
  EXPECT_TRUE(requests[0].missing.empty());
}

// Portions asked for by index are of the version being assembled, which a newer broadcast may
// have moved past the announced one (the peer serves held versions by index).
TEST(PeerExchange, AsksAgainForTheVersionBeingAssembled) {
  const MemorySnapshot v1 = MakeSnapshot(2, 20, 1);
  const MemorySnapshot v2 = MakeSnapshot(2, 21, 2);
  PeerExchange dut(1, PeerExchangeOptions{});
  Clock::time_point t{};
  dut.OnAnnounce(Announce(2, 1, v1), t);
  ASSERT_EQ(dut.Tick(t).at(0).version, 1);
  EXPECT_FALSE(dut.OnPortion(v2.Portion(0), t).has_value());  // a broadcast of version 2
  const auto requests = dut.Tick(t + milliseconds(600));
  ASSERT_EQ(requests.size(), 1u);
  EXPECT_EQ(requests[0].version, 2);
  EXPECT_EQ(requests[0].missing.size(), static_cast<size_t>(v2.count()) - 1);
}

// A peer may answer with a version newer than it announced (tscd sends its current structure
// for a snapshot a merge withdrew). Once that version is complete, the announced one is not
// fetched again: it would bring back the version just merged at every tick until the peer's
// next announce (seen in the demo's team, ten rounds a second); nor is it after an announce of
// it heard late. A newer version, or the same one after a restart, is fetched as ever.
TEST(PeerExchange, AnAnnouncedVersionOlderThanOneCompletedIsNotFetched) {
  const MemorySnapshot v1 = MakeSnapshot(2, 20, 1);
  const MemorySnapshot v2 = MakeSnapshot(2, 21, 2);
  PeerExchange dut(1, PeerExchangeOptions{});
  Clock::time_point t{};
  dut.OnAnnounce(Announce(2, 1, v1), t);
  ASSERT_EQ(dut.Tick(t).at(0).version, 1);
  std::optional<SnapshotAssembler> complete;
  for (const memory_portion_v2_t& p : AllPortions(v2)) complete = dut.OnPortion(p, t);
  ASSERT_TRUE(complete.has_value());
  EXPECT_EQ(complete->version(), 2);
  dut.MarkMerged(2, {v2.version, v2.digest});
  EXPECT_TRUE(dut.Tick(t + milliseconds(100)).empty());
  dut.OnAnnounce(Announce(2, 2, v1), t + milliseconds(200));  // sent before the answer
  EXPECT_TRUE(dut.Tick(t + milliseconds(300)).empty());

  const MemorySnapshot v3 = MakeSnapshot(2, 22, 3);
  dut.OnAnnounce(Announce(2, 3, v3), t + milliseconds(400));
  auto requests = dut.Tick(t + milliseconds(500));
  ASSERT_EQ(requests.size(), 1u);
  EXPECT_EQ(requests[0].version, 3);
  for (const memory_portion_v2_t& p : AllPortions(v3)) complete = dut.OnPortion(p, t);
  ASSERT_TRUE(complete.has_value());
  dut.MarkMerged(2, {v3.version, v3.digest});

  announce_t restarted = Announce(2, 1, v1);
  restarted.boot_id = 6;
  dut.OnAnnounce(restarted, t + milliseconds(600));
  requests = dut.Tick(t + milliseconds(700));
  ASSERT_EQ(requests.size(), 1u);
  EXPECT_EQ(requests[0].version, 1);
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
  memory_portion_v2_t forged = two.Portion(two.structure_portions);
  forged.places[0].mean[0] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_FALSE(dut.OnPortion(forged, t).has_value());
  EXPECT_EQ(dut.rejected_portions(), 1);
  EXPECT_EQ(dut.last_rejection(), "non-finite or out-of-range mean");
}

}  // namespace
}  // namespace tsc
