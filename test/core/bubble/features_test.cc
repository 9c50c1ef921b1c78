#include "core/bubble/features.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <numbers>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/bubble/descriptor.h"
#include "core/bubble/surface.h"
#include "core/split_mix64.h"

namespace tsc {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

TEST(FeatureSet, ThesisSetsHaveTheThesisSizes) {
  const int sizes[] = {3, 6, 1, 4, 7};
  for (int l = 1; l <= 5; ++l) {
    EXPECT_EQ(FeatureSet::Thesis(l, false).size(), sizes[l - 1]) << "L" << l;
    EXPECT_EQ(FeatureSet::Thesis(l, true).size(), sizes[l - 1] + 1) << "L" << l;
    EXPECT_EQ(FeatureSet::Thesis(l, true).features().back(), Feature::kIntensity);
    EXPECT_FALSE(FeatureSet::Thesis(l, false).Contains(Feature::kIntensity));
  }
  EXPECT_EQ(FeatureSet::Thesis(2).IndexOf(Feature::kHue), 0);
  EXPECT_EQ(FeatureSet::Thesis(2).IndexOf(Feature::kDepth), -1);
  EXPECT_TRUE(FeatureSet::Thesis(3).NeedsDepth());
  EXPECT_TRUE(FeatureSet::Thesis(5).NeedsDepth());
  EXPECT_FALSE(FeatureSet::Thesis(2).NeedsDepth());
  EXPECT_THROW(FeatureSet::Thesis(0), std::invalid_argument);
  EXPECT_THROW(FeatureSet::Thesis(6), std::invalid_argument);
}

TEST(FeatureSet, ParsesThesisNamesWithAndWithoutIntensity) {
  EXPECT_EQ(FeatureSet::Parse("L2").features(), FeatureSet::Thesis(2, true).features());
  EXPECT_EQ(FeatureSet::Parse("L2+I").features(), FeatureSet::Thesis(2, true).features());
  EXPECT_EQ(FeatureSet::Parse("L2-I").features(), FeatureSet::Thesis(2, false).features());
  EXPECT_EQ(FeatureSet::Parse("l5+i").features(), FeatureSet::Thesis(5, true).features());
  for (const char* bad : {"", "L", "L0", "L6", "L2+", "L2+X", "X2", "L12"}) {
    EXPECT_THROW(FeatureSet::Parse(bad), std::invalid_argument) << "'" << bad << "'";
  }
  for (int l = 1; l <= 5; ++l) {
    for (bool with_intensity : {true, false}) {
      const FeatureSet set = FeatureSet::Thesis(l, with_intensity);
      EXPECT_EQ(FeatureSet::Parse(set.ToString()).features(), set.features()) << set.ToString();
    }
  }
}

TEST(FeatureSet, RejectsDuplicatesAndEmptyLists) {
  EXPECT_THROW(FeatureSet({Feature::kHue, Feature::kVertical, Feature::kHue}),
               std::invalid_argument);
  EXPECT_THROW(FeatureSet({}), std::invalid_argument);
  const FeatureSet custom({Feature::kIntensity, Feature::kPolar});
  EXPECT_EQ(custom.IndexOf(Feature::kPolar), 1);
  EXPECT_EQ(custom.ToString(), "intensity,polar");
}

// A 24 x 24 image whose 12 x 12 patch at (kX0, kY0) is value(u, v), (u, v) in [-1, 1].
class PatchFeatureExtractorTest : public ::testing::Test {
 protected:
  static constexpr int kX0 = 5, kY0 = 7;

  PatchFeatureExtractorTest()
      : set_({Feature::kVertical, Feature::kHorizontal, Feature::kHyperbolic, Feature::kPolar,
              Feature::kConcentric, Feature::kIntensity, Feature::kHue}),
        grey_(24, 24, CV_32F, cv::Scalar(0.0f)),
        hue_cos_(24, 24, CV_32F, cv::Scalar(0.0f)),
        hue_sin_(24, 24, CV_32F, cv::Scalar(0.0f)) {}

