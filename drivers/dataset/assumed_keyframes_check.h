#pragma once
// Frames taken for keyframes only because nothing declared their spacing, yet changing as
// little from one to the next as a camera's frames do: the caution that says what to declare.
// `tsc eval` judges the whole sequence (AssumedKeyframesCaution); tscd's folder camera and
// `tsc run` read base point by base point (AssumedKeyframesCheck).

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "drivers/dataset/base_point_spacing.h"
#include "drivers/dataset/camera_lens.h"

namespace tsc {

/// Keyframes change more than this from one to the next (χ² of normalised descriptors, the
/// median over a sequence) through the calibrated lens: the real loop's, about a metre apart,
/// by 0.010; a simulated camera's frames 0.05-0.15 m apart by 0.0025-0.005
/// (docs/calibration.md, twenty-ninth pass).
inline constexpr double kKeyframeChangeChi2 = 0.005;

/// When keyframes were only assumed (`spacing.assumed`) but consecutive frames change less than
/// kKeyframeChangeChi2 in the median, as a camera's frames do: a caution that names what to
/// declare (camera.json "fps" or "spacing_m"), since τ_p would count keyframes a metre apart
/// (3) where a video needs ~25. Nothing otherwise. The threshold follows `lens`
/// (ChangeResponse: a 45° lens's frames change 0.62x as much as 58°'s).
std::optional<std::string> AssumedKeyframesCaution(const BasePointSpacing& spacing,
                                                   double consecutive_chi2_median,
                                                   const CameraLens& lens);

class AssumedKeyframesCheck {
 public:
  /// Base points whose consecutive change is judged (a minute of keyframes, a few seconds of
  /// a video).
  static constexpr int kSample = 64;

  /// Watches only when `spacing.assumed`; `lens` as AssumedKeyframesCaution's.
  AssumedKeyframesCheck(const BasePointSpacing& spacing, const CameraLens& lens);

  /// The next base point's descriptor. Returns the caution once, at the base point that
  /// completes the sample, when its median consecutive χ² is below kKeyframeChangeChi2
  /// scaled by the lens.
  std::optional<std::string> Add(const Eigen::VectorXf& descriptor);

 private:
  BasePointSpacing spacing_;
  CameraLens lens_;
  bool watching_;
  std::optional<Eigen::VectorXf> previous_;
  std::vector<double> changes_;
};

}  // namespace tsc
