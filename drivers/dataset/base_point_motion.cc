#include "drivers/dataset/base_point_motion.h"

#include <cmath>
#include <numbers>

#include "drivers/dataset/base_point_stride.h"

namespace tsc {

bool BasePointMotion::Moved(const PlanarPose& pose) const {
  if (!last_) return true;
  const double travel = std::hypot(pose.x - last_->x, pose.y - last_->y);
  const double turn_deg =
      std::abs(std::remainder(pose.heading - last_->heading, 2.0 * std::numbers::pi)) * 180.0 /
      std::numbers::pi;
  return travel >= kStillTravelM || turn_deg >= kStillTurnDeg;
}

std::vector<int> FramesOfRoute(const std::vector<std::optional<PlanarPose>>& poses, int stride) {
  BasePointStride taken(stride);
  for (const std::optional<PlanarPose>& pose : poses) {
    if (!pose) return {};
  }
  BasePointMotion motion;
  std::vector<int> frames;
  for (size_t i = 0; i < poses.size(); ++i) {
    if (!taken.Take(/*ends_base_point=*/true, motion.Moved(*poses[i]))) continue;
    motion.Taken(*poses[i]);
    frames.push_back(static_cast<int>(i));
  }
  return frames;
}

}  // namespace tsc
