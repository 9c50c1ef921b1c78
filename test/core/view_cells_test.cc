#include "core/memory/view_cells.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "core/memory/view_index.h"
#include "test/support/synthetic_places.h"

namespace tsc {
namespace {

constexpr int kDim = 32;
constexpr int kGroup = 3;  // keys per place, as the view index files them
constexpr uint32_t kSeed = 2311;

// `rows` keys (a row each) around 40 cluster centres, from a fixed seed.
Eigen::MatrixXf ClusteredKeys(Eigen::Index rows, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, 1.0f);
  Eigen::MatrixXf centres(40, kDim);
  for (Eigen::Index i = 0; i < centres.size(); ++i) centres.data()[i] = 10.0f * noise(rng);
  Eigen::MatrixXf keys(rows, kDim);
  for (Eigen::Index r = 0; r < rows; ++r) {
    keys.row(r) = centres.row(r % centres.rows());
    for (int d = 0; d < kDim; ++d) keys(r, d) += noise(rng);
  }
  return keys;
}

// The smallest ‖k − q‖² over each group's keys and the queries, every key read.
std::vector<float> ExactEstimates(const Eigen::MatrixXf& keys, const Eigen::MatrixXf& queries) {
  std::vector<float> out(static_cast<size_t>(keys.rows() / kGroup),
                         std::numeric_limits<float>::infinity());
  for (Eigen::Index r = 0; r < keys.rows(); ++r) {
    for (Eigen::Index j = 0; j < queries.cols(); ++j) {
      float& e = out[static_cast<size_t>(r / kGroup)];
      e = std::min(e, (keys.row(r).transpose() - queries.col(j)).squaredNorm());
    }
  }
  return out;
}

ViewCells Trained(const Eigen::MatrixXf& keys, Simd simd) {
  ViewCells cells;
  cells.Train(keys, keys.rows(), simd);
  return cells;
}

TEST(ViewCells, ReadingEveryCellGivesEveryGroupsExactEstimate) {
  SCOPED_TRACE("seed " + std::to_string(kSeed));
  const Eigen::MatrixXf keys = ClusteredKeys(3 * 12000, kSeed);
  const Eigen::MatrixXf queries = keys.row(100).transpose() * Eigen::RowVectorXf::Ones(2) +
                                  Eigen::MatrixXf::Constant(kDim, 2, 0.5f);
  const Eigen::RowVectorXf norms = queries.colwise().squaredNorm();
  for (Simd simd : {Simd::kPortable, FastestSimd()}) {
    const ViewCells cells = Trained(keys, simd);
    ASSERT_TRUE(cells.trained());
    const std::vector<float> exact = ExactEstimates(keys, queries);
    const std::vector<float> read = cells.Estimate(queries, norms, static_cast<int>(exact.size()),
                                                   kGroup, static_cast<int>(keys.rows()));
    ASSERT_EQ(read.size(), exact.size());
    for (size_t g = 0; g < exact.size(); ++g)
      ASSERT_NEAR(read[g], exact[g], 1e-3f * (1.0f + exact[g])) << "group " << g;
  }
}

TEST(ViewCells, ReadingTheNearestCellsFindsTheNearestGroupsAndNoGroupNearerThanItIs) {
  SCOPED_TRACE("seed " + std::to_string(kSeed));
  const Eigen::MatrixXf keys = ClusteredKeys(3 * 12000, kSeed + 1);
  const ViewCells cells = Trained(keys, FastestSimd());
  int found = 0;
  for (int target = 0; target < 12000; target += 997) {
    const Eigen::MatrixXf queries = keys.row(3 * target + 1).transpose();
    const std::vector<float> exact = ExactEstimates(keys, queries);
    // A few percent of the keys: the cells nearest the query.
    const std::vector<float> read = cells.Estimate(queries, queries.colwise().squaredNorm(),
                                                   static_cast<int>(exact.size()), kGroup, 1024);
    found += read[static_cast<size_t>(target)] < 1e-3f;
    // A key read is measured, so never nearer than the group's true distance; a group read
    // only in part or not at all may stand at the one distance the unread cells are expected
    // at. So every group estimated nearer than it is stands at that one value.
    std::vector<float> nearer;
    for (size_t g = 0; g < exact.size(); ++g) {
      if (read[g] < exact[g] - 1e-3f * (1.0f + exact[g])) nearer.push_back(read[g]);
    }
    EXPECT_TRUE(std::all_of(nearer.begin(), nearer.end(),
                            [&nearer](float e) { return e == nearer.front(); }));
  }
  // The query's own key is filed under its nearest centroid: that cell is read first.
  EXPECT_EQ(found, 13);
}

TEST(ViewCells, AKeyFiledAgainMovesToItsNewCell) {
  const Eigen::MatrixXf original = ClusteredKeys(3 * 8000, kSeed + 2);
  Eigen::MatrixXf keys = original;
  ViewCells cells = Trained(keys, FastestSimd());
  // Group 5's keys take group 4000's values: read from group 4000's neighbourhood, both are
  // at distance zero.
  for (int k = 0; k < kGroup; ++k) {
    keys.row(3 * 5 + k) = original.row(3 * 4000 + k);
    cells.File(keys, 3 * 5 + k, keys.row(3 * 5 + k).squaredNorm());
  }
  const Eigen::MatrixXf queries = original.row(3 * 4000).transpose();
  const std::vector<float> read =
      cells.Estimate(queries, queries.colwise().squaredNorm(), 8000, kGroup, 1024);
  EXPECT_LT(read[4000], 1e-3f);
  EXPECT_LT(read[5], 1e-3f);
}

TEST(ViewCells, RefusesToEstimateOrFileBeforeTraining) {
  ViewCells cells;
  const Eigen::MatrixXf keys = ClusteredKeys(30, kSeed);
  EXPECT_FALSE(cells.trained());
  EXPECT_THROW(cells.File(keys, 0, 1.0f), std::logic_error);
  EXPECT_THROW(cells.Estimate(keys.row(0).transpose(), Eigen::RowVectorXf::Ones(1), 10, kGroup, 9),
               std::logic_error);
  EXPECT_THROW(cells.Train(keys, 0, Simd::kPortable), std::invalid_argument);
}

// The view index trains its cells at ViewIndex::kCellsFrom places: past it, a fresh visit's
// place is still among the shortlist's, as without cells.
TEST(ViewIndexCells, AFreshVisitsPlaceIsShortlistedPastTheCellsThreshold) {
  SCOPED_TRACE("seed " + std::to_string(kSeed));
  testing_support::SyntheticPlaces places(kSeed, 64, 256, 0.03f);
  ViewIndex with_cells, without(FastestSimd(), false);
  const int n = ViewIndex::kCellsFrom + 100;
  for (int p = 0; p < n; ++p) {
    const DetectedPlace d = places.Visit(p, 0, 6);
    with_cells.Set(p, d.Mean(), d.descriptors);
    without.Set(p, d.Mean(), d.descriptors);
  }
  int with_found = 0, without_found = 0;
  for (int p = 0; p < n; p += n / 40) {
    const Eigen::MatrixXf queries = ViewIndex::Queries(places.Visit(p, 1, 6).descriptors);
    const std::vector<int> a = Shortlist(with_cells.Estimate(queries), 32);
    const std::vector<int> b = Shortlist(without.Estimate(queries), 32);
    with_found += std::binary_search(a.begin(), a.end(), p);
    without_found += std::binary_search(b.begin(), b.end(), p);
  }
  EXPECT_GT(without_found, 0);
  EXPECT_EQ(with_found, without_found);
}

// A restore appends every place and files them once (ViewIndex::FileAppended): the cells then
// give the estimates that Set, one place at a time, gives, past the threshold and a doubling
// of it (trained at kCellsFrom and 2·kCellsFrom places, the later keys filed), whether the cells
// are found on one thread or three. And an index refuses to estimate with places appended but
// not filed.
TEST(ViewIndexCells, AppendingThenFilingOnceEqualsSettingEachPlace) {
  SCOPED_TRACE("seed " + std::to_string(kSeed));
  testing_support::SyntheticPlaces places(kSeed, 64, 256, 0.03f);
  ViewIndex one_by_one, appended, on_threads;
  const int n = 2 * ViewIndex::kCellsFrom + 300;
  for (int p = 0; p < n; ++p) {
    const DetectedPlace d = places.Visit(p, 0, 4);
    one_by_one.Set(p, d.Mean(), d.descriptors);
    appended.Append(d.Mean(), d.descriptors);
    on_threads.Append(d.Mean(), d.descriptors);
    if (p == 10) {
      EXPECT_THROW(appended.Estimate(ViewIndex::Queries(d.descriptors)), std::logic_error);
      appended.FileAppended();  // a first run, below the threshold
      on_threads.FileAppended(3);
    }
  }
  appended.FileAppended();
  on_threads.FileAppended(3);
  for (int p = 0; p < n; p += n / 25) {
    const Eigen::MatrixXf queries = ViewIndex::Queries(places.Visit(p, 1, 4).descriptors);
    const std::vector<float> a = one_by_one.Estimate(queries), b = appended.Estimate(queries),
                             c = on_threads.Estimate(queries);
    ASSERT_EQ(a.size(), b.size());
    ASSERT_EQ(a.size(), c.size());
    int same = 0, same_on_threads = 0;
    for (size_t i = 0; i < a.size(); ++i) {
      same += a[i] == b[i];
      same_on_threads += a[i] == c[i];
    }
    EXPECT_EQ(same, static_cast<int>(a.size())) << "query of place " << p;
    EXPECT_EQ(same_on_threads, static_cast<int>(a.size())) << "query of place " << p;
  }
}

}  // namespace
}  // namespace tsc
