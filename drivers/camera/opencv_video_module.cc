// libtscd_opencv_video.so: cv::VideoCapture behind the VideoDevice and VideoFileReader
// interfaces, loaded by drivers/camera/opencv_video.cc only for camera.source device or video.
// Self-contained on purpose: it links OpenCV alone, none of tscd's libraries.
#include <exception>
#include <filesystem>
#include <opencv2/videoio.hpp>
#include <string>
#include <system_error>

#include "drivers/camera/opencv_video.h"

namespace tsc {
namespace {

constexpr uint32_t FourCc(const char (&code)[5]) {
  return static_cast<uint32_t>(code[0]) | static_cast<uint32_t>(code[1]) << 8 |
         static_cast<uint32_t>(code[2]) << 16 | static_cast<uint32_t>(code[3]) << 24;
}

// OpenCV throws cv::Exception from a backend it cannot drive: the interfaces say false.
template <typename Call>
bool WithoutThrowing(Call call) {
  try {
    return call();
  } catch (const std::exception&) {
    return false;
  }
}

// The frame size the device or container declares (0x0 when it does not say).
cv::Size DeclaredSize(const cv::VideoCapture& capture) {
  return {static_cast<int>(capture.get(cv::CAP_PROP_FRAME_WIDTH)),
          static_cast<int>(capture.get(cv::CAP_PROP_FRAME_HEIGHT))};
}

class V4l2Device : public VideoDevice {
 public:
  explicit V4l2Device(const OpencvDeviceRequest& request)
      : path_(request.path),
        index_(request.index),
        width_(request.width),
        height_(request.height),
        fps_(request.fps) {}

  bool Open() override {
    capture_.release();
    // V4L2 only: other backends would take a device path for a file or a pipeline. A missing
    // path is not handed to OpenCV at all (it would log a warning per attempt).
    std::error_code ec;
    if (!path_.empty() && !std::filesystem::exists(path_, ec)) return false;
    const bool opened = WithoutThrowing([this] {
      if (path_.empty()) {
        capture_.open(index_, cv::CAP_V4L2);
      } else {
        capture_.open(path_, cv::CAP_V4L2);
      }
      if (!capture_.isOpened()) return false;
      if (width_ > 0) capture_.set(cv::CAP_PROP_FRAME_WIDTH, width_);
      if (height_ > 0) capture_.set(cv::CAP_PROP_FRAME_HEIGHT, height_);
      if (fps_ > 0.0) capture_.set(cv::CAP_PROP_FPS, fps_);
      // An MJPEG device's frames are taken undecoded so that DeviceCamera can read the JPEG
      // header first: OpenCV's own decode would allocate whatever size a frame claims.
      const auto fourcc = static_cast<uint32_t>(capture_.get(cv::CAP_PROP_FOURCC));
      if (fourcc == FourCc("MJPG") || fourcc == FourCc("JPEG")) {
        capture_.set(cv::CAP_PROP_CONVERT_RGB, 0);
      }
      return true;
    });
    if (!opened) capture_.release();  // half open, or a device OpenCV cannot drive
    return opened;
  }
  void Close() override { capture_.release(); }
  bool IsOpen() const override { return capture_.isOpened(); }
  bool Grab() override {
    return WithoutThrowing([this] { return capture_.grab(); });
  }
  bool Retrieve(cv::Mat* frame) override {
    return WithoutThrowing([&] { return capture_.retrieve(*frame) && !frame->empty(); });
  }
  cv::Size FrameSize() const override { return DeclaredSize(capture_); }

 private:
  std::string path_;
  int index_;
  int width_;
  int height_;
  double fps_;
  cv::VideoCapture capture_;
};

class CvVideoFile : public VideoFileReader {
 public:
  bool Open(const char* path) {
    return WithoutThrowing([&] { return capture_.open(path, cv::CAP_ANY) && capture_.isOpened(); });
  }
  bool Read(cv::Mat* frame) override {
    return WithoutThrowing([&] { return capture_.read(*frame) && !frame->empty(); });
  }
  cv::Size FrameSize() const override { return DeclaredSize(capture_); }

 private:
  cv::VideoCapture capture_;
};

}  // namespace
}  // namespace tsc

// The entry points drivers/camera/opencv_video.cc looks up by name.
extern "C" {

__attribute__((visibility("default"))) int tsc_opencv_video_abi() { return tsc::kOpencvVideoAbi; }

__attribute__((visibility("default"))) tsc::VideoDevice* tsc_opencv_v4l2_device(
    const tsc::OpencvDeviceRequest* request) {
  return new tsc::V4l2Device(*request);
}

__attribute__((visibility("default"))) tsc::VideoFileReader* tsc_opencv_video_file(
    const char* path) {
  auto* file = new tsc::CvVideoFile;
  if (file->Open(path)) return file;
  delete file;
  return nullptr;
}

}  // extern "C"
