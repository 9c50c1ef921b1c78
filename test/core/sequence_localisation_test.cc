#include "core/memory/sequence_localisation.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

namespace tsc {
namespace {

// A corridor of `n` views whose descriptors repeat every `period` (doors alike), with a small
// drift that makes each view unique only in context; columns are positive, like amplitudes.
Eigen::MatrixXf Corridor(int n, int period, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.5f, 1.5f);
  Eigen::MatrixXf pattern(16, period);
  for (int i = 0; i < pattern.size(); ++i) pattern.data()[i] = u(rng);
  Eigen::MatrixXf out(16, n);
  for (int c = 0; c < n; ++c)
    out.col(c) = pattern.col(c % period) * (1.0f + 0.01f * static_cast<float>(c));
  return out;
}

TEST(LocaliseAlongSequence, NamesTheMemberItsNeighbourhoodMatchesInEitherDirection) {
  const Eigen::MatrixXf members = Corridor(30, 30, 1);
  // Revisit of members 10..19 with noise: each frame alone may be nearest to another member.
  std::mt19937 rng(2);
  std::normal_distribution<float> noise(0.0f, 0.25f);
  Eigen::MatrixXf again = members.middleCols(10, 10);
  for (int i = 0; i < again.size(); ++i) again.data()[i] *= 1.0f + noise(rng);
  const std::vector<int> shown = LocaliseAlongSequence(again, members);
  int right = 0;
  for (int j = 0; j < 10; ++j) right += std::abs(shown[static_cast<size_t>(j)] - (10 + j)) <= 1;
  EXPECT_GE(right, 8);
  // The same stretch driven the other way.
  const Eigen::MatrixXf reversed = again.rowwise().reverse();
  const std::vector<int> back = LocaliseAlongSequence(reversed, members);
  int right_back = 0;
  for (int j = 0; j < 10; ++j) right_back += std::abs(back[static_cast<size_t>(j)] - (19 - j)) <= 1;
  EXPECT_GE(right_back, 8);
  // A window of 0 is the nearest descriptor: it does worse on the noisy revisit.
  const std::vector<int> single = LocaliseAlongSequence(again, members, 0);
  int right_single = 0;
  for (int j = 0; j < 10; ++j)
    right_single += std::abs(single[static_cast<size_t>(j)] - (10 + j)) <= 1;
  EXPECT_LT(right_single, right);
}

TEST(LocaliseAlongSequence, ExactCopiesAreNamedAndNoMembersNameNothing) {
  const Eigen::MatrixXf members = Corridor(12, 12, 3);
  const std::vector<int> shown = LocaliseAlongSequence(members, members);
  for (int j = 0; j < 12; ++j) EXPECT_EQ(shown[static_cast<size_t>(j)], j);
  EXPECT_EQ(LocaliseAlongSequence(members, Eigen::MatrixXf(16, 0)), std::vector<int>(12, -1));
  EXPECT_THROW(LocaliseAlongSequence(members, Eigen::MatrixXf(8, 3)), std::invalid_argument);
  EXPECT_THROW(LocaliseAlongSequence(members, members, -1), std::invalid_argument);
}

}  // namespace
}  // namespace tsc
