#include "drivers/dataset/assumed_keyframes_check.h"

#include <algorithm>

#include "core/bubble/descriptor.h"

namespace tsc {

AssumedKeyframesCheck::AssumedKeyframesCheck(const BasePointSpacing& spacing)
    : spacing_(spacing), watching_(spacing.assumed) {}

std::optional<std::string> AssumedKeyframesCheck::Add(const Eigen::VectorXf& descriptor) {
  if (!watching_) return std::nullopt;
  if (previous_ && previous_->size() == descriptor.size()) {
    changes_.push_back(ChiSquared(*previous_, descriptor));
  }
  previous_ = descriptor;
  if (static_cast<int>(changes_.size()) + 1 < kSample) return std::nullopt;
  watching_ = false;  // judged once
  std::vector<double> sorted = std::move(changes_);
  previous_.reset();
  if (sorted.empty()) return std::nullopt;
  const auto mid = sorted.begin() + static_cast<long>(sorted.size() / 2);
  std::nth_element(sorted.begin(), mid, sorted.end());
  return AssumedKeyframesCaution(spacing_, *mid);
}

}  // namespace tsc
