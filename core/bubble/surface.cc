#include "core/bubble/surface.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

namespace tsc {
namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;
// Patch site lists kept for distinct camera directions (a PTZ sweep revisits a few).
constexpr size_t kSiteCacheSize = 16;

// Number of d_phi steps in 180 degrees; throws unless it is a whole number.
int StepsIn180(double d_phi_deg) {
  BubbleSurfaceOptions::kDPhiDegRange.Check("bubble.d_phi_deg", d_phi_deg);
  const double steps = 180.0 / d_phi_deg;
  const double whole = std::round(steps);
  if (std::abs(steps - whole) > 1e-9 * steps) {
    throw std::invalid_argument("bubble.d_phi_deg must divide 180 into whole steps, got " +
                                std::to_string(d_phi_deg));
  }
  return static_cast<int>(whole);
}

// Size of the image resized so that d_phi spans patch_px pixels in both directions.
cv::Size ResizedSize(const CameraIntrinsics& camera, const BubbleSurfaceOptions& options) {
  const double d_phi = options.d_phi_deg * kDegToRad;
  const double sx = options.patch_px / (camera.fx() * d_phi);
  const double sy = options.patch_px / (camera.fy() * d_phi);
  return cv::Size(std::max(1, static_cast<int>(std::lround(camera.width() * sx))),
                  std::max(1, static_cast<int>(std::lround(camera.height() * sy))));
}

const BubbleSurfaceOptions& Validated(const BubbleSurfaceOptions& options) {
  options.Validate();
  return options;
}

// cos and sin of the 8-bit OpenCV hue (H in [0, 180), 2 degrees per step).
struct HueTable {
  std::array<float, 256> cos_h{}, sin_h{};
  HueTable() {
    for (int h = 0; h < 256; ++h) {
      const double a = 2.0 * h * kDegToRad;
      cos_h[h] = static_cast<float>(std::cos(a));
      sin_h[h] = static_cast<float>(std::sin(a));
    }
  }
};

}  // namespace

ViewingGrid::ViewingGrid(double d_phi_deg)
    : d_phi_rad_(d_phi_deg * kDegToRad),
      n_pan_(2 * StepsIn180(d_phi_deg)),
      n_tilt_(StepsIn180(d_phi_deg)) {}

void BubbleSurfaceOptions::Validate() const {
  StepsIn180(d_phi_deg);
  kRestRadiusRange.Check("bubble.rest_radius", rest_radius);
  kMaxDepthMRange.Check("bubble.max_depth_m", max_depth_m);
  kPatchPxRange.Check("bubble.patch_px", patch_px);
  try {
    PatchFeatureExtractor{patch_px};  // a side may sample a grating only at its zeros
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("bubble.patch_px = " + std::to_string(patch_px) + ": " + e.what());
  }
  kOrientationBlurDegRange.Check("bubble.orientation_blur_deg", orientation_blur_deg);
}

BubbleSurface::BubbleSurface(FeatureSet features, CameraIntrinsics camera,
                             BubbleSurfaceOptions options)
    : features_(std::move(features)),
      camera_(camera),
      options_(Validated(options)),
      grid_(options_.d_phi_deg),
      extractor_(options_.patch_px),
      resized_size_(ResizedSize(camera_, options_)),
      resized_camera_(camera_.Scaled(resized_size_.width, resized_size_.height)) {
  rho_.assign(features_.size(),
              Eigen::MatrixXf::Constant(grid_.n_tilt(), grid_.n_pan(), options_.rest_radius));
  observed_.setZero(grid_.n_tilt(), grid_.n_pan());
  observed_columns_.assign(static_cast<size_t>(grid_.n_pan()), 0);
}

void BubbleSurface::Reset() {
  for (int i = 0; i < grid_.n_pan(); ++i) {
    if (!ColumnObserved(i)) continue;  // it holds rho_0 already
    for (auto& r : rho_) r.col(i).setConstant(options_.rest_radius);
  }
  observed_.setZero();
  std::fill(observed_columns_.begin(), observed_columns_.end(), uint8_t{0});
}

