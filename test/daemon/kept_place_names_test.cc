#include "daemon/kept_place_names.h"

#include <gtest/gtest.h>

namespace tsc {
namespace {

TEST(KeptPlaceNames, FindsEachBodyByDigestWithItsSourcesSorted) {
  const KeptPlaceNames names(
      700, {{-5, PlaceId{2, 3}, {PlaceId{3, 9}, PlaceId{1, 4}, PlaceId{3, 1}}},
            {42, PlaceId{2, 1}, {}},
            {7, PlaceId{2, 2}, {PlaceId{1, 1}}},
            {42, PlaceId{2, 9}, {PlaceId{1, 2}}}});  // a digest again: the first name stays
  EXPECT_EQ(names.dims(), 700);
  EXPECT_EQ(names.size(), 3u);
  const auto three = names.Find(-5);
  ASSERT_TRUE(three.has_value());
  EXPECT_EQ(three->id, (PlaceId{2, 3}));
  const std::vector<PlaceId> sorted{PlaceId{1, 4}, PlaceId{3, 1}, PlaceId{3, 9}};
  EXPECT_EQ(std::vector<PlaceId>(three->sources.begin(), three->sources.end()), sorted);
  const auto one = names.Find(42);
  ASSERT_TRUE(one.has_value());
  EXPECT_EQ(one->id, (PlaceId{2, 1}));
  EXPECT_TRUE(one->sources.empty());
  const auto two = names.Find(7);
  ASSERT_TRUE(two.has_value());
  ASSERT_EQ(two->sources.size(), 1u);
  EXPECT_EQ(two->sources[0], (PlaceId{1, 1}));
  EXPECT_FALSE(names.Find(8).has_value());
  EXPECT_FALSE(KeptPlaceNames().Find(42).has_value());
}

}  // namespace
}  // namespace tsc
