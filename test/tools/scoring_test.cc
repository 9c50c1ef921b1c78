#include "tools/scoring.h"

#include <gtest/gtest.h>

#include <cmath>
#include <initializer_list>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

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
  // The same judgement place by place, in the order given (tsc eval's "decisions").
  ASSERT_EQ(s.verdicts.size(), seq.size());
  const bool should[] = {false, false, true, true, false};
  const bool correct[] = {false, false, true, false, false};
  for (size_t i = 0; i < seq.size(); ++i) {
    EXPECT_EQ(s.verdicts[i].should, should[i]) << i;
    EXPECT_EQ(s.verdicts[i].correct, correct[i]) << i;
    EXPECT_FALSE(s.verdicts[i].view_should) << i;  // no poses
  }
}

// An ambiguous detected place (no place: neither recognised nor learned) is a miss where it
// should be recognised, and founds nothing a later revisit could be recognised as.
TEST(Scoring, AnAmbiguousPlaceIsAMissAndFoundsNothing) {
  GroundTruth truth;
  truth.labels = {"a", "a", "a", "a", "b", "b", "b", "b"};
  const PlaceId p1{1, 1}, p2{1, 2};
  const std::vector<Assignment> seq = {
      {{0, 1}, p1, false},            // learn a
      {{2, 3}, std::nullopt, false},  // a again, ambiguous: missed
      {{4, 5}, std::nullopt, false},  // b, ambiguous: nothing to recognise yet
      {{6, 7}, p2, false},            // b again: learned, and nothing to recognise either
  };
  const RecognitionScore s = ScoreRecognition(truth, seq);
  EXPECT_EQ(s.recognitions, 0);
  EXPECT_EQ(s.should_be_recognized, 1);
  EXPECT_EQ(s.recall, 0.0);
  ASSERT_EQ(s.verdicts.size(), 4u);
  EXPECT_TRUE(s.verdicts[1].should);
  EXPECT_FALSE(s.verdicts[1].correct);
  EXPECT_FALSE(s.verdicts[2].should);
  EXPECT_FALSE(s.verdicts[3].should);
}

TEST(Scoring, RecognitionCorrectWrongAndMissed) {
  GroundTruth truth;
  truth.labels = {"a", "a", "b", "b", "a", "a", "b", "b"};
  const PlaceId p1{1, 1}, p2{1, 2}, p3{1, 3};
  // a learned, b learned, a recognised correctly, b missed (learned again as p3).
  const RecognitionScore correct_and_missed = ScoreRecognition(
      truth, {{{0, 1}, p1, false}, {{2, 3}, p2, false}, {{4, 5}, p1, true}, {{6, 7}, p3, false}});
  EXPECT_EQ(correct_and_missed.recognitions, 1);
  EXPECT_EQ(correct_and_missed.correct, 1);
  EXPECT_EQ(correct_and_missed.should_be_recognized, 2);
  EXPECT_DOUBLE_EQ(correct_and_missed.precision, 1.0);
  EXPECT_DOUBLE_EQ(correct_and_missed.recall, 0.5);
  // b recognised as a: a wrong recognition.
  const RecognitionScore wrong = ScoreRecognition(truth, {{{0, 1}, p1, false}, {{2, 3}, p1, true}});
  EXPECT_EQ(wrong.recognitions, 1);
  EXPECT_EQ(wrong.correct, 0);
  EXPECT_EQ(wrong.should_be_recognized, 0);
  EXPECT_DOUBLE_EQ(wrong.precision, 0.0);
}

TEST(Scoring, TrueBoundariesCountTransitionsOnce) {
  const std::vector<std::string> labels = {"", "a", "a", "", "", "b", "b", "c", "", "c", ""};
  const std::vector<FrameSpan> t = TrueBoundaries(labels);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t[0], (FrameSpan{3, 5}));  // a -> "" "" -> b: once, the transition span
  EXPECT_EQ(t[1], (FrameSpan{7, 7}));  // b -> c directly; c -> "" -> c is none
}

TEST(Scoring, DetectedBoundariesSpanClosedToOpened) {
  const std::vector<FrameSpan> d = DetectedBoundaries({{0, 1, 2}, {6, 7}, {8, 9}});
  ASSERT_EQ(d.size(), 2u);
  EXPECT_EQ(d[0], (FrameSpan{2, 6}));
  EXPECT_EQ(d[1], (FrameSpan{7, 8}));
}

