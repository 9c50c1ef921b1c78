#include "core/memory/member_views.h"

#include <gtest/gtest.h>

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

// Views on a small integer grid, so many pairs lie at exactly the same distance (the ties the
// rule orders), and a few repeated views (distance 0).
TEST(ThinViews, KeepsWhatDroppingTheCloserPairOneAtATimeKeeps) {
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
        const Eigen::MatrixXf thinned = ThinViews(pool, cap);
        ASSERT_EQ(thinned.cols(), expected.cols()) << n << " " << cap;
        EXPECT_EQ(thinned, expected) << "n " << n << ", cap " << cap << ", trial " << trial;
        ++pools;
      }
    }
  }
  EXPECT_EQ(pools, 120);
}

}  // namespace
}  // namespace tsc
