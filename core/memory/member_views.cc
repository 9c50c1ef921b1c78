#include "core/memory/member_views.h"

#include <algorithm>
#include <limits>
#include <vector>

#include "core/assert.h"
#include "core/median.h"
#include "core/memory/simd.h"

namespace tsc {
namespace {

// Squared distances between the columns of `x` (n x n, symmetric, zero diagonal).
Eigen::MatrixXf PairwiseSquared(const Eigen::MatrixXf& x) {
  const Eigen::Index n = x.cols();
  Eigen::VectorXf sq(n);
  Eigen::MatrixXf d(n, n);
  if (FastestSimd() == Simd::kAvx2Fma) {
    // A place's dozen views: Eigen's product packed both sides for every place (a quarter of
    // a 10⁴ + 10⁴ merge's restore, which measures every place's spacing and spread views).
    avx2::ColumnDots(x.data(), static_cast<int>(n), x.data(), static_cast<int>(n),
                     static_cast<int>(x.rows()), d.data(), sq.data());
    d *= -2.0f;
  } else {
    sq = x.colwise().squaredNorm().transpose();
    d = -2.0f * (x.transpose() * x);
  }
  d.colwise() += sq;
  d.rowwise() += sq.transpose();
  d = d.cwiseMax(0.0f);
  d.diagonal().setZero();
  return d;
}

}  // namespace

Eigen::MatrixXf EvenlySpaced(const Eigen::MatrixXf& x, int cap) {
  const Eigen::Index n = x.cols();
  if (n <= cap) return x;
  Eigen::MatrixXf out(x.rows(), cap);
  for (int j = 0; j < cap; ++j) out.col(j) = x.col(static_cast<Eigen::Index>(j) * n / cap);
  return out;
}

namespace {

// ThinViews with the pool's pairwise squared distances `d` given (n > cap).
Eigen::MatrixXf Thinned(const Eigen::MatrixXf& pool, int cap, const Eigen::MatrixXf& d) {
  const Eigen::Index n = pool.cols();
  std::vector<char> kept(static_cast<size_t>(n), 1);
  // Each kept view's nearest earlier kept view (−1: none), so a round looks at n views
  // instead of n² pairs; only views whose nearest was dropped look again.
  std::vector<Eigen::Index> earlier(static_cast<size_t>(n), -1);
  auto nearest_earlier = [&](Eigen::Index j) {
    Eigen::Index at = -1;
    for (Eigen::Index i = 0; i < j; ++i) {
      if (kept[static_cast<size_t>(i)] && (at < 0 || d(i, j) < d(at, j))) at = i;
    }
    return at;
  };
  // Each kept view's distance to its nearest earlier kept view (infinite when it has none or
  // is dropped), side by side: a round scans one row of floats instead of looking each pair up
  // in `d` (the lookups were a tenth of a 10⁴ + 10⁴ merge, which thins 64 views to 2).
  std::vector<float> to_earlier(static_cast<size_t>(n), std::numeric_limits<float>::infinity());
  auto link = [&](Eigen::Index j) {
    const Eigen::Index i = nearest_earlier(j);
    earlier[static_cast<size_t>(j)] = i;
    to_earlier[static_cast<size_t>(j)] = i >= 0 ? d(i, j) : std::numeric_limits<float>::infinity();
  };
  for (Eigen::Index j = 1; j < n; ++j) link(j);
  for (Eigen::Index left = n; left > cap; --left) {
    // The closest pair among the kept views; ties go to the earlier pair in column order
    // (the later view of the lowest-ordered pair (j, i) is dropped).
    float best = std::numeric_limits<float>::infinity();
    Eigen::Index drop = -1;
    for (Eigen::Index j = 1; j < n; ++j) {
      if (to_earlier[static_cast<size_t>(j)] < best) {
        best = to_earlier[static_cast<size_t>(j)];
        drop = j;
      }
    }
    TSC_ASSERT(drop >= 0, "at least two finite views are kept while more than cap are");
    if (drop < 0) break;
    kept[static_cast<size_t>(drop)] = 0;
    to_earlier[static_cast<size_t>(drop)] = std::numeric_limits<float>::infinity();
    for (Eigen::Index j = drop + 1; j < n; ++j) {
      if (kept[static_cast<size_t>(j)] && earlier[static_cast<size_t>(j)] == drop) link(j);
    }
  }
  Eigen::MatrixXf out(pool.rows(), std::count(kept.begin(), kept.end(), 1));
  Eigen::Index c = 0;
  for (Eigen::Index j = 0; j < n; ++j) {
    if (kept[static_cast<size_t>(j)]) out.col(c++) = pool.col(j);
  }
  return out;
}

// ViewSpacing from the views' pairwise squared distances `d` (n ≥ 2).
double Spacing(const Eigen::MatrixXf& d) {
  const Eigen::Index n = d.cols();
  std::vector<float> nearest(static_cast<size_t>(n), std::numeric_limits<float>::infinity());
  for (Eigen::Index j = 0; j < n; ++j) {
    for (Eigen::Index i = 0; i < n; ++i) {
      if (i != j)
        nearest[static_cast<size_t>(j)] = std::min(nearest[static_cast<size_t>(j)], d(i, j));
    }
  }
  return UpperMedian(std::move(nearest));
}

}  // namespace

Eigen::MatrixXf ThinViews(const Eigen::MatrixXf& pool, int cap) {
  if (pool.cols() <= cap) return pool;
  return Thinned(pool, cap, PairwiseSquared(pool));
}

double ViewSpacing(const Eigen::MatrixXf& views) {
  return views.cols() < 2 ? 0.0 : Spacing(PairwiseSquared(views));
}

ViewSummary SummariseViews(const Eigen::MatrixXf& views, int spread_cap) {
  if (views.cols() < 2) return {0.0, views};  // nothing to thin (spread_cap ≥ 1)
  const Eigen::MatrixXf d = PairwiseSquared(views);
  return {Spacing(d), views.cols() <= spread_cap ? views : Thinned(views, spread_cap, d)};
}

}  // namespace tsc
