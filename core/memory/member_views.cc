#include "core/memory/member_views.h"

#include <algorithm>
#include <limits>
#include <vector>

#include "core/assert.h"
#include "core/median.h"
#include "core/memory/simd.h"

namespace tsc {
namespace {

constexpr float kNone = std::numeric_limits<float>::infinity();

// avx2::Least and avx2::FirstLeast (core/memory/simd.h) on `simd`: the same index and value.
float LeastOf(const float* values, Eigen::Index n, Simd simd) {
  if (simd == Simd::kAvx2Fma) return avx2::Least(values, static_cast<int>(n));
  float least = kNone;
  for (Eigen::Index i = 0; i < n; ++i) {
    if (values[i] < least) least = values[i];
  }
  return least;
}

Eigen::Index FirstLeastOf(const float* values, Eigen::Index n, Simd simd) {
  if (simd == Simd::kAvx2Fma) return avx2::FirstLeast(values, static_cast<int>(n));
  Eigen::Index at = -1;
  float least = kNone;
  for (Eigen::Index i = 0; i < n; ++i) {
    if (values[i] < least) {
      least = values[i];
      at = i;
    }
  }
  return at;
}

// Squared distances between the columns of `x` (n x n, zero diagonal), entry (i, j) computed
// as (−2·x_iᵀx_j + ‖x_i‖²) + ‖x_j‖², clamped at 0.
Eigen::MatrixXf PairwiseSquared(const Eigen::MatrixXf& x, Simd simd) {
  const Eigen::Index n = x.cols();
  Eigen::VectorXf sq(n);
  Eigen::MatrixXf dots(n, n);
  if (simd == Simd::kAvx2Fma) {
    // A place's dozens of views: Eigen's product packed both sides for every place (a quarter
    // of a 10⁴ + 10⁴ merge's restore, which measures every place's spacing and spread views).
    // Only the products on and above the diagonal, a band of columns at a time, then mirrored:
    // x_iᵀx_j and x_jᵀx_i are the same FMAs lane for lane, and a ColumnDots result does not
    // depend on the columns beside it, so the floats are those of the whole square. Bands of
    // 8, the AVX-512 kernel's block (64 views to 2: 11.0 µs, 11.7 with 16, 25 for the square).
    constexpr Eigen::Index kBand = 8;
    std::vector<float> band;
    for (Eigen::Index j0 = 0; j0 < n; j0 += kBand) {
      const Eigen::Index nb = std::min(kBand, n - j0), na = j0 + nb;
      band.resize(static_cast<size_t>(na * nb));
      avx2::ColumnDots(x.data(), static_cast<int>(na), x.col(j0).data(), static_cast<int>(nb),
                       static_cast<int>(x.rows()), band.data(), sq.data() + j0);
      for (Eigen::Index c = 0; c < nb; ++c)
        std::copy_n(band.data() + c * na, na, dots.col(j0 + c).data());
    }
    for (Eigen::Index j = 0; j < n; ++j) {
      for (Eigen::Index i = j + 1; i < n; ++i) dots(i, j) = dots(j, i);
    }
  } else {
    sq = x.colwise().squaredNorm().transpose();
    dots.noalias() = x.transpose() * x;
  }
  Eigen::MatrixXf d = (((-2.0f * dots).colwise() + sq).rowwise() + sq.transpose()).cwiseMax(0.0f);
  d.diagonal().setZero();
  return d;
}

}  // namespace

namespace {

// The column of n that EvenlySpaced keeps j-th of cap (n > cap).
Eigen::Index SpacedColumn(int j, Eigen::Index n, int cap) {
  return static_cast<Eigen::Index>(j) * n / cap;
}

}  // namespace

Eigen::MatrixXf EvenlySpaced(const Eigen::MatrixXf& x, int cap) {
  const Eigen::Index n = x.cols();
  if (n <= cap) return x;
  Eigen::MatrixXf out(x.rows(), cap);
  for (int j = 0; j < cap; ++j) out.col(j) = x.col(SpacedColumn(j, n, cap));
  return out;
}

Eigen::MatrixXf EvenlySpaced(const CompactViews& x, int cap) {
  const Eigen::Index n = x.cols();
  if (n <= cap) return x.Decoded();
  Eigen::MatrixXf out(x.rows(), cap);
  for (int j = 0; j < cap; ++j) x.DecodeColInto(SpacedColumn(j, n, cap), out.col(j).data());
  return out;
}

namespace {

// ThinViews with the pool's pairwise squared distances `d` given (n > cap); `d` is used up.
Eigen::MatrixXf Thinned(const Eigen::MatrixXf& pool, int cap, Eigen::MatrixXf d, Simd simd) {
  const Eigen::Index n = pool.cols();
  std::vector<char> kept(static_cast<size_t>(n), 1);
  // Each kept view's nearest earlier kept view (−1: none), so a round looks at n views
  // instead of n² pairs; only views whose nearest was dropped look again.
  std::vector<Eigen::Index> earlier(static_cast<size_t>(n), -1);
  // Each kept view's distance to its nearest earlier kept view (infinite when it has none or
  // is dropped), side by side: a round scans one row of floats instead of looking each pair up
  // in `d` (the lookups were a tenth of a 10⁴ + 10⁴ merge, which thins 64 views to 2).
  std::vector<float> to_earlier(static_cast<size_t>(n), kNone);
  // A dropped view's row of `d` is infinite above the diagonal, so j's nearest earlier kept
  // view is the first least of column j's first j entries: one vector scan, no lookups of
  // `kept` (the first least, as the pair rule orders ties).
  auto link = [&](Eigen::Index j) {
    const Eigen::Index i = FirstLeastOf(d.col(j).data(), j, simd);
    earlier[static_cast<size_t>(j)] = i;
    to_earlier[static_cast<size_t>(j)] = i >= 0 ? d(i, j) : kNone;
  };
  for (Eigen::Index j = 1; j < n; ++j) link(j);
  for (Eigen::Index left = n; left > cap; --left) {
    // The closest pair among the kept views; ties go to the earlier pair in column order
    // (the later view of the lowest-ordered pair (j, i) is dropped).
    const Eigen::Index drop = FirstLeastOf(to_earlier.data(), n, simd);
    TSC_ASSERT(drop >= 0, "at least two finite views are kept while more than cap are");
    if (drop < 0) break;
    kept[static_cast<size_t>(drop)] = 0;
    to_earlier[static_cast<size_t>(drop)] = kNone;
    for (Eigen::Index j = drop + 1; j < n; ++j) d(drop, j) = kNone;
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
double Spacing(const Eigen::MatrixXf& d, Simd simd) {
  const Eigen::Index n = d.cols();
  std::vector<float> nearest(static_cast<size_t>(n));
  for (Eigen::Index j = 0; j < n; ++j) {
    const float* column = d.col(j).data();
    nearest[static_cast<size_t>(j)] =
        std::min(LeastOf(column, j, simd), LeastOf(column + j + 1, n - j - 1, simd));
  }
  return UpperMedian(std::move(nearest));
}

}  // namespace

Eigen::MatrixXf ThinViews(const Eigen::MatrixXf& pool, int cap, Simd simd) {
  if (pool.cols() <= cap) return pool;
  return Thinned(pool, cap, PairwiseSquared(pool, simd), simd);
}

double ViewSpacing(const Eigen::MatrixXf& views, Simd simd) {
  return views.cols() < 2 ? 0.0 : Spacing(PairwiseSquared(views, simd), simd);
}

ViewSummary SummariseViews(const Eigen::MatrixXf& views, int spread_cap, Simd simd) {
  if (views.cols() < 2) return {0.0, views};  // nothing to thin (spread_cap ≥ 1)
  Eigen::MatrixXf d = PairwiseSquared(views, simd);
  ViewSummary summary{Spacing(d, simd), {}};
  summary.spread =
      views.cols() <= spread_cap ? views : Thinned(views, spread_cap, std::move(d), simd);
  return summary;
}

}  // namespace tsc
