#pragma once
// Bubble surfaces B_i(x, t) (A.1, A.2): one radius rho_i per sampled viewing direction and
// feature, accumulated over the observations made at one base point.

#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "core/bubble/camera.h"
#include "core/bubble/features.h"
#include "core/range.h"

namespace tsc {

/// Regular sampling of the viewing sphere: f1 (pan) in [0, 2π) at n_pan() steps of d_phi,
/// f2 (tilt from the zenith) in [0, π] at n_tilt() cell centres (j + 1/2)·d_phi.
class ViewingGrid {
 public:
  /// d_phi in degrees; must divide 180 into a whole number of steps (e.g. 2.5, 5).
  explicit ViewingGrid(double d_phi_deg = 2.5);
  double d_phi_rad() const { return d_phi_rad_; }
  int n_pan() const { return n_pan_; }
  int n_tilt() const { return n_tilt_; }
  double f1(int i) const { return i * d_phi_rad_; }
  double f2(int j) const { return (j + 0.5) * d_phi_rad_; }

 private:
  double d_phi_rad_;
  int n_pan_, n_tilt_;
};

/// One camera frame as the bubble space sees it.
struct Observation {
  cv::Mat bgr;       ///< CV_8UC3 colour image
  cv::Mat depth_m;   ///< optional CV_32F range in metres (0 = no reading), same size as bgr
  PanTilt pan_tilt;  ///< camera direction relative to the base when the frame was taken
};

struct BubbleSurfaceOptions {
  double d_phi_deg = 2.5;     ///< grid spacing of viewing directions, degrees
  float rest_radius = 0.0f;   ///< rho_0, radius of unobserved directions
  double max_depth_m = 10.0;  ///< range that maps to depth feature value 1
  int patch_px = 12;          ///< side of the resampled d_phi x d_phi patch, pixels
  /// σ of the Gaussian blur before the orientation gradients, degrees of view (0 = none).
  double orientation_blur_deg = 0.0;
  // Valid ranges (also the configuration's, bubble.*); d_phi_deg must also divide 180.
  // Down to 0.5°: a finer grid holds more cells than any camera resolves (0.001° asked for
  // 10¹⁰ cells and ended in bad_alloc).
  static constexpr Range kDPhiDegRange{0.5, 90};
  static constexpr Range kRestRadiusRange{0, 1};
  static constexpr Range kMaxDepthMRange{0, 1000, /*min_open=*/true};
  static constexpr Range kPatchPxRange{6, 64};
  static constexpr Range kOrientationBlurDegRange{0, 10};
  void Validate() const;  ///< throws std::invalid_argument naming the bad field
};

/// The N_v bubble surfaces of one base point. Observe() overwrites the directions a frame
/// covers (A.2); directions never observed keep rho_0.
class BubbleSurface {
 public:
  BubbleSurface(FeatureSet features, CameraIntrinsics camera, BubbleSurfaceOptions options = {});

  /// Adds one frame. Throws std::invalid_argument if the image size does not match the
  /// camera, or depth is needed and missing / of another size.
  void Observe(const Observation& obs);
  /// Forgets all observations (a new base point).
  void Reset();
  /// Sets feature block `feature`'s value at one grid direction (row `tilt`, column `pan`) and
  /// marks the direction observed; the other features there keep their values. For surfaces
  /// made of known values (tests, synthetic data). Throws std::invalid_argument on an index
  /// out of range or a value that is not finite and >= 0.
  void Set(int feature, int tilt, int pan, float value);

  const ViewingGrid& grid() const { return grid_; }
  const FeatureSet& features() const { return features_; }
  const CameraIntrinsics& camera() const { return camera_; }
  /// rho for feature block `i`: n_tilt x n_pan, row = tilt index, column = pan index.
  const Eigen::MatrixXf& radius(int i) const { return rho_[i]; }
  /// 1 where a direction has been observed.
  const Eigen::Matrix<uint8_t, Eigen::Dynamic, Eigen::Dynamic>& observed() const {
    return observed_;
  }
  int ObservedCount() const;
  /// Whether a direction of pan column `pan` has been observed since the last Reset(); every
  /// other column holds rho_0 in every feature block.
  bool ColumnObserved(int pan) const { return observed_columns_[static_cast<size_t>(pan)] != 0; }
  float rest_radius() const { return options_.rest_radius; }

 private:
  FeatureSet features_;
  CameraIntrinsics camera_;
  BubbleSurfaceOptions options_;
  ViewingGrid grid_;
  PatchFeatureExtractor extractor_;
  std::vector<Eigen::MatrixXf> rho_;
  Eigen::Matrix<uint8_t, Eigen::Dynamic, Eigen::Dynamic> observed_;
  // 1 for each pan column with an observed direction: a frame covers a sixth of the columns,
  // and Reset() and the descriptor's sums pass over the others without reading them.
  std::vector<uint8_t> observed_columns_;

  // A grid direction seen by a frame: its cell (column-major index into rho_ and observed_)
  // and the top-left corner of its patch in the resized image.
  struct PatchSite {
    int cell;
    int x0, y0;
  };
  // Patch sites of one camera direction; computed once per (pan, tilt) and kept.
  struct SiteList {
    PanTilt pan_tilt;
    std::vector<PatchSite> sites;
  };
  const std::vector<PatchSite>& Sites(const PanTilt& pan_tilt);
  std::vector<PatchSite> ComputeSites(const PanTilt& pan_tilt) const;
  // Resizes `in` to resized_size_ (area averaging, a prefiltered bilinear step).
  void Resize(const cv::Mat& in, cv::Mat& out);

  cv::Size resized_size_;  // image size at which a d_phi patch is patch_px wide
  CameraIntrinsics resized_camera_;
  std::vector<SiteList> site_cache_;  // most recent last, bounded
  // Per-frame images, reused from frame to frame to avoid allocations. A copy of the surface
  // starts with its own, empty ones (copied cv::Mats would share their pixels).
  struct Scratch {
    cv::Mat shrunk, prefiltered, small_bgr, grey8, hsv, depth_norm, depth_valid;
    FeatureImages images;
    Scratch() = default;
    Scratch(const Scratch&) {}
    Scratch& operator=(const Scratch&) { return *this; }
  };
  Scratch scratch_;
};

}  // namespace tsc
