#include "daemon/memory_snapshot.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <functional>
#include <memory>
#include <random>
#include <set>
#include <unordered_set>

#include "daemon/lcm_bus.h"
#include "test/support/random_memory.h"

namespace tsc {
namespace {

constexpr int kDim = 96;

// A memory of `places` random places (each 12 members), mapped in a chain.
testing_support::RandomMemory Fixture(int places) {
  return testing_support::MakeRandomMemory(5, places, kDim, static_cast<unsigned>(places), 12);
}

TEST(MemorySnapshot, StructureStaysWithinTheBudgetBodiesComeOneEachEverythingOnce) {
  const auto f = Fixture(60);
  const int budget = 4096;
  const MemorySnapshot dut = BuildSnapshot(f.memory, f.map, {5, 99, 3, 1000}, budget);
  ASSERT_GT(dut.structure_portions, 1);
  ASSERT_EQ(static_cast<size_t>(dut.count()), static_cast<size_t>(dut.structure_portions) + 60);
  ASSERT_EQ(dut.body_digests.size(), 60u);
  std::set<int32_t> entries, places, nodes;
  size_t edges = 0;
  for (int32_t i = 0; i < dut.count(); ++i) {
    const memory_portion_v2_t p = dut.Portion(i);
    const bool structure = p.index < dut.structure_portions;
    if (structure) {
      EXPECT_LE(LcmBus::Encode(p).size(), static_cast<size_t>(budget)) << i;
    }
    EXPECT_EQ(p.index, i);
    EXPECT_EQ(p.count, dut.count());
    EXPECT_EQ(p.structure_portions, dut.structure_portions);
    EXPECT_EQ(p.robot, 5);
    EXPECT_EQ(p.version, 3);
    EXPECT_EQ(p.digest, dut.digest);
    EXPECT_EQ(p.total_places, 60);
    EXPECT_EQ(p.num_places, structure ? 0 : 1) << i;
    for (int32_t k = 0; k < p.num_entries; ++k) {
      EXPECT_TRUE(entries.insert(p.first_place + k).second);
      const place_entry_t& e = p.entries[static_cast<size_t>(k)];
      EXPECT_EQ(e.body_digest, dut.body_digests[static_cast<size_t>(p.first_place + k)]);
      EXPECT_EQ(e.slink_pi, f.memory.slink().pi()[static_cast<size_t>(p.first_place + k)]);
    }
    for (int32_t k = 0; k < p.num_places; ++k) {
      EXPECT_EQ(p.first_place, p.index - dut.structure_portions);
      EXPECT_TRUE(places.insert(p.first_place + k).second);
      const learned_place_v2_t& lp = p.places[static_cast<size_t>(k)];
      const LearnedPlace& want = f.memory.places()[static_cast<size_t>(p.first_place + k)];
      EXPECT_EQ(lp.id.local, static_cast<int32_t>(want.id.local));
      EXPECT_EQ(lp.dims, kDim);
      EXPECT_EQ(lp.mean[7], want.mean[7]);
      EXPECT_EQ(lp.num_samples, want.samples.cols());
      EXPECT_EQ(BodyDigest(lp), dut.body_digests[static_cast<size_t>(p.first_place)]);
    }
    for (const memory_node_t& n : p.nodes) EXPECT_TRUE(nodes.insert(n.index).second);
    edges += p.edges.size();
  }
  EXPECT_EQ(entries.size(), 60u);
  EXPECT_EQ(places.size(), 60u);
  EXPECT_EQ(nodes.size(), f.memory.nodes().size());
  EXPECT_EQ(edges, f.map.edges().size());
}

// Issue 23: a place seen again changes its body and the structure, nothing else, so a peer
// that holds the other bodies is sent the structure and one body.
TEST(MemorySnapshot, APlaceSeenAgainChangesItsBodyAndTheStructureOnly) {
  auto f = Fixture(40);
  const SnapshotHeader h{5, 1, 1, 0};
  const MemorySnapshot before = BuildSnapshot(f.memory, f.map, h, 8192);
  DetectedPlace revisit;
  revisit.index = 41;
  revisit.descriptors = Eigen::MatrixXf::Constant(kDim, 3, 0.25f);
  revisit.members = {4100, 4101, 4102};
  f.memory.Update(7, revisit);
  const MemorySnapshot after = BuildSnapshot(f.memory, f.map, h, 8192);
  ASSERT_EQ(after.body_digests.size(), 40u);
  for (size_t i = 0; i < 40; ++i) {
    EXPECT_EQ(after.body_digests[i] != before.body_digests[i], i == 7) << i;
  }
  std::vector<int32_t> want(static_cast<size_t>(after.structure_portions));
  for (int32_t i = 0; i < after.structure_portions; ++i) want[static_cast<size_t>(i)] = i;
  want.push_back(after.structure_portions + 7);
  EXPECT_EQ(PortionsBeyond(after, {before.body_digests.begin(), before.body_digests.end()}), want);
  EXPECT_EQ(PortionsBeyond(after, {}).size(), static_cast<size_t>(after.count()));
}

// tscd builds each snapshot on the one before: bodies of places that did not change are shared
// with it (one copy of what consecutive snapshots have in common, nothing encoded again), found
// by place id wherever they stand, and the result is portion for portion the snapshot built
// from scratch. A body whose content differs in any value is built again.
TEST(MemorySnapshot, BuiltOnThePreviousItSharesUnchangedBodiesAndEqualsOneFromScratch) {
  auto f = Fixture(40);
  const MemorySnapshot before = BuildSnapshot(f.memory, f.map, {5, 1, 1, 0}, 8192);
  DetectedPlace revisit;
  revisit.index = 41;
  revisit.descriptors = Eigen::MatrixXf::Constant(kDim, 3, 0.25f);
  revisit.members = {4100, 4101, 4102};
  f.memory.Update(7, revisit);
  const SnapshotHeader h{5, 1, 2, 0};
  const MemorySnapshot scratch = BuildSnapshot(f.memory, f.map, h, 8192);
  auto same_as_scratch = [&](const MemorySnapshot& dut) {
    ASSERT_EQ(dut.count(), scratch.count());
    EXPECT_EQ(dut.digest, scratch.digest);
    EXPECT_EQ(dut.body_digests, scratch.body_digests);
    for (int32_t i = 0; i < dut.count(); ++i) {
      EXPECT_EQ(LcmBus::Encode(dut.Portion(i)), LcmBus::Encode(scratch.Portion(i))) << i;
    }
  };

  const MemorySnapshot dut = BuildSnapshot(f.memory, f.map, h, 8192, &before);
  same_as_scratch(dut);
  for (size_t i = 0; i < 40; ++i) EXPECT_EQ(dut.bodies[i] == before.bodies[i], i != 7) << i;

  // The previous snapshot's bodies in another order (as after a merge): found by id.
  MemorySnapshot reversed = before;
  std::reverse(reversed.bodies.begin(), reversed.bodies.end());
  std::reverse(reversed.body_digests.begin(), reversed.body_digests.end());
  const MemorySnapshot from_reversed = BuildSnapshot(f.memory, f.map, h, 8192, &reversed);
  same_as_scratch(from_reversed);
  for (size_t i = 0; i < 40; ++i) {
    EXPECT_EQ(from_reversed.bodies[i] == before.bodies[i], i != 7) << i;
  }

  // A previous body of the same id whose content differs (one view value, or one source) is
  // not taken.
  MemorySnapshot altered = before;
  auto view = std::make_shared<learned_place_v2_t>(*before.bodies[3]);
  view->samples[1][2] ^= 1;
  altered.bodies[3] = view;
  auto source = std::make_shared<learned_place_v2_t>(*before.bodies[4]);
  source->sources.push_back(source->id);
  source->num_sources = static_cast<int32_t>(source->sources.size());
  altered.bodies[4] = source;
  const MemorySnapshot from_altered = BuildSnapshot(f.memory, f.map, h, 8192, &altered);
  same_as_scratch(from_altered);
  EXPECT_NE(from_altered.bodies[3], altered.bodies[3]);
  EXPECT_NE(from_altered.bodies[4], altered.bodies[4]);
  EXPECT_EQ(from_altered.bodies[5], altered.bodies[5]);
}

DetectedPlace Revisit() {
  DetectedPlace d;
  d.index = 41;
  d.descriptors = Eigen::MatrixXf::Constant(kDim, 3, 0.25f);
  d.members = {4100, 4101, 4102};
  return d;
}

// The portions of `dut` (built without bodies) with its bodies from `body`, byte for byte
// those of `scratch` (built with them).
void ExpectSamePortions(const MemorySnapshot& dut, const MemorySnapshot& scratch,
                        const std::function<std::shared_ptr<const learned_place_v2_t>(int)>& body) {
  ASSERT_EQ(dut.count(), scratch.count());
  EXPECT_EQ(dut.digest, scratch.digest);
  EXPECT_EQ(dut.body_digests, scratch.body_digests);
  memory_portion_v2_t unused;
  for (int32_t i = 0; i < dut.structure_portions; ++i) {
    EXPECT_EQ(LcmBus::Encode(dut.Portion(i, unused)), LcmBus::Encode(scratch.Portion(i))) << i;
  }
  for (int32_t place = 0; place < dut.places; ++place) {
    const int32_t i = dut.structure_portions + place;
    const std::shared_ptr<const learned_place_v2_t> b = body(place);
    ASSERT_TRUE(b) << place;
    EXPECT_EQ(LcmBus::Encode(dut.Portion(i, unused, b.get())), LcmBus::Encode(scratch.Portion(i)))
        << i;
  }
}

// tscd's snapshots hold no body (issue 23: a second copy of the memory): built without them
// they are the snapshot built with them, portion for portion, once each body is read from the
// memory; on the previous one, only the places named changed are hashed again, so a changed
// place left out keeps its stale digest (what the caller's tracking must prevent).
TEST(MemorySnapshot, BuiltWithoutBodiesItEqualsOneWithThemBodiesReadFromTheMemory) {
  auto f = Fixture(40);
  const MemorySnapshot dut =
      BuildSnapshotWithoutBodies(f.memory, f.map, {5, 1, 1, 0}, 8192, nullptr, {});
  for (const auto& b : dut.bodies) EXPECT_EQ(b, nullptr);
  memory_portion_v2_t unused;
  EXPECT_THROW(dut.Portion(dut.structure_portions, unused), std::logic_error);
  const auto from_memory = [&](int place) {
    return std::make_shared<const learned_place_v2_t>(
        BodyOf(f.memory.places()[static_cast<size_t>(place)]));
  };
  ExpectSamePortions(dut, BuildSnapshot(f.memory, f.map, {5, 1, 1, 0}, 8192), from_memory);

  f.memory.Update(7, Revisit());
  const SnapshotHeader h{5, 1, 2, 0};
  const MemorySnapshot scratch = BuildSnapshot(f.memory, f.map, h, 8192);
  ExpectSamePortions(BuildSnapshotWithoutBodies(f.memory, f.map, h, 8192, &dut, {7}), scratch,
                     from_memory);
  const MemorySnapshot untold = BuildSnapshotWithoutBodies(f.memory, f.map, h, 8192, &dut, {});
  EXPECT_EQ(untold.body_digests[7], dut.body_digests[7]);
  EXPECT_NE(untold.digest, scratch.digest);
}

// What lets a snapshot hold no body: it serves the bodies it named from the memory while their
// places are unchanged and from what was kept just before a place changed or the memory was
// replaced, for as long as it is alive, whatever the memory learned since.
TEST(SnapshotBodies, ASnapshotServesTheBodiesItNamedAfterTheMemoryChanged) {
  auto f = Fixture(40);
  SnapshotBodies dut;
  auto first = std::make_shared<const MemorySnapshot>(
      BuildSnapshotWithoutBodies(f.memory, f.map, {5, 1, 1, 0}, 8192, nullptr, {}));
  dut.Track(first);
  const MemorySnapshot first_scratch = BuildSnapshot(f.memory, f.map, {5, 1, 1, 0}, 8192);
  const auto of_first = [&](int place) { return dut.Body(*first, place, f.memory); };
  ExpectSamePortions(*first, first_scratch, of_first);
  EXPECT_EQ(dut.ChangedSince(*first), std::unordered_set<int>{});

  dut.BeforeUpdate(f.memory, 7);
  f.memory.Update(7, Revisit());
  dut.BeforeUpdate(f.memory, 7);  // again: the first body kept stays
  f.memory.Update(7, Revisit());
  f.memory.Learn(Revisit());  // a place beyond the snapshot's
  EXPECT_EQ(dut.ChangedSince(*first), std::unordered_set<int>{7});
  ExpectSamePortions(*first, first_scratch, of_first);

  const SnapshotHeader h{5, 1, 2, 0};
  auto second = std::make_shared<const MemorySnapshot>(
      BuildSnapshotWithoutBodies(f.memory, f.map, h, 8192, first.get(), *dut.ChangedSince(*first)));
  dut.Track(second);
  const MemorySnapshot second_scratch = BuildSnapshot(f.memory, f.map, h, 8192);
  const auto of_second = [&](int place) { return dut.Body(*second, place, f.memory); };
  ExpectSamePortions(*second, second_scratch, of_second);

  // One no longer alive is no longer tracked, nor served.
  EXPECT_EQ(dut.tracked(), 2u);
  first.reset();
  EXPECT_EQ(dut.tracked(), 1u);
  EXPECT_TRUE(dut.Serves(*second));
  EXPECT_EQ(dut.Body(*second, 3, f.memory)->id.local, second_scratch.bodies[3]->id.local);

  // A merge replaces the memory: the snapshots built before withdraw their bodies (a second
  // copy of the memory otherwise) and say nothing of what changed since them.
  dut.BeforeReplace();
  f.memory = Fixture(30).memory;
  EXPECT_FALSE(dut.Serves(*second));
  EXPECT_EQ(dut.Body(*second, 3, f.memory), nullptr);
  EXPECT_EQ(dut.ChangedSince(*second), std::nullopt);
  EXPECT_EQ(dut.tracked(), 0u);

  // A place changed without BeforeUpdate is not served under the digest of its old body.
  auto third = std::make_shared<const MemorySnapshot>(
      BuildSnapshotWithoutBodies(f.memory, f.map, {5, 1, 3, 0}, 8192, nullptr, {}));
  dut.Track(third);
  f.memory.Update(3, Revisit());
  EXPECT_EQ(dut.Body(*third, 3, f.memory), nullptr);
  EXPECT_NE(dut.Body(*third, 4, f.memory), nullptr);
}

// Issue 23, "a 10⁴-place memory changing one place sends ≤ 1 % of the full snapshot's bytes",
// at the descriptor size tscd uses (1200 dimensions; 12 members, fewer than the 32 a place may
// keep, so a smaller body and a larger share for the structure than in operation). The
// structure costs the same per place at any size and the one body a smaller share of more
// places, so what holds for 500 places holds for 10⁴ (bench: BM_SnapshotDeltaBytes).
TEST(MemorySnapshot, OnePlaceChangedSendsUnderOnePercentOfTheSnapshot) {
  auto f = testing_support::MakeRandomMemory(5, 500, 1200, 500, 12);
  const SnapshotHeader h{5, 1, 1, 0};
  const MemorySnapshot before = BuildSnapshot(f.memory, f.map, h, 60000);
  DetectedPlace revisit;
  revisit.index = 501;
  revisit.descriptors = Eigen::MatrixXf::Constant(1200, 3, 0.25f);
  revisit.members = {50100, 50101, 50102};
  f.memory.Update(250, revisit);
  const MemorySnapshot after = BuildSnapshot(f.memory, f.map, h, 60000);
  int64_t full = 0, delta = 0;
  for (const memory_portion_v2_t& p : AllPortions(after)) full += p.getEncodedSize();
  for (int32_t i :
       PortionsBeyond(after, {before.body_digests.begin(), before.body_digests.end()})) {
    delta += after.Portion(i).getEncodedSize();
  }
  std::printf(
      "500 places of 1200 dimensions: full snapshot %lld bytes, one place changed %lld "
      "bytes (%.3f %%)\n",
      static_cast<long long>(full), static_cast<long long>(delta),
      100.0 * static_cast<double>(delta) / static_cast<double>(full));
  EXPECT_LE(static_cast<double>(delta), 0.01 * static_cast<double>(full));
}

TEST(MemorySnapshot, DigestIsDeterministicAndFollowsContent) {
  const auto a = Fixture(10), b = Fixture(10), c = Fixture(11);
  const SnapshotHeader h{5, 1, 1, 0};
  const MemorySnapshot sa = BuildSnapshot(a.memory, a.map, h, 60000);
  EXPECT_EQ(sa.digest, BuildSnapshot(b.memory, b.map, h, 60000).digest);
  EXPECT_NE(sa.digest, BuildSnapshot(c.memory, c.map, h, 60000).digest);
  EXPECT_NE(sa.digest, 0);
}

TEST(MemorySnapshot, EmptyMemoryIsOneStructurePortion) {
  const PlaceMemory empty(2, PlaceMemoryOptions{});
  const MemorySnapshot dut = BuildSnapshot(empty, TopologicalMap{}, {2, 1, 1, 0}, 4096);
  ASSERT_EQ(static_cast<size_t>(dut.count()), 1u);
  EXPECT_EQ(dut.structure_portions, 1);
  EXPECT_EQ(dut.Portion(0).total_places, 0);
  EXPECT_EQ(dut.Portion(0).count, 1);
  EXPECT_EQ(dut.Portion(0).structure_portions, 1);
}

}  // namespace
}  // namespace tsc
