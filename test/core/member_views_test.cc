#include "core/memory/member_views.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <random>
#include <vector>

namespace tsc {
namespace {

// ThinViews as its contract states it, pair by pair: while more than `cap` remain, drop the
// later view of the closest kept pair, ties to the earlier pair in column order.
Eigen::MatrixXf ThinByEveryPair(const Eigen::MatrixXf& pool, int cap) {
  const Eigen::Index n = pool.cols();
  std::vector<char> kept(static_cast<size_t>(n), 1);
  for (Eigen::Index left = n; left > cap; --left) {
    float best = std::numeric_limits<float>::infinity();
    Eigen::Index drop = -1;
    for (Eigen::Index j = 1; j < n; ++j) {
      for (Eigen::Index i = 0; i < j; ++i) {
        if (!kept[static_cast<size_t>(i)] || !kept[static_cast<size_t>(j)]) continue;
        const float d = (pool.col(i) - pool.col(j)).squaredNorm();
        if (d < best) {
          best = d;
          drop = j;
        }
      }
    }
    if (drop < 0) break;  // no finite pair left (the grids here always have one)
    kept[static_cast<size_t>(drop)] = 0;
  }
  std::vector<Eigen::Index> columns;
  for (Eigen::Index j = 0; j < n; ++j) {
    if (kept[static_cast<size_t>(j)]) columns.push_back(j);
  }
  Eigen::MatrixXf out(pool.rows(), static_cast<Eigen::Index>(columns.size()));
  for (size_t c = 0; c < columns.size(); ++c)
    out.col(static_cast<Eigen::Index>(c)) = pool.col(columns[c]);
  return out;
}

// ViewSpacing as its contract states it: the upper median of each view's squared distance to
// its nearest other view.
double SpacingByEveryPair(const Eigen::MatrixXf& views) {
  std::vector<float> nearest;
  for (Eigen::Index j = 0; j < views.cols(); ++j) {
    float least = std::numeric_limits<float>::infinity();
    for (Eigen::Index i = 0; i < views.cols(); ++i) {
      if (i != j) least = std::min(least, (views.col(i) - views.col(j)).squaredNorm());
    }
    nearest.push_back(least);
  }
  std::nth_element(nearest.begin(), nearest.begin() + nearest.size() / 2, nearest.end());
  return nearest[nearest.size() / 2];
}

// The instruction sets a test runs on: the build's own, and AVX2 where the CPU has it.
std::vector<Simd> InstructionSets() {
  std::vector<Simd> sets = {Simd::kPortable};
  if (FastestSimd() == Simd::kAvx2Fma) sets.push_back(Simd::kAvx2Fma);
  return sets;
}

// Views on a small integer grid, so many pairs lie at exactly the same distance (the ties the
// rule orders), and a few repeated views (distance 0); on each instruction set, and through
// SummariseViews, which thins with the distances its spacing measured.
TEST(ThinViews, KeepsWhatDroppingTheCloserPairOneAtATimeKeeps) {
  for (Simd simd : InstructionSets()) {
    SCOPED_TRACE(simd == Simd::kPortable ? "portable" : "AVX2");
    std::mt19937 rng(3);  // fixed seed: the same pools every run
    std::uniform_int_distribution<int> coordinate(0, 3);
    int pools = 0;
    for (int n : {2, 5, 12, 24, 40, 64}) {
      for (int cap : {1, 2, 8, 12}) {
        for (int trial = 0; trial < 5; ++trial) {
          Eigen::MatrixXf pool(6, n);
          for (Eigen::Index i = 0; i < pool.size(); ++i)
            pool.data()[i] = static_cast<float>(coordinate(rng));
          if (n > 3) pool.col(n - 1) = pool.col(1);
          const Eigen::MatrixXf expected = n <= cap ? pool : ThinByEveryPair(pool, cap);
          const Eigen::MatrixXf thinned = ThinViews(pool, cap, simd);
          ASSERT_EQ(thinned.cols(), expected.cols()) << n << " " << cap;
          EXPECT_EQ(thinned, expected) << "n " << n << ", cap " << cap << ", trial " << trial;
          const ViewSummary summary = SummariseViews(pool, cap, simd);
          EXPECT_EQ(summary.spread, expected) << "n " << n << ", cap " << cap;
          EXPECT_EQ(summary.spacing, SpacingByEveryPair(pool)) << "n " << n << ", cap " << cap;
          EXPECT_EQ(ViewSpacing(pool, simd), summary.spacing);
          ++pools;
        }
      }
    }
    EXPECT_EQ(pools, 120);
  }
}

// Vote points taken from 8-bit views are the decoded views' evenly spaced columns, whether the
// place holds fewer views than the cap, as many, or more.
TEST(EvenlySpaced, FromEightBitViewsDecodesTheColumnsTheFloatsWouldGive) {
  std::mt19937 rng(32);  // fixed seed: the same views every run
  std::normal_distribution<float> normal;
  for (int n : {1, 31, 32, 33, 64, 100}) {
    Eigen::MatrixXf views(20, n);
    for (Eigen::Index i = 0; i < views.size(); ++i) views.data()[i] = normal(rng) * 0.01f;
    const CompactViews compact(views);
    const Eigen::MatrixXf expected = EvenlySpaced(compact.Decoded(), 32);
    EXPECT_EQ(expected.cols(), std::min(n, 32));
    EXPECT_EQ(EvenlySpaced(compact, 32), expected) << n << " views";
  }
}

}  // namespace
}  // namespace tsc
