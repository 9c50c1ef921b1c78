#include "daemon/snapshot_assembler.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "test/support/random_memory.h"

namespace tsc {
namespace {

constexpr int kDim = 64;

MemorySnapshot MakeSnapshot(int places, int64_t version, int portion_bytes = 6000) {
  const auto m = testing_support::MakeRandomMemory(2, places, kDim, static_cast<unsigned>(places));
  return BuildSnapshot(m.memory, m.map, {2, 77, version, 1}, portion_bytes);
}

TEST(SnapshotAssembler, CompletesFromShuffledDuplicatedPortionsAfterAskingForTheLostOne) {
  const MemorySnapshot snap = MakeSnapshot(30, 4);
  ASSERT_GE(snap.portions.size(), 3u);
  std::vector<memory_portion_t> order = snap.portions;
  std::mt19937 rng(1);
  std::shuffle(order.begin(), order.end(), rng);
  const memory_portion_t lost = order.back();
  order.pop_back();
  order.push_back(order.front());  // a duplicate

  SnapshotAssembler dut(2);
  for (const memory_portion_t& p : order) {
    const auto r = dut.Accept(p);
    EXPECT_NE(r.verdict, SnapshotAssembler::Verdict::kRejected) << r.reason;
  }
  EXPECT_FALSE(dut.complete());
  EXPECT_EQ(dut.Missing(), std::vector<int32_t>{lost.index});
  EXPECT_EQ(dut.Accept(lost).verdict, SnapshotAssembler::Verdict::kAccepted);
  ASSERT_TRUE(dut.complete());
  std::string reason;
  const auto got = dut.Take(&reason);
  ASSERT_TRUE(got.has_value()) << reason;
  EXPECT_EQ(got->places.size(), 30u);
  EXPECT_EQ(got->version, 4);
  EXPECT_EQ(got->edges.size(), 29u);
  std::vector<learned_place_t> sent;
  for (const memory_portion_t& p : snap.portions)
    sent.insert(sent.end(), p.places.begin(), p.places.end());
  ASSERT_EQ(sent.size(), 30u);
  for (size_t i = 0; i < sent.size(); ++i) EXPECT_EQ(got->places[i].mean, sent[i].mean) << i;
  int32_t expected_local = 1;
  for (const learned_place_t& p : got->places) EXPECT_EQ(p.id.local, expected_local++);
}

TEST(SnapshotAssembler, RejectsForeignNonFiniteAndInconsistentPortions) {
  const MemorySnapshot snap = MakeSnapshot(12, 1);
  SnapshotAssembler dut(2);
  memory_portion_t other = snap.portions[0];
  other.robot = 3;
  EXPECT_EQ(dut.Accept(other).verdict, SnapshotAssembler::Verdict::kRejected);

  memory_portion_t nan = snap.portions[0];
  ASSERT_FALSE(nan.places.empty());
  nan.places[0].mean[3] = std::nanf("");
  EXPECT_EQ(dut.Accept(nan).verdict, SnapshotAssembler::Verdict::kRejected);

  memory_portion_t inf = snap.portions[0];
  inf.places[0].samples[0][1] = INFINITY;
  EXPECT_EQ(dut.Accept(inf).verdict, SnapshotAssembler::Verdict::kRejected);

  memory_portion_t lengths = snap.portions[0];
  lengths.num_places += 1;
  EXPECT_EQ(dut.Accept(lengths).verdict, SnapshotAssembler::Verdict::kRejected);

  memory_portion_t index = snap.portions[0];
  index.index = index.count;
  EXPECT_EQ(dut.Accept(index).verdict, SnapshotAssembler::Verdict::kRejected);
  EXPECT_FALSE(dut.started());  // nothing kept
}

TEST(SnapshotAssembler, TamperedContentFailsTheDigest) {
  const MemorySnapshot snap = MakeSnapshot(8, 1);
  SnapshotAssembler dut(2);
  for (memory_portion_t p : snap.portions) {
    if (!p.places.empty()) p.places[0].mean[0] += 0.25f;  // finite, plausible, wrong
    ASSERT_EQ(dut.Accept(p).verdict, SnapshotAssembler::Verdict::kAccepted);
  }
  std::string reason;
  EXPECT_FALSE(dut.Take(&reason).has_value());
  EXPECT_EQ(reason, "digest mismatch");
  EXPECT_FALSE(dut.started());
}

TEST(SnapshotAssembler, NewerVersionRestartsOlderIsStale) {
  const MemorySnapshot v1 = MakeSnapshot(8, 1);
  const MemorySnapshot v2 = MakeSnapshot(9, 2);
  SnapshotAssembler dut(2);
  ASSERT_EQ(dut.Accept(v1.portions[0]).verdict, SnapshotAssembler::Verdict::kAccepted);
  ASSERT_EQ(dut.Accept(v2.portions[0]).verdict, SnapshotAssembler::Verdict::kAccepted);
  EXPECT_EQ(dut.version(), 2);
  EXPECT_EQ(dut.Accept(v1.portions[0]).verdict, SnapshotAssembler::Verdict::kStale);
  for (const memory_portion_t& p : v2.portions) dut.Accept(p);
  std::string reason;
  const auto got = dut.Take(&reason);
  ASSERT_TRUE(got.has_value()) << reason;
  EXPECT_EQ(got->places.size(), 9u);
}

TEST(SnapshotAssembler, BrokenTreeIsRefusedAsAWhole) {
  MemorySnapshot snap = MakeSnapshot(6, 1, 60000);
  ASSERT_EQ(snap.portions.size(), 1u);
  memory_portion_t p = snap.portions[0];
  ASSERT_GE(p.nodes.size(), 2u);
  p.nodes.back().children.push_back(p.nodes.back().index);  // a node its own child
  p.nodes.back().num_children += 1;
  SnapshotAssembler dut(2);
  ASSERT_EQ(dut.Accept(p).verdict, SnapshotAssembler::Verdict::kAccepted);
  std::string reason;
  EXPECT_FALSE(dut.Take(&reason).has_value());
  EXPECT_FALSE(reason.empty());
}

}  // namespace
}  // namespace tsc
