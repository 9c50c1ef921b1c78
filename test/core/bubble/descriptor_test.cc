#include "core/bubble/descriptor.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>

#include "core/bubble/surface.h"

namespace tsc {
namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;

CameraIntrinsics Vga() { return CameraIntrinsics::FromHorizontalFov(640, 480, 54.0); }

cv::Mat LoadFrame(const std::string& name) {
  const std::string path = std::string(TSCD_DATA_DIR) + "/rtabmap-loop/" + name;
  cv::Mat image = cv::imread(path, cv::IMREAD_COLOR);
  if (image.empty()) throw std::runtime_error("cannot read " + path);
  return image;
}

// Largest entry-wise difference relative to the largest entry of `a`.
double RelativeError(const Eigen::VectorXf& a, const Eigen::VectorXf& b) {
  return (a - b).cwiseAbs().maxCoeff() / a.cwiseAbs().maxCoeff();
}

// Random values on a random subset of directions, in a band of tilt rows, for every feature.
void FillRandom(BubbleSurface& surface, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const ViewingGrid& g = surface.grid();
  for (int i = 0; i < g.n_pan(); ++i) {
    for (int j = g.n_tilt() / 4; j < 3 * g.n_tilt() / 4; ++j) {
      if (u(rng) > 0.3f) continue;
      for (int k = 0; k < surface.features().size(); ++k) surface.Set(k, j, i, u(rng));
    }
  }
}

// `surface` with nothing observed, then each observed direction (j, i) of it set again at
// `to(j, i)` = (tilt row, pan column) with its values mapped by `value(feature, v)`.
template <typename To, typename Value>
BubbleSurface Remapped(const BubbleSurface& surface, To to, Value value) {
  BubbleSurface out = surface;
  out.Reset();
  for (int i = 0; i < surface.grid().n_pan(); ++i) {
    for (int j = 0; j < surface.grid().n_tilt(); ++j) {
      if (!surface.observed()(j, i)) continue;
      const auto [tilt, pan] = to(j, i);
      for (int f = 0; f < surface.features().size(); ++f) {
        out.Set(f, tilt, pan, value(f, surface.radius(f)(j, i)));
      }
    }
  }
  return out;
}
const auto kSameValue = [](int, float v) { return v; };

// The same surface turned by k grid steps in f1 (a heading change of k·d_phi).
BubbleSurface RotatedInPan(const BubbleSurface& surface, int k) {
  const int n = surface.grid().n_pan();
  return Remapped(
      surface,
      [&](int j, int i) {
        return std::pair{j, ((i + k) % n + n) % n};
      },
      kSameValue);
}

class DescriptorTest : public ::testing::Test {
 protected:
  DescriptorTest() : surface_(FeatureSet::Thesis(2, true), Vga()), dut_(surface_.grid()) {}

