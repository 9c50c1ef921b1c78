#pragma once
// OpenCV's video I/O (cv::VideoCapture: V4L2 devices, video files through FFmpeg or
// GStreamer), loaded only when a camera needs it. Debian builds libopencv_videoio against
// some 230 libraries, all bound at load: linked into tscd they made 64 MB of every process's
// resident set, whatever its camera (docs/reliability.md, "What a memory costs tscd"). They
// live in a module (libtscd_opencv_video.so, found relative to the running program's folder)
// that the device and video cameras load on first use.

#include <string>

#include "drivers/camera/video_device.h"
#include "drivers/camera/video_file_reader.h"

namespace tsc {

/// What the module needs to open a V4L2 device: a path, or an index (path empty).
struct OpencvDeviceRequest {
  const char* path = "";  ///< "/dev/videoN" or any V4L2 device path; "" to use `index`
  int index = -1;
  int width = 0;  ///< requested capture size; 0 = the device's default
  int height = 0;
  double fps = 0.0;  ///< requested rate; 0 = the device's default
};

/// The module's entry points; their version must equal kOpencvVideoAbi.
struct OpencvVideoModule {
  /// A device that is not opened yet; never null.
  VideoDevice* (*v4l2_device)(const OpencvDeviceRequest* request) = nullptr;
  /// The file opened by cv::VideoCapture (any backend), or null when OpenCV cannot open it.
  VideoFileReader* (*video_file)(const char* path) = nullptr;
};

inline constexpr int kOpencvVideoAbi = 1;

/// The module, loaded on the first call (later calls return the same). Throws
/// CameraError(recoverable = false) naming the module file and why it cannot be loaded.
const OpencvVideoModule& OpencvVideo();

/// Where OpencvVideo() looks for the module: the running program's folder joined with the
/// relative path the build configured (the same in the build tree and once installed).
std::string OpencvVideoModulePath();

}  // namespace tsc
