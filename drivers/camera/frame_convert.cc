#include "drivers/camera/frame_convert.h"

#include <opencv2/imgproc.hpp>

namespace tsc {

cv::Mat ToBgrOfSize(const cv::Mat& raw, const CameraIntrinsics& intrinsics) {
  CV_Assert(!raw.empty());
  cv::Mat eight = raw;
  if (raw.depth() == CV_16U) raw.convertTo(eight, CV_8U, 1.0 / 256.0);
  cv::Mat bgr;
  switch (eight.channels()) {
    case 1:
      cv::cvtColor(eight, bgr, cv::COLOR_GRAY2BGR);
      break;
    case 4:
      cv::cvtColor(eight, bgr, cv::COLOR_BGRA2BGR);
      break;
    default:
      bgr = eight;
      break;
  }
  CV_Assert(bgr.type() == CV_8UC3);
  if (bgr.cols != intrinsics.width() || bgr.rows != intrinsics.height()) {
    cv::Mat resized;
    cv::resize(bgr, resized, cv::Size(intrinsics.width(), intrinsics.height()), 0, 0,
               cv::INTER_AREA);
    return resized;
  }
  return bgr;
}

}  // namespace tsc
