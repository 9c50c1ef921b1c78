#include "tools/events_json.h"

#include <gtest/gtest.h>

#include <limits>

namespace tsc {
namespace {

// A learned place says why it was not recognised: the cost that failed τ_r and its terms.
TEST(EventsJson, LearnedAndRecognisedCarryTheCostAndItsTerms) {
  PlaceEvent e;
  e.kind = EventKind::kLearned;
  e.frame = 41;
  e.detected_place = 3;
  e.place = PlaceId{1, 4};
  e.cost = 2.75;
  e.terms.best = 0;
  e.terms.distance = 1.5;
  e.terms.ratio = 0.75;
  e.terms.vote = 0.5;
  e.terms.agreement = 0.25;
  EXPECT_EQ(EventToJson(e),
            "{\"frame\":41,\"event\":\"learned\",\"detected_place\":3,\"place\":\"1:4\","
            "\"cost\":2.75,\"terms\":{\"distance\":1.5,\"ratio\":0.75,\"vote\":0.5,"
            "\"agreement\":0.25}}");
  e.kind = EventKind::kRecognized;
  e.hybrid = true;
  EXPECT_EQ(EventToJson(e),
            "{\"frame\":41,\"event\":\"recognized\",\"detected_place\":3,\"place\":\"1:4\","
            "\"cost\":2.75,\"terms\":{\"distance\":1.5,\"ratio\":0.75,\"vote\":0.5,"
            "\"agreement\":0.25},\"partial\":false,\"hybrid\":true,\"neighbour\":false}");
  e.neighbour = true;
  EXPECT_NE(EventToJson(e).find("\"hybrid\":true,\"neighbour\":true}"), std::string::npos);
}

// The first place is learned with no g_N evaluated: no terms, and an infinite cost is null.
TEST(EventsJson, NoTermsWithoutACostAndNullForAnInfiniteOne) {
  PlaceEvent e;
  e.kind = EventKind::kLearned;
  e.place = PlaceId{2, 1};
  e.cost = std::numeric_limits<double>::infinity();
  EXPECT_EQ(EventToJson(e),
            "{\"frame\":0,\"event\":\"learned\",\"detected_place\":0,\"place\":\"2:1\","
            "\"cost\":null}");
}

// An ambiguous place has a cost but no place; a near miss says so.
TEST(EventsJson, AnAmbiguousPlaceSaysWhetherItWasANearMiss) {
  PlaceEvent e;
  e.kind = EventKind::kAmbiguous;
  e.frame = 7;
  e.detected_place = 2;
  e.cost = 3.5;
  e.terms.best = 1;
  e.terms.distance = 2;
  e.terms.ratio = 0.5;
  e.terms.vote = 0.5;
  e.terms.agreement = 1;
  const std::string disagreed =
      "{\"frame\":7,\"event\":\"ambiguous\",\"detected_place\":2,\"cost\":3.5,\"terms\":{"
      "\"distance\":2,\"ratio\":0.5,\"vote\":0.5,\"agreement\":1}";
  EXPECT_EQ(EventToJson(e), disagreed + "}");
  e.near_miss = true;
  EXPECT_EQ(EventToJson(e), disagreed + ",\"near_miss\":true}");
}

}  // namespace
}  // namespace tsc
