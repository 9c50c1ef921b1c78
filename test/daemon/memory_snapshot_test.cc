#include "daemon/memory_snapshot.h"

#include <gtest/gtest.h>

#include <random>
#include <set>

#include "daemon/lcm_bus.h"
#include "test/support/random_memory.h"

namespace tsc {
namespace {

constexpr int kDim = 96;

// A memory of `places` random places (each 12 members), mapped in a chain.
testing_support::RandomMemory Fixture(int places) {
  return testing_support::MakeRandomMemory(5, places, kDim, static_cast<unsigned>(places), 12);
}

TEST(MemorySnapshot, PortionsStayWithinTheBudgetAndCoverEverythingOnce) {
  const auto f = Fixture(60);
  const int budget = 8192;
  const MemorySnapshot dut = BuildSnapshot(f.memory, f.map, {5, 99, 3, 1000}, budget);
  ASSERT_GT(dut.portions.size(), 1u);
  std::set<int32_t> places, nodes;
  size_t edges = 0;
  for (size_t i = 0; i < dut.portions.size(); ++i) {
    const memory_portion_t& p = dut.portions[i];
    EXPECT_LE(LcmBus::Encode(p).size(), static_cast<size_t>(budget)) << i;
    EXPECT_EQ(p.index, static_cast<int32_t>(i));
    EXPECT_EQ(p.count, static_cast<int32_t>(dut.portions.size()));
    EXPECT_EQ(p.robot, 5);
    EXPECT_EQ(p.version, 3);
    EXPECT_EQ(p.digest, dut.digest);
    EXPECT_EQ(p.total_places, 60);
    for (int32_t k = 0; k < p.num_places; ++k) {
      EXPECT_TRUE(places.insert(p.first_place + k).second);
      const learned_place_t& lp = p.places[static_cast<size_t>(k)];
      const LearnedPlace& want = f.memory.places()[static_cast<size_t>(p.first_place + k)];
      EXPECT_EQ(lp.id.local, static_cast<int32_t>(want.id.local));
      EXPECT_EQ(lp.dims, kDim);
      EXPECT_EQ(lp.mean[7], want.mean[7]);
      EXPECT_EQ(lp.num_samples, want.samples.cols());
    }
    for (const memory_node_t& n : p.nodes) EXPECT_TRUE(nodes.insert(n.index).second);
    edges += p.edges.size();
  }
  EXPECT_EQ(places.size(), 60u);
  EXPECT_EQ(nodes.size(), f.memory.nodes().size());
  EXPECT_EQ(edges, f.map.edges().size());
}

TEST(MemorySnapshot, DigestIsDeterministicAndFollowsContent) {
  const auto a = Fixture(10), b = Fixture(10), c = Fixture(11);
  const SnapshotHeader h{5, 1, 1, 0};
  const MemorySnapshot sa = BuildSnapshot(a.memory, a.map, h, 60000);
  EXPECT_EQ(sa.digest, BuildSnapshot(b.memory, b.map, h, 60000).digest);
  EXPECT_NE(sa.digest, BuildSnapshot(c.memory, c.map, h, 60000).digest);
  EXPECT_NE(sa.digest, 0);
}

TEST(MemorySnapshot, EmptyMemoryIsOnePortion) {
  const PlaceMemory empty(2, PlaceMemoryOptions{});
  const MemorySnapshot dut = BuildSnapshot(empty, TopologicalMap{}, {2, 1, 1, 0}, 4096);
  ASSERT_EQ(dut.portions.size(), 1u);
  EXPECT_EQ(dut.portions[0].total_places, 0);
  EXPECT_EQ(dut.portions[0].count, 1);
}

}  // namespace
}  // namespace tsc