TEST(Scoring, BoundaryHitWithinToleranceAndMissOutside) {
  // 100 frames: tolerance max(3, 2) = 3.
  const std::vector<FrameSpan> truth = {{20, 20}, {60, 62}};
  const BoundaryScore s = ScoreBoundaries(truth, {{23, 24}, {70, 71}}, 100);
  EXPECT_EQ(s.tolerance, 3);
  EXPECT_EQ(s.matched, 1);  // 23 is 3 from 20: hit; 70 is 8 from 62: miss
  EXPECT_DOUBLE_EQ(s.precision, 0.5);
  EXPECT_DOUBLE_EQ(s.recall, 0.5);
  EXPECT_DOUBLE_EQ(s.f1, 0.5);
  // One-to-one: two detections next to one true boundary match it once.
  const BoundaryScore twice = ScoreBoundaries({{20, 20}}, {{19, 19}, {21, 21}}, 100);
  EXPECT_EQ(twice.matched, 1);
  EXPECT_DOUBLE_EQ(twice.precision, 0.5);
  EXPECT_DOUBLE_EQ(twice.recall, 1.0);
  // 1000 frames: tolerance 20.
  EXPECT_EQ(ScoreBoundaries({{500, 500}}, {{519, 519}}, 1000).matched, 1);
  EXPECT_DOUBLE_EQ(ScoreBoundaries({{500, 500}}, {}, 1000).f1, 0.0);
}

TEST(Scoring, EdgePrecisionOnHandMadeMap) {
  GroundTruth truth;
  // Route a -> b -> c -> b: adjacent pairs {a,b} and {b,c}; a and c never touch.
  truth.labels = {"a", "a", "", "b", "b", "c", "c", "", "b", "b"};
  const auto adjacent = AdjacentLabels(truth.labels);
  ASSERT_EQ(adjacent.size(), 2u);
  EXPECT_EQ(adjacent[0], (std::pair<std::string, std::string>("a", "b")));
  EXPECT_EQ(adjacent[1], (std::pair<std::string, std::string>("b", "c")));

  const PlaceId pa{1, 1}, pb{1, 2}, pc{1, 3}, pb2{1, 4}, pu{1, 5};
  const std::map<PlaceId, std::vector<int>> frames_of = {
      {pa, {0, 1}}, {pb, {3, 4}}, {pc, {5, 6}}, {pb2, {8, 9}}, {pu, {2}}};
  TopologicalMap map;
  map.RecordTransition(pa, pb, {});   // a-b adjacent: correct
  map.RecordTransition(pb, pc, {});   // b-c adjacent: correct
  map.RecordTransition(pb, pb2, {});  // b-b same label: correct
  map.RecordTransition(pa, pc, {});   // a-c: wrong
  map.RecordTransition(pc, pu, {});   // unlabelled place: wrong
  const EdgeScore s = ScoreMapEdges(truth, frames_of, map);
  EXPECT_EQ(s.edges, 5);
  EXPECT_EQ(s.correct, 3);
  EXPECT_DOUBLE_EQ(s.precision, 0.6);
}

TEST(Scoring, RecallAtFullPrecisionIsBestRecallWithPrecisionOne) {
  EXPECT_DOUBLE_EQ(RecallAtFullPrecision({{1.0, 1.0, 0.2}, {1.2, 1.0, 0.5}, {1.4, 0.8, 0.9}}), 0.5);
  EXPECT_DOUBLE_EQ(RecallAtFullPrecision({{1.0, 0.9, 0.2}}), 0.0);
  EXPECT_DOUBLE_EQ(RecallAtFullPrecision({}), 0.0);
}

