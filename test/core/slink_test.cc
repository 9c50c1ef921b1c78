#include "core/memory/slink.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string>
#include <utility>
#include <vector>

namespace tsc {
namespace {

// Independent single linkage by brute force: repeatedly join the two clusters with the
// smallest minimum pairwise distance. O(n³).
std::vector<double> BruteForceHeights(const std::vector<Eigen::VectorXd>& x) {
  const size_t n = x.size();
  std::vector<std::vector<double>> d(n, std::vector<double>(n));
  for (size_t i = 0; i < n; ++i)
    for (size_t j = 0; j < n; ++j) d[i][j] = (x[i] - x[j]).squaredNorm();
  std::vector<bool> alive(n, true);
  std::vector<double> heights;
  for (size_t step = 0; step + 1 < n; ++step) {
    double best = 1e300;
    size_t bi = 0, bj = 0;
    for (size_t i = 0; i < n; ++i)
      for (size_t j = i + 1; j < n; ++j)
        if (alive[i] && alive[j] && d[i][j] < best) best = d[i][j], bi = i, bj = j;
    heights.push_back(best);
    alive[bj] = false;
    for (size_t k = 0; k < n; ++k) d[bi][k] = d[k][bi] = std::min(d[bi][k], d[bj][k]);
  }
  std::sort(heights.begin(), heights.end());
  return heights;
}

TEST(Slink, IncrementalInsertionMatchesBruteForceSingleLinkage) {
  std::mt19937 rng(42);
  std::normal_distribution<double> normal;
  std::vector<Eigen::VectorXd> points;
  Slink dut;
  for (int n = 0; n < 200; ++n) {
    Eigen::VectorXd p(5);
    for (int d = 0; d < 5; ++d) p[d] = normal(rng) + (n % 4) * 3.0;  // four loose groups
    std::vector<double> dist;
    for (const auto& q : points) dist.push_back((q - p).squaredNorm());
    dut.Insert(dist);
    points.push_back(p);
  }
  const std::vector<DendrogramMerge> merges = ToDendrogram(dut);
  ASSERT_EQ(merges.size(), 199u);
  const std::vector<double> expected = BruteForceHeights(points);
  for (size_t i = 0; i < merges.size(); ++i) {
    EXPECT_NEAR(merges[i].height, expected[i], 1e-9) << "merge " << i;
  }
}

TEST(Slink, DendrogramMergesFormOneTree) {
  Slink dut;
  dut.Insert({});
  dut.Insert({1.0});
  dut.Insert({4.0, 2.0});
  const auto merges = ToDendrogram(dut);
  ASSERT_EQ(merges.size(), 2u);
  EXPECT_DOUBLE_EQ(merges[0].height, 1.0);
  EXPECT_DOUBLE_EQ(merges[1].height, 2.0);
  // The second merge joins point 2 with cluster 3 (the first merge).
  EXPECT_TRUE((merges[1].a == 2 && merges[1].b == 3) || (merges[1].a == 3 && merges[1].b == 2));
}

TEST(Slink, IncrementalOrderMatchesSortedHeightsAndRestore) {
  // order() is maintained incrementally by Insert; it must equal a full sort of (λ(i), i)
  // after every insertion (ties included: distances are small integers) and the order a
  // restored state builds from scratch.
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> dist(0, 6);
  Slink dut;
  for (int n = 0; n < 120; ++n) {
    std::vector<double> d(n);
    for (double& x : d) x = dist(rng);
    dut.Insert(d);
    std::vector<std::pair<double, int>> want;
    for (int i = 0; i + 1 < dut.size(); ++i) want.push_back({dut.lambda()[i], i});
    std::sort(want.begin(), want.end());
    ASSERT_EQ(dut.order(), want) << "after point " << n;
    ASSERT_EQ(Slink(dut.pi(), dut.lambda()).order(), want) << "after point " << n;
  }
}

TEST(Slink, RestoreRejectsInvalidPointerRepresentation) {
  EXPECT_THROW(Slink({0, 1}, {1.0, Slink::kInfinity}), std::invalid_argument);
  EXPECT_THROW(Slink({1}, {1.0, 2.0}), std::invalid_argument);
  EXPECT_NO_THROW(Slink({1, 1}, {1.0, Slink::kInfinity}));
}

TEST(Slink, InsertRejectsWrongDistanceCount) {
  Slink dut;
  EXPECT_THROW(dut.Insert({1.0}), std::invalid_argument);
}

// InsertBounded gives the state Insert gives, whatever valid lower bounds it is handed
// (loose, tight, zero), on points with many tied distances (integer coordinates) and on
// clustered ones, and measures a distance only where needed.
TEST(Slink, InsertBoundedEndsInTheStateInsertReaches) {
  constexpr uint32_t kSeed = 4242;
  SCOPED_TRACE("seed " + std::to_string(kSeed));
  std::mt19937 rng(kSeed);
  long long measured = 0, asked = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const bool ties = trial % 2 == 0;
    const int n = 20 + trial * 3;
    std::uniform_int_distribution<int> grid(0, 4);
    std::normal_distribution<double> noise(0.0, 1.0);
    std::vector<Eigen::VectorXd> x;
    for (int i = 0; i < n; ++i) {
      Eigen::VectorXd v(3);
      const double site = 20.0 * (i % 5);  // five clusters far apart
      for (int k = 0; k < 3; ++k) v[k] = ties ? grid(rng) + site : noise(rng) + site;
      x.push_back(v);
    }
    Slink reference, dut;
    for (int i = 0; i < n; ++i) {
      std::vector<double> exact(static_cast<size_t>(i)), lower(static_cast<size_t>(i));
      std::uniform_real_distribution<double> loose(0.0, 1.0);
      for (int j = 0; j < i; ++j) {
        exact[j] = (x[j] - x[i]).squaredNorm();
        // A third of the trials tight bounds, a third loose, a third mixed with zeros.
        const int kind = trial % 3;
        lower[j] = kind == 0   ? exact[j]
                   : kind == 1 ? exact[j] * loose(rng)
                               : (j % 4 == 0 ? 0.0 : exact[j] * 0.9);
      }
      reference.Insert(exact);
      std::vector<char> seen(static_cast<size_t>(i), 0);
      dut.InsertBounded(lower, [&](int j) {
        EXPECT_FALSE(seen[j]) << "distance " << j << " asked twice";
        seen[j] = 1;
        ++measured;
        return exact[j];
      });
      asked += i;
      ASSERT_EQ(dut.pi(), reference.pi()) << "trial " << trial << ", point " << i;
      ASSERT_EQ(dut.lambda(), reference.lambda()) << "trial " << trial << ", point " << i;
      ASSERT_EQ(dut.order(), reference.order()) << "trial " << trial << ", point " << i;
    }
  }
  // Far clusters are settled by their bounds: fewer than half the distances are measured.
  EXPECT_LT(measured, asked / 2) << measured << " of " << asked;
}

TEST(Slink, InsertBoundedRefusesWrongSizesAndBadValues) {
  Slink s;
  s.Insert({});
  s.Insert({1.0});
  auto one = [](int) { return 1.0; };
  EXPECT_THROW(s.InsertBounded(std::vector<double>{1.0}, one), std::invalid_argument);
  EXPECT_THROW(s.InsertBounded(std::vector<double>{1.0, -1.0}, one), std::invalid_argument);
  EXPECT_THROW(s.InsertBounded(std::vector<double>{0.0, 0.0}, [](int) { return -1.0; }),
               std::invalid_argument);
}

}  // namespace
}  // namespace tsc
