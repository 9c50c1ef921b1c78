#include "core/memory/recognition_cost.h"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <iostream>
#include <limits>
#include <random>
#include <span>
#include <stdexcept>
#include <vector>

#include "core/memory/decoded_views.h"
#include "core/memory/simd.h"

namespace tsc {
namespace {

constexpr uint32_t kSeed = 7031;
constexpr int kDim = 1200;

// Descriptor-like views: positive entries on the scale of a sum-normalised descriptor.
Eigen::MatrixXf Views(std::mt19937& rng, int count) {
  std::uniform_real_distribution<float> u(0.0f, 2.0f / kDim);
  Eigen::MatrixXf m(kDim, count);
  for (Eigen::Index i = 0; i < m.size(); ++i) m.data()[i] = u(rng);
  return m;
}

LearnedPlace PlaceOf(uint32_t local, Eigen::MatrixXf samples) {
  LearnedPlace p;
  p.id = PlaceId{1, local};
  p.mean = samples.rowwise().mean();
  p.member_count = samples.cols();
  p.samples = CompactViews(samples);
  return p;
}

// Places of 1 to 33 views and vote points near some of their views (1 % apart, so the nearest
// distances are small against the norms, where the norm expansion loses most).
class ViewDistancesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::cout << "seed " << kSeed << "\n";
    std::mt19937 rng(kSeed);
    uint32_t local = 1;
    for (int count : {1, 2, 5, 12, 32, 33}) places_.push_back(PlaceOf(local++, Views(rng, count)));
    std::normal_distribution<float> noise(0.0f, 0.01f);
    votes_ = Views(rng, 13);
    for (int j = 0; j < 13; j += 2) {
      const Eigen::MatrixXf s = places_[static_cast<size_t>(j) % places_.size()].samples.Decoded();
      votes_.col(j) = s.col(j % s.cols());
      for (Eigen::Index i = 0; i < kDim; ++i) votes_(i, j) *= 1.0f + noise(rng);
    }
    for (const LearnedPlace& p : places_) pointers_.push_back(&p);
    units_.assign(places_.size(), 1e-6);
  }
  std::vector<LearnedPlace> places_;
  std::vector<const LearnedPlace*> pointers_;
  std::vector<double> units_;
  Eigen::MatrixXf votes_;
};

TEST_F(ViewDistancesTest, AnswersInfinityAndNoViewForPlacesNotMeasured) {
  std::vector<const LearnedPlace*> some = pointers_;
  some[1] = nullptr;
  some[4] = nullptr;
  const std::vector<float> estimates = {1, 2, 3, 4, 5, 6};
  for (Simd simd : {Simd::kPortable, FastestSimd()}) {
    const ViewDistances dut(votes_, some, units_, estimates, simd);
    EXPECT_EQ(dut.num_places(), 6);
    EXPECT_EQ(dut.num_votes(), 13);
    for (int p = 0; p < dut.num_places(); ++p) {
      EXPECT_EQ(dut.measured(p), some[static_cast<size_t>(p)] != nullptr) << p;
      EXPECT_EQ(dut.estimate(p), estimates[static_cast<size_t>(p)]);
      for (int j = 0; j < dut.num_votes(); ++j) {
        if (dut.measured(p)) {
          EXPECT_TRUE(std::isfinite(dut.distance(j, p))) << j << ", " << p;
          EXPECT_GE(dut.view(j, p), 0);
        } else {
          EXPECT_EQ(dut.distance(j, p), std::numeric_limits<float>::infinity()) << j << ", " << p;
          EXPECT_EQ(dut.view(j, p), -1);
        }
      }
    }
  }
  // Nothing measured: every place is infinitely far, and there are still vote points.
  const std::vector<const LearnedPlace*> none(places_.size(), nullptr);
  const ViewDistances empty(votes_, none, units_);
  for (int p = 0; p < empty.num_places(); ++p) EXPECT_FALSE(empty.measured(p)) << p;
  EXPECT_EQ(empty.num_votes(), 13);
  EXPECT_EQ(empty.distance(0, 0), std::numeric_limits<float>::infinity());
  EXPECT_EQ(empty.estimate(0), std::numeric_limits<float>::infinity());
}

