#include "core/detect/place_detector.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

namespace tsc {
namespace {

struct Outcome {
  std::vector<PlaceClosed> closed;
  std::vector<PlaceOpened> opened;
  std::vector<PlacePruned> pruned;
  std::vector<WindowClosed> windows;
};

// Runs a good/bad pattern ('g' good, 'b' bad) through the detector, 0-based indices.
Outcome RunPattern(const std::string& pattern, DetectorOptions options) {
  PlaceDetector dut(options);
  Outcome o;
  auto collect = [&o](const std::vector<DetectionEvent>& events) {
    for (const auto& e : events) {
      if (auto* c = std::get_if<PlaceClosed>(&e)) o.closed.push_back(*c);
      if (auto* p = std::get_if<PlaceOpened>(&e)) o.opened.push_back(*p);
      if (auto* p = std::get_if<PlacePruned>(&e)) o.pruned.push_back(*p);
      if (auto* w = std::get_if<WindowClosed>(&e)) o.windows.push_back(*w);
    }
  };
  for (size_t k = 0; k < pattern.size(); ++k) {
    collect(dut.Add(static_cast<BaseIndex>(k), pattern[k] == 'g'));
  }
  collect(dut.Finish());
  return o;
}

TEST(PlaceDetector, ReproducesFigure3_2) {
  // Figure 3.2 (1-based): Q*(1)={1,2,3}, T*(1)={4,5,6}, Q*(7)={7,8,9}, T*(7)={10},
  // Q*(11)={11,12,13}, T*(11)={14,15,16}; τ_n = τ_w = τ_p = 2.
  const Outcome o = RunPattern("gggbbbgggbgggbbb", DetectorOptions{2, 2, 2});
  ASSERT_EQ(o.closed.size(), 2u);
  EXPECT_EQ(o.closed[0].place, 1);
  EXPECT_EQ(o.closed[0].members, (std::vector<BaseIndex>{0, 1, 2}));  // D1 = {1,2,3}
  EXPECT_EQ(o.closed[1].place, 2);
  // D2 = Q*(7) ∪ Q*(11) = {7,8,9,11,12,13}
  EXPECT_EQ(o.closed[1].members, (std::vector<BaseIndex>{6, 7, 8, 10, 11, 12}));
  EXPECT_TRUE(o.pruned.empty());
  ASSERT_EQ(o.windows.size(), 3u);
  EXPECT_TRUE(o.windows[0].transition);
  EXPECT_FALSE(o.windows[1].transition);  // T*(7) is noise inside D2
  EXPECT_TRUE(o.windows[2].transition);
  EXPECT_EQ(o.closed[1].transition_before, (TransitionRegion{3, 5}));
  EXPECT_TRUE(o.closed[0].transition_before.empty());
}

TEST(PlaceDetector, OpensPlaceWhenExtentPassesTauP) {
  const Outcome o = RunPattern("ggggg", DetectorOptions{2, 2, 3});
  ASSERT_EQ(o.opened.size(), 1u);
  EXPECT_EQ(o.opened[0].members, (std::vector<BaseIndex>{0, 1, 2, 3}));
  ASSERT_EQ(o.closed.size(), 1u);
  EXPECT_EQ(o.closed[0].members.size(), 5u);
}

TEST(PlaceDetector, PrunesPlaceWithExtentAtMostTauP) {
  const Outcome o = RunPattern("ggbbbgggggg", DetectorOptions{2, 2, 2});
  ASSERT_EQ(o.pruned.size(), 1u);
  EXPECT_EQ(o.pruned[0].members, (std::vector<BaseIndex>{0, 1}));
  ASSERT_EQ(o.closed.size(), 1u);
  EXPECT_EQ(o.closed[0].place, 1);  // pruned places take no index
  EXPECT_EQ(o.closed[0].members.front(), 5);
}

// τ_p as a length (DESIGN §3.2 amended): 3.75 m is 25 base points of the simulated camera's
// 0.15 m step and 3 of keyframes a metre apart; an explicit τ_p wins.
TEST(PlaceDetector, TauPFollowsTheBasePointSpacing) {
  DetectorOptions options;
  EXPECT_EQ(options.EffectiveTauP(), 25);
  options.spacing_m = 1.0;
  EXPECT_EQ(options.EffectiveTauP(), 3);
  EXPECT_EQ(RunPattern("ggg", options).pruned.size(), 1u);   // 3 m: pruned
  EXPECT_EQ(RunPattern("gggg", options).closed.size(), 1u);  // 4 m: a place
  options.tau_p = 7;
  EXPECT_EQ(options.EffectiveTauP(), 7);
  options.tau_p = -2;
  EXPECT_THROW(options.Validate(), std::invalid_argument);
  options.tau_p = -1;
  options.spacing_m = 0.0;
  EXPECT_THROW(options.Validate(), std::invalid_argument);
}

// Base points found to lie at another spacing (tscd's odometry): the detector counts τ_p and
// τ_w anew from the next base point on, and a place already open stays open.
TEST(PlaceDetector, ReadaptsToAnotherSpacingMidStream) {
  DetectorOptions sparse;  // assumed 0.3 m apart: τ_p 12, τ_w 1
  sparse.spacing_m = 0.3;
  sparse.tau_w = 1;
  PlaceDetector dut(sparse);
  BaseIndex k = 0;
  for (; k < 10; ++k) EXPECT_TRUE(dut.Add(k, true).empty());
  DetectorOptions measured = sparse;  // 0.1 m apart: τ_p 37, τ_w 2
  measured.spacing_m = 0.1;
  measured.tau_w = 2;
  dut.Readapt(measured);
  EXPECT_EQ(dut.options().EffectiveTauP(), 37);
  for (; k < 37; ++k) EXPECT_TRUE(dut.Add(k, true).empty()) << "no place at " << k + 1;
  const std::vector<DetectionEvent> opened = dut.Add(k++, true);  // the 38th: 3.8 m
  ASSERT_EQ(opened.size(), 1u);
  EXPECT_TRUE(std::holds_alternative<PlaceOpened>(opened[0]));
  // One bad point is noise under τ_w 2 (it was a transition under 1).
  EXPECT_TRUE(dut.Add(k++, false).empty());
  for (int i = 0; i < 2; ++i) dut.Add(k++, true);
  EXPECT_TRUE(dut.place_open());
  // Back to 0.3 m: the open place stays open though it is now longer than τ_p anyway, and a
  // single bad point now closes it.
  dut.Readapt(sparse);
  EXPECT_TRUE(dut.place_open());
  dut.Add(k++, false);
  int closed = 0;
  for (int i = 0; i < 2; ++i) {
    for (const DetectionEvent& e : dut.Add(k++, true))
      closed += std::holds_alternative<PlaceClosed>(e);
  }
  EXPECT_EQ(closed, 1);
  DetectorOptions invalid = sparse;
  invalid.spacing_m = 0.0;
  EXPECT_THROW(dut.Readapt(invalid), std::invalid_argument);
  EXPECT_EQ(dut.options().spacing_m, 0.3);
}

TEST(PlaceDetector, AbsorbsGoodPointsBetweenBadPointsWithinTauN) {
  // Bad, good, good, bad: with τ_n = 3 the two good points belong to the window, which then
  // spans 4 points and is a transition (τ_w = 4).
  const Outcome o = RunPattern("ggggbggbgggggg", DetectorOptions{3, 4, 2});
  ASSERT_EQ(o.windows.size(), 1u);
  EXPECT_EQ(o.windows[0].first, 4);
  EXPECT_EQ(o.windows[0].last, 7);
  EXPECT_TRUE(o.windows[0].transition);
  ASSERT_EQ(o.closed.size(), 2u);
  EXPECT_EQ(o.closed[1].members.front(), 8);
  EXPECT_EQ(o.closed[1].transition_before, (TransitionRegion{4, 7}));
}

TEST(PlaceDetector, ShortWindowIsNoiseInsidePlace) {
  const Outcome o = RunPattern("gggggbgggg", DetectorOptions{2, 2, 2});
  ASSERT_EQ(o.closed.size(), 1u);
  EXPECT_EQ(o.closed[0].members.size(), 9u);
}

TEST(PlaceDetector, SplitsTheOpenPlaceBeforeAMember) {
  DetectorOptions options{2, 2, 3};
  PlaceDetector dut(options);
  for (BaseIndex k = 0; k < 10; ++k) dut.Add(k, true);
  ASSERT_TRUE(dut.place_open());
  const std::vector<DetectionEvent> events = dut.SplitBefore(6);
  ASSERT_EQ(events.size(), 2u);
  const auto* head = std::get_if<PlaceClosed>(&events[0]);
  ASSERT_NE(head, nullptr);
  EXPECT_EQ(head->members, (std::vector<BaseIndex>{0, 1, 2, 3, 4, 5}));
  const auto* tail = std::get_if<PlaceOpened>(&events[1]);
  ASSERT_NE(tail, nullptr);
  EXPECT_EQ(tail->place, head->place + 1);
  EXPECT_EQ(tail->members, (std::vector<BaseIndex>{6, 7, 8, 9}));
  // The tail continues as the open place and closes with no base point between the two.
  const std::vector<DetectionEvent> end = dut.Finish();
  ASSERT_EQ(end.size(), 1u);
  const auto& closed = std::get<PlaceClosed>(end[0]);
  EXPECT_EQ(closed.members.front(), 6);
  EXPECT_TRUE(closed.transition_before.empty());
}

TEST(PlaceDetector, SplitLeavesAHeadOfTauPOrFewerToD0AndRefusesWithoutAnOpenPlace) {
  PlaceDetector dut(DetectorOptions{2, 2, 3});
  EXPECT_THROW(dut.SplitBefore(0), std::logic_error);
  for (BaseIndex k = 0; k < 8; ++k) dut.Add(k, true);
  EXPECT_THROW(dut.SplitBefore(0), std::logic_error);  // nothing before the first member
  EXPECT_THROW(dut.SplitBefore(8), std::logic_error);  // not a member
  const std::vector<DetectionEvent> events = dut.SplitBefore(3);
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(std::get<PlacePruned>(events[0]).members, (std::vector<BaseIndex>{0, 1, 2}));
  // The tail opens once it passes τ_p, and keeps the rest of the members.
  EXPECT_EQ(std::get<PlaceOpened>(events[1]).members, (std::vector<BaseIndex>{3, 4, 5, 6}));
  EXPECT_EQ(dut.current_members(), (std::vector<BaseIndex>{3, 4, 5, 6, 7}));
}

TEST(PlaceDetector, RejectsOutOfOrderBasePoints) {
  PlaceDetector dut(DetectorOptions{});
  dut.Add(0, true);
  EXPECT_THROW(dut.Add(2, true), std::invalid_argument);
}

TEST(PlaceDetector, ContinuesIndicesAfterRestart) {
  PlaceDetector dut(DetectorOptions{1, 1, 0}, /*next_place=*/7, /*first_base=*/100);
  dut.Add(100, true);
  const auto events = dut.Finish();
  ASSERT_FALSE(events.empty());
  const auto* closed = std::get_if<PlaceClosed>(&events.back());
  ASSERT_NE(closed, nullptr);
  EXPECT_EQ(closed->place, 7);
  EXPECT_EQ(dut.next_place(), 8);
}

TEST(DetectorOptions, ValidateNamesBadKey) {
  DetectorOptions o;
  o.tau_n = 0;
  try {
    o.Validate();
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("tau_n"), std::string::npos);
  }
}

}  // namespace
}  // namespace tsc