  std::mt19937 rng_{20240611};
  BubbleSurface surface_;
  DescriptorComputer dut_;
};

TEST_F(DescriptorTest, IsInvariantWhenObservationsShiftInPan) {
  FillRandom(surface_, rng_);
  const Eigen::VectorXf reference = dut_.Compute(surface_).values();
  for (int k : {1, 5, 10, 37, 72, 143, -3}) {
    const Eigen::VectorXf shifted = dut_.Compute(RotatedInPan(surface_, k)).values();
    EXPECT_LT(RelativeError(reference, shifted), 1e-5) << "k = " << k;
  }
}

TEST_F(DescriptorTest, IsInvariantWhenShiftedWithEnergyEntriesAndRestRadius) {
  BubbleSurfaceOptions options;
  options.rest_radius = 0.25f;
  BubbleSurface surface(FeatureSet::Thesis(1, true), Vga(), options);
  FillRandom(surface, rng_);
  DescriptorOptions energy;
  energy.amplitude = false;
  const DescriptorComputer computer(surface.grid(), energy);
  const Eigen::VectorXf reference = computer.Compute(surface).values();
  for (int k : {2, 50, 100}) {
    const Eigen::VectorXf shifted = computer.Compute(RotatedInPan(surface, k)).values();
    EXPECT_LT(RelativeError(reference, shifted), 1e-5) << "k = " << k;
    for (int f = 0; f < surface.features().size(); ++f) {
      const Eigen::VectorXf raw = computer.RawBlock(surface, f);
      const Eigen::VectorXf raw_shifted = computer.RawBlock(RotatedInPan(surface, k), f);
      EXPECT_LT(RelativeError(raw, raw_shifted), 1e-5) << "k = " << k << ", block " << f;
    }
  }
}

TEST_F(DescriptorTest, KeepsFeatureLevelOnlyWithFixedScale) {
  FillRandom(surface_, rng_);
  // The same hue pattern at half the level.
  const BubbleSurface brighter = Remapped(
      surface_,
      [](int j, int i) {
        return std::pair{j, i};
      },
      [](int f, float v) { return f == 0 ? 0.5f * v : v; });
  const Eigen::VectorXf block_sum = dut_.Compute(surface_).values();
  EXPECT_LT(RelativeError(block_sum, dut_.Compute(brighter).values()), 1e-5);

  DescriptorOptions fixed;
  fixed.block_sum = false;
  const DescriptorComputer computer(surface_.grid(), fixed);
  const Eigen::VectorXf a = computer.Compute(surface_).values();
  const Eigen::VectorXf b = computer.Compute(brighter).values();
  EXPECT_GT(RelativeError(a, b), 0.01);
  EXPECT_NEAR(b.head(dut_.block_size()).sum(), 0.5f * a.head(dut_.block_size()).sum(), 1e-6);
  for (int k : {1, 37, 143}) {
    EXPECT_LT(RelativeError(a, computer.Compute(RotatedInPan(surface_, k)).values()), 1e-5);
  }
}

TEST_F(DescriptorTest, IsAlsoInvariantWhenObservationsShiftInTiltAwayFromThePoles) {
  // z holds both cos(h2 f2) and sin(h2 f2) terms, so a shift in f2 only rotates each pair
  // and zᵀz (A.7) keeps it, as long as nothing crosses f2 = 0 or π.
  FillRandom(surface_, rng_);
  const BubbleSurface moved = Remapped(
      surface_,
      [](int j, int i) {
        return std::pair{j + 3, i};
      },
      kSameValue);
  EXPECT_LT(RelativeError(dut_.Compute(surface_).values(), dut_.Compute(moved).values()), 1e-5);
}

TEST_F(DescriptorTest, ChangesWhenPanColumnsAreRearranged) {
  FillRandom(surface_, rng_);
  std::vector<int> order(surface_.grid().n_pan());
  for (int i = 0; i < static_cast<int>(order.size()); ++i) order[i] = i;
  std::shuffle(order.begin(), order.end(), rng_);
  const BubbleSurface shuffled = Remapped(
      surface_,
      [&](int j, int i) {
        return std::pair{j, order[i]};
      },
      kSameValue);
  EXPECT_GT(ChiSquared(dut_.Compute(surface_).values(), dut_.Compute(shuffled).values()), 1e-4);
}

TEST(DescriptorComputer, HasDimensionNvTimesHarmonicsForEveryThesisSet) {
  for (int l = 1; l <= 5; ++l) {
    for (bool with_intensity : {true, false}) {
      const FeatureSet set = FeatureSet::Thesis(l, with_intensity);
      const BubbleSurface surface(set, Vga());
      const DescriptorComputer dut(surface.grid());
      const Descriptor d = dut.Compute(surface);
      EXPECT_EQ(d.dim(), set.size() * 10 * 10) << set.ToString();
      EXPECT_EQ(d.values().sum(), 0.0f) << "nothing observed: all blocks stay zero";
    }
  }
  const BubbleSurface surface(FeatureSet::Thesis(2, true), Vga());
  EXPECT_EQ(DescriptorComputer(surface.grid()).Compute(surface).dim(), 700);
  DescriptorOptions small;
  small.h1 = 3;
  small.h2 = 4;
  EXPECT_EQ(DescriptorComputer(surface.grid(), small).Compute(surface).dim(), 7 * 4 * 5);
}

TEST_F(DescriptorTest, IsNonNegativeWithBlocksSummingToOneOverNv) {
  FillRandom(surface_, rng_);
  // A feature that saw nothing.
  for (int i = 0; i < surface_.grid().n_pan(); ++i) {
    for (int j = 0; j < surface_.grid().n_tilt(); ++j) {
      if (surface_.observed()(j, i)) surface_.Set(2, j, i, 0.0f);
    }
  }
  const Descriptor d = dut_.Compute(surface_);
  const int nv = surface_.features().size();
  ASSERT_EQ(d.dim(), nv * dut_.block_size());
  EXPECT_GE(d.values().minCoeff(), 0.0f);
  for (int f = 0; f < nv; ++f) {
    const float sum = d.values().segment(f * dut_.block_size(), dut_.block_size()).sum();
    if (f == 2) {
      EXPECT_EQ(sum, 0.0f);
    } else {
      EXPECT_NEAR(sum, 1.0 / nv, 1e-6) << "block " << f;
    }
  }
}

TEST(BubbleSurface, SetMarksTheDirectionObservedAndChecksItsInput) {
  BubbleSurface dut(FeatureSet::Thesis(2, true), Vga());
  dut.Set(1, 5, 7, 0.25f);
  EXPECT_EQ(dut.observed()(5, 7), 1);
  EXPECT_EQ(dut.radius(1)(5, 7), 0.25f);
  EXPECT_EQ(dut.ObservedCount(), 1);
  EXPECT_THROW(dut.Set(dut.features().size(), 0, 0, 0.5f), std::invalid_argument);
  EXPECT_THROW(dut.Set(0, dut.grid().n_tilt(), 0, 0.5f), std::invalid_argument);
  EXPECT_THROW(dut.Set(0, 0, -1, 0.5f), std::invalid_argument);
  EXPECT_THROW(dut.Set(0, 0, 0, -0.1f), std::invalid_argument);
  EXPECT_THROW(dut.Set(0, 0, 0, std::numeric_limits<float>::quiet_NaN()), std::invalid_argument);
  EXPECT_EQ(dut.ObservedCount(), 1);
}

TEST_F(DescriptorTest, RawBlockIsQuadratureOfA4ForAConstantSurface) {
  // ρ = 1 everywhere: z_00 = (1/π²)·2π·π·[1, 0, 0, 0], so I_00 = 4; every h1 > 0 vanishes.
  for (int i = 0; i < surface_.grid().n_pan(); ++i) {
    for (int j = 0; j < surface_.grid().n_tilt(); ++j) surface_.Set(0, j, i, 1.0f);
  }
  const Eigen::VectorXf raw = dut_.RawBlock(surface_, 0);
  EXPECT_NEAR(raw[0], 4.0, 1e-4);
  for (int h1 = 1; h1 <= 9; ++h1) {
    for (int h2 = 0; h2 <= 9; ++h2) EXPECT_NEAR(raw[h1 * 10 + h2], 0.0, 1e-6);
  }
}

TEST(Descriptor, RejectsNegativeOrNonFiniteValues) {
  EXPECT_THROW(Descriptor(Eigen::VectorXf::Constant(3, -0.1f)), std::invalid_argument);
  Eigen::VectorXf v = Eigen::VectorXf::Zero(3);
  v[1] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(Descriptor{v}, std::invalid_argument);
  EXPECT_NO_THROW(Descriptor(Eigen::VectorXf::Zero(3)));
}

TEST(DescriptorOptions, ValidateThrowsWhenHarmonicsAreNegative) {
  DescriptorOptions o;
  o.h1 = -1;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
  o = DescriptorOptions{};
  o.h2 = -2;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
  EXPECT_NO_THROW(DescriptorOptions{}.Validate());
}

TEST(ChiSquared, IsZeroForEqualOneForDisjointAndSymmetric) {
  Eigen::VectorXf a(4), b(4), c(4);
  a << 0.5f, 0.5f, 0.0f, 0.0f;
  b << 0.0f, 0.0f, 0.25f, 0.75f;
  c << 0.25f, 0.25f, 0.25f, 0.25f;
  EXPECT_DOUBLE_EQ(ChiSquared(a, a), 0.0);
  EXPECT_NEAR(ChiSquared(a, b), 1.0, 1e-12);
  EXPECT_NEAR(ChiSquared(a, c), ChiSquared(c, a), 1e-12);
  // ½ [2·(0.25²/0.75) + 2·(0.25²/0.25)]
  EXPECT_NEAR(ChiSquared(a, c), 0.5 * (2 * 0.0625 / 0.75 + 2 * 0.0625 / 0.25), 1e-7);
  EXPECT_DOUBLE_EQ(ChiSquared(Eigen::VectorXf::Zero(5), Eigen::VectorXf::Zero(5)), 0.0);
  EXPECT_THROW(ChiSquared(a, Eigen::VectorXf::Zero(3)), std::invalid_argument);
}

class RealFrameTest : public ::testing::Test {
 protected:
  RealFrameTest()
      : frame_(LoadFrame("1.jpg")),
        dut_(FeatureSet::Thesis(2, true),
             CameraIntrinsics::FromHorizontalFov(frame_.cols, frame_.rows, 54.0)),
        computer_(dut_.grid()) {}

