#include "core/detect/reliability.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <stdexcept>
#include <string>

#include "core/bubble/descriptor.h"

namespace tsc {
namespace {

class ReliabilityTest : public ::testing::Test {
 protected:
  ReliabilityTest()
      : frame_(cv::imread(std::string(TSCD_DATA_DIR) + "/rtabmap-loop/1.jpg", cv::IMREAD_COLOR)),
        surface_(FeatureSet::Thesis(2, true),
                 CameraIntrinsics::FromHorizontalFov(frame_.cols, frame_.rows, 54.0)),
        computer_(surface_.grid()) {}

  void SetUp() override { ASSERT_FALSE(frame_.empty()) << "cannot read 1.jpg"; }

  // Status of `image` as the first base point (no previous descriptor) or after `previous`.
  BaseStatus Classify(const cv::Mat& image, const Eigen::VectorXf* previous = nullptr) {
    surface_.Reset();
    surface_.Observe(Observation{image, cv::Mat(), PanTilt{}});
    stats_ = IntensityStatistics(surface_);
    descriptor_ = computer_.Compute(surface_).values();
    return ClassifyBasePoint(options_, stats_, descriptor_, previous);
  }

  cv::Mat Uniform(int grey) const {
    return cv::Mat(frame_.size(), CV_8UC3, cv::Scalar(grey, grey, grey));
  }

  cv::Mat frame_;
  BubbleSurface surface_;
  DescriptorComputer computer_;
  ReliabilityOptions options_;
  IntensityStats stats_;
  Eigen::VectorXf descriptor_;
};

TEST_F(ReliabilityTest, DarkFrameIsUninformative) {
  EXPECT_EQ(Classify(Uniform(8)), BaseStatus::kUninformative);
  EXPECT_LE(stats_.mean, options_.tau_mu);
  // Dark with some texture is still too dark.
  cv::Mat dark = frame_ * 0.1;
  EXPECT_EQ(Classify(dark), BaseStatus::kUninformative);
}

TEST_F(ReliabilityTest, FlatGreyFrameIsUninformativeByVariance) {
  EXPECT_EQ(Classify(Uniform(128)), BaseStatus::kUninformative);
  EXPECT_GT(stats_.mean, options_.tau_mu);
  EXPECT_LE(stats_.variance, options_.tau_sigma);
}

TEST_F(ReliabilityTest, NormalFrameIsGood) {
  EXPECT_EQ(Classify(frame_), BaseStatus::kGood);
  EXPECT_GT(stats_.mean, options_.tau_mu);
  EXPECT_GT(stats_.variance, options_.tau_sigma);
  const Eigen::VectorXf first = descriptor_;
  EXPECT_EQ(Classify(frame_, &first), BaseStatus::kGood) << "same view twice is coherent";
}

TEST_F(ReliabilityTest, VeryDifferentConsecutiveDescriptorsAreIncoherent) {
  EXPECT_EQ(Classify(frame_), BaseStatus::kGood);
  // The same frame seen with the camera turned a quarter turn: the informative part of the
  // surface moves, but the descriptor is pan invariant, so this stays coherent ...
  const Eigen::VectorXf previous = descriptor_;
  surface_.Reset();
  surface_.Observe(Observation{frame_, cv::Mat(), PanTilt{1.5707963267948966, 0.0}});
  EXPECT_EQ(ClassifyBasePoint(options_, IntensityStatistics(surface_),
                              computer_.Compute(surface_).values(), &previous),
            BaseStatus::kGood);
  // ... while a descriptor with its energy in other harmonics is incoherent.
  Eigen::VectorXf other = Eigen::VectorXf::Zero(previous.size());
  for (Eigen::Index k = 0; k < other.size(); k += 100) other[k + 99] = 1.0f;
  other /= other.sum();
  EXPECT_GT(ChiSquared(previous, other), options_.tau_kappa);
  EXPECT_EQ(ClassifyBasePoint(options_, stats_, other, &previous), BaseStatus::kIncoherent);
  // Informativeness is decided first.
  EXPECT_EQ(ClassifyBasePoint(options_, IntensityStats{0.01, 0.1}, other, &previous),
            BaseStatus::kUninformative);
}

TEST(IntensityStatistics, UsesObservedDirectionsOnly) {
  BubbleSurfaceOptions options;
  options.rest_radius = 0.9f;  // unobserved directions must not count
  BubbleSurface dut(FeatureSet::Thesis(1, true),
                    CameraIntrinsics::FromHorizontalFov(320, 240, 60.0), options);
  EXPECT_EQ(IntensityStatistics(dut).mean, 0.0);
  EXPECT_EQ(IntensityStatistics(dut).variance, 0.0);
  const int block = dut.features().IndexOf(Feature::kIntensity);
  dut.Set(block, 10, 0, 0.2f);
  dut.Set(block, 11, 0, 0.6f);
  const IntensityStats stats = IntensityStatistics(dut);
  EXPECT_NEAR(stats.mean, 0.4, 1e-7);
  EXPECT_NEAR(stats.variance, 0.04, 1e-7);
}

TEST(IntensityStatistics, ThrowsWithoutIntensityFeature) {
  const BubbleSurface dut(FeatureSet::Thesis(2, false),
                          CameraIntrinsics::FromHorizontalFov(320, 240, 60.0));
  EXPECT_THROW(IntensityStatistics(dut), std::invalid_argument);
}

TEST(ReliabilityOptions, ValidateNamesTheBadField) {
  ReliabilityOptions o;
  EXPECT_NO_THROW(o.Validate());
  o.tau_kappa = -0.1;
  try {
    o.Validate();
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("tau_kappa"), std::string::npos) << e.what();
  }
  o = ReliabilityOptions{};
  o.tau_mu = 2.0;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
  o = ReliabilityOptions{};
  o.tau_sigma = -1.0;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
}

TEST(BaseStatus, HasNames) {
  EXPECT_STREQ(BaseStatusName(BaseStatus::kGood), "good");
  EXPECT_STREQ(BaseStatusName(BaseStatus::kUninformative), "uninformative");
  EXPECT_STREQ(BaseStatusName(BaseStatus::kIncoherent), "incoherent");
}

}  // namespace
}  // namespace tsc