// DESIGN §7.1b's places per label: a place (its own id with the ids it absorbed) takes the
// commonest label of its ids; a room held twice raises the figure, an unlabelled place is
// left out.
TEST(Scoring, PlacesPerLabelCountsEachPlaceUnderItsCommonestLabel) {
  const PlaceId a{1, 1}, b{1, 2}, c{1, 3}, d{2, 1}, e{2, 2}, f{1, 4};
  const std::map<PlaceId, std::string> labels = {{a, "room1"}, {b, "room2"}, {c, "room1"},
                                                 {d, "room2"}, {e, "room3"}, {f, ""}};
  // room1 twice (a, c), room2 once (b absorbed d): 3 places of 2 labels.
  EXPECT_DOUBLE_EQ(PlacesPerLabel({{a}, {b, d}, {c}}, labels), 1.5);
  // One place per room.
  EXPECT_DOUBLE_EQ(PlacesPerLabel({{a}, {b, d}, {e}}, labels), 1.0);
  // A place of an unlabelled id, or of ids nobody labelled, is not counted.
  EXPECT_DOUBLE_EQ(PlacesPerLabel({{a}, {f}, {PlaceId{9, 9}}}, labels), 1.0);
  // A tie of labels goes to the smallest: {b, e} is room2, so room2 is held twice.
  EXPECT_DOUBLE_EQ(PlacesPerLabel({{b, e}, {d}, {a}}, labels), 1.5);
  EXPECT_DOUBLE_EQ(PlacesPerLabel({}, labels), 0.0);
}

}  // namespace
}  // namespace tsc

