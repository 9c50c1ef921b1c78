#include "drivers/dataset/assumed_keyframes_check.h"

#include <algorithm>
#include <cstdio>

#include "core/bubble/descriptor.h"
#include "core/median.h"
#include "drivers/dataset/lens_response.h"

namespace tsc {

std::optional<std::string> AssumedKeyframesCaution(const BasePointSpacing& spacing,
                                                   double consecutive_chi2_median,
                                                   const CameraLens& lens) {
  const double threshold = kKeyframeChangeChi2 * ChangeResponse(lens);
  if (!spacing.assumed || !(consecutive_chi2_median < threshold)) return std::nullopt;
  char text[420];
  std::snprintf(text, sizeof text,
                "nothing says how far apart these frames are, so they were taken for keyframes "
                "about a metre apart, but consecutive frames change as little as a camera's "
                "frames do (median chi2 %.4f, keyframes at this lens: above %.4f, such as the "
                "real loop's 0.010): if they are a video's, declare its \"fps\" (or "
                "\"spacing_m\") in camera.json",
                consecutive_chi2_median, threshold);
  return std::string(text);
}

AssumedKeyframesCheck::AssumedKeyframesCheck(const BasePointSpacing& spacing,
                                             const CameraLens& lens)
    : spacing_(spacing), lens_(lens), watching_(spacing.assumed) {}

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
  return AssumedKeyframesCaution(spacing_, UpperMedian(std::move(changes)), lens_);
}

}  // namespace tsc
