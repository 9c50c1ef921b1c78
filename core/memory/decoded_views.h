#pragma once
// A place's member views decoded to floats once, with their squared norms: what
// ViewDistances measures, kept by a caller that measures many vote sets against the same
// places. A merge's N* is such a caller: each of its places was decoded again for every
// incoming place that shortlisted it, 32 times on average in a 10⁴ + 10⁴ merge
// (docs/decisions.md "A merge runs on the robot's cores").

#include <Eigen/Core>
#include <cstddef>

#include "core/memory/compact_views.h"
#include "core/memory/simd.h"

namespace tsc {

/// Member views as floats and their squared norms, computed as ViewDistances computes them on
/// `simd`, so a ViewDistances given them measures the same floats as one that decodes.
class DecodedViews {
 public:
  explicit DecodedViews(const CompactViews& compact, Simd simd = FastestSimd());
  const Eigen::MatrixXf& views() const { return views_; }
  /// ‖view j‖², one per column of views().
  const Eigen::RowVectorXf& squared_norms() const { return squared_norms_; }
  Simd simd() const { return simd_; }
  std::size_t bytes() const {
    return sizeof(float) * static_cast<std::size_t>(views_.size() + squared_norms_.size());
  }

 private:
  Eigen::MatrixXf views_;
  Eigen::RowVectorXf squared_norms_;
  Simd simd_;
};

}  // namespace tsc
