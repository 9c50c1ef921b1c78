#pragma once
// The member views a learned place keeps (DESIGN §3.3 amended, docs/decisions.md "Member
// views"): a bounded set of its base points' descriptors that represents every heading and
// every visit, and the view spacing that is the place's own unit of distance.

#include <Eigen/Core>

#include "core/memory/compact_views.h"
#include "core/memory/simd.h"

namespace tsc {

/// `cap` columns of `x` evenly spaced in order (all of them when there are fewer).
/// Deterministic. Precondition: cap >= 1.
Eigen::MatrixXf EvenlySpaced(const Eigen::MatrixXf& x, int cap);
/// EvenlySpaced(x.Decoded(), cap), decoding only the columns it keeps (a merge takes 32 of an
/// incoming place's 64 views as vote points).
Eigen::MatrixXf EvenlySpaced(const CompactViews& x, int cap);

/// Thins `pool` (dim x n, the kept views first, then new ones) to at most `cap` views by
/// dropping, while too many remain, the later view of the closest pair: what remains is spread
/// over the views' whole extent, so a visit that shows something new keeps its views however
/// many base points earlier visits had (evenly spaced thinning kept 7 of 8 from the second of
/// two equal visits). Views repeating a kept one go first. Deterministic, and the same views
/// on either instruction set `simd`. Precondition: cap >= 1.
Eigen::MatrixXf ThinViews(const Eigen::MatrixXf& pool, int cap, Simd simd = FastestSimd());

/// The place's view spacing: the median over its views of the squared distance to the
/// nearest other view; 0 with fewer than two views. A fresh view of the place lies about
/// that far from the nearest kept view, at 30 frames per second or one frame a metre alike.
double ViewSpacing(const Eigen::MatrixXf& views, Simd simd = FastestSimd());

/// What a place memory derives from a place's member views, from one set of their pairwise
/// distances: ViewSpacing(views) and ThinViews(views, spread_cap), the views the view index
/// keys the place by (restoring a merged 2·10⁵ places measured every place's views twice).
struct ViewSummary {
  double spacing = 0.0;
  Eigen::MatrixXf spread;
};
ViewSummary SummariseViews(const Eigen::MatrixXf& views, int spread_cap, Simd simd = FastestSimd());

}  // namespace tsc
