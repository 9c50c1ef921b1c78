#include "drivers/camera/video_camera.h"

#include <stdexcept>
#include <system_error>

#include "drivers/camera/frame_convert.h"
#include "drivers/camera/opencv_video.h"

namespace tsc {
namespace fs = std::filesystem;
namespace {

std::unique_ptr<VideoFileReader> OpenCapture(const fs::path& file) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) {
    throw CameraError("video:" + file.string() + ": no such file", false);
  }
  std::unique_ptr<VideoFileReader> reader(OpencvVideo().video_file(file.c_str()));
  if (reader == nullptr) {
    throw CameraError("video:" + file.string() + ": OpenCV cannot open it (container or codec)",
                      false);
  }
  return reader;
}

/// Frame size from the container, or from the first frame when the container does not say.
CameraIntrinsics IntrinsicsOf(const fs::path& file, double hfov_deg, int64_t max_pixels) {
  const std::unique_ptr<VideoFileReader> capture = OpenCapture(file);
  const cv::Size declared = capture->FrameSize();
  int width = declared.width;
  int height = declared.height;
  if (int64_t{width} * height > max_pixels) {
    throw CameraError("video:" + file.string() + ": its frames are " + std::to_string(width) + "x" +
                          std::to_string(height) + " pixels, more than the limit of " +
                          std::to_string(max_pixels) + " (camera.max_image_pixels)",
                      false);
  }
  if (width <= 0 || height <= 0) {
    cv::Mat first;
    if (!capture->Read(&first)) {
      throw CameraError("video:" + file.string() + ": no decodable frame", false);
    }
    width = first.cols;
    height = first.rows;
  }
  return CameraIntrinsics::FromHorizontalFov(width, height, hfov_deg);
}

}  // namespace

void VideoCameraOptions::Validate() const {
  if (file.empty()) throw std::invalid_argument("video camera: file is empty");
  if (!(fps >= 0.0 && fps <= 1000.0)) {
    throw std::invalid_argument("video camera: fps " + std::to_string(fps) +
                                " must be in [0, 1000]");
  }
  if (!(hfov_deg > 0.0 && hfov_deg < 180.0)) {
    throw std::invalid_argument("video camera: hfov_deg " + std::to_string(hfov_deg) +
                                " must be in (0, 180)");
  }
  if (max_image_pixels < 1) {
    throw std::invalid_argument("video camera: max_image_pixels " +
                                std::to_string(max_image_pixels) + " must be at least 1");
  }
}

VideoCamera::VideoCamera(const VideoCameraOptions& options, Clock& clock)
    : options_((options.Validate(), options)),
      clock_(clock),
      intrinsics_(IntrinsicsOf(options.file, options.hfov_deg, options.max_image_pixels)),
      pacer_(options.fps, clock) {
  Open();
}

void VideoCamera::Open() {
  reader_ = OpenCapture(options_.file);
  read_since_open_ = 0;
}

bool VideoCamera::Read(cv::Mat* bgr) {
  cv::Mat raw;
  if (!reader_->Read(&raw)) return false;
  *bgr = ToBgrOfSize(raw, intrinsics_);
  ++read_since_open_;
  return true;
}

std::optional<CameraFrame> VideoCamera::Next() {
  if (interrupted_.raised()) return std::nullopt;
  CameraFrame frame;
  if (!Read(&frame.observation.bgr)) {
    if (!options_.loop || read_since_open_ == 0) return std::nullopt;
    Open();
    if (!Read(&frame.observation.bgr)) return std::nullopt;
  }
  pacer_.Wait(&interrupted_);
  if (interrupted_.raised()) return std::nullopt;
  frame.utime = clock_.WallMicros();
  frame.sequence = delivered_++;
  return frame;
}

}  // namespace tsc
