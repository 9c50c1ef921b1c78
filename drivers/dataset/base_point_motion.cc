#include "drivers/dataset/base_point_motion.h"

#include <numbers>

namespace tsc {

bool BasePointMotion::Moved(const PlanarPose& pose) const {
  if (!last_) return true;
  return Travel(pose, *last_) >= kStillTravelM ||
         Turn(pose, *last_) * 180.0 / std::numbers::pi >= kStillTurnDeg;
}

}  // namespace tsc
