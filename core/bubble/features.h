#pragma once
// Sensory features q_i of the bubble space (thesis section 2.3) and the feature sets L1..L5.

#include <array>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace tsc {

/// One visual or depth feature. Values q_i are in [0, 1].
enum class Feature {
  kHue,         ///< circular mean hue of the patch, scaled to [0,1]
  kVertical,    ///< response to a vertical grating (Cartesian)
  kHorizontal,  ///< response to a horizontal grating (Cartesian)
  kHyperbolic,  ///< response to a hyperbolic grating (non-Cartesian, Gallant et al. 1993)
  kPolar,       ///< response to a polar (angular) grating (non-Cartesian)
  kConcentric,  ///< response to a concentric (radial) grating (non-Cartesian)
  kIntensity,   ///< mean grey level of the patch in [0,1]; used for informativeness (app. C)
  kDepth,       ///< mean range of the patch divided by the sensor's maximum range
  // Hue as a pair (DESIGN §3.1 amended): 0.5 + 0.5·mean(saturation·cos hue), likewise sin.
  // Red does not wrap and grey (0.5, 0.5) is no colour, unlike kHue where grey is red.
  kHueCos,
  kHueSin,
  // Contrast-normalised gradient orientation: the share of the patch's gradient energy along
  // 0°, 45°, 90° and 135° (image x axis; the four sum to just under 1 on a textured patch, 0 on
  // a flat one, through the flat-patch floor of features.cc). An offset of the light leaves
  // them unchanged and a gain scales the four alike, where a grating's response scales with it.
  kOrient0,
  kOrient45,
  kOrient90,
  kOrient135,
};
inline constexpr int kNumFeatureKinds = 14;

const char* FeatureName(Feature f);

/// An ordered list of distinct features; its order is the block order of the descriptor.
class FeatureSet {
 public:
  /// Throws std::invalid_argument on an empty list or a repeated feature.
  explicit FeatureSet(std::vector<Feature> features);
  /// Thesis sets: L1 hue+Cartesian, L2 L1+non-Cartesian, L3 depth, L4 L1+depth, L5 L2+depth.
  /// `with_intensity` appends intensity (the thesis' 7th feature, needed by place detection).
  static FeatureSet Thesis(int l, bool with_intensity = true);
  /// Hue as a (cos, sin) pair, the L2 gratings, the four orientation shares and intensity:
  /// the set measured in docs/decisions.md "Features that survive lighting" (not the default).
  static FeatureSet Recognition();
  /// Parses "L2", "L5", "L2+I" (with intensity, the default) or "L2-I" (without), or a
  /// comma-separated list of feature names ("hue_cos,hue_sin,orient_0,...,intensity").
  static FeatureSet Parse(const std::string& name);

  const std::vector<Feature>& features() const { return features_; }
  int size() const { return static_cast<int>(features_.size()); }
  /// Block index of `f`, or -1 if absent.
  int IndexOf(Feature f) const;
  bool Contains(Feature f) const { return IndexOf(f) >= 0; }
  bool NeedsDepth() const { return Contains(Feature::kDepth); }
  bool NeedsHue() const;
  bool NeedsOrientation() const;
  /// Whether a feature of the set is computed from the grey image.
  bool NeedsGrey() const;
  /// The thesis name ("L2+I") or the comma-separated list Parse reads back.
  std::string ToString() const;

 private:
  std::vector<Feature> features_;
};

/// The per-frame images the features are computed from, all of one size (the resized frame);
/// an image no feature of the set needs stays empty.
struct FeatureImages {
  cv::Mat grey;                   ///< CV_32F in [0,1]
  cv::Mat hue_cos, hue_sin;       ///< CV_32F per-pixel cos/sin of hue weighted by saturation
  cv::Mat depth;                  ///< CV_32F in [0,1], 0 = no reading
  std::array<cv::Mat, 4> orient;  ///< CV_32F gradient energy along 0°, 45°, 90°, 135°
  /// The blurred grey ComputeOrientationImages reuses from frame to frame (no meaning outside
  /// it).
  cv::Mat blurred_grey;
};

/// Fills `out.orient` from `grey`: per pixel, with (gx, gy) the central-difference gradient
/// and m its magnitude, the doubled-angle vector m·(cos 2θ, sin 2θ) = ((gx²−gy²), 2gx·gy)/m
/// split into its four half-wave parts (0°: cos 2θ > 0, 90°: < 0; 45°: sin 2θ > 0, 135°: < 0).
/// With `blur_px` > 0 the gradients are taken of `grey` blurred by a Gaussian of that σ
/// (pixels; borders reflected), so that they follow the scene's edges rather than sensor noise
/// and compression blocks (docs/calibration.md, fifteenth pass).
void ComputeOrientationImages(const cv::Mat& grey, FeatureImages& out, double blur_px = 0.0);

/// Computes feature values on square patches of side `patch_px` of a prepared image.
/// The grating kernels are zero-mean and unit-norm; a response is the magnitude of the
/// quadrature pair (cosine and sine phase) of the kernel, divided by patch_px/2 (the largest
/// possible response of a [0,1] patch) and clamped to [0,1].
/// Kernels, with (u, v) the patch coordinates centred and scaled to [-1, 1]:
///   vertical    cos/sin(2π·2·u)             horizontal  cos/sin(2π·2·v)
///   hyperbolic  cos/sin(2π·2·u·v)            polar       cos/sin(4·atan2(v,u))
///   concentric  cos/sin(2π·2·sqrt(u²+v²))
class PatchFeatureExtractor {
 public:
  explicit PatchFeatureExtractor(int patch_px = 12);
  int patch_px() const { return patch_px_; }
  /// (x0, y0) is the patch's top-left corner, fully inside the images. Writes one value per
  /// feature of `set` into `out`.
  void Compute(const FeatureSet& set, const FeatureImages& images, int x0, int y0,
               float* out) const;

 private:
  int patch_px_;
  // Per grating: cosine and sine kernel, patch_px*patch_px each, row-major.
  std::array<std::vector<float>, 10> kernels_;
};

}  // namespace tsc