namespace tsc {
namespace {

// Two robots; robot 1 merged 2:1 into 1:1 (same room A: correct) and 2:2 into 1:2 (B vs C:
// wrong); robot 2 made the first merge too (counted once); 1:2 and 2:3 share room B but were
// never merged (a miss).
TEST(ScoreMerges, CountsEachPairOnceAndScoresAgainstLabels) {
  const PlaceId a1{1, 1}, b1{1, 2}, a2{2, 1}, c2{2, 2}, b2{2, 3};
  TeamMemoryForScoring r1{{{a1, "A"}, {b1, "B"}}, {{a1, a2}, {b1, c2}}, {}, {}};
  TeamMemoryForScoring r2{{{a2, "A"}, {c2, "C"}, {b2, "B"}}, {{a2, a1}, {c2}, {b2}}, {}, {}};
  const MergeScore dut = ScoreMerges({r1, r2});
  EXPECT_EQ(dut.merges, 2);
  EXPECT_EQ(dut.correct, 1);
  EXPECT_EQ(dut.same_label_pairs, 2);  // (1:1, 2:1) and (1:2, 2:3)
  EXPECT_DOUBLE_EQ(dut.precision, 0.5);
  EXPECT_DOUBLE_EQ(dut.recall, 0.5);
  EXPECT_EQ(dut.places_with_namesake, 4);  // 1:1, 2:1 (A); 1:2, 2:3 (B)
  EXPECT_EQ(dut.places_merged_with_namesake, 2);
  EXPECT_DOUBLE_EQ(dut.place_recall, 0.5);
  EXPECT_TRUE(std::isnan(dut.view_place_recall));  // no poses: undefined, null in the JSON
}

// One room learned twice by each robot (two headings): four pairs of different robots, and
// merging each view with the peer's same view leaves two of them apart, yet every place is
// merged with a namesake.
TEST(ScoreMerges, PlaceRecallCountsAPlaceMergedWithAnyNamesake) {
  const PlaceId a1{1, 1}, a1b{1, 2}, a2{2, 1}, a2b{2, 2};
  TeamMemoryForScoring r1{{{a1, "A"}, {a1b, "A"}}, {{a1, a2}, {a1b, a2b}}, {}, {}};
  TeamMemoryForScoring r2{{{a2, "A"}, {a2b, "A"}}, {{a1, a2}, {a1b, a2b}}, {}, {}};
  const MergeScore dut = ScoreMerges({r1, r2});
  EXPECT_EQ(dut.same_label_pairs, 4);
  EXPECT_EQ(dut.correct, 2);
  EXPECT_DOUBLE_EQ(dut.recall, 0.5);
  EXPECT_EQ(dut.places_with_namesake, 4);
  EXPECT_EQ(dut.places_merged_with_namesake, 4);
  EXPECT_DOUBLE_EQ(dut.place_recall, 1.0);
}

// Robot 2's pipeline recognised robot 1's place 1:1 (room A) twice, once in room A (correct)
// and once in room B (wrong), and an unknown place once (wrong: no label to agree with).
TEST(ScoreMerges, ScoresRecognitionsOfPeerPlacesAgainstTheirOwnersLabels) {
  const PlaceId a1{1, 1}, b2{2, 1};
  TeamMemoryForScoring r1{{{a1, "A"}}, {{a1}, {b2}}, {}, {}};
  TeamMemoryForScoring r2{{{b2, "B"}}, {{a1}, {b2}}, {{a1, "A"}, {a1, "B"}, {{3, 1}, "A"}}, {}};
  const MergeScore dut = ScoreMerges({r1, r2});
  EXPECT_EQ(dut.peer_recognitions, 3);
  EXPECT_EQ(dut.peer_recognitions_correct, 1);
  ASSERT_EQ(dut.wrong_peer_recognitions.size(), 2u);
  EXPECT_EQ(dut.wrong_peer_recognitions[0].place, a1);
  EXPECT_EQ(dut.wrong_peer_recognitions[0].place_label, "A");
  EXPECT_EQ(dut.wrong_peer_recognitions[0].frames_label, "B");
  EXPECT_EQ(dut.wrong_peer_recognitions[1].place, (PlaceId{3, 1}));
  EXPECT_EQ(dut.wrong_peer_recognitions[1].place_label, "");
  EXPECT_EQ(dut.wrong_peer_recognitions[1].frames_label, "A");
  EXPECT_EQ(dut.merges, 0);
}

// Robot 2's pipeline recognised robot 1's room A instead of learning a copy of it (as robots
// that exchange while they drive do), so no place of one robot has a namesake of another and
// nothing is left to merge: the recalls are undefined (null in the JSON), not 0, although the
// team shares its one room.
TEST(ScoreMerges, ATeamThatSharedEveryRoomByRecognitionHasNoRecallToScore) {
  const PlaceId a1{1, 1};
  TeamMemoryForScoring r1{{{a1, "A"}}, {{a1}}, {}, {}};
  TeamMemoryForScoring r2{{}, {{a1}}, {{a1, "A"}}, {}};
  r1.own_poses[a1] = {GroundTruthPose{0, 0, 0}};
  const MergeScore dut = ScoreMerges({r1, r2});
  EXPECT_EQ(dut.peer_recognitions_correct, 1);
  EXPECT_EQ(dut.merges, 0);
  EXPECT_EQ(dut.places_with_namesake, 0);
  EXPECT_TRUE(std::isnan(dut.recall));
  EXPECT_TRUE(std::isnan(dut.place_recall));
  EXPECT_TRUE(std::isnan(dut.view_place_recall));  // poses, but no namesake to share a view
  EXPECT_DOUBLE_EQ(dut.precision, 1.0);
}

TEST(ScoreMerges, UnlabelledPlacesNeverCountAsSameAndNothingMergedIsPrecise) {
  const PlaceId a1{1, 1}, a2{2, 1};
  TeamMemoryForScoring r1{{{a1, ""}}, {{a1}}, {}, {}};
  TeamMemoryForScoring r2{{{a2, ""}}, {{a2}}, {}, {}};
  const MergeScore dut = ScoreMerges({r1, r2});
  EXPECT_EQ(dut.merges, 0);
  EXPECT_EQ(dut.same_label_pairs, 0);
  EXPECT_DOUBLE_EQ(dut.precision, 1.0);
  EXPECT_TRUE(std::isnan(dut.recall));  // no pair to merge
}

// View-overlap merge recall (DESIGN §7.1b's rule for a forward camera): room A's places of
// robots 1 and 2 were seen from within 2 m and 45° and merged; room B's were seen from
// opposite headings (robot 2 crossed it the other way) and stayed apart, so they count in
// the label recall but not in the view one.
TEST(ScoreMerges, ViewPlaceRecallCountsOnlyPlacesThatShareAViewWithANamesake) {
  const PlaceId a1{1, 1}, b1{1, 2}, a2{2, 1}, b2{2, 2};
  const GroundTruthPose east{0, 0, 0}, east_near{1.5, 0.5, 0.7}, west{0.5, 0, 3.1};
  TeamMemoryForScoring r1{
      {{a1, "A"}, {b1, "B"}}, {{a1, a2}, {b1}}, {}, {{a1, {east}}, {b1, {east, east_near}}}};
  TeamMemoryForScoring r2{
      {{a2, "A"}, {b2, "B"}}, {{a1, a2}, {b2}}, {}, {{a2, {east_near}}, {b2, {west}}}};
  const MergeScore dut = ScoreMerges({r1, r2});
  EXPECT_EQ(dut.places_with_namesake, 4);
  EXPECT_DOUBLE_EQ(dut.place_recall, 0.5);
  EXPECT_EQ(dut.view_places_with_namesake, 2);  // 1:1 and 2:1
  EXPECT_EQ(dut.view_places_merged_with_namesake, 2);
  EXPECT_DOUBLE_EQ(dut.view_place_recall, 1.0);
  // Robot 2 seeing room B the same way as robot 1: B's places now count, unmerged.
  r2.own_poses[b2] = {GroundTruthPose{2.0, 0, -0.5}};
  const MergeScore both = ScoreMerges({r1, r2});
  EXPECT_EQ(both.view_places_with_namesake, 4);
  EXPECT_DOUBLE_EQ(both.view_place_recall, 0.5);
}

// Frame-level loop closure with revisits.csv (DESIGN §7.1b): a named frame within ±2 frames
// of a ground-truth earlier frame is correct, 3 frames off is not.
TEST(LoopClosures, RevisitsCountWithinTwoFrames) {
  GroundTruth truth;
  truth.revisits.resize(20);
  truth.revisits[12] = {2, 3};
  truth.revisits[13] = {4};
  truth.revisits[15] = {6};
  EXPECT_TRUE(LoopClosureCorrect(truth, 12, 5));    // 3 + 2
  EXPECT_TRUE(LoopClosureCorrect(truth, 12, 0));    // 2 - 2
  EXPECT_FALSE(LoopClosureCorrect(truth, 13, 7));   // 4 + 3
  EXPECT_FALSE(LoopClosureCorrect(truth, 14, 4));   // 14 revisits nothing
  EXPECT_FALSE(LoopClosureCorrect(truth, 12, -1));  // named no frame
  EXPECT_FALSE(LoopClosureCorrect(truth, 13, 13));  // not an earlier frame
  EXPECT_TRUE(HasEarlierRevisit(truth, 15));
  EXPECT_FALSE(HasEarlierRevisit(truth, 14));

  // 3 frames of 20 have a revisit; 4 detections of which 2 are correct (12->5, 15->6).
  const LoopClosureScore dut = ScoreLoopClosures(truth, {{12, 5}, {13, 7}, {14, 4}, {15, 6}}, 20);
  EXPECT_EQ(dut.frames_with_revisit, 3);
  EXPECT_EQ(dut.detections, 4);
  EXPECT_EQ(dut.not_judged, 0);  // every frame of revisits.csv is judged
  EXPECT_EQ(dut.correct, 2);
  EXPECT_DOUBLE_EQ(dut.precision, 0.5);
  EXPECT_DOUBLE_EQ(dut.recall, 2.0 / 3.0);

  const LoopClosureScore none = ScoreLoopClosures(truth, {}, 20);
  EXPECT_DOUBLE_EQ(none.precision, 1.0);
  EXPECT_DOUBLE_EQ(none.recall, 0.0);
}

// With labels only: a correct named frame lies before k's own visit (the run of consecutive
// frames with k's label around k), within ±2 frames of a frame of k's label there.
TEST(LoopClosures, LabelsOnlyNeedAFrameOutsideTheOwnVisit) {
  GroundTruth truth;
  //              0    1    2    3    4    5    6    7    8    9   10   11
  truth.labels = {"a", "a", "a", "b", "b", "b", "b", "a", "a", "", "a", "b"};
  EXPECT_EQ(VisitOf(truth.labels, 8), (FrameSpan{7, 8}));
  EXPECT_EQ(VisitOf(truth.labels, 0), (FrameSpan{0, 2}));
  EXPECT_EQ(VisitOf(truth.labels, 10), (FrameSpan{10, 10}));  // "" ends a visit
  EXPECT_FALSE(HasEarlierRevisit(truth, 2));                  // first visit of a
  EXPECT_FALSE(HasEarlierRevisit(truth, 3));                  // first visit of b
  EXPECT_TRUE(HasEarlierRevisit(truth, 7));
  EXPECT_FALSE(HasEarlierRevisit(truth, 9));  // unlabelled
  EXPECT_TRUE(HasEarlierRevisit(truth, 11));

  EXPECT_TRUE(LoopClosureCorrect(truth, 8, 1));    // a, first visit
  EXPECT_FALSE(LoopClosureCorrect(truth, 8, 7));   // a, but its own visit
  EXPECT_TRUE(LoopClosureCorrect(truth, 8, 4));    // b, 2 frames from a's first visit
  EXPECT_FALSE(LoopClosureCorrect(truth, 8, 5));   // b, 3 frames from it
  EXPECT_TRUE(LoopClosureCorrect(truth, 10, 8));   // a, the visit before the doorway
  EXPECT_TRUE(LoopClosureCorrect(truth, 10, 9));   // the doorway, next to that visit
  EXPECT_FALSE(LoopClosureCorrect(truth, 9, 3));   // unlabelled frames revisit nothing
  EXPECT_TRUE(LoopClosureCorrect(truth, 11, 3));   // b
  EXPECT_FALSE(LoopClosureCorrect(truth, 11, 0));  // a, 3 frames from b
  EXPECT_FALSE(LoopClosureCorrect(truth, 7, 8));   // not an earlier frame

  // Revisits: 7, 8, 10 (a) and 11 (b) = 4 frames. Detections 8->1 and 8->4 ok, 7->8 and
  // 11->0 wrong; 9 is unlabelled: not judged, in neither precision nor recall.
  EXPECT_FALSE(LoopClosureJudged(truth, 9));
  EXPECT_TRUE(LoopClosureJudged(truth, 2));
  const LoopClosureScore dut =
      ScoreLoopClosures(truth, {{8, 1}, {7, 8}, {9, 3}, {11, 0}, {8, 4}}, 12);
  EXPECT_EQ(dut.frames_with_revisit, 4);
  EXPECT_EQ(dut.detections, 4);
  EXPECT_EQ(dut.not_judged, 1);
  EXPECT_EQ(dut.correct, 2);
  EXPECT_DOUBLE_EQ(dut.precision, 0.5);
  EXPECT_DOUBLE_EQ(dut.recall, 0.5);
}

// The recall denominator counts in one pass what HasEarlierRevisit says frame by frame.
TEST(LoopClosures, DenominatorAgreesWithTheRuleFrameByFrame) {
  GroundTruth truth;
  truth.labels = {"a", "", "a", "a", "b", "", "", "b", "c", "a", "", "c", "b", "b"};
  int expected = 0;
  for (int k = 0; k < 14; ++k) expected += HasEarlierRevisit(truth, k);
  EXPECT_EQ(expected, 7);  // 2, 3 (a after a doorway), 7, 9, 11, 12, 13
  EXPECT_EQ(ScoreLoopClosures(truth, {}, 14).frames_with_revisit, expected);
}

// revisits.csv wins over labels when a dataset has both.
TEST(LoopClosures, RevisitsTakePrecedenceOverLabels) {
  GroundTruth truth;
  truth.labels = {"a", "b", "a"};
  truth.revisits = {{}, {}, {}};
  EXPECT_FALSE(HasEarlierRevisit(truth, 2));
  EXPECT_FALSE(LoopClosureCorrect(truth, 2, 0));
}

Eigen::MatrixXf Columns(std::initializer_list<std::pair<float, float>> points) {
  Eigen::MatrixXf m(2, static_cast<Eigen::Index>(points.size()));
  Eigen::Index j = 0;
  for (const auto& [x, y] : points) m.col(j++) << x, y;
  return m;
}

// Each frame of a recognised place names the member frame of the place it shows (along the
// sequence: core/memory/sequence_localisation), over the place as it was when recognised; the
// recognised frames join it afterwards. Descriptors are amplitudes (positive): A, B, C, D
// below are distinct directions.
TEST(PlaceMembersMirror, NamesTheMemberItShowsAsThePlaceWasWhenRecognised) {
  const PlaceId p{1, 1}, q{1, 2};
  const std::pair<float, float> a{1.0f, 0.1f}, b{0.6f, 0.6f}, c{0.1f, 1.0f}, d{0.3f, 0.9f};
  PlaceMembersMirror dut;
  dut.Learn(p, {0, 1, 2}, Columns({a, b, c}));
  dut.Learn(q, {3}, Columns({d}));
  // The stretch seen again names its frames; d is q's view, but only p's members compete.
  EXPECT_EQ(dut.Recognise(p, {10, 11, 12}, Columns({a, b, d})),
            (std::vector<LoopClosure>{{10, 0}, {11, 1}, {12, 2}}));
  // Now 10, 11, 12 are members of p; 20 and 21 show 12's view: both name 12 (20 was not yet a
  // member when p was recognised, so 21 cannot name it).
  EXPECT_EQ(dut.Recognise(p, {20, 21}, Columns({d, d})),
            (std::vector<LoopClosure>{{20, 12}, {21, 12}}));
  // A place the mirror never saw learned names no frame.
  EXPECT_EQ(dut.Recognise({1, 9}, {30}, Columns({a})), (std::vector<LoopClosure>{{30, -1}}));
  EXPECT_THROW(dut.Recognise(p, {40, 41}, Columns({a})), std::invalid_argument);
}

TEST(ViewOverlap, TwoMetresAndFortyFiveDegreesAroundTheCircle) {
  constexpr double kPi = 3.14159265358979323846;
  const GroundTruthPose origin{0, 0, 0};
  EXPECT_TRUE(ViewsOverlap(origin, {2.0, 0, 0}));
  EXPECT_TRUE(ViewsOverlap(origin, {1.2, 1.6, 0}));  // 2 m diagonally
  EXPECT_FALSE(ViewsOverlap(origin, {2.05, 0, 0}));
  EXPECT_TRUE(ViewsOverlap(origin, {0, 0, kPi / 4}));
  EXPECT_FALSE(ViewsOverlap(origin, {0, 0, kPi / 4 + 0.02}));
  EXPECT_FALSE(ViewsOverlap(origin, {0, 0, kPi}));                // entered from the other side
  EXPECT_TRUE(ViewsOverlap({0, 0, 2 * kPi - 0.3}, {0, 0, 0.3}));  // 34° across 0
  EXPECT_TRUE(ViewsOverlap({0, 0, -3.0}, {0, 0, 3.0}));           // 16° across ±π
  EXPECT_TRUE(ViewsOverlap({0, 0, 7 * kPi}, {0, 0, -kPi}));       // same heading, other turns
  EXPECT_FALSE(ViewsOverlap({0, 0, 3 * kPi / 2}, {0, 0, 0}));     // 90°
}

// Room a is revisited from the other side (no shared view), room b along the same path.
TEST(ViewOverlap, RecallCountsOnlyPlacesThatShareAViewWithTheirMatch) {
  constexpr double kPi = 3.14159265358979323846;
  GroundTruth truth;
  truth.labels = {"a", "a", "b", "b", "a", "a", "b", "b"};
  truth.poses = {GroundTruthPose{0, 0, 0},     GroundTruthPose{1, 0, 0},
                 GroundTruthPose{5, 0, 0},     GroundTruthPose{6, 0, 0},
                 GroundTruthPose{1, 0, kPi},   GroundTruthPose{0, 0, kPi},
                 GroundTruthPose{5.5, 1, 0.5}, std::nullopt};
  EXPECT_FALSE(FramesShareView(truth, {4, 5}, {0, 1}));
  EXPECT_TRUE(FramesShareView(truth, {6, 7}, {2, 3}));
  EXPECT_FALSE(FramesShareView(truth, {7}, {2, 3}));  // no pose
  const PlaceId p1{1, 1}, p2{1, 2}, p3{1, 3};
  // a recognised (correct, but no shared view); b missed although it shares a view.
  const RecognitionScore missed = ScoreRecognition(
      truth, {{{0, 1}, p1, false}, {{2, 3}, p2, false}, {{4, 5}, p1, true}, {{6, 7}, p3, false}});
  EXPECT_EQ(missed.should_be_recognized, 2);
  EXPECT_EQ(missed.correct, 1);
  EXPECT_DOUBLE_EQ(missed.recall, 0.5);
  EXPECT_EQ(missed.view_should_be_recognized, 1);
  EXPECT_EQ(missed.view_correct, 0);
  EXPECT_DOUBLE_EQ(missed.view_recall, 0.0);
  // Both recognised: the view recall counts b alone.
  const RecognitionScore both = ScoreRecognition(
      truth, {{{0, 1}, p1, false}, {{2, 3}, p2, false}, {{4, 5}, p1, true}, {{6, 7}, p2, true}});
  EXPECT_EQ(both.view_should_be_recognized, 1);
  EXPECT_EQ(both.view_correct, 1);
  EXPECT_DOUBLE_EQ(both.view_recall, 1.0);
  // Without poses nothing counts for the view recall.
  truth.poses.clear();
  EXPECT_EQ(
      ScoreRecognition(truth, {{{0, 1}, p1, false}, {{4, 5}, p1, true}}).view_should_be_recognized,
      0);
}

}  // namespace
}  // namespace tsc