void BubbleSurface::Set(int feature, int tilt, int pan, float value) {
  if (feature < 0 || feature >= static_cast<int>(rho_.size()) || tilt < 0 ||
      tilt >= grid_.n_tilt() || pan < 0 || pan >= grid_.n_pan()) {
    throw std::invalid_argument("bubble surface: no feature " + std::to_string(feature) +
                                " at tilt row " + std::to_string(tilt) + ", pan column " +
                                std::to_string(pan));
  }
  if (!(std::isfinite(value) && value >= 0.0f)) {
    throw std::invalid_argument("bubble surface: value " + std::to_string(value) +
                                " is not finite and >= 0");
  }
  rho_[feature](tilt, pan) = value;
  observed_(tilt, pan) = 1;
  observed_columns_[static_cast<size_t>(pan)] = 1;
}

int BubbleSurface::ObservedCount() const { return observed_.cast<int>().sum(); }

std::vector<BubbleSurface::PatchSite> BubbleSurface::ComputeSites(const PanTilt& pan_tilt) const {
  const int n = options_.patch_px;
  const double half = 0.5 * (n - 1);  // patch centre relative to its top-left pixel
  const double fx = resized_camera_.fx(), fy = resized_camera_.fy();
  const double cx = resized_camera_.cx(), cy = resized_camera_.cy();
  const double ct = std::cos(pan_tilt.tilt_rad), st = std::sin(pan_tilt.tilt_rad);
  std::vector<PatchSite> sites;
  for (int i = 0; i < grid_.n_pan(); ++i) {
    // Azimuth relative to the optical axis, positive to the left.
    const double a = grid_.f1(i) - pan_tilt.pan_rad;
    const double ca = std::cos(a), sa = std::sin(a);
    if (ca <= 0.0) continue;  // behind the camera's pan direction (beyond ±90°)
    for (int j = 0; j < grid_.n_tilt(); ++j) {
      const double elevation = 0.5 * std::numbers::pi - grid_.f2(j);
      const double ce = std::cos(elevation), se = std::sin(elevation);
      // Direction in the panned base frame (x forward, y left, z up), then tilted camera.
      const double vx = ce * ca, vy = ce * sa, vz = se;
      const double forward = vx * ct + vz * st;
      const double up = -vx * st + vz * ct;
      if (forward <= 1e-6) continue;
      const double x = cx - fx * vy / forward;  // left → smaller image x
      const double y = cy - fy * up / forward;  // up → smaller image y
      const long x0 = std::lround(x - half);
      const long y0 = std::lround(y - half);
      if (x0 < 0 || y0 < 0 || x0 + n > resized_size_.width || y0 + n > resized_size_.height) {
        continue;
      }
      sites.push_back(
          PatchSite{i * grid_.n_tilt() + j, static_cast<int>(x0), static_cast<int>(y0)});
    }
  }
  // In image order, so that the patch sums walk each band of rows once, left to right, rather
  // than down one pan column after another (each site sets its own cell: the order is free).
  std::sort(sites.begin(), sites.end(), [](const PatchSite& a, const PatchSite& b) {
    return a.y0 != b.y0 ? a.y0 < b.y0 : a.x0 < b.x0;
  });
  return sites;
}

const std::vector<BubbleSurface::PatchSite>& BubbleSurface::Sites(const PanTilt& pan_tilt) {
  for (const SiteList& s : site_cache_) {
    if (s.pan_tilt.pan_rad == pan_tilt.pan_rad && s.pan_tilt.tilt_rad == pan_tilt.tilt_rad) {
      return s.sites;
    }
  }
  if (site_cache_.size() >= kSiteCacheSize) site_cache_.erase(site_cache_.begin());
  site_cache_.push_back(SiteList{pan_tilt, ComputeSites(pan_tilt)});
  return site_cache_.back().sites;
}

