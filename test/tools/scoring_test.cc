#include "tools/scoring.h"

#include <gtest/gtest.h>

namespace tsc {
namespace {

TEST(Scoring, RevisitMatchNeedsAThirdOfFrames) {
  GroundTruth truth;
  truth.revisits.resize(12);
  truth.revisits[9] = {0};
  truth.revisits[10] = {1};
  EXPECT_TRUE(FramesMatch(truth, {9, 10, 11}, {0, 1, 2}));        // 2 of 3 revisit
  EXPECT_FALSE(FramesMatch(truth, {6, 7, 8}, {0, 1, 2}));         // none
  EXPECT_FALSE(FramesMatch(truth, {3, 4, 5, 6, 7, 9, 11}, {0}));  // 1 of 7 < a third
}

TEST(Scoring, LabelsMatchByMajority) {
  GroundTruth truth;
  truth.labels = {"a", "a", "b", "", "a", "b", "b"};
  EXPECT_EQ(MajorityLabel(truth, {0, 1, 2, 3}), "a");
  EXPECT_TRUE(FramesMatch(truth, {0, 1}, {4}));
  EXPECT_FALSE(FramesMatch(truth, {0, 1}, {5, 6}));
}

TEST(Scoring, PrecisionAndRecallFollowDesignRules) {
  GroundTruth truth;
  truth.labels = {"a", "a", "b", "b", "a", "a", "b", "b", "c", "c"};
  const PlaceId p1{1, 1}, p2{1, 2}, p3{1, 3};
  const std::vector<Assignment> seq = {
      {{0, 1}, p1, false},  // learn a
      {{2, 3}, p2, false},  // learn b
      {{4, 5}, p1, true},   // a recognised as a: correct
      {{6, 7}, p1, true},   // b recognised as a: wrong
      {{8, 9}, p3, false},  // c: nothing to recognise
  };
  const RecognitionScore s = ScoreRecognition(truth, seq);
  EXPECT_EQ(s.recognitions, 2);
  EXPECT_EQ(s.correct, 1);
  EXPECT_EQ(s.should_be_recognized, 2);
  EXPECT_DOUBLE_EQ(s.precision, 0.5);
  EXPECT_DOUBLE_EQ(s.recall, 0.5);
}

}  // namespace
}  // namespace tsc