  Descriptor Observe(double pan_rad, double tilt_rad = 0.0) {
    dut_.Reset();
    dut_.Observe(Observation{frame_, cv::Mat(), PanTilt{pan_rad, tilt_rad}});
    return computer_.Compute(dut_);
  }

  cv::Mat frame_;
  BubbleSurface dut_;
  DescriptorComputer computer_;
};

TEST_F(RealFrameTest, GivesSameDescriptorWhenPannedByWholeGridSteps) {
  const double step = dut_.grid().d_phi_rad();
  const Descriptor at_zero = Observe(0.0);
  const auto observed_at_zero = dut_.observed();
  const int count = dut_.ObservedCount();
  ASSERT_GT(count, 100);
  for (int k : {10, -7, 100}) {
    const Descriptor panned = Observe(k * step);
    EXPECT_EQ(dut_.ObservedCount(), count) << "k = " << k;
    EXPECT_LT(RelativeError(at_zero.values(), panned.values()), 1e-4) << "k = " << k;
    EXPECT_LT(ChiSquared(at_zero.values(), panned.values()), 1e-8) << "k = " << k;
  }
  // The frame lands k columns further along f1 (positive pan = left).
  Observe(10 * step);
  const int n = dut_.grid().n_pan();
  for (int i = 0; i < n; ++i) {
    EXPECT_TRUE(dut_.observed().col((i + 10) % n) == observed_at_zero.col(i)) << "column " << i;
  }
  // The same holds with the camera tilted.
  const Descriptor tilted = Observe(0.0, 10 * kDegToRad);
  const Descriptor tilted_panned = Observe(10 * step, 10 * kDegToRad);
  EXPECT_LT(RelativeError(tilted.values(), tilted_panned.values()), 1e-4);
  EXPECT_GT(ChiSquared(at_zero.values(), tilted.values()), 1e-6) << "tilt moves the view";
}

TEST_F(RealFrameTest, AccumulatesDirectionsAndChangesDescriptorDuringAPtzSweep) {
  const Descriptor first = Observe(0.0);
  int count = dut_.ObservedCount();
  Eigen::VectorXf previous = first.values();
  for (double pan_deg : {40.0, 80.0, 120.0, -60.0}) {
    dut_.Observe(Observation{frame_, cv::Mat(), PanTilt{pan_deg * kDegToRad, 0.0}});
    EXPECT_GT(dut_.ObservedCount(), count) << "pan " << pan_deg;
    count = dut_.ObservedCount();
    const Eigen::VectorXf now = computer_.Compute(dut_).values();
    EXPECT_GT(ChiSquared(previous, now), 1e-6) << "pan " << pan_deg;
    previous = now;
  }
  dut_.Reset();
  EXPECT_EQ(dut_.ObservedCount(), 0);
  EXPECT_EQ(dut_.radius(0).cwiseAbs().maxCoeff(), 0.0f);
}

TEST_F(RealFrameTest, OverwritesDirectionsWhenObservedAgain) {
  Observe(0.0);
  const int count = dut_.ObservedCount();
  cv::Mat dark(frame_.size(), CV_8UC3, cv::Scalar(10, 10, 10));
  dut_.Observe(Observation{dark, cv::Mat(), PanTilt{}});
  EXPECT_EQ(dut_.ObservedCount(), count);
  const int intensity = dut_.features().IndexOf(Feature::kIntensity);
  EXPECT_NEAR(dut_.radius(intensity).maxCoeff(), 10.0 / 255.0, 1e-3);
}

TEST_F(RealFrameTest, SeesTheLeftOfTheImageAtLargerPan) {
  // Bright left half, dark right half: directions left of the optical axis (f1 just above 0)
  // are bright, those to the right (f1 just below 2π) dark.
  cv::Mat half(frame_.size(), CV_8UC3, cv::Scalar(0, 0, 0));
  half(cv::Rect(0, 0, frame_.cols / 2, frame_.rows)).setTo(cv::Scalar(255, 255, 255));
  dut_.Observe(Observation{half, cv::Mat(), PanTilt{}});
  const int intensity = dut_.features().IndexOf(Feature::kIntensity);
  const int row = dut_.grid().n_tilt() / 2;
  const int last = dut_.grid().n_pan() - 1;
  ASSERT_TRUE(dut_.observed()(row, 3));
  ASSERT_TRUE(dut_.observed()(row, last - 3));
  EXPECT_GT(dut_.radius(intensity)(row, 3), 0.99f);
  EXPECT_LT(dut_.radius(intensity)(row, last - 3), 0.01f);
  // Upper rows (small f2, towards the zenith) come from the top of the image.
  EXPECT_TRUE(dut_.observed()(row - 5, 0));
  EXPECT_FALSE(dut_.observed()(row, last / 2));  // behind the camera
}

TEST_F(RealFrameTest, ThrowsWhenImageSizeDoesNotMatchCamera) {
  cv::Mat small;
  cv::resize(frame_, small, cv::Size(frame_.cols / 2, frame_.rows / 2));
  EXPECT_THROW(dut_.Observe(Observation{small, cv::Mat(), PanTilt{}}), std::invalid_argument);
  cv::Mat grey(frame_.size(), CV_8UC1, cv::Scalar(0));
  EXPECT_THROW(dut_.Observe(Observation{grey, cv::Mat(), PanTilt{}}), std::invalid_argument);
  EXPECT_EQ(dut_.ObservedCount(), 0);
}

TEST(BubbleSurface, ThrowsWhenDepthIsNeededAndMissingOrOfAnotherSize) {
  BubbleSurface dut(FeatureSet::Thesis(4, true), Vga());
  const cv::Mat bgr(480, 640, CV_8UC3, cv::Scalar(90, 120, 150));
  EXPECT_THROW(dut.Observe(Observation{bgr, cv::Mat(), PanTilt{}}), std::invalid_argument);
  EXPECT_THROW(dut.Observe(Observation{bgr, cv::Mat(240, 320, CV_32F, 2.0f), PanTilt{}}),
               std::invalid_argument);
  EXPECT_NO_THROW(dut.Observe(Observation{bgr, cv::Mat(480, 640, CV_32F, 2.0f), PanTilt{}}));
}

TEST(BubbleSurfaceOptions, ValidateNamesTheBadField) {
  BubbleSurfaceOptions o;
  o.d_phi_deg = 7.0;  // does not divide 180
  try {
    o.Validate();
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("d_phi_deg"), std::string::npos) << e.what();
  }
  o = BubbleSurfaceOptions{};
  o.max_depth_m = 0.0;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
  o = BubbleSurfaceOptions{};
  o.rest_radius = -1.0f;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
  o = BubbleSurfaceOptions{};
  o.patch_px = 2;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
  EXPECT_NO_THROW(BubbleSurfaceOptions{}.Validate());
}

