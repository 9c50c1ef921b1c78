#pragma once
// A V4L2 / USB camera through OpenCV's videoio (loaded as a module, drivers/camera/opencv_video.h).
// Survives the device going away: a failed read is a recoverable CameraError and later calls reopen
// the device with a bounded exponential backoff.

#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "drivers/camera/camera_source.h"
#include "drivers/camera/video_device.h"
#include "drivers/clock.h"
#include "drivers/image/bounded_decode.h"

namespace tsc {

struct DeviceCameraOptions {
  std::string device;      ///< "/dev/videoN" (or any V4L2 device path) or an index "N"
  double fps = 10.0;       ///< frames per second delivered (extra frames are dropped); 0 = all
  double hfov_deg = 60.0;  ///< horizontal field of view, degrees in (0, 180)
  int width = 0;           ///< requested capture size in pixels; 0 = the device's default
  int height = 0;
  double reopen_min_s = 0.5;  ///< first wait before reopening a lost device, seconds
  double reopen_max_s = 5.0;  ///< the wait doubles after every failed reopen, up to this
  /// Largest compressed (MJPEG) frame decoded, width x height by its JPEG header
  /// (camera.max_image_pixels): a frame claiming more is refused before it is decoded.
  int64_t max_image_pixels = kDefaultMaxImagePixels;
  /// Throws std::invalid_argument naming the bad field.
  void Validate() const;
};

/// The V4L2 device of options.device through cv::VideoCapture of OpenCV's video module
/// (drivers/camera/opencv_video.h; requesting options' size and rate). Does not open it.
/// Throws CameraError(recoverable = false) when the module cannot be loaded.
std::unique_ptr<VideoDevice> MakeV4l2Device(const DeviceCameraOptions& options);

class DeviceCamera : public CameraSource {
 public:
  /// Opens the device. Throws CameraError(recoverable = false) naming the device when it does
  /// not exist or cannot be opened, std::invalid_argument for bad options. `clock` must
  /// outlive the camera.
  explicit DeviceCamera(const DeviceCameraOptions& options, Clock& clock = Clock::System());
  /// The same over any VideoDevice (tests); `device` is opened here.
  DeviceCamera(const DeviceCameraOptions& options, std::unique_ptr<VideoDevice> device,
               Clock& clock = Clock::System());

  /// The newest frame at most fps times per second (frames in between are grabbed and
  /// dropped so none is stale). Never nullopt. A compressed frame whose header claims more
  /// than max_image_pixels, or that does not decode, is a recoverable CameraError naming the
  /// frame and its claimed size (the device stays open). When the device stops delivering, throws
  /// CameraError(recoverable = true); the next calls wait out the backoff, try to reopen and
  /// either deliver again or throw CameraError(recoverable = true) with a longer backoff.
  std::optional<CameraFrame> Next() override;
  /// Intrinsics at the size first opened; later frames of another size are resized to it.
  const CameraIntrinsics& intrinsics() const override { return intrinsics_; }
  std::string name() const override { return "device:" + options_.device; }
  bool rides_the_base() const override { return true; }

  /// Current wait before the next reopen attempt, microseconds (for logs and tests).
  int64_t backoff_us() const { return backoff_us_; }
  bool is_open() const { return device_->IsOpen(); }

 private:
  [[noreturn]] void Lost(const std::string& why);

  DeviceCameraOptions options_;
  Clock& clock_;
  std::unique_ptr<VideoDevice> device_;
  CameraIntrinsics intrinsics_;
  int64_t period_us_ = 0;
  int64_t due_us_ = 0;
  int64_t backoff_us_ = 0;
  int64_t retry_at_us_ = 0;
  int64_t delivered_ = 0;
  int64_t retrieved_ = 0;  ///< frames taken from the device, delivered or refused
};

}  // namespace tsc
