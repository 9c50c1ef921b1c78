#include "core/bubble/features.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <type_traits>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

namespace tsc {
namespace {

// Largest patch side the extractor accepts.
constexpr int kMaxPatchPx = 64;
// Smallest patch side on which every grating (two cycles across the patch) is resolved.
constexpr int kMinPatchPx = 6;

// Grating index of a feature (kernels_[2g] is the cosine, kernels_[2g + 1] the sine kernel),
// or -1 for a feature that is not a grating response.
int GratingIndex(Feature f) {
  switch (f) {
    case Feature::kVertical:
      return 0;
    case Feature::kHorizontal:
      return 1;
    case Feature::kHyperbolic:
      return 2;
    case Feature::kPolar:
      return 3;
    case Feature::kConcentric:
      return 4;
    default:
      return -1;
  }
}

// Orientation bin of a feature (0°, 45°, 90°, 135°), or -1.
int OrientationIndex(Feature f) {
  switch (f) {
    case Feature::kOrient0:
      return 0;
    case Feature::kOrient45:
      return 1;
    case Feature::kOrient90:
      return 2;
    case Feature::kOrient135:
      return 3;
    default:
      return -1;
  }
}

// Gradient energy per pixel (grey in [0,1]) that a patch's shares are taken against: a flat
// patch, whose gradients are sensor noise, gives small shares rather than noise's random ones.
// 0.004, 0.03 and 0.1 gave nearest-revisit accuracy 0.825 / 0.831 / 0.827 on 15 simulated day
// worlds (docs/decisions.md "Features that survive lighting").
constexpr float kFlatGradient = 0.03f;

int FeatureByName(const std::string& name) {
  for (int k = 0; k < kNumFeatureKinds; ++k) {
    if (name == FeatureName(static_cast<Feature>(k))) return k;
  }
  return -1;
}

// Phase of grating g at patch coordinates (u, v) in [-1, 1]; see features.h.
double GratingPhase(int g, double u, double v) {
  constexpr double kTwoPi = 2.0 * std::numbers::pi;
  switch (g) {
    case 0:
      return kTwoPi * 2.0 * u;
    case 1:
      return kTwoPi * 2.0 * v;
    case 2:
      return kTwoPi * 2.0 * u * v;
    case 3:
      return 4.0 * std::atan2(v, u);
    default:
      return kTwoPi * 2.0 * std::sqrt(u * u + v * v);
  }
}

// Makes `k`, grating g on a patch of n x n pixels, zero-mean and unit-norm.
void Standardise(std::vector<double>& k, int g, int n) {
  double mean = 0.0;
  for (double x : k) mean += x;
  mean /= static_cast<double>(k.size());
  double norm2 = 0.0;
  for (double& x : k) {
    x -= mean;
    norm2 += x * x;
  }
  if (norm2 < 1e-12) {
    // E.g. 8 pixels put every pixel centre of the vertical cosine on one of its zeros.
    throw std::invalid_argument("a patch of " + std::to_string(n) +
                                " pixels samples grating kernel " + std::to_string(g) +
                                " only where it vanishes; choose another patch side");
  }
  const double inv = 1.0 / std::sqrt(norm2);
  for (double& x : k) x *= inv;
}

std::string Upper(std::string s) {
  for (char& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

}  // namespace

const char* FeatureName(Feature f) {
  switch (f) {
    case Feature::kHue:
      return "hue";
    case Feature::kVertical:
      return "vertical";
    case Feature::kHorizontal:
      return "horizontal";
    case Feature::kHyperbolic:
      return "hyperbolic";
    case Feature::kPolar:
      return "polar";
    case Feature::kConcentric:
      return "concentric";
    case Feature::kIntensity:
      return "intensity";
    case Feature::kDepth:
      return "depth";
    case Feature::kHueCos:
      return "hue_cos";
    case Feature::kHueSin:
      return "hue_sin";
    case Feature::kOrient0:
      return "orient_0";
    case Feature::kOrient45:
      return "orient_45";
    case Feature::kOrient90:
      return "orient_90";
    case Feature::kOrient135:
      return "orient_135";
  }
  return "unknown";
}

FeatureSet::FeatureSet(std::vector<Feature> features) : features_(std::move(features)) {
  if (features_.empty()) throw std::invalid_argument("feature set is empty");
  for (size_t i = 0; i < features_.size(); ++i) {
    const int kind = static_cast<int>(features_[i]);
    if (kind < 0 || kind >= kNumFeatureKinds) {
      throw std::invalid_argument("feature set holds an unknown feature " + std::to_string(kind));
    }
    for (size_t j = 0; j < i; ++j) {
      if (features_[j] == features_[i]) {
        throw std::invalid_argument(std::string("feature set repeats ") +
                                    FeatureName(features_[i]));
      }
    }
  }
}

FeatureSet FeatureSet::Thesis(int l, bool with_intensity) {
  const std::vector<Feature> l1 = {Feature::kHue, Feature::kVertical, Feature::kHorizontal};
  const std::vector<Feature> non_cartesian = {Feature::kHyperbolic, Feature::kPolar,
                                              Feature::kConcentric};
  std::vector<Feature> f;
  switch (l) {
    case 1:  // hue + Cartesian
      f = l1;
      break;
    case 2:  // L1 + non-Cartesian
      f = l1;
      f.insert(f.end(), non_cartesian.begin(), non_cartesian.end());
      break;
    case 3:  // depth only
      f = {Feature::kDepth};
      break;
    case 4:  // L1 + depth
      f = l1;
      f.push_back(Feature::kDepth);
      break;
    case 5:  // L2 + depth
      f = l1;
      f.insert(f.end(), non_cartesian.begin(), non_cartesian.end());
      f.push_back(Feature::kDepth);
      break;
    default:
      throw std::invalid_argument("thesis feature set l must be 1..5, got " + std::to_string(l));
  }
  if (with_intensity) f.push_back(Feature::kIntensity);
  return FeatureSet(std::move(f));
}

FeatureSet FeatureSet::Recognition() {
  return FeatureSet({Feature::kHueCos, Feature::kHueSin, Feature::kVertical, Feature::kHorizontal,
                     Feature::kHyperbolic, Feature::kPolar, Feature::kConcentric, Feature::kOrient0,
                     Feature::kOrient45, Feature::kOrient90, Feature::kOrient135,
                     Feature::kIntensity});
}

FeatureSet FeatureSet::Parse(const std::string& name) {
  const std::string s = Upper(name);
  if (s.size() >= 2 && s[0] == 'L' && s[1] >= '1' && s[1] <= '5') {
    const int l = s[1] - '0';
    const std::string rest = s.substr(2);
    if (rest.empty() || rest == "+I") return Thesis(l, true);
    if (rest == "-I") return Thesis(l, false);
  }
  if (name.find(',') != std::string::npos || FeatureByName(name) >= 0) {
    std::vector<Feature> list;
    size_t start = 0;
    while (start <= name.size()) {
      const size_t end = std::min(name.find(',', start), name.size());
      const std::string item = name.substr(start, end - start);
      const int kind = FeatureByName(item);
      if (kind < 0) {
        throw std::invalid_argument("feature set '" + name + "' names an unknown feature '" + item +
                                    "'");
      }
      list.push_back(static_cast<Feature>(kind));
      start = end + 1;
    }
    return FeatureSet(std::move(list));
  }
  throw std::invalid_argument(
      "feature set name must be L1..L5 with optional +I or -I, or a comma-separated list of "
      "feature names, got '" +
      name + "'");
}

int FeatureSet::IndexOf(Feature f) const {
  for (size_t i = 0; i < features_.size(); ++i) {
    if (features_[i] == f) return static_cast<int>(i);
  }
  return -1;
}

std::string FeatureSet::ToString() const {
  for (int l = 1; l <= 5; ++l) {
    for (bool with_intensity : {true, false}) {
      if (Thesis(l, with_intensity).features_ == features_) {
        return "L" + std::to_string(l) + (with_intensity ? "+I" : "-I");
      }
    }
  }
  std::string s;
  for (size_t i = 0; i < features_.size(); ++i) {
    if (i > 0) s += ",";
    s += FeatureName(features_[i]);
  }
  return s;
}

bool FeatureSet::NeedsHue() const {
  return Contains(Feature::kHue) || Contains(Feature::kHueCos) || Contains(Feature::kHueSin);
}

bool FeatureSet::NeedsOrientation() const {
  for (Feature f : features_) {
    if (OrientationIndex(f) >= 0) return true;
  }
  return false;
}

bool FeatureSet::NeedsGrey() const {
  for (Feature f : features_) {
    if (GratingIndex(f) >= 0 || OrientationIndex(f) >= 0 || f == Feature::kIntensity) return true;
  }
  return false;
}

namespace {

// The central difference of `row` at x (one-sided at the ends, 0 across a single pixel).
float RowDifference(const float* row, int x, int n) {
  if (n < 2) return 0.0f;
  if (x == 0) return row[1] - row[0];
  if (x == n - 1) return row[n - 1] - row[n - 2];
  return (row[x + 1] - row[x - 1]) * 0.5f;
}

// The four half-wave parts of the doubled-angle vector of gradient (gx, gy), written at x.
void SplitOrientation(float gx, float gy, std::array<float*, 4>& out, int x) {
  // m·cos 2θ = (gx² − gy²)/m and m·sin 2θ = 2gx·gy/m; where m = 0 both numerators are 0, and
  // the floor on m keeps them 0 instead of 0/0.
  const float m = std::max(std::sqrt(gx * gx + gy * gy), std::numeric_limits<float>::min());
  const float c = (gx * gx - gy * gy) / m;
  const float s = (2.0f * gx * gy) / m;
  out[0][x] = std::max(c, 0.0f);
  out[1][x] = std::max(s, 0.0f);
  out[2][x] = std::max(-c, 0.0f);
  out[3][x] = std::max(-s, 0.0f);
}

#if defined(__SSE2__)
// SplitOrientation on four pixels at once: the same operations in the same order, each
// correctly rounded, so the same floats as the scalar loop.
void SplitOrientation4(__m128 gx, __m128 gy, std::array<float*, 4>& out, int x) {
  const __m128 xx = _mm_mul_ps(gx, gx), yy = _mm_mul_ps(gy, gy);
  const __m128 m =
      _mm_max_ps(_mm_sqrt_ps(_mm_add_ps(xx, yy)), _mm_set1_ps(std::numeric_limits<float>::min()));
  const __m128 c = _mm_div_ps(_mm_sub_ps(xx, yy), m);
  const __m128 s = _mm_div_ps(_mm_mul_ps(_mm_mul_ps(_mm_set1_ps(2.0f), gx), gy), m);
  const __m128 zero = _mm_setzero_ps();
  _mm_storeu_ps(out[0] + x, _mm_max_ps(c, zero));
  _mm_storeu_ps(out[1] + x, _mm_max_ps(s, zero));
  _mm_storeu_ps(out[2] + x, _mm_max_ps(_mm_sub_ps(zero, c), zero));
  _mm_storeu_ps(out[3] + x, _mm_max_ps(_mm_sub_ps(zero, s), zero));
}
#endif

// Four float lanes: SSE2's where the build has it, else four floats added alike (the same
// floats either way).
#if defined(__SSE2__)
using Lanes = __m128;
Lanes ZeroLanes() { return _mm_setzero_ps(); }
Lanes LoadLanes(const float* p) { return _mm_loadu_ps(p); }
Lanes AddLanes(Lanes a, Lanes b) { return _mm_add_ps(a, b); }
Lanes MulLanes(Lanes a, Lanes b) { return _mm_mul_ps(a, b); }
float SumLanes(Lanes a) {
  std::array<float, 4> l{};
  _mm_storeu_ps(l.data(), a);
  return (l[0] + l[1]) + (l[2] + l[3]);
}
#else
using Lanes = std::array<float, 4>;
Lanes ZeroLanes() { return Lanes{}; }
Lanes LoadLanes(const float* p) { return Lanes{p[0], p[1], p[2], p[3]}; }
Lanes AddLanes(Lanes a, Lanes b) {
  return Lanes{a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3]};
}
Lanes MulLanes(Lanes a, Lanes b) {
  return Lanes{a[0] * b[0], a[1] * b[1], a[2] * b[2], a[3] * b[3]};
}
float SumLanes(Lanes a) { return (a[0] + a[1]) + (a[2] + a[3]); }
#endif

// Calls body(std::integral_constant<int, N>{}) for the N of kCounts equal to `count`, so that a
// count known only at run time picks a loop unrolled for it; false when no N is.
template <int... kCounts, typename Body>
bool WithCount(int count, Body&& body) {
  return ((count == kCounts && (body(std::integral_constant<int, kCounts>{}), true)) || ...);
}

// Sums of the n x n blocks at (x0, y0) of kCount CV_32F images of one size. Per image: four
// lanes, each adding every fourth pixel of each row in turn, then the row tails and the lanes.
// The images' chains of additions interleave, so a patch's sums wait on the add's latency once,
// not once per image. (A lambda over an Eigen block, one image at a time, took a tenth of a
// frame.)
template <int kCount>
void BlockSumsOf(const cv::Mat* const* images, int x0, int y0, int n, float* sums) {
  const int wide = n - n % 4;
  std::array<float, kCount> tail{};
  Lanes acc[kCount];  // NOLINT(*-avoid-c-arrays): std::array would drop __m128's alignment
  for (Lanes& a : acc) a = ZeroLanes();
  for (int y = 0; y < n; ++y) {
    std::array<const float*, kCount> row{};
#pragma GCC unroll 16
    for (int m = 0; m < kCount; ++m) row[m] = images[m]->ptr<float>(y0 + y) + x0;
    for (int x = 0; x < wide; x += 4) {
#pragma GCC unroll 16
      for (int m = 0; m < kCount; ++m) acc[m] = AddLanes(acc[m], LoadLanes(row[m] + x));
    }
    for (int x = wide; x < n; ++x) {
#pragma GCC unroll 16
      for (int m = 0; m < kCount; ++m) tail[m] += row[m][x];
    }
  }
#pragma GCC unroll 16
  for (int m = 0; m < kCount; ++m) sums[m] = SumLanes(acc[m]) + tail[m];
}

// The patch sums of up to seven images (hue pair, grey, four orientations) in one pass.
void BlockSums(const cv::Mat* const* images, int count, int x0, int y0, int n, float* sums) {
  const bool done = WithCount<0, 1, 2, 3, 4, 5, 6, 7>(count, [&](auto k) {
    if constexpr (decltype(k)::value > 0) {
      BlockSumsOf<decltype(k)::value>(images, x0, y0, n, sums);
    }
  });
  if (!done) throw std::logic_error("BlockSums of more than seven images");
}

// Dot products of kCount n x n kernels (row-major) with the n x n block of CV_32F `grey` at
// (x0, y0), in BlockSumsOf's order per kernel (four lanes over each row in turn, the row tails,
// then the lanes). The kernels share each load of the patch and their chains interleave.
template <int kCount>
void KernelDotsOf(const float* const* kernels, const cv::Mat& grey, int x0, int y0, int n,
                  float* dots) {
  const int wide = n - n % 4;
  std::array<float, kCount> tail{};
  Lanes acc[kCount];  // NOLINT(*-avoid-c-arrays): std::array would drop __m128's alignment
  for (Lanes& a : acc) a = ZeroLanes();
  for (int y = 0; y < n; ++y) {
    const float* row = grey.ptr<float>(y0 + y) + x0;
    const int at = y * n;
    for (int x = 0; x < wide; x += 4) {
      const Lanes pixels = LoadLanes(row + x);
#pragma GCC unroll 16
      for (int m = 0; m < kCount; ++m) {
        acc[m] = AddLanes(acc[m], MulLanes(LoadLanes(kernels[m] + at + x), pixels));
      }
    }
    for (int x = wide; x < n; ++x) {
#pragma GCC unroll 16
      for (int m = 0; m < kCount; ++m) tail[m] += kernels[m][at + x] * row[x];
    }
  }
#pragma GCC unroll 16
  for (int m = 0; m < kCount; ++m) dots[m] = SumLanes(acc[m]) + tail[m];
}

// The dots of up to the ten grating kernels (a cosine and a sine each) in one pass.
void KernelDots(const float* const* kernels, int count, const cv::Mat& grey, int x0, int y0, int n,
                float* dots) {
  const bool done = WithCount<0, 2, 4, 6, 8, 10>(count, [&](auto k) {
    if constexpr (decltype(k)::value > 0) {
      KernelDotsOf<decltype(k)::value>(kernels, grey, x0, y0, n, dots);
    }
  });
  if (!done) throw std::logic_error("KernelDots of an odd count or more than ten kernels");
}

}  // namespace

void ComputeOrientationImages(const cv::Mat& grey, FeatureImages& out, double blur_px) {
  CV_Assert(grey.type() == CV_32F);
  if (!(blur_px >= 0.0 && std::isfinite(blur_px))) {
    throw std::invalid_argument("orientation blur must be finite and >= 0, got " +
                                std::to_string(blur_px));
  }
  const cv::Mat* source = &grey;
  if (blur_px > 0.0) {
    cv::GaussianBlur(grey, out.blurred_grey, cv::Size(0, 0), blur_px, blur_px, cv::BORDER_REFLECT);
    source = &out.blurred_grey;
  }
  // One pass over the pixels: the gradient and its four parts per pixel, where whole-image
  // OpenCV operations took fifteen trips through memory (a sixth of a 640x480 frame's time).
  const int cols = source->cols, rows = source->rows;
  for (cv::Mat& o : out.orient) o.create(source->size(), CV_32F);
  for (int y = 0; y < rows; ++y) {
    // Central differences inside, one-sided at the border, 0 across a single row.
    const float* here = source->ptr<float>(y);
    const float* up = source->ptr<float>(rows < 2 ? y : y == 0 ? 0 : y - 1);
    const float* down = source->ptr<float>(rows < 2 ? y : y == rows - 1 ? y : y + 1);
    const float row_scale = (rows < 2 || y == 0 || y == rows - 1) ? 1.0f : 0.5f;
    std::array<float*, 4> parts{};
    for (size_t b = 0; b < 4; ++b) parts[b] = out.orient[b].ptr<float>(y);
    int x = 0;
    if (cols >= 2) {
      SplitOrientation(RowDifference(here, 0, cols), (down[0] - up[0]) * row_scale, parts, 0);
      x = 1;
    }
#if defined(__SSE2__)
    const __m128 half = _mm_set1_ps(0.5f), scale = _mm_set1_ps(row_scale);
    for (; x + 4 < cols; x += 4) {
      const __m128 gx =
          _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(here + x + 1), _mm_loadu_ps(here + x - 1)), half);
      const __m128 gy = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(down + x), _mm_loadu_ps(up + x)), scale);
      SplitOrientation4(gx, gy, parts, x);
    }
