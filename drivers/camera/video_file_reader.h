#pragma once
// What VideoCamera needs from a video file: its frames in order, decoded. Implemented by
// OpenCV's video module (drivers/camera/opencv_video.h).

#include <opencv2/core.hpp>

namespace tsc {

class VideoFileReader {
 public:
  virtual ~VideoFileReader() = default;
  /// The next frame, decoded (as the container's codec gives it); false at the end of the
  /// file or when a frame cannot be decoded.
  virtual bool Read(cv::Mat* frame) = 0;
  /// Frame size the container declares; 0x0 when it does not say.
  virtual cv::Size FrameSize() const = 0;
};

}  // namespace tsc
