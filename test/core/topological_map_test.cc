#include "core/map/topological_map.h"

#include <gtest/gtest.h>

namespace tsc {
namespace {

TEST(TopologicalMap, RecordsUndirectedEdgesWithTraversalsAndRegions) {
  TopologicalMap dut;
  const PlaceId a{1, 1}, b{1, 2};
  EXPECT_TRUE(dut.RecordTransition(a, b, TransitionRegion{10, 14}));
  EXPECT_TRUE(dut.RecordTransition(b, a, TransitionRegion{40, 41}));
  ASSERT_EQ(dut.edges().size(), 1u);
  const MapEdge* e = dut.Find(b, a);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->traversals, 2);
  EXPECT_EQ(e->a, a);
  ASSERT_EQ(e->transitions.size(), 2u);
  EXPECT_EQ(e->transitions[1], (TransitionRegion{40, 41}));
  EXPECT_EQ(dut.places().size(), 2u);
}

// Over months an edge is crossed without end: it counts every crossing and keeps the latest
// regions only, also when a restore (a merge's collapse) hands it more.
TEST(TopologicalMap, AnEdgeKeepsItsLatestTransitionRegions) {
  constexpr int64_t kCrossings = MapEdge::kMaxTransitions + 100;
  TopologicalMap dut;
  const PlaceId a{1, 1}, b{1, 2};
  for (int64_t i = 0; i < kCrossings; ++i) {
    dut.RecordTransition(i % 2 ? a : b, i % 2 ? b : a, TransitionRegion{10 * i, 10 * i + 3});
  }
  const MapEdge* e = dut.Find(a, b);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->traversals, kCrossings);
  ASSERT_EQ(e->transitions.size(), MapEdge::kMaxTransitions);
  EXPECT_EQ(e->transitions.front().first, 10 * (kCrossings - MapEdge::kMaxTransitions));
  EXPECT_EQ(e->transitions.back().first, 10 * (kCrossings - 1));

  // Two edges' regions joined out of order: the latest by first base point stay, in order.
  MapEdge joined{a, b, 5, {}};
  for (int64_t i = kCrossings - 1; i >= 0; --i) joined.transitions.push_back({2 * i, 2 * i});
  TopologicalMap restored;
  restored.RestoreEdge(joined);
  const MapEdge* r = restored.Find(a, b);
  ASSERT_NE(r, nullptr);
  ASSERT_EQ(r->transitions.size(), MapEdge::kMaxTransitions);
  EXPECT_EQ(r->transitions.front().first, 2 * (kCrossings - MapEdge::kMaxTransitions));
  EXPECT_EQ(r->transitions.back().first, 2 * (kCrossings - 1));
  EXPECT_EQ(r->traversals, 5);
}

TEST(TopologicalMap, SelfTransitionAddsNoEdge) {
  TopologicalMap dut;
  EXPECT_FALSE(dut.RecordTransition({1, 1}, {1, 1}, {}));
  EXPECT_TRUE(dut.edges().empty());
  EXPECT_THROW(dut.RestoreEdge(MapEdge{{1, 1}, {1, 1}, 1, {}}), std::invalid_argument);
}

// Both ends of an edge name each other, whichever id is smaller and whoever learned them.
TEST(TopologicalMap, NeighboursAreThePlacesAnEdgeJoinsToAPlace) {
  TopologicalMap dut;
  const PlaceId a{1, 1}, b{1, 2}, c{2, 1}, d{1, 3};
  dut.RecordTransition(b, a, {});
  dut.RecordTransition(b, c, {});
  dut.RecordTransition(d, b, {});
  dut.RecordTransition(a, d, {});
  EXPECT_EQ(dut.Neighbours(b), (std::vector<PlaceId>{a, d, c}));
  EXPECT_EQ(dut.Neighbours(a), (std::vector<PlaceId>{b, d}));
  EXPECT_EQ(dut.Neighbours(c), (std::vector<PlaceId>{b}));
  EXPECT_TRUE(dut.Neighbours(PlaceId{3, 1}).empty());
}

}  // namespace
}  // namespace tsc
