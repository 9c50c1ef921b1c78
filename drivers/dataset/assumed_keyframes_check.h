#pragma once
// The caution of AssumedKeyframesCaution for a source read base point by base point (tscd's
// folder camera, `tsc run`), which `tsc eval` gives from the whole sequence: keyframes were
// only assumed, yet the first base points change as little as a camera's frames do.

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "drivers/dataset/base_point_spacing.h"

namespace tsc {

class AssumedKeyframesCheck {
 public:
  /// Base points whose consecutive change is judged (a minute of keyframes, a few seconds of
  /// a video).
  static constexpr int kSample = 64;

  /// Watches only when `spacing.assumed`; `lens_change` as AssumedKeyframesCaution's.
  explicit AssumedKeyframesCheck(const BasePointSpacing& spacing, double lens_change = 1.0);

  /// The next base point's descriptor. Returns the caution once, at the base point that
  /// completes the sample, when its median consecutive χ² is below kKeyframeChangeChi2
  /// scaled by the lens.
  std::optional<std::string> Add(const Eigen::VectorXf& descriptor);

 private:
  BasePointSpacing spacing_;
  double lens_change_;
  bool watching_;
  std::optional<Eigen::VectorXf> previous_;
  std::vector<double> changes_;
};

}  // namespace tsc