// The portable products and the fastest kernels both find the nearest view by brute force:
// the view is the same, the distance the same up to the rounding of ‖s‖² + ‖x‖² − 2 sᵀx.
TEST_F(ViewDistancesTest, NearestViewsEqualBruteForceWithEitherSimd) {
  const ViewDistances portable(votes_, pointers_, units_, {}, Simd::kPortable);
  const ViewDistances fastest(votes_, pointers_, units_, {}, FastestSimd());
  int near = 0;
  for (int p = 0; p < static_cast<int>(places_.size()); ++p) {
    const Eigen::MatrixXd s = places_[static_cast<size_t>(p)].samples.Decoded().cast<double>();
    for (int j = 0; j < votes_.cols(); ++j) {
      const Eigen::VectorXd x = votes_.col(j).cast<double>();
      const Eigen::RowVectorXd d = (s.colwise() - x).colwise().squaredNorm();
      Eigen::Index view = 0;
      const double want = d.minCoeff(&view);
      // The expansion rounds at the scale of the squared norms, not of the distance.
      const double tolerance = 4e-6 * (x.squaredNorm() + s.col(view).squaredNorm());
      near += want < 0.01 * x.squaredNorm();
      for (const ViewDistances* dut : {&portable, &fastest}) {
        EXPECT_NEAR(dut->distance(j, p), want, tolerance) << "vote " << j << ", place " << p;
        EXPECT_EQ(dut->view(j, p), view) << "vote " << j << ", place " << p;
      }
    }
  }
  EXPECT_GE(near, 7);  // the votes made from views are measured where precision matters
}

// A caller that keeps places' views decoded (a merge's N*) gets the floats decoding gives, bit
// for bit, on either instruction set, for places given decoded and places left to decode alike.
TEST_F(ViewDistancesTest, ViewsGivenDecodedMeasureTheSameFloats) {
  for (Simd simd : {Simd::kPortable, FastestSimd()}) {
    std::vector<DecodedViews> kept;
    for (const LearnedPlace& p : places_) kept.emplace_back(p.samples, simd);
    std::vector<const DecodedViews*> given;
    for (size_t p = 0; p < places_.size(); ++p) given.push_back(p % 3 == 1 ? nullptr : &kept[p]);
    std::vector<const LearnedPlace*> some = pointers_;
    some[2] = nullptr;  // not measured, though given
    const std::vector<float> estimates = {1, 2, 3, 4, 5, 6};
    const ViewDistances decoding(votes_, some, units_, estimates, simd);
    const ViewDistances dut(votes_, some, units_, estimates, simd, given);
    for (int p = 0; p < dut.num_places(); ++p) {
      ASSERT_EQ(dut.measured(p), decoding.measured(p)) << p;
      for (int j = 0; j < dut.num_votes(); ++j) {
        EXPECT_EQ(dut.distance(j, p), decoding.distance(j, p)) << "vote " << j << ", place " << p;
        EXPECT_EQ(dut.view(j, p), decoding.view(j, p)) << "vote " << j << ", place " << p;
      }
    }
    for (int j = 0; j < dut.num_votes(); ++j)
      EXPECT_EQ(dut.NearestPlace(j), decoding.NearestPlace(j));
  }
}

TEST_F(ViewDistancesTest, RejectsDecodedViewsThatAreNotThePlaces) {
  std::vector<DecodedViews> kept;
  for (const LearnedPlace& p : places_) kept.emplace_back(p.samples, FastestSimd());
  std::vector<const DecodedViews*> given;
  for (const DecodedViews& d : kept) given.push_back(&d);
  std::swap(given[3], given[4]);  // another place's views: 12 and 32 of them
  EXPECT_THROW(ViewDistances(votes_, pointers_, units_, {}, FastestSimd(), given),
               std::invalid_argument);
  std::swap(given[3], given[4]);
  given.pop_back();  // one short
  EXPECT_THROW(ViewDistances(votes_, pointers_, units_, {}, FastestSimd(), given),
               std::invalid_argument);
  if (FastestSimd() != Simd::kPortable) {  // decoded for the other instruction set
    const std::vector<const DecodedViews*> all(given.begin(), given.end());
    std::vector<const DecodedViews*> full = all;
    full.push_back(&kept.back());
    EXPECT_THROW(ViewDistances(votes_, pointers_, units_, {}, Simd::kPortable, full),
                 std::invalid_argument);
  }
}

