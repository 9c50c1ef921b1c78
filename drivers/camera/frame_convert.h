#pragma once
// Normalising decoded frames to what the pipeline expects: CV_8UC3 BGR at the camera's size.

#include <opencv2/core.hpp>

#include "core/bubble/camera.h"

namespace tsc {

/// `raw` (8-bit grey, BGR or BGRA; 16-bit is scaled down) as CV_8UC3 BGR of the intrinsics'
/// size (resized when the source changed resolution). Precondition: raw is not empty.
cv::Mat ToBgrOfSize(const cv::Mat& raw, const CameraIntrinsics& intrinsics);

}  // namespace tsc
