#include "core/memory/decoded_views.h"

namespace tsc {

DecodedViews::DecodedViews(const CompactViews& compact, Simd simd)
    : views_(compact.Decoded()), squared_norms_(views_.cols()), simd_(simd) {
  if (simd == Simd::kAvx2Fma) {
    avx2::ColumnSquaredNorms(views_.data(), static_cast<int>(views_.cols()),
                             static_cast<int>(views_.rows()), squared_norms_.data());
  } else {
    squared_norms_ = views_.colwise().squaredNorm();
  }
}

}  // namespace tsc