  void Paint(const std::function<double(double, double)>& value) {
    const int n = dut_.patch_px();
    for (int y = 0; y < n; ++y) {
      for (int x = 0; x < n; ++x) {
        const double u = (2.0 * x + 1.0) / n - 1.0, v = (2.0 * y + 1.0) / n - 1.0;
        grey_.at<float>(kY0 + y, kX0 + x) = static_cast<float>(value(u, v));
      }
    }
  }
  // Feature values in the order of set_.
  std::vector<float> Values() {
    std::vector<float> out(set_.size());
    FeatureImages images;
    images.grey = grey_;
    images.hue_cos = hue_cos_;
    images.hue_sin = hue_sin_;
    dut_.Compute(set_, images, kX0, kY0, out.data());
    return out;
  }

  PatchFeatureExtractor dut_{12};
  FeatureSet set_;
  cv::Mat grey_, hue_cos_, hue_sin_;
};

TEST_F(PatchFeatureExtractorTest, VerticalGratingRespondsToVerticalKernelMore) {
  Paint([](double u, double) { return 0.5 + 0.5 * std::cos(kTwoPi * 2.0 * u); });
  const std::vector<float> q = Values();
  EXPECT_GT(q[0], 0.5f);
  EXPECT_LT(q[1], 0.05f);
  EXPECT_GT(q[0], 10.0f * q[1]);
  EXPECT_NEAR(q[5], 0.5f, 0.02f);
  // The response is a quadrature magnitude: the phase of the grating does not matter.
  Paint([](double u, double) { return 0.5 + 0.5 * std::sin(kTwoPi * 2.0 * u + 0.7); });
  EXPECT_NEAR(Values()[0], q[0], 0.02f);
}

TEST_F(PatchFeatureExtractorTest, HorizontalGratingRespondsToHorizontalKernelMore) {
  Paint([](double, double v) { return 0.5 + 0.5 * std::cos(kTwoPi * 2.0 * v); });
  const std::vector<float> q = Values();
  EXPECT_GT(q[1], 0.5f);
  EXPECT_GT(q[1], 10.0f * q[0]);
}

TEST_F(PatchFeatureExtractorTest, NonCartesianGratingsRespondToTheirOwnPattern) {
  Paint([](double u, double v) { return 0.5 + 0.5 * std::cos(kTwoPi * 2.0 * std::hypot(u, v)); });
  std::vector<float> q = Values();
  EXPECT_GT(q[4], q[0]);
  EXPECT_GT(q[4], q[3]);
  Paint([](double u, double v) { return 0.5 + 0.5 * std::cos(4.0 * std::atan2(v, u)); });
  q = Values();
  EXPECT_GT(q[3], q[0]);
  EXPECT_GT(q[3], q[4]);
  Paint([](double u, double v) { return 0.5 + 0.5 * std::cos(kTwoPi * 2.0 * u * v); });
  q = Values();
  EXPECT_GT(q[2], q[0]);
  EXPECT_GT(q[2], q[1]);
}

TEST_F(PatchFeatureExtractorTest, FlatPatchHasNoGratingResponse) {
  grey_.setTo(cv::Scalar(0.37f));
  const std::vector<float> q = Values();
  for (int k = 0; k < 5; ++k) EXPECT_NEAR(q[k], 0.0f, 1e-5f) << FeatureName(set_.features()[k]);
  EXPECT_NEAR(q[5], 0.37f, 1e-6f);
  EXPECT_EQ(q[6], 0.0f) << "no saturation, no hue";
}

TEST_F(PatchFeatureExtractorTest, ResponsesStayInUnitRangeForExtremePatches) {
  Paint([](double u, double) { return u > 0.0 ? 1.0 : 0.0; });
  for (float q : Values()) {
    EXPECT_GE(q, 0.0f);
    EXPECT_LE(q, 1.0f);
  }
  Paint([](double u, double) { return std::cos(kTwoPi * 2.0 * u) > 0.0 ? 1.0 : 0.0; });
  for (float q : Values()) {
    EXPECT_GE(q, 0.0f);
    EXPECT_LE(q, 1.0f);
  }
}

TEST_F(PatchFeatureExtractorTest, HueIsTheCircularMeanScaledToUnitRange) {
  const double angle = kTwoPi / 3.0;  // green
  hue_cos_.setTo(cv::Scalar(std::cos(angle)));
  hue_sin_.setTo(cv::Scalar(std::sin(angle)));
  EXPECT_NEAR(Values()[6], 1.0 / 3.0, 1e-5);
  // Hues either side of red average to red, not to cyan.
  for (int y = 0; y < 24; ++y) {
    for (int x = 0; x < 24; ++x) {
      const double a = (x % 2 == 0 ? 0.1 : -0.1);
      hue_cos_.at<float>(y, x) = static_cast<float>(std::cos(a));
      hue_sin_.at<float>(y, x) = static_cast<float>(std::sin(a));
    }
  }
  const float red = Values()[6];
  EXPECT_TRUE(red < 1e-4f || red > 1.0f - 1e-4f) << red;
}

double MeanOverObservedIn(const FeatureSet& set, const cv::Scalar& bgr, Feature f);

// The orientation shares of one patch painted with `value(u, v)` under light `gain·q + offset`.
std::array<float, 4> OrientationShares(const std::function<double(double, double)>& value,
                                       double gain = 1.0, double offset = 0.0) {
  const int n = 12, x0 = 5, y0 = 7;
  cv::Mat grey(24, 24, CV_32F, cv::Scalar(offset));
  for (int y = 0; y < 24; ++y) {
    for (int x = 0; x < 24; ++x) {
      // The whole image, so the patch's border gradients see the pattern go on.
      const double u = (2.0 * (x - x0) + 1.0) / n - 1.0, v = (2.0 * (y - y0) + 1.0) / n - 1.0;
      grey.at<float>(y, x) = static_cast<float>(gain * value(u, v) + offset);
    }
  }
  FeatureImages images;
  images.grey = grey;
  ComputeOrientationImages(grey, images);
  const FeatureSet set(
      {Feature::kOrient0, Feature::kOrient45, Feature::kOrient90, Feature::kOrient135});
  std::array<float, 4> out{};
  PatchFeatureExtractor(n).Compute(set, images, x0, y0, out.data());
  return out;
}

TEST(OrientationShares, EachEdgeDirectionFillsItsOwnShare) {
  const auto stripes = [](double angle) {
    return [angle](double u, double v) {
      return 0.5 + 0.5 * std::cos(kTwoPi * 2.0 * (u * std::cos(angle) + v * std::sin(angle)));
    };
  };
  // Stripes whose intensity changes along direction k·45° put their gradient energy there.
  for (int k = 0; k < 4; ++k) {
    const std::array<float, 4> q = OrientationShares(stripes(k * std::numbers::pi / 4.0));
    for (int b = 0; b < 4; ++b) {
      if (b == k) {
        EXPECT_GT(q[static_cast<size_t>(b)], 0.6f) << "stripes along " << 45 * k << "°";
      } else {
        EXPECT_LT(q[static_cast<size_t>(b)], q[static_cast<size_t>(k)] / 2) << "bin " << b;
      }
    }
  }
  // A flat patch has no orientation, however bright.
  for (float v : OrientationShares([](double, double) { return 0.7; })) EXPECT_EQ(v, 0.0f);
}

TEST(OrientationShares, DimmerLightKeepsTheRatiosBetweenShares) {
  // A patch with two edge directions: night light (gain 0.27, black lifted by 0.09, the
  // simulator's dim) scales every share alike, where a grating's response falls with the gain.
  const auto pattern = [](double u, double v) {
    return 0.5 + 0.3 * std::cos(kTwoPi * 2.0 * u) + 0.2 * std::cos(kTwoPi * 1.5 * v);
  };
  const std::array<float, 4> day = OrientationShares(pattern);
  const std::array<float, 4> night = OrientationShares(pattern, 0.27, 0.09);
  ASSERT_GT(day[2], 0.05f);
  ASSERT_GT(night[2], 0.0f);
  // One factor for every share (the flat-patch floor of features.cc), and most of each kept.
  const float factor = night[0] / day[0];
  for (size_t k = 0; k < 4; ++k) {
    if (day[k] > 0.01f) {
      EXPECT_NEAR(night[k] / day[k], factor, 1e-3f) << "bin " << k;
    }
  }
  EXPECT_GT(factor, 0.7f);
}

// The four orientation shares of a 12-pixel patch at (18, 18) of a 48x48 scene painted with
// `value(x, y)` under light `gain·q + offset`, with `noise` times a fixed pseudo-random field
// (SplitMix64 of the pixel index, seed 0x5eed; values in [-1, 1]) added; gradients of the
// frame blurred by `blur_px`. Returned as proportions (summing to 1), which is what the
// descriptor's block normalisation keeps of them.
std::array<double, 4> NoisyOrientationProportions(const std::function<double(int, int)>& value,
                                                  double gain, double offset, double noise,
                                                  double blur_px) {
  constexpr int kSide = 48, kPatch = 12, kCorner = 18;
  constexpr uint64_t kSeed = 0x5eed;
  cv::Mat grey(kSide, kSide, CV_32F);
  for (int y = 0; y < kSide; ++y) {
    for (int x = 0; x < kSide; ++x) {
      const uint64_t h = SplitMix64(kSeed + static_cast<uint64_t>(y * kSide + x));
      const double r = 2.0 * static_cast<double>(h >> 11) / static_cast<double>(1ull << 53) - 1.0;
      grey.at<float>(y, x) = static_cast<float>(gain * value(x, y) + offset + noise * r);
    }
  }
  FeatureImages images;
  images.grey = grey;
  ComputeOrientationImages(grey, images, blur_px);
  const FeatureSet set(
      {Feature::kOrient0, Feature::kOrient45, Feature::kOrient90, Feature::kOrient135});
  std::array<float, 4> q{};
  PatchFeatureExtractor(kPatch).Compute(set, images, kCorner, kCorner, q.data());
  const double total = static_cast<double>(q[0] + q[1] + q[2] + q[3]);
  EXPECT_GT(total, 0.0);
  std::array<double, 4> p{};
  for (size_t b = 0; b < 4; ++b) p[b] = static_cast<double>(q[b]) / total;
  return p;
}

TEST(OrientationShares, BlurKeepsANoisyDimEdgeLikeItsDaylightView) {
  // A wall corner (a vertical step) and a fainter horizontal one crossing the patch. At night
  // (the simulator's dim: gain 0.27, black lifted by 0.09) with sensor noise of ±0.04, noise
  // fills every unblurred share; blurred over half a patch they keep the edges' proportions.
  const auto corner = [](int x, int y) { return 0.3 + 0.4 * (x >= 24) + 0.15 * (y >= 26); };
  const auto distance = [&corner](double blur_px) {
    const std::array<double, 4> day = NoisyOrientationProportions(corner, 1.0, 0.0, 0.0, blur_px);
    const std::array<double, 4> night =
        NoisyOrientationProportions(corner, 0.27, 0.09, 0.04, blur_px);
    double d = 0.0;
    for (size_t b = 0; b < 4; ++b) d += std::abs(day[b] - night[b]);
    return d;
  };
  const double sharp = distance(0.0), blurred = distance(6.0);
  EXPECT_GT(sharp, 0.3) << "noise should spread the unblurred shares";
  EXPECT_LT(blurred, 0.5 * sharp) << "sharp " << sharp;
  EXPECT_THROW(NoisyOrientationProportions(corner, 1.0, 0.0, 0.0, -1.0), std::invalid_argument);
}

TEST(HuePair, RedDoesNotWrapAndGreyIsNoColour) {
  const FeatureSet set({Feature::kHueCos, Feature::kHueSin, Feature::kIntensity});
  const auto pair = [&set](const cv::Scalar& bgr) {
    return std::array<double, 2>{MeanOverObservedIn(set, bgr, Feature::kHueCos),
                                 MeanOverObservedIn(set, bgr, Feature::kHueSin)};
  };
  const auto red = pair(cv::Scalar(0, 0, 255));
  EXPECT_NEAR(red[0], 1.0, 0.01);
  EXPECT_NEAR(red[1], 0.5, 0.01);
  const auto grey = pair(cv::Scalar(128, 128, 128));
  EXPECT_NEAR(grey[0], 0.5, 1e-3);
  EXPECT_NEAR(grey[1], 0.5, 1e-3);
  // Reds 9° either side of 0° are as near as their hue angles (chord 0.16); the scalar hue
  // puts them at 0.03 and 0.97.
  const auto warm = pair(cv::Scalar(0, 40, 255)), cool = pair(cv::Scalar(40, 0, 255));
  EXPECT_LT(std::hypot(warm[0] - cool[0], warm[1] - cool[1]), 0.2);
  const FeatureSet scalar = FeatureSet::Thesis(1, true);
  EXPECT_GT(MeanOverObservedIn(scalar, cv::Scalar(40, 0, 255), Feature::kHue) -
                MeanOverObservedIn(scalar, cv::Scalar(0, 40, 255), Feature::kHue),
            0.9);
}

TEST(FeatureSet, ParsesFeatureListsAndNamesTheUnknownOne) {
  const FeatureSet set = FeatureSet::Recognition();
  EXPECT_EQ(FeatureSet::Parse(set.ToString()).features(), set.features());
  EXPECT_TRUE(set.Contains(Feature::kIntensity));  // place detection needs it
  EXPECT_TRUE(set.NeedsOrientation() && set.NeedsHue() && set.NeedsGrey());
  EXPECT_EQ(FeatureSet::Parse("orient_90").features(), std::vector<Feature>{Feature::kOrient90});
  try {
    FeatureSet::Parse("hue_cos,orient_7,intensity");
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'orient_7'"), std::string::npos) << e.what();
  }
  EXPECT_THROW(FeatureSet::Parse("hue_cos,,intensity"), std::invalid_argument);
  EXPECT_THROW(FeatureSet::Parse("hue_cos,hue_cos"), std::invalid_argument);
}

TEST(PatchFeatureExtractor, RejectsPatchesTooSmallForTheGratings) {
  EXPECT_THROW(PatchFeatureExtractor(4), std::invalid_argument);
  EXPECT_NO_THROW(PatchFeatureExtractor(6));
}

// 8 pixels sample the vertical cosine only at its zeros: the configuration names the key, so
// tscd exits as for any other bad value (it used to stop on a logic_error naming no key).
TEST(PatchFeatureExtractor, RejectsASideThatSamplesAGratingAtItsZeros) {
  EXPECT_THROW(PatchFeatureExtractor(8), std::invalid_argument);
  BubbleSurfaceOptions options;
  options.patch_px = 8;
  try {
    options.Validate();
    ADD_FAILURE() << "patch_px 8 was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("bubble.patch_px = 8"), std::string::npos) << e.what();
  }
  for (int n = static_cast<int>(BubbleSurfaceOptions::kPatchPxRange.min);
       n <= static_cast<int>(BubbleSurfaceOptions::kPatchPxRange.max); ++n) {
    options.patch_px = n;
    if (n == 8) continue;
    EXPECT_NO_THROW(options.Validate()) << "side " << n;
  }
}

// Observes a uniform colour frame and returns the mean of feature `f` over observed directions.
double MeanOverObserved(const FeatureSet& set, const cv::Scalar& bgr, const cv::Mat& depth,
                        Feature f) {
  BubbleSurface surface(set, CameraIntrinsics::FromHorizontalFov(320, 240, 60.0));
  surface.Observe(Observation{cv::Mat(240, 320, CV_8UC3, bgr), depth, PanTilt{}});
  const Eigen::MatrixXf& rho = surface.radius(set.IndexOf(f));
  double sum = 0.0;
  for (Eigen::Index k = 0; k < rho.size(); ++k) sum += surface.observed()(k) ? rho(k) : 0.0;
  return sum / surface.ObservedCount();
}

double MeanOverObservedIn(const FeatureSet& set, const cv::Scalar& bgr, Feature f) {
  return MeanOverObserved(set, bgr, cv::Mat(), f);
}

TEST(BubbleSurfaceFeatures, HueOfRedAndGreenFramesDiffer) {
  const FeatureSet set = FeatureSet::Thesis(1, true);
  const double red = MeanOverObserved(set, cv::Scalar(0, 0, 255), cv::Mat(), Feature::kHue);
  const double green = MeanOverObserved(set, cv::Scalar(0, 255, 0), cv::Mat(), Feature::kHue);
  const double blue = MeanOverObserved(set, cv::Scalar(255, 0, 0), cv::Mat(), Feature::kHue);
  EXPECT_NEAR(red, 0.0, 1e-3);
  EXPECT_NEAR(green, 1.0 / 3.0, 0.01);
  EXPECT_NEAR(blue, 2.0 / 3.0, 0.01);
  EXPECT_NEAR(MeanOverObserved(set, cv::Scalar(128, 128, 128), cv::Mat(), Feature::kIntensity),
              128.0 / 255.0, 1e-3);
}

TEST(BubbleSurfaceFeatures, DepthIsMeanValidRangeOverMaxRange) {
  const FeatureSet set = FeatureSet::Thesis(3, true);
  // Every other column has no reading (0): those are ignored, not averaged in.
  cv::Mat depth(240, 320, CV_32F, cv::Scalar(0.0f));
  for (int y = 0; y < depth.rows; ++y) {
    for (int x = 0; x < depth.cols; x += 2) depth.at<float>(y, x) = 4.0f;
  }
  EXPECT_NEAR(MeanOverObserved(set, cv::Scalar(50, 50, 50), depth, Feature::kDepth), 0.4, 1e-4);
  // Beyond the maximum range saturates at 1.
  EXPECT_NEAR(MeanOverObserved(set, cv::Scalar(50, 50, 50),
                               cv::Mat(240, 320, CV_32F, cv::Scalar(25.0f)), Feature::kDepth),
              1.0, 1e-6);
}

// A frame larger than the grid, shrunk by less than 2 (a bilinear step, as the real loop's
// 512x384 frames are): detail finer than the grid's pixels, here a checkerboard of ±40 grey
// levels on single pixels (the finest sensor noise or JPEG ringing), is averaged away before
// the features see it. Unfiltered, the bilinear step aliased it into grating and orientation
// responses (up to 0.29 of their unit range) (docs/decisions.md "Resampling to the grid").
TEST(BubbleSurfaceFeatures, DetailFinerThanTheGridIsAveragedNotAliased) {
  const FeatureSet set = FeatureSet::Recognition();
  const auto observe = [&](const cv::Mat& frame) {
    BubbleSurface surface(set, CameraIntrinsics::FromHorizontalFov(frame.cols, frame.rows, 60.0));
    surface.Observe(Observation{frame, cv::Mat(), PanTilt{}});
    return surface;
  };
  const cv::Mat flat(384, 512, CV_8UC3, cv::Scalar(128, 128, 128));
  cv::Mat checkered = flat.clone();
  for (int y = 0; y < checkered.rows; ++y) {
    for (int x = 0; x < checkered.cols; ++x) {
      checkered.at<cv::Vec3b>(y, x) = cv::Vec3b::all((x + y) % 2 == 0 ? 88 : 168);
    }
  }
  const BubbleSurface a = observe(flat), b = observe(checkered);
  ASSERT_EQ(a.ObservedCount(), b.ObservedCount());
  double largest = 0.0;
  for (int f = 0; f < set.size(); ++f) {
    for (Eigen::Index k = 0; k < a.radius(f).size(); ++k) {
      if (!a.observed()(k)) continue;
      largest = std::max(largest, static_cast<double>(std::abs(a.radius(f)(k) - b.radius(f)(k))));
    }
  }
  EXPECT_LT(largest, 0.01);  // 0.29 unfiltered; 0.0000 now
}

// Pseudo-random grey in [0, 1] of a rows x cols image (SplitMix64 of the pixel index, `seed`).
cv::Mat RandomGrey(int rows, int cols, uint64_t seed) {
  cv::Mat grey(rows, cols, CV_32F);
  for (int k = 0; k < rows * cols; ++k) {
    const uint64_t h = SplitMix64(seed + static_cast<uint64_t>(k));
    grey.at<float>(k / cols, k % cols) =
        static_cast<float>(static_cast<double>(h >> 11) / static_cast<double>(1ull << 53));
  }
  return grey;
}

// ComputeOrientationImages against its formula, pixel by pixel in double, on images whose rows
// and columns exercise the border rules and the single-pixel case (features.h). It runs as one
// vectorised pass over the pixels, four at a time with scalar ends.
TEST(OrientationImages, MatchTheFormulaAtEveryPixelAndBorder) {
  constexpr uint64_t kSeed = 0x0de5;
  for (const auto& [rows, cols] : std::vector<std::pair<int, int>>{
           {7, 13}, {5, 4}, {6, 5}, {1, 9}, {9, 1}, {1, 1}, {2, 2}, {3, 17}}) {
    const cv::Mat grey = RandomGrey(rows, cols, kSeed);
    FeatureImages images;
    ComputeOrientationImages(grey, images);
    const auto diff = [](const cv::Mat& g, int y0, int x0, int y1, int x1, double scale) {
      return scale * (static_cast<double>(g.at<float>(y1, x1)) - g.at<float>(y0, x0));
    };
    for (int y = 0; y < rows; ++y) {
      for (int x = 0; x < cols; ++x) {
        const double gx = cols < 2        ? 0.0
                          : x == 0        ? diff(grey, y, 0, y, 1, 1.0)
                          : x == cols - 1 ? diff(grey, y, x - 1, y, x, 1.0)
                                          : diff(grey, y, x - 1, y, x + 1, 0.5);
        const double gy = rows < 2        ? 0.0
                          : y == 0        ? diff(grey, 0, x, 1, x, 1.0)
                          : y == rows - 1 ? diff(grey, y - 1, x, y, x, 1.0)
                                          : diff(grey, y - 1, x, y + 1, x, 0.5);
        const double m = std::sqrt(gx * gx + gy * gy);
        const double c = m > 0.0 ? (gx * gx - gy * gy) / m : 0.0;
        const double s = m > 0.0 ? 2.0 * gx * gy / m : 0.0;
        const std::array<double, 4> want = {std::max(c, 0.0), std::max(s, 0.0), std::max(-c, 0.0),
                                            std::max(-s, 0.0)};
        for (size_t b = 0; b < 4; ++b) {
          ASSERT_EQ(images.orient[b].size(), grey.size());
          EXPECT_NEAR(images.orient[b].at<float>(y, x), want[b], 1e-6)
              << rows << "x" << cols << " image, pixel (" << x << ", " << y << "), bin " << b;
        }
      }
    }
  }
}

// A patch's intensity is the mean of its pixels for every side the extractor accepts, whether
// or not the side is a whole number of four-pixel steps.
TEST(PatchFeatureExtractor, IntensityIsThePatchMeanForEverySide) {
  constexpr uint64_t kSeed = 0x51de;
  const cv::Mat grey = RandomGrey(80, 80, kSeed);
  const FeatureSet set({Feature::kIntensity});
  FeatureImages images;
  images.grey = grey;
  for (int n = 6; n <= 64; n += 1) {
    if (n == 8) continue;  // no extractor (RejectsASideThatSamplesAGratingAtItsZeros)
    const int x0 = 80 - n - n % 7, y0 = n % 5;
    double sum = 0.0;
    for (int y = 0; y < n; ++y) {
      for (int x = 0; x < n; ++x) sum += grey.at<float>(y0 + y, x0 + x);
    }
    float value = -1.0f;
    PatchFeatureExtractor(n).Compute(set, images, x0, y0, &value);
    EXPECT_NEAR(value, sum / (n * n), 1e-6) << "side " << n;
  }
}

// Reset forgets what frames and Set wrote, whatever rho_0: every direction holds rho_0 again,
// none is observed, and the descriptor is that of a fresh surface.
TEST(BubbleSurfaceFeatures, ResetRestoresRestRadiusEverywhere) {
  BubbleSurfaceOptions options;
  options.rest_radius = 0.25f;
  const FeatureSet set = FeatureSet::Recognition();
  const CameraIntrinsics camera = CameraIntrinsics::FromHorizontalFov(160, 120, 60.0);
  BubbleSurface fresh(set, camera, options), used(set, camera, options);
  const cv::Mat frame = cv::Mat(120, 160, CV_8UC3, cv::Scalar(30, 120, 200));
  used.Observe(Observation{frame, cv::Mat(), PanTilt{0.4, 0.1}});
  used.Set(3, 5, used.grid().n_pan() - 1, 0.9f);  // a column no frame reached
  ASSERT_GT(used.ObservedCount(), 0);
  used.Reset();
  EXPECT_EQ(used.ObservedCount(), 0);
  for (int f = 0; f < set.size(); ++f) {
    EXPECT_EQ((used.radius(f).array() != 0.25f).count(), 0) << "feature block " << f;
  }
  const DescriptorComputer computer(fresh.grid());
  EXPECT_EQ(computer.Compute(used).values(), computer.Compute(fresh).values());
}

}  // namespace
}  // namespace tsc
