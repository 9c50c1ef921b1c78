#include "core/memory/view_index.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <utility>
#include <vector>

#include "core/memory/place_memory.h"
#include "test/support/synthetic_places.h"

namespace tsc {
namespace {

constexpr int kDim = 200;

// Places grouped in 16 sites, views 3 % apart (test/support/synthetic_places.h).
class Places {
 public:
  explicit Places(uint32_t seed) : places_(seed, kDim, 16, 0.03f) {}
  DetectedPlace Visit(int p, int visit, int views = 10) const {
    return places_.Visit(p, static_cast<uint32_t>(visit), views);
  }

 private:
  testing_support::SyntheticPlaces places_;
};

// Keys `d` as place `place`, its views the descriptors themselves (no view basis).
void Key(ViewIndex& index, int place, const DetectedPlace& d) {
  index.Set(place, d.Mean(), d.descriptors);
}

TEST(ViewIndex, NamesThePlacesWhoseKeysAreNearestInIncreasingOrder) {
  Places places(11);
  ViewIndex index;
  for (int p = 0; p < 200; ++p) Key(index, p, places.Visit(p, 0));
  ASSERT_EQ(index.size(), 200);
  int found = 0;
  for (int p = 0; p < 200; p += 7) {
    const std::vector<int> near = Shortlist(index.Estimate(places.Visit(p, 1).descriptors), 8);
    ASSERT_EQ(near.size(), 8u);
    EXPECT_TRUE(std::is_sorted(near.begin(), near.end()));
    found += std::binary_search(near.begin(), near.end(), p);
  }
  // A fresh visit's place is among the 8 of 200 nearest (every one of 29 here).
  EXPECT_EQ(found, 29);
  // Asked for as many as it holds, or more, the index names every place.
  EXPECT_EQ(Shortlist(index.Estimate(places.Visit(0, 1).descriptors), 500).size(), 200u);
}

TEST(ViewIndex, RekeysAPlaceItAlreadyHolds) {
  Places places(12);
  ViewIndex index;
  for (int p = 0; p < 50; ++p) Key(index, p, places.Visit(p, 0));
  const Eigen::MatrixXf elsewhere = places.Visit(49, 1).descriptors;
  Key(index, 3, places.Visit(49, 2));  // place 3 now looks like place 49
  const std::vector<int> near = Shortlist(index.Estimate(elsewhere), 2);
  EXPECT_EQ(near, (std::vector<int>{3, 49}));
  EXPECT_EQ(index.size(), 50);
  EXPECT_THROW(Key(index, 52, places.Visit(1, 0)), std::out_of_range);
}

// Keys copied from another index (a merge takes over its unchanged places' keys) estimate as
// the keys they copy; keys of another shape or dimension are refused.
TEST(ViewIndex, KeysAppendedFromAnotherIndexEstimateAsItsOwn) {
  Places places(13);
  ViewIndex source;
  for (int p = 0; p < 60; ++p) Key(source, p, places.Visit(p, 0));
  ViewIndex copy;
  for (int p = 59; p >= 0; --p) copy.AppendKeys(source.KeysOf(p));  // reversed
  copy.FileAppended();
  ASSERT_EQ(copy.size(), 60);
  const Eigen::MatrixXf query = ViewIndex::Queries(places.Visit(17, 1).descriptors);
  const std::vector<float> a = source.Estimate(query), b = copy.Estimate(query);
  for (int p = 0; p < 60; ++p) EXPECT_EQ(a[static_cast<size_t>(p)], b[static_cast<size_t>(59 - p)]);
  EXPECT_THROW(source.KeysOf(60), std::out_of_range);
  ViewIndex::PlaceKeys wrong = source.KeysOf(0);
  wrong.dimension = kDim + 1;
  EXPECT_THROW(copy.AppendKeys(wrong), std::invalid_argument);
  wrong = source.KeysOf(0);
  wrong.keys.conservativeResize(2, Eigen::NoChange);
  EXPECT_THROW(copy.AppendKeys(wrong), std::invalid_argument);
  EXPECT_EQ(copy.size(), 60);
}

// The definition by brute force: the `count` smallest (estimate, index) pairs, by index.
TEST(Shortlist, TakesTheSmallestEstimatesAndTheLowerIndexOnTies) {
  std::mt19937 rng(15);
  std::uniform_int_distribution<int> level(0, 9);  // few values: many ties
  for (int size : {1, 5, 40, 1000}) {
    std::vector<float> estimates(static_cast<size_t>(size));
    for (float& e : estimates) e = 0.5f * static_cast<float>(level(rng));
    for (int count : {0, 1, 3, 7, 39, 40, 999, 2000}) {
      std::vector<int> order(estimates.size());
      std::iota(order.begin(), order.end(), 0);
      std::sort(order.begin(), order.end(), [&](int a, int b) {
        return std::pair(estimates[static_cast<size_t>(a)], a) <
               std::pair(estimates[static_cast<size_t>(b)], b);
      });
      order.resize(static_cast<size_t>(std::min(count, size)));
      std::sort(order.begin(), order.end());
      EXPECT_EQ(Shortlist(estimates, count), order) << size << " places, " << count;
    }
  }
}

// The AVX2 kernel and the portable product give the same estimates up to rounding, over more
// keys than one block of the scan and any number of queries.
TEST(ViewIndex, EstimatesAreTheSameWithEitherSimd) {
  Places places(14);
  ViewIndex portable(Simd::kPortable), fastest(FastestSimd());
  for (int p = 0; p < 400; ++p) {  // 1200 keys
    const DetectedPlace d = places.Visit(p, 0);
    Key(portable, p, d);
    Key(fastest, p, d);
  }
  for (int count : {1, 3, 5}) {
    const Eigen::MatrixXf queries = places.Visit(17, 1).descriptors.leftCols(count);
    const std::vector<float> a = portable.Estimate(queries), b = fastest.Estimate(queries);
    ASSERT_EQ(a.size(), b.size());
    // ‖k‖² + ‖q‖² − 2 kᵀq rounds at the scale of the norms (estimates are on it).
    const float tolerance = 1e-5f * 2.0f * queries.colwise().squaredNorm().maxCoeff();
    for (size_t p = 0; p < a.size(); ++p) EXPECT_NEAR(a[p], b[p], tolerance) << p;
    EXPECT_EQ(Shortlist(a, 8), Shortlist(b, 8));
  }
}

// The shortlist changes how much is measured, not what is recognised: a memory of 300 places
// measuring 16 of them per recognition names the same place as one measuring all of them.
TEST(PlaceMemoryShortlist, RecognisesWhatTheExhaustiveSearchRecognises) {
  Places places(13);
  PlaceMemoryOptions options;
  options.shortlist = 16;
  PlaceMemory memory(1, options);
  for (int p = 0; p < 300; ++p) memory.Learn(places.Visit(p, 0));
  PlaceMemoryOptions exhaustive_options = options;
  exhaustive_options.shortlist = 0;
  const PlaceMemory exhaustive = PlaceMemory::Restore(1, exhaustive_options, memory.places(),
                                                      memory.slink(), memory.next_local_id(), {});
  int recognised = 0, correct = 0;
  for (int p = 0; p < 300; p += 5) {
    const DetectedPlace revisit = places.Visit(p, 1, 6);
    const Recognition fast = memory.Recognize(revisit);
    const Recognition full = exhaustive.Recognize(revisit);
    EXPECT_EQ(fast.place, full.place) << "place " << p;
    recognised += fast.place.has_value();
    correct += fast.place == p;
  }
  EXPECT_GT(recognised, 30);  // of 60 revisits: the comparison is about real recognitions
  EXPECT_EQ(correct, recognised);

  // Hybrid recognition starts beside the previous place, far from the revisit: no place under
  // its first nodes is shortlisted (their cost is infinite, and the search climbs on).
  int hybrid_recognised = 0;
  for (int p = 0; p < 300; p += 5) {
    const DetectedPlace revisit = places.Visit(p, 1, 6);
    const int previous = (p + 150) % 300;
    const Recognition fast = memory.Recognize(revisit, previous);
    EXPECT_EQ(fast.place, exhaustive.Recognize(revisit, previous).place) << "place " << p;
    hybrid_recognised += fast.place.has_value();
  }
  EXPECT_GT(hybrid_recognised, 30);

  // Only the shortlist is measured: the other places are infinitely far.
  const Votes votes = memory.VotePoints(places.Visit(7, 1));
  const ViewDistances vd = memory.DistancesOf(votes.views, memory.DistanceUnit());
  int measured = 0;
  for (int p = 0; p < vd.num_places(); ++p) measured += std::isfinite(vd.distance(0, p));
  EXPECT_EQ(measured, 16);
  EXPECT_TRUE(std::isfinite(vd.distance(0, 7)));
}

}  // namespace
}  // namespace tsc