void BubbleSurface::Resize(const cv::Mat& in, cv::Mat& out) {
  // Area averaging against aliasing. OpenCV's area resize (INTER_AREA) is fast only for whole
  // factors, so shrink by the largest whole factor k first and finish with a bilinear step
  // whose ratio lies in (1/2, 1] (or enlarges). Every step maps the image edges onto each
  // other, so the geometry is that of one resize (resized_camera_).
  const int k = std::min(in.cols / resized_size_.width, in.rows / resized_size_.height);
  const cv::Mat* src = &in;
  if (k >= 2) {
    const cv::Size whole(in.cols / k, in.rows / k);
    if (whole == resized_size_) {
      cv::resize(in, out, resized_size_, 0, 0, cv::INTER_AREA);
      return;
    }
    cv::resize(in, scratch_.shrunk, whole, 0, 0, cv::INTER_AREA);
    src = &scratch_.shrunk;
  }
  // A bilinear step that shrinks by f reads 2 x 2 pixels per output pixel, and where an output
  // pixel falls on an input pixel, that one alone: sensor noise and compression blocks finer
  // than the grid pass into the features unaveraged (on the real loop, gaussian noise of 4 grey
  // levels or JPEG quality 20 made its second place look like its first; docs/decisions.md
  // "Resampling to the grid"). So it is prefiltered with a gaussian of half an output pixel,
  // σ = f/2 input pixels. An enlarging step (the simulated 160x120 frames) is left as it was.
  const double fx = static_cast<double>(src->cols) / resized_size_.width;
  const double fy = static_cast<double>(src->rows) / resized_size_.height;
  if (fx > 1.0 || fy > 1.0) {
    // A σ of 0 would make OpenCV derive it from the other axis; 1e-3 is a one-tap kernel.
    // Five taps (±2 pixels, ±2.2σ or more for the σ < 1 of a step under 2): OpenCV's own
    // choice for σ ≥ 0.75 (seven taps, the loop's 512x384 frames) runs on its generic path at
    // twice the time of its five-tap one, and the two taps it adds weigh under 0.5 % each.
    const auto taps = [](double f) { return f > 1.0 ? 5 : 1; };
    cv::GaussianBlur(*src, scratch_.prefiltered, cv::Size(taps(fx), taps(fy)),
                     fx > 1.0 ? fx / 2 : 1e-3, fy > 1.0 ? fy / 2 : 1e-3);
    src = &scratch_.prefiltered;
  }
  cv::resize(*src, out, resized_size_, 0, 0, cv::INTER_LINEAR);
}

