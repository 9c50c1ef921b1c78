#pragma once
// Which of a live camera's views are base points, as tscd's camera thread takes them: every
// stride-th, none while the robot stands still (BasePointMotion), and, when the robot's
// odometry gives its speed, the stride its measured speed asks for instead of the one an
// assumed speed gave (StrideFor: base points about the calibrated 0.15 m apart). A robot at
// 0.5 m/s with a 10 fps camera takes frames 0.05 m apart, which the defaults detect little in
// (boundary F1 0.42 on the nine calibration worlds, 0.87 one frame in three; docs/calibration.md,
// twenty-seventh and twenty-eighth passes). A base point's first view decides for all its
// views, so a pan sweep's views stay together.

#include <cstdint>
#include <optional>
#include <vector>

#include "drivers/dataset/base_point_motion.h"
#include "drivers/dataset/base_point_stride.h"

namespace tsc {

/// What is known of the robot when a view is taken.
struct ViewMotion {
  std::optional<PlanarPose> pose;   ///< odometry, or the pose a simulated camera reports
  std::optional<double> speed_mps;  ///< forward speed by odometry
  int64_t utime = 0;                ///< capture time, microseconds
};

class BasePointPicker {
 public:
  /// Forward speeds below this are a robot turning or stopping, not driving: they say nothing
  /// of its spacing.
  static constexpr double kDrivingMps = 0.05;
  /// Base points a measured spacing takes (the median of the last kWindow driving ones), and
  /// how many it needs before it replaces the assumed one.
  static constexpr int kWindow = 64;
  static constexpr int kLeastSamples = 16;
  /// The base points' measured spacing replaces the one adopted when it differs by more than
  /// this factor (or the stride changed).
  static constexpr double kRespaceRatio = 1.2;

  /// `stride` for the spacing assumed or declared (StrideFor). Throws std::invalid_argument
  /// unless stride ≥ 1.
  explicit BasePointPicker(int stride) : stride_(stride) {}

  /// Whether the next view, closing its base point when `ends_base_point`, is taken.
  bool Take(bool ends_base_point, const ViewMotion& motion);

  /// Whether the current base point was passed over because the robot stood still.
  bool standing() const { return standing_; }
  /// The stride in use: the assumed one until the robot's speed was measured.
  int stride() const { return stride_.stride(); }
  /// How far apart the robot's frames lie by its odometry, once measured.
  std::optional<double> measured_spacing_m() const { return measured_m_; }
  /// How far apart the base points it takes lie by the robot's odometry (the frames' spacing
  /// times the stride), once measured: what place detection counts τ_p and τ_w at
  /// (AdaptToSpacing). It moves only with the stride, or when the base points' spacing
  /// leaves a fifth either way of it, so that a speed's noise does not recount them at every
  /// base point.
  std::optional<double> base_point_spacing_m() const { return adopted_m_; }

 private:
  void Measure(const ViewMotion& motion);

  BasePointStride stride_;
  BasePointMotion still_;
  bool at_start_ = true;  // the next view opens a base point
  bool taking_ = false;
  bool standing_ = false;
  std::optional<int64_t> last_utime_;  // of the previous base point's first view
  std::vector<double> steps_;          // ring of the last kWindow driving steps, metres
  size_t next_step_ = 0;
  std::optional<double> measured_m_;
  std::optional<double> adopted_m_;
};

/// The frames of a route seen at `poses` that are base points, as BasePointPicker takes them
/// without a speed: every `stride`-th, the count waiting while the camera stands still. Empty
/// unless every frame has a pose. Throws std::invalid_argument unless stride ≥ 1.
std::vector<int> FramesOfRoute(const std::vector<std::optional<PlanarPose>>& poses, int stride);

}  // namespace tsc
