#include "drivers/dataset/assumed_keyframes_check.h"

#include <algorithm>

#include "core/bubble/descriptor.h"
#include "core/median.h"

namespace tsc {

AssumedKeyframesCheck::AssumedKeyframesCheck(const BasePointSpacing& spacing, double lens_change)
    : spacing_(spacing), lens_change_(lens_change), watching_(spacing.assumed) {}

std::optional<std::string> AssumedKeyframesCheck::Add(const Eigen::VectorXf& descriptor) {
  if (!watching_) return std::nullopt;
  if (previous_ && previous_->size() == descriptor.size()) {
    changes_.push_back(ChiSquared(*previous_, descriptor));
  }
  previous_ = descriptor;
  if (static_cast<int>(changes_.size()) + 1 < kSample) return std::nullopt;
  watching_ = false;  // judged once
  std::vector<double> changes = std::move(changes_);
  previous_.reset();
  if (changes.empty()) return std::nullopt;
  return AssumedKeyframesCaution(spacing_, UpperMedian(std::move(changes)), lens_change_);
}

}  // namespace tsc
