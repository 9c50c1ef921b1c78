#include "drivers/dataset/camera_lens.h"

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "core/bubble/camera.h"

namespace tsc {

void CheckHorizontalFov(double hfov_deg) {
  if (!(hfov_deg > 0.0 && hfov_deg < 180.0)) {
    throw std::invalid_argument(
        "a lens's horizontal field of view must be in (0, 180) degrees, not " +
        std::to_string(hfov_deg));
  }
}

CameraLens::CameraLens(double hfov_deg, int views_per_base_point)
    : hfov_deg_(hfov_deg), views_(views_per_base_point) {
  CheckHorizontalFov(hfov_deg);
  if (views_per_base_point < 1) {
    throw std::invalid_argument("a base point takes at least one view, not " +
                                std::to_string(views_per_base_point));
  }
}

CameraLens CameraLens::Of(const CameraIntrinsics& camera, int views_per_base_point) {
  const double deg = 2.0 * std::atan(0.5 * camera.width() / camera.fx()) * 180.0 / std::numbers::pi;
  return CameraLens(std::round(deg * 1e6) / 1e6, views_per_base_point);
}

}  // namespace tsc