#endif
    for (; x < cols; ++x) {
      SplitOrientation(RowDifference(here, x, cols), (down[x] - up[x]) * row_scale, parts, x);
    }
  }
}

PatchFeatureExtractor::PatchFeatureExtractor(int patch_px) : patch_px_(patch_px) {
  if (patch_px < kMinPatchPx || patch_px > kMaxPatchPx) {
    throw std::invalid_argument("patch_px must be in [" + std::to_string(kMinPatchPx) + ", " +
                                std::to_string(kMaxPatchPx) + "], got " + std::to_string(patch_px));
  }
  const int n = patch_px;
  for (int g = 0; g < 5; ++g) {
    std::vector<double> c(static_cast<size_t>(n * n)), s(c.size());
    for (int y = 0; y < n; ++y) {
      const double v = (2.0 * y + 1.0) / n - 1.0;  // pixel centres, in (-1, 1)
      for (int x = 0; x < n; ++x) {
        const double u = (2.0 * x + 1.0) / n - 1.0;
        const double phase = GratingPhase(g, u, v);
        c[y * n + x] = std::cos(phase);
        s[y * n + x] = std::sin(phase);
      }
    }
    Standardise(c, g, n);
    Standardise(s, g, n);
    kernels_[2 * g].assign(c.begin(), c.end());
    kernels_[2 * g + 1].assign(s.begin(), s.end());
  }
}

