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
