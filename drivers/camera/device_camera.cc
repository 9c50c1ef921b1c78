#include "drivers/camera/device_camera.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <span>
#include <stdexcept>
#include <system_error>

#include "drivers/camera/frame_convert.h"
#include "drivers/camera/opencv_video.h"

namespace tsc {
namespace {

bool IsIndex(const std::string& device) {
  return !device.empty() && device.size() <= 4 &&
         std::all_of(device.begin(), device.end(),
                     [](unsigned char c) { return std::isdigit(c) != 0; });
}

bool PathMissing(const std::string& device) {
  std::error_code ec;
  return !IsIndex(device) && !std::filesystem::exists(device, ec);
}

/// A compressed frame as a device hands it over: bytes in one row (or column) of CV_8UC1.
bool IsCompressed(const cv::Mat& raw) {
  return raw.type() == CV_8UC1 && (raw.rows == 1 || raw.cols == 1) && raw.total() >= 2 &&
         raw.isContinuous();
}

VideoDevice& OpenOrThrow(const DeviceCameraOptions& options, VideoDevice& device) {
  options.Validate();
  if (!device.Open()) {
    throw CameraError("device:" + options.device +
                          (PathMissing(options.device)
                               ? ": no such device"
                               : ": cannot open (busy, no permission or not a V4L2 capture "
                                 "device)"),
                      false);
  }
  return device;
}

/// `raw` decoded when it is a compressed frame, bounded by options.max_image_pixels; `raw`
/// itself otherwise. Throws CameraError(recoverable) naming frame `number` and why.
cv::Mat Decoded(const cv::Mat& raw, const DeviceCameraOptions& options, int64_t number) {
  if (!IsCompressed(raw)) return raw;
  ImageLimits limits;
  limits.max_pixels = options.max_image_pixels;
  DecodedImage decoded =
      DecodeBounded(std::span(raw.ptr<uint8_t>(), raw.total()), PixelLayout::kBgr, limits);
  if (!decoded.ok()) {
    throw CameraError("device:" + options.device + ": frame " + std::to_string(number) + " (" +
                          std::to_string(raw.total()) + " bytes) refused: " + decoded.error,
                      true);
  }
  return decoded.image;
}

CameraIntrinsics IntrinsicsOf(VideoDevice& device, const DeviceCameraOptions& options) {
  cv::Size size = device.FrameSize();
  if (size.width <= 0 || size.height <= 0) {
    cv::Mat first;
    if (!device.Grab() || !device.Retrieve(&first)) {
      throw CameraError("device:" + options.device + ": opened but delivers no frame", false);
    }
    try {
      size = Decoded(first, options, 0).size();
    } catch (const CameraError& e) {
      throw CameraError(std::string(e.what()) + "; its size is unknown", false);
    }
  }
  return CameraIntrinsics::FromHorizontalFov(size.width, size.height, options.hfov_deg);
}

int64_t Micros(double seconds) { return static_cast<int64_t>(std::llround(seconds * 1e6)); }

}  // namespace

std::unique_ptr<VideoDevice> MakeV4l2Device(const DeviceCameraOptions& options) {
  const bool index = IsIndex(options.device);
  OpencvDeviceRequest request;
  request.path = index ? "" : options.device.c_str();
  request.index = index ? std::stoi(options.device) : -1;
  request.width = options.width;
  request.height = options.height;
  request.fps = options.fps;
  return std::unique_ptr<VideoDevice>(OpencvVideo().v4l2_device(&request));
}

void DeviceCameraOptions::Validate() const {
  if (device.empty()) throw std::invalid_argument("device camera: device is empty");
  if (!(fps >= 0.0 && fps <= 1000.0)) {
    throw std::invalid_argument("device camera: fps " + std::to_string(fps) +
                                " must be in [0, 1000]");
  }
  if (!(hfov_deg > 0.0 && hfov_deg < 180.0)) {
    throw std::invalid_argument("device camera: hfov_deg " + std::to_string(hfov_deg) +
                                " must be in (0, 180)");
  }
  if (width < 0 || height < 0) {
    throw std::invalid_argument("device camera: requested size " + std::to_string(width) + "x" +
                                std::to_string(height) + " must not be negative");
  }
  if (max_image_pixels < 1) {
    throw std::invalid_argument("device camera: max_image_pixels " +
                                std::to_string(max_image_pixels) + " must be at least 1");
  }
  if (!(reopen_min_s > 0.0 && reopen_max_s >= reopen_min_s && reopen_max_s <= 3600.0)) {
    throw std::invalid_argument("device camera: reopen backoff [" + std::to_string(reopen_min_s) +
                                ", " + std::to_string(reopen_max_s) +
                                "] s must satisfy 0 < min ≤ max ≤ 3600");
  }
}

DeviceCamera::DeviceCamera(const DeviceCameraOptions& options, Clock& clock)
    : DeviceCamera(options, MakeV4l2Device(options), clock) {}

DeviceCamera::DeviceCamera(const DeviceCameraOptions& options, std::unique_ptr<VideoDevice> device,
                           Clock& clock)
    : options_(options),
      clock_(clock),
      device_(std::move(device)),
      intrinsics_(IntrinsicsOf(OpenOrThrow(options, *device_), options)),
      period_us_(options.fps > 0.0 ? Micros(1.0 / options.fps) : 0),
      backoff_us_(Micros(options.reopen_min_s)) {}

void DeviceCamera::Lost(const std::string& why) {
  device_->Close();
  retry_at_us_ = clock_.SteadyMicros() + backoff_us_;
  char wait[32];
  std::snprintf(wait, sizeof wait, "%.1f", static_cast<double>(backoff_us_) * 1e-6);
  throw CameraError(name() + ": " + why + "; reopening in " + wait + " s", true);
}

std::optional<CameraFrame> DeviceCamera::Next() {
  if (interrupted_.raised()) return std::nullopt;
  if (!device_->IsOpen()) {
    if (!clock_.WaitUntil(retry_at_us_, interrupted_)) return std::nullopt;
    if (!device_->Open()) {
      backoff_us_ = std::min(2 * backoff_us_, Micros(options_.reopen_max_s));
      Lost("device not available");
    }
    backoff_us_ = Micros(options_.reopen_min_s);
    due_us_ = 0;
  }
  // Grab (cheap, no decode) until a frame is due; deliver the newest one.
  for (;;) {
    // Each grab waits one frame of the device at most; a slow rate is many grabs.
    if (interrupted_.raised()) return std::nullopt;
    if (!device_->Grab()) Lost("no frame (device disconnected?)");
    const int64_t now = clock_.SteadyMicros();
    if (period_us_ == 0 || now >= due_us_) {
      due_us_ = now > due_us_ + period_us_ ? now + period_us_ : due_us_ + period_us_;
      break;
    }
  }
  cv::Mat raw;
  if (!device_->Retrieve(&raw)) {
    throw CameraError(name() + ": a frame could not be decoded", true);  // device stays open
  }
  const int64_t number = retrieved_++;  // counts refused frames too, so each keeps its number
  CameraFrame frame;
  frame.observation.bgr = ToBgrOfSize(Decoded(raw, options_, number), intrinsics_);
  frame.utime = clock_.WallMicros();
  frame.sequence = delivered_++;
  return frame;
}

}  // namespace tsc
