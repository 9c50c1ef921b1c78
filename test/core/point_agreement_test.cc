#include "core/memory/point_agreement.h"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <stdexcept>
#include <vector>

#include "core/memory/compact_views.h"
#include "core/memory/learned_place.h"

namespace tsc {
namespace {

constexpr int kDim = 8;

// A place of one view: the unit vector e_axis scaled to a descriptor-like size.
LearnedPlace OneView(uint32_t local, int axis) {
  Eigen::MatrixXf v = Eigen::MatrixXf::Zero(kDim, 1);
  v(axis, 0) = 0.5f;
  LearnedPlace p;
  p.id = PlaceId{1, local};
  p.mean = v.col(0);
  p.member_count = 1;
  p.samples = CompactViews(v);
  return p;
}

// Vote points: `counts[a]` copies of place a's view, moved by `offset` along the last axis.
Eigen::MatrixXf Votes(const std::vector<int>& counts, float offset = 0.01f) {
  int n = 0;
  for (int c : counts) n += c;
  Eigen::MatrixXf x = Eigen::MatrixXf::Zero(kDim, n);
  int j = 0;
  for (size_t a = 0; a < counts.size(); ++a) {
    for (int c = 0; c < counts[a]; ++c, ++j) {
      x(static_cast<Eigen::Index>(a), j) = 0.5f;
      x(kDim - 1, j) = offset;
    }
  }
  return x;
}

class PointAgreementTest : public ::testing::Test {
 protected:
  void SetUp() override {
    for (int a = 0; a < 3; ++a) places_.push_back(OneView(static_cast<uint32_t>(a + 1), a));
    for (const LearnedPlace& p : places_) pointers_.push_back(&p);
  }
  ViewDistances Of(const Eigen::MatrixXf& votes) const {
    return ViewDistances(votes, pointers_, std::vector<double>(places_.size(), 1e-3));
  }
  std::vector<LearnedPlace> places_;
  std::vector<const LearnedPlace*> pointers_;
};

TEST_F(PointAgreementTest, CountsThePointsWhoseNearestPlaceIsThePlace) {
  const ViewDistances vd = Of(Votes({4, 6, 2}));
  EXPECT_DOUBLE_EQ(PointAgreement(vd, 0, {}, 1.0), 4.0 / 12);
  EXPECT_DOUBLE_EQ(PointAgreement(vd, 1, {}, 1.0), 6.0 / 12);
  EXPECT_DOUBLE_EQ(PointAgreement(vd, 2, {}, 1.0), 2.0 / 12);
  EXPECT_EQ(vd.NearestPlace(0), 0);
  EXPECT_EQ(vd.NearestPlace(11), 2);
}

// A room held twice: the points nearest its copy agree with it too.
TEST_F(PointAgreementTest, PointsNearestACopyAgree) {
  const ViewDistances vd = Of(Votes({4, 6, 2}));
  const std::vector<int> copies = {1};
  EXPECT_DOUBLE_EQ(PointAgreement(vd, 0, copies, 1.0), 10.0 / 12);
}

// A point between two places agrees with the farther one only when the slack covers the ratio
// of its two squared distances (a near tie is no disagreement).
TEST_F(PointAgreementTest, ANearTieAgreesWithinTheSlack) {
  Eigen::MatrixXf x = Eigen::MatrixXf::Zero(kDim, 1);
  x(0, 0) = 0.3f;  // nearer place 0 (0.04 + 0.04 = 0.08) than place 1 (0.09 + 0.09 = 0.18)
  x(1, 0) = 0.2f;
  const ViewDistances vd = Of(x);
  ASSERT_EQ(vd.NearestPlace(0), 0);
  EXPECT_DOUBLE_EQ(PointAgreement(vd, 1, {}, 1.0), 0.0);
  EXPECT_DOUBLE_EQ(PointAgreement(vd, 1, {}, 2.0), 0.0);  // 0.18 > 2 · 0.08
  EXPECT_DOUBLE_EQ(PointAgreement(vd, 1, {}, 3.0), 1.0);  // 0.18 ≤ 3 · 0.08
}

TEST_F(PointAgreementTest, OnlyMeasuredPlacesAreNamed) {
  std::vector<const LearnedPlace*> some = pointers_;
  some[1] = nullptr;  // left out of a shortlist: infinitely far
  const ViewDistances vd(Votes({4, 6, 2}), some, std::vector<double>(3, 1e-3));
  // The points at place 1's view now lie nearest place 0 or 2 (at equal distance: the lower).
  EXPECT_EQ(vd.NearestPlace(4), 0);
  EXPECT_DOUBLE_EQ(PointAgreement(vd, 0, {}, 1.0), 10.0 / 12);
  EXPECT_THROW(PointAgreement(vd, 1, {}, 1.0), std::invalid_argument);
  EXPECT_THROW(PointAgreement(vd, 0, {}, 0.5), std::invalid_argument);
  const std::vector<const LearnedPlace*> none(3, nullptr);
  const ViewDistances empty(Votes({1}), none, std::vector<double>(3, 1e-3));
  EXPECT_EQ(empty.NearestPlace(0), -1);
}

}  // namespace
}  // namespace tsc
