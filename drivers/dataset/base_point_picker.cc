#include "drivers/dataset/base_point_picker.h"

#include <algorithm>
#include <cmath>

#include "core/median.h"
#include "drivers/dataset/base_point_spacing.h"

namespace tsc {

void BasePointPicker::Measure(const ViewMotion& motion) {
  const std::optional<int64_t> previous = last_utime_;
  last_utime_ = motion.utime;
  if (!previous || !motion.speed_mps || motion.utime <= *previous) return;
  const double speed = std::abs(*motion.speed_mps);
  if (!(speed >= kDrivingMps) || !std::isfinite(speed)) return;
  // Travel per base point: the speed over the time since the previous one (a sweep's views
  // and any frames the camera did not deliver included).
  const double step = speed * static_cast<double>(motion.utime - *previous) * 1e-6;
  if (steps_.size() < static_cast<size_t>(kWindow)) {
    steps_.push_back(step);
  } else {
    steps_[next_step_] = step;
    next_step_ = (next_step_ + 1) % steps_.size();
  }
  if (steps_.size() < static_cast<size_t>(kLeastSamples)) return;
  measured_m_ = UpperMedian(steps_);
  // The stride changes only when the base points it gives leave what StrideFor allows
  // (kClosestSpacingM to kCalibratedSpacingM apart) by more than 5 %: a Jaguar at its 1 m/s
  // limit with a 10 fps camera is at 0.1 m, where StrideFor steps from 1 to 2, and its speed's
  // noise must not flip the stride to and fro.
  const double apart = *measured_m_ * stride_.stride();
  bool restrided = false;
  if (apart < kClosestSpacingM * 0.95 || apart > kCalibratedSpacingM * 1.05) {
    const int stride = StrideFor(BasePointSpacing{*measured_m_, "odometry"});
    if (stride != stride_.stride()) {
      stride_ = BasePointStride(stride);
      restrided = true;
    }
  }
  const double taken = *measured_m_ * stride_.stride();
  if (!adopted_m_ || restrided || taken > *adopted_m_ * kRespaceRatio ||
      taken < *adopted_m_ / kRespaceRatio) {
    adopted_m_ = taken;
  }
}

bool BasePointPicker::Take(bool ends_base_point, const ViewMotion& motion) {
  if (at_start_) {
    Measure(motion);
    const bool moved = !motion.pose || still_.Moved(*motion.pose);
    taking_ = stride_.Take(/*ends_base_point=*/true, moved);
    standing_ = !taking_ && !moved;
    if (taking_ && motion.pose) still_.Taken(*motion.pose);
  }
  at_start_ = ends_base_point;
  return taking_;
}

std::vector<int> FramesOfRoute(const std::vector<std::optional<PlanarPose>>& poses, int stride) {
  BasePointPicker taken(stride);
  for (const std::optional<PlanarPose>& pose : poses) {
    if (!pose) return {};
  }
  std::vector<int> frames;
  for (size_t i = 0; i < poses.size(); ++i) {
    if (taken.Take(/*ends_base_point=*/true, ViewMotion{poses[i], std::nullopt, 0})) {
      frames.push_back(static_cast<int>(i));
    }
  }
  return frames;
}

}  // namespace tsc
