#pragma once
// What DeviceCamera needs from a capture device: the seam that lets tests unplug one, and the
// interface the V4L2 device of OpenCV's video module implements (drivers/camera/opencv_video.h).

#include <opencv2/core.hpp>

namespace tsc {

class VideoDevice {
 public:
  virtual ~VideoDevice() = default;
  /// Opens (or reopens) the device; false when it is not available.
  virtual bool Open() = 0;
  virtual void Close() = 0;
  virtual bool IsOpen() const = 0;
  /// Waits for the next frame and keeps it undecoded; false when the device stopped delivering.
  virtual bool Grab() = 0;
  /// The last grabbed frame: pixels, or a compressed frame as it came from the device (JPEG
  /// bytes in one CV_8UC1 row), which DeviceCamera decodes under its size bound. False when
  /// there is none.
  virtual bool Retrieve(cv::Mat* frame) = 0;
  /// Frame size the open device reports; 0x0 when it does not say.
  virtual cv::Size FrameSize() const = 0;
};

}  // namespace tsc
