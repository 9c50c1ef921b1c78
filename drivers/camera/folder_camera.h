#pragma once
// Frames of a dataset folder (DESIGN §7.1) as a camera: natural name order, with depth when
// the folder has it, paced to a frame rate, optionally looping.

#include <cstdint>
#include <deque>
#include <filesystem>
#include <optional>
#include <string>

#include "drivers/camera/camera_source.h"
#include "drivers/clock.h"
#include "drivers/dataset/dataset.h"

namespace tsc {

struct FolderCameraOptions {
  std::filesystem::path folder;  ///< a dataset folder (frames directly in it or in rgb/)
  double fps = 10.0;             ///< frames per second delivered; 0 = as fast as possible
  bool loop = false;             ///< start again at the first frame after the last
  /// Horizontal field of view, degrees in (0, 180), used when the folder has no camera.json
  /// (camera.json, when present, wins).
  double hfov_deg = 60.0;
  /// Largest frame decoded, width x height by the file's header (DatasetOptions).
  int64_t max_image_pixels = kDefaultMaxImagePixels;
  /// Throws std::invalid_argument naming the bad field.
  void Validate() const;
};

class FolderCamera : public CameraSource {
 public:
  /// Opens the dataset (Dataset::Open). Throws CameraError(recoverable = false) naming the
  /// folder or file at fault, std::invalid_argument for bad options. `clock` must outlive
  /// the camera.
  explicit FolderCamera(const FolderCameraOptions& options, Clock& clock = Clock::System());

  /// The next frame in name order, at most fps per second; a frame of a pan-sweep dataset
  /// comes as its views, the last one ending the base point. A frame that cannot be decoded
  /// (missing, empty, truncated or corrupt file, other size) throws CameraError(recoverable = true)
  /// naming the file; the following call continues with the frame after it. nullopt after
  /// the last frame unless looping.
  std::optional<CameraFrame> Next() override;
  bool replays_every_frame() const override { return options_.fps == 0.0; }
  const CameraIntrinsics& intrinsics() const override { return intrinsics_; }
  std::string name() const override { return "folder:" + options_.folder.string(); }
  std::optional<BasePointSpacing> spacing() const override { return dataset_.spacing(); }
  int views_per_base_point() const override { return dataset_.sweep().views(); }

  /// Frames in the folder.
  int size() const { return dataset_.size(); }

 private:
  FolderCameraOptions options_;
  Clock& clock_;
  Dataset dataset_;
  CameraIntrinsics intrinsics_;
  Pacer pacer_;
  int next_index_ = 0;               ///< frame read by the next Next()
  std::deque<Observation> pending_;  ///< views of the current frame not yet delivered
  int64_t delivered_ = 0;
};

/// False when an image file is evidently cut short: a JPEG without its end-of-image marker
/// near the end, a PNG without its IEND chunk. Files of other types pass. Reads only the
/// file's tail. Decoders fill a truncated JPEG with grey and report success; this catches it.
bool ImageFileLooksComplete(const std::filesystem::path& file);

}  // namespace tsc
