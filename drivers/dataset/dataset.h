#pragma once
// A dataset folder, the input of the offline tools (DESIGN §7.1): colour frames in natural
// name order, optional depth, optional camera intrinsics and optional ground truth.
//
//   DATASET/            frames (*.jpg, *.jpeg, *.png) here, or in DATASET/rgb/ when it exists
//   DATASET/depth/      optional: <stem>.png per frame, 16-bit, millimetres (0 = no reading)
//   DATASET/camera.json optional: {"width":W,"height":H,"hfov_deg":F} or fx, fy, cx, cy
//                       (default: 60° horizontal field of view at the first image's size);
//                       "sweep_views":K,"sweep_deg":D: every image holds the K views of a
//                       pan sweep side by side (view j at pan j·D/K, counter-clockwise), and
//                       the intrinsics are those of one view; "spacing_m":S (metres of
//                       travel between frames), "fps":F (frames of a camera moving at
//                       kAssumedSpeedMps) or "keyframes":true (about a metre apart) declare
//                       how far apart the frames are (BasePointSpacing)
//   DATASET/groundtruth.csv  optional: frame,place[,x,y,heading]   (frame 1-based)
//   DATASET/revisits.csv     optional: frame,revisits              (1-based, space separated)
//   DATASET/groundtruth.bmp  optional, read when there is no revisits.csv: the same as an
//                            N x N bitmap, RTAB-Map's form (drivers/dataset/revisit_bitmap.h)
//
// Frames are read one at a time by Load(): a dataset of 10⁴ frames costs a list of paths.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/bubble/camera.h"
#include "core/bubble/surface.h"
#include "drivers/dataset/base_point_spacing.h"
#include "drivers/dataset/planar_pose.h"
#include "drivers/image/bounded_decode.h"

namespace tsc {

/// Any problem with a dataset folder. The message names the file or folder at fault.
class DatasetError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
  /// "<where>: <what>".
  DatasetError(const std::filesystem::path& where, const std::string& what)
      : std::runtime_error(where.string() + ": " + what) {}
};

/// Planar pose of the camera from groundtruth.csv (units as the dataset gives them; heading
/// in radians by convention).
using GroundTruthPose = PlanarPose;

/// "2.jpg" < "10.jpg": runs of digits compare by value, everything else byte-wise.
bool NaturalLess(const std::string& a, const std::string& b);

/// The views of a pan sweep written side by side in `strip` (each `strip.cols / views` wide),
/// each with its pan; `strip` itself, unchanged, for one view. Precondition: the width is a
/// multiple of sweep.views().
std::vector<Observation> SplitSweep(Observation strip, const PanSweep& sweep);

/// What Open does with an image file of zero bytes: refuse the dataset (the offline tools),
/// or list it like any frame so that Load() fails on it as on a truncated file (a camera,
/// which logs a bad frame and reads on).
enum class EmptyImages { kRefuse, kLoadFails };

/// How a dataset is read.
struct DatasetOptions {
  EmptyImages empty_images = EmptyImages::kRefuse;
  /// Largest frame (or depth image) accepted, width x height pixels by the file's header; a
  /// larger one is refused before it is decoded (camera.max_image_pixels, default 4096x4096).
  int64_t max_image_pixels = kDefaultMaxImagePixels;
  /// Throws std::invalid_argument naming the bad field.
  void Validate() const;
};

class Dataset {
 public:
  /// Lists the frames and reads the side files. Checks at once what is cheap to check: the
  /// folder, the presence of images, zero-size image files (options.empty_images), the first
  /// image that is not empty (for the size; decoded only when its header claims at most
  /// options.max_image_pixels), one depth file per frame, camera.json, groundtruth.csv and
  /// revisits.csv (or groundtruth.bmp). Throws DatasetError naming the file or folder at fault (and
  /// an image's claimed size), std::invalid_argument for bad options.
  static Dataset Open(const std::filesystem::path& folder, const DatasetOptions& options = {});

  const std::filesystem::path& folder() const { return folder_; }
  /// Number of frames.
  int size() const { return static_cast<int>(images_.size()); }
  /// Frame i (0-based, natural name order).
  const std::filesystem::path& image_path(int i) const { return images_.at(i); }
  bool has_depth() const { return !depths_.empty(); }
  /// Depth file of frame i; precondition: has_depth().
  const std::filesystem::path& depth_path(int i) const { return depths_.at(i); }
  /// Intrinsics of one view (from camera.json or the 60° default).
  const CameraIntrinsics& camera() const { return camera_; }
  /// The pan sweep of every frame (one view without "sweep_views" in camera.json).
  const PanSweep& sweep() const { return sweep_; }
  /// Reads frame i as its views (one without a sweep): CV_8UC3 colour and, with depth,
  /// CV_32F metres, each with its pan (zero without a sweep). Throws DatasetError naming the
  /// file when it cannot be read or has another size than the first frame; the size is checked
  /// on the file's header, before anything is decoded, and the error says what it claims.
  std::vector<Observation> Load(int i) const;

  /// How far apart the frames are: camera.json's "spacing_m", "fps" (at kAssumedSpeedMps) or
  /// "keyframes"; else the median step between consecutive ground-truth poses; else a
  /// keyframe sequence (kKeyframeSpacingM) is assumed. Place detection's τ_p follows it.
  const BasePointSpacing& spacing() const { return spacing_; }

  /// Per-frame place label (0-based frames, "" where unlabelled); empty without
  /// groundtruth.csv.
  const std::vector<std::string>& labels() const { return labels_; }
  /// Per-frame pose when groundtruth.csv has x,y,heading; empty otherwise.
  const std::vector<std::optional<GroundTruthPose>>& poses() const { return poses_; }
  /// Per-frame earlier frames showing the same place (0-based); empty without revisits.csv
  /// or groundtruth.bmp.
  const std::vector<std::vector<int>>& revisits() const { return revisits_; }
  /// The file the revisits were read from ("revisits.csv" or "groundtruth.bmp"; "" without).
  const std::string& revisits_file() const { return revisits_file_; }

  /// Frames 0, stride, 2·stride, ... as a dataset of their own (the base points of a camera
  /// denser than the calibrated spacing: StrideFor): labels, poses and depth follow their
  /// frames, a revisit names the taken frame nearest it (kept when earlier than the frame),
  /// and spacing() is EveryNth's. Image paths stay the files', so messages name them. Throws
  /// std::invalid_argument unless stride ≥ 1.
  Dataset EveryNth(int stride) const;
  /// The given frames (ascending, 0-based) as a dataset of their own, as EveryNth takes its
  /// frames; spacing() stays this one's. Throws std::invalid_argument for a frame out of order
  /// or range.
  Dataset Subset(const std::vector<int>& frames) const;

 private:
  Dataset(std::filesystem::path folder, std::vector<std::filesystem::path> images,
          std::vector<std::filesystem::path> depths, CameraIntrinsics camera, PanSweep sweep,
          cv::Size frame_size, DatasetOptions options);

  std::filesystem::path folder_;
  std::vector<std::filesystem::path> images_;
  std::vector<std::filesystem::path> depths_;
  CameraIntrinsics camera_;
  PanSweep sweep_;
  BasePointSpacing spacing_;
  cv::Size frame_size_;  ///< of every frame (all its views side by side): the first frame's
  DatasetOptions options_;
  std::vector<std::string> labels_;
  std::vector<std::optional<GroundTruthPose>> poses_;
  std::vector<std::vector<int>> revisits_;
  std::string revisits_file_;
};

}  // namespace tsc