void BubbleSurface::Observe(const Observation& obs) {
  if (obs.bgr.empty() || obs.bgr.type() != CV_8UC3) {
    throw std::invalid_argument("observation bgr must be a non-empty CV_8UC3 image");
  }
  if (obs.bgr.cols != camera_.width() || obs.bgr.rows != camera_.height()) {
    throw std::invalid_argument("observation image is " + std::to_string(obs.bgr.cols) + "x" +
                                std::to_string(obs.bgr.rows) + ", camera is " +
                                std::to_string(camera_.width()) + "x" +
                                std::to_string(camera_.height()));
  }
  if (!(std::isfinite(obs.pan_tilt.pan_rad) && std::isfinite(obs.pan_tilt.tilt_rad))) {
    throw std::invalid_argument("observation pan/tilt must be finite");
  }
  const bool need_depth = features_.NeedsDepth();
  if (need_depth) {
    if (obs.depth_m.empty() || obs.depth_m.type() != CV_32F) {
      throw std::invalid_argument("feature set " + features_.ToString() +
                                  " needs a CV_32F depth image");
    }
    if (obs.depth_m.size() != obs.bgr.size()) {
      throw std::invalid_argument("depth image is " + std::to_string(obs.depth_m.cols) + "x" +
                                  std::to_string(obs.depth_m.rows) + ", colour image is " +
                                  std::to_string(obs.bgr.cols) + "x" +
                                  std::to_string(obs.bgr.rows));
    }
  }
  const bool need_grey = features_.NeedsGrey();
  const bool need_hue = features_.NeedsHue();
  FeatureImages& images = scratch_.images;

  // One resize so that every d_phi x d_phi patch is patch_px x patch_px pixels.
  Resize(obs.bgr, scratch_.small_bgr);
  if (need_grey) {
    cv::cvtColor(scratch_.small_bgr, scratch_.grey8, cv::COLOR_BGR2GRAY);
    scratch_.grey8.convertTo(images.grey, CV_32F, 1.0 / 255.0);
    if (features_.NeedsOrientation()) {
      // In resized pixels, where d_phi spans patch_px: the blur is an angle of view whatever
      // the camera's resolution.
      const double blur_px = options_.orientation_blur_deg * options_.patch_px / options_.d_phi_deg;
      ComputeOrientationImages(images.grey, images, blur_px);
    }
  }
  if (need_hue) {
    // Unit hue vectors weighted by saturation, averaged per patch (circular mean).
    static const HueTable kHue;
    cv::cvtColor(scratch_.small_bgr, scratch_.hsv, cv::COLOR_BGR2HSV);
    images.hue_cos.create(scratch_.hsv.size(), CV_32F);
    images.hue_sin.create(scratch_.hsv.size(), CV_32F);
    for (int y = 0; y < scratch_.hsv.rows; ++y) {
      const uint8_t* p = scratch_.hsv.ptr<uint8_t>(y);
      float* c = images.hue_cos.ptr<float>(y);
      float* s = images.hue_sin.ptr<float>(y);
      for (int x = 0; x < scratch_.hsv.cols; ++x) {
        const float sat = p[3 * x + 1] * (1.0f / 255.0f);
        c[x] = kHue.cos_h[p[3 * x]] * sat;
        s[x] = kHue.sin_h[p[3 * x]] * sat;
      }
    }
  }
  if (need_depth) {
    // Range / max range, clamped to [0, 1]; zero (no reading) and non-finite values are
    // invalid and excluded from the area averages through a validity mask.
    scratch_.depth_norm.create(obs.depth_m.size(), CV_32F);
    scratch_.depth_valid.create(obs.depth_m.size(), CV_32F);
    const float inv_max = static_cast<float>(1.0 / options_.max_depth_m);
    for (int y = 0; y < obs.depth_m.rows; ++y) {
      const float* d = obs.depth_m.ptr<float>(y);
      float* nd = scratch_.depth_norm.ptr<float>(y);
      float* v = scratch_.depth_valid.ptr<float>(y);
      for (int x = 0; x < obs.depth_m.cols; ++x) {
        const bool valid = std::isfinite(d[x]) && d[x] > 0.0f;
        nd[x] = valid ? std::min(1.0f, d[x] * inv_max) : 0.0f;
        v[x] = valid ? 1.0f : 0.0f;
      }
    }
    cv::Mat sum, weight;
    Resize(scratch_.depth_norm, sum);
    Resize(scratch_.depth_valid, weight);
    images.depth.create(resized_size_, CV_32F);
    for (int y = 0; y < images.depth.rows; ++y) {
      const float* s = sum.ptr<float>(y);
      const float* w = weight.ptr<float>(y);
      float* out = images.depth.ptr<float>(y);
      for (int x = 0; x < images.depth.cols; ++x) {
        // Mean of the valid readings under the pixel; 0 marks "no reading".
        out[x] = w[x] > 1e-6f ? std::clamp(s[x] / w[x], 1e-6f, 1.0f) : 0.0f;
      }
    }
  }

  // (A.2): each observed direction takes the new feature values.
  const int nv = features_.size();
  std::array<float, kNumFeatureKinds> q{};
  for (const PatchSite& site : Sites(obs.pan_tilt)) {
    extractor_.Compute(features_, images, site.x0, site.y0, q.data());
    for (int k = 0; k < nv; ++k) rho_[k](site.cell) = q[k];
    observed_(site.cell) = 1;
    observed_columns_[static_cast<size_t>(site.cell / grid_.n_tilt())] = 1;
  }
}

}  // namespace tsc