TEST(ViewingGrid, SamplesPanFromZeroAndTiltAtCellCentres) {
  const ViewingGrid dut(2.5);
  EXPECT_EQ(dut.n_pan(), 144);
  EXPECT_EQ(dut.n_tilt(), 72);
  EXPECT_DOUBLE_EQ(dut.f1(0), 0.0);
  EXPECT_NEAR(dut.f2(0), 1.25 * kDegToRad, 1e-12);
  EXPECT_NEAR(dut.f2(71), 178.75 * kDegToRad, 1e-12);
}

TEST(CameraIntrinsics, ScalesAndRejectsBadValues) {
  const CameraIntrinsics dut = CameraIntrinsics::FromHorizontalFov(640, 480, 90.0);
  EXPECT_NEAR(dut.fx(), 320.0, 1e-9);
  EXPECT_NEAR(dut.cx(), 319.5, 1e-12);
  const CameraIntrinsics half = dut.Scaled(320, 240);
  EXPECT_NEAR(half.fx(), 160.0, 1e-9);
  EXPECT_NEAR(half.cx(), 159.5, 1e-12);
  EXPECT_THROW(CameraIntrinsics(0, 480, 500, 500, 0, 240), std::invalid_argument);
  EXPECT_THROW(CameraIntrinsics(640, 480, -1, 500, 320, 240), std::invalid_argument);
  EXPECT_THROW(CameraIntrinsics(640, 480, 500, 500, 700, 240), std::invalid_argument);
  EXPECT_THROW(CameraIntrinsics::FromHorizontalFov(640, 480, 180.0), std::invalid_argument);
}

}  // namespace
}  // namespace tsc