TEST_F(ViewDistancesTest, RejectsViewsOfAnotherDimension) {
  places_[2].samples = CompactViews(Eigen::MatrixXf::Ones(kDim - 1, 3));
  EXPECT_THROW(ViewDistances(votes_, pointers_, units_), std::invalid_argument);
  EXPECT_THROW(ViewDistances(votes_, pointers_, units_, {}, Simd::kPortable),
               std::invalid_argument);
}

// N² is the nearest child that does not hold N¹'s place again, however many copies of N¹ lie
// nearer D than it (a merge's crowded hyper-terminal has tens): twenty copies of N¹ and
// thirty other places, shuffled among the candidates; the ratio is γ̃(N¹) over the smallest
// γ̃ of the others, found here by brute force.
TEST(RecognitionCostTest, RatioSkipsEveryCopyOfTheNearestPlace) {
  std::cout << "seed " << kSeed << "\n";
  std::mt19937 rng(kSeed);
  const Eigen::MatrixXf votes = Views(rng, 8);
  // Squared norms of the offsets, in units u: N¹ lies 1 u from D's points, its copies 0.01 to
  // 0.2 u from N¹'s views, the others 3 to 32 u from D's points. (At u = 1e-6 the copies'
  // offsets lay below the grid of 8-bit views in 1200 dimensions, ~2e-8.)
  const double unit = 1e-4;
  auto offset = [&rng](const Eigen::MatrixXf& from, double squared) {
    std::normal_distribution<float> n(0.0f, static_cast<float>(std::sqrt(squared / kDim)));
    Eigen::MatrixXf m = from;
    for (Eigen::Index i = 0; i < m.size(); ++i) m.data()[i] += n(rng);
    return m;
  };
  std::vector<LearnedPlace> places;
  std::vector<char> is_copy;
  places.push_back(PlaceOf(1, offset(votes, unit)));
  is_copy.push_back(0);
  for (int k = 0; k < 20; ++k) {
    places.push_back(PlaceOf(2 + k, offset(places[0].samples.Decoded(), unit * 0.01 * (1 + k))));
    is_copy.push_back(1);
  }
  for (int k = 0; k < 30; ++k) {
    places.push_back(PlaceOf(22 + k, offset(votes, unit * (3 + k))));
    is_copy.push_back(0);
  }
  std::vector<int> order(places.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::shuffle(order.begin(), order.end(), rng);
  std::vector<const LearnedPlace*> pointers;
  for (int i : order) pointers.push_back(&places[static_cast<size_t>(i)]);
  const ViewDistances vd(votes, pointers, std::vector<double>(places.size(), unit));
  std::vector<int> columns(places.size());
  for (size_t c = 0; c < columns.size(); ++c) columns[c] = static_cast<int>(c);
  std::vector<CostCandidate> candidates(places.size());
  for (size_t c = 0; c < candidates.size(); ++c) {
    candidates[c].places = std::span<const int>(columns).subspan(c, 1);
    candidates[c].centroid_sum = &pointers[c]->mean;
  }
  const CostTerms t = RecognitionCost(vd, votes.rowwise().mean(), candidates, {});
  ASSERT_GE(t.best, 0);
  EXPECT_EQ(order[static_cast<size_t>(t.best)], 0);  // N¹ itself, not one of its copies
  auto gamma = [&vd](int c) {
    std::vector<double> d;
    for (int j = 0; j < vd.num_votes(); ++j) d.push_back(vd.distance(j, c));
    std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
    return d[d.size() / 2];
  };
  double second = std::numeric_limits<double>::infinity();
  int copies_nearer = 0;
  for (size_t c = 0; c < candidates.size(); ++c) {
    if (!is_copy[static_cast<size_t>(order[c])] && static_cast<int>(c) != t.best)
      second = std::min(second, gamma(static_cast<int>(c)));
  }
  for (size_t c = 0; c < candidates.size(); ++c) {
    copies_nearer += is_copy[static_cast<size_t>(order[c])] && gamma(static_cast<int>(c)) < second;
  }
  EXPECT_EQ(copies_nearer, 20);  // every copy is tried before N²
  EXPECT_FALSE(t.only_copies);
  EXPECT_NEAR(t.ratio, gamma(t.best) / second, 1e-12);
  EXPECT_LT(t.ratio, 0.5);
}

}  // namespace
}  // namespace tsc