void PatchFeatureExtractor::Compute(const FeatureSet& set, const FeatureImages& images, int x0,
                                    int y0, float* out) const {
  const int n = patch_px_;
  const int n2 = n * n;
  const float inv_area = 1.0f / static_cast<float>(n2);
  // Largest response of a zero-mean unit-norm kernel to a [0,1] patch is below n/2.
  const float inv_max_response = 2.0f / static_cast<float>(n);

  // The dot products of every grating kernel the set reads with the grey patch, together.
  std::array<const float*, 10> kernels{};
  std::array<size_t, 5> dot_at{};  // per grating, the index of its cosine's dot
  size_t n_kernels = 0;
  for (const Feature f : set.features()) {
    const int g = GratingIndex(f);
    if (g < 0) continue;
    const auto grating = static_cast<size_t>(g);
    dot_at[grating] = n_kernels;
    kernels[n_kernels++] = kernels_[2 * grating].data();
    kernels[n_kernels++] = kernels_[2 * grating + 1].data();
  }
  std::array<float, 10> dots{};
  KernelDots(kernels.data(), static_cast<int>(n_kernels), images.grey, x0, y0, n, dots.data());
  // Every patch sum the set reads, taken together (BlockSums): the hue pair, grey (intensity)
  // and the four orientation energies.
  const bool hue = set.NeedsHue(), intensity = set.Contains(Feature::kIntensity);
  const bool oriented = set.NeedsOrientation();
  std::array<const cv::Mat*, 7> summed{};
  int n_summed = 0;
  const int hue_at = n_summed;
  if (hue) {
    summed[n_summed++] = &images.hue_cos;
    summed[n_summed++] = &images.hue_sin;
  }
  const int grey_at = n_summed;
  if (intensity) summed[n_summed++] = &images.grey;
  const int orient_at = n_summed;
  if (oriented) {
    for (const cv::Mat& m : images.orient) summed[n_summed++] = &m;
  }
  std::array<float, 7> sums{};
  BlockSums(summed.data(), n_summed, x0, y0, n, sums.data());
  // The orientation energies' normaliser.
  float orient_norm = 0.0f;
  if (oriented) {
    float total = 0.0f;
    for (int b = 0; b < 4; ++b) total += sums[orient_at + b];
    orient_norm = 1.0f / (total + kFlatGradient * static_cast<float>(n2));
  }

  for (int k = 0; k < set.size(); ++k) {
    const Feature f = set.features()[k];
    const int g = GratingIndex(f);
    if (g >= 0) {
      const size_t at = dot_at[static_cast<size_t>(g)];
      const float c = dots[at];
      const float s = dots[at + 1];
      out[k] = std::min(1.0f, std::sqrt(c * c + s * s) * inv_max_response);
      continue;
    }
    const int o = OrientationIndex(f);
    if (o >= 0) {
      out[k] = std::clamp(sums[orient_at + o] * orient_norm, 0.0f, 1.0f);
      continue;
    }
    switch (f) {
      case Feature::kHue: {
        // Circular mean of the saturation-weighted hue vectors; 0 for a grey patch.
        const float c = sums[hue_at];
        const float s = sums[hue_at + 1];
        if (std::sqrt(c * c + s * s) * inv_area < 1e-3f) {
          out[k] = 0.0f;
        } else {
          float a = std::atan2(s, c) * static_cast<float>(0.5 * std::numbers::inv_pi);
          if (a < 0.0f) a += 1.0f;
          out[k] = std::clamp(a, 0.0f, 1.0f);
        }
        break;
      }
      case Feature::kHueCos:
        out[k] = std::clamp(0.5f + 0.5f * sums[hue_at] * inv_area, 0.0f, 1.0f);
        break;
      case Feature::kHueSin:
        out[k] = std::clamp(0.5f + 0.5f * sums[hue_at + 1] * inv_area, 0.0f, 1.0f);
        break;
      case Feature::kIntensity:
        out[k] = std::clamp(sums[grey_at] * inv_area, 0.0f, 1.0f);
        break;
      case Feature::kDepth: {
        const cv::Mat& depth = images.depth;
        if (depth.empty()) throw std::invalid_argument("depth feature needs a depth image");
        // Mean of the valid (non-zero) readings; 0 when the patch has none.
        float sum = 0.0f;
        int count = 0;
        for (int y = 0; y < n; ++y) {
          const float* row = depth.ptr<float>(y0 + y) + x0;
          for (int x = 0; x < n; ++x) {
            if (row[x] > 0.0f) {
              sum += row[x];
              ++count;
            }
          }
        }
        out[k] = count > 0 ? std::clamp(sum / static_cast<float>(count), 0.0f, 1.0f) : 0.0f;
        break;
      }
      default:
        break;
    }
  }
}

}  // namespace tsc
