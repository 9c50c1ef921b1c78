#pragma once
// A video file as a camera (any container and codec OpenCV's videoio reads, loaded as a module:
// drivers/camera/opencv_video.h), paced to a frame rate, optionally looping.

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "drivers/camera/camera_source.h"
#include "drivers/camera/video_file_reader.h"
#include "drivers/clock.h"

namespace tsc {

struct VideoCameraOptions {
  std::filesystem::path file;
  double fps = 10.0;       ///< frames per second delivered; 0 = as fast as they decode
  bool loop = false;       ///< start again at the first frame after the last
  double hfov_deg = 60.0;  ///< horizontal field of view, degrees in (0, 180)
  /// Largest frame size accepted, width x height as the container declares it (checked when
  /// the file is opened, before a frame is read for the pipeline; FFmpeg's decoders refuse
  /// frames beyond (w+128)(h+128) ≥ 2^28 themselves).
  int64_t max_image_pixels = int64_t{4096} * 4096;
  /// Throws std::invalid_argument naming the bad field.
  void Validate() const;
};

class VideoCamera : public CameraSource {
 public:
  /// Opens the file and reads its frame size. Throws CameraError(recoverable = false) naming
  /// the file when it is missing, OpenCV's video module cannot be loaded or cannot decode it or its
  /// frames are larger than max_image_pixels (naming the declared size), std::invalid_argument for
  /// bad options. `clock` must outlive the camera.
  explicit VideoCamera(const VideoCameraOptions& options, Clock& clock = Clock::System());

  /// The next decoded frame (CV_8UC3), at most fps per second; nullopt at the end of the file
  /// unless looping (a file that yields no frame at all ends even when looping).
  std::optional<CameraFrame> Next() override;
  bool replays_every_frame() const override { return options_.fps == 0.0; }
  const CameraIntrinsics& intrinsics() const override { return intrinsics_; }
  std::string name() const override { return "video:" + options_.file.string(); }

 private:
  void Open();
  /// Reads one frame into `bgr`; false at the end of the file.
  bool Read(cv::Mat* bgr);

  VideoCameraOptions options_;
  Clock& clock_;
  std::unique_ptr<VideoFileReader> reader_;
  CameraIntrinsics intrinsics_;
  Pacer pacer_;
  int64_t delivered_ = 0;
  int64_t read_since_open_ = 0;
};

}  // namespace tsc
