#include "core/pipeline/pipeline.h"

#include <gtest/gtest.h>

#include <map>
#include <random>

namespace tsc {
namespace {

constexpr int kDim = 700;

// Descriptors on the normalised scale: non-negative, summing to 1.
Eigen::VectorXf Normalised(Eigen::VectorXf v) { return v / v.sum(); }

class PipelineTest : public ::testing::Test {
 protected:
  PipelineTest()
      : dut_(CameraIntrinsics::FromHorizontalFov(64, 48, 60), Options(),
             PlaceMemory(1, Options().memory), TopologicalMap()) {
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (int c = 0; c < 3; ++c) {
      Eigen::VectorXf v(kDim);
      for (int i = 0; i < kDim; ++i) v[i] = u(rng_);
      centres_.push_back(Normalised(v));
    }
  }
  static PipelineOptions Options() {
    PipelineOptions o;
    o.detector = DetectorOptions{2, 2, 3};
    return o;
  }
  // `n` frames of place `c` (small noise), then a transition of 3 incoherent frames.
  void Visit(int c, int n) {
    std::normal_distribution<float> noise(0.0f, 0.02f);
    for (int j = 0; j < n; ++j) {
      Eigen::VectorXf v = centres_[c];
      for (int i = 0; i < kDim; ++i) v[i] = std::max(0.0f, v[i] * (1.0f + noise(rng_)));
      Collect(dut_.ProcessDescriptor(Descriptor(Normalised(v)), IntensityStats{0.5, 0.05}));
    }
    std::uniform_int_distribution<int> pick(0, kDim - 1);
    for (int j = 0; j < 3; ++j) {
      Eigen::VectorXf v = Eigen::VectorXf::Zero(kDim);
      for (int s = 0; s < 5; ++s) v[pick(rng_)] = 1.0f;  // sparse: far from everything
      Collect(dut_.ProcessDescriptor(Descriptor(Normalised(v)), IntensityStats{0.5, 0.05}));
    }
  }
  void Collect(const FrameResult& r) {
    for (const PlaceEvent& e : r.events) events_.push_back(e);
  }
  int Count(EventKind k, bool partial = false) const {
    int n = 0;
    for (const auto& e : events_) n += e.kind == k && e.partial == partial;
    return n;
  }

  std::mt19937 rng_{11};
  std::vector<Eigen::VectorXf> centres_;
  std::vector<PlaceEvent> events_;
  Pipeline dut_;
};

TEST_F(PipelineTest, LearnsNewPlacesRecognisesRevisitsAndMapsTransitions) {
  Visit(0, 15);
  Visit(1, 15);
  Visit(2, 15);
  Visit(0, 15);  // revisit
  Collect(dut_.Finish());
  EXPECT_EQ(Count(EventKind::kDetected), 4);
  EXPECT_EQ(Count(EventKind::kLearned), 3);
  EXPECT_EQ(Count(EventKind::kRecognized), 1);
  EXPECT_GE(Count(EventKind::kRecognized, /*partial=*/true), 1);
  ASSERT_EQ(dut_.memory().places().size(), 3u);
  EXPECT_EQ(dut_.memory().places()[0].detected, (std::vector<DetectedPlaceIndex>{1, 4}));
  // 15 + 14: the first frame after a transition is incoherent with its predecessor.
  EXPECT_EQ(dut_.memory().places()[0].member_count, 29);
  // Edges 1-2, 2-3, 3-1; each transition region spans the 3 incoherent frames... and the
  // first good frame after them, which is incoherent with respect to its predecessor.
  EXPECT_EQ(dut_.map().edges().size(), 3u);
  const MapEdge* e = dut_.map().Find(PlaceId{1, 1}, PlaceId{1, 2});
  ASSERT_NE(e, nullptr);
  ASSERT_EQ(e->transitions.size(), 1u);
  EXPECT_EQ(e->transitions[0].first, 15);
  EXPECT_EQ(Count(EventKind::kMapped), 3);
}

TEST_F(PipelineTest, StateContinuesIndices) {
  Visit(0, 10);
  Collect(dut_.Finish());
  const PipelineState s = dut_.state();
  EXPECT_EQ(s.next_base, 13);
  EXPECT_EQ(s.next_detected, 2);
  ASSERT_TRUE(s.previous_place.has_value());
  EXPECT_EQ(*s.previous_place, (PlaceId{1, 1}));
}

TEST(PipelineOptions, RequiresIntensity) {
  PipelineOptions o;
  o.features = FeatureSet::Thesis(2, false);
  EXPECT_THROW(o.Validate(), std::invalid_argument);
}

}  // namespace
}  // namespace tsc
