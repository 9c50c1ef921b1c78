#include "core/memory/unchanged_places.h"

#include <gtest/gtest.h>

#include <vector>

namespace tsc {
namespace {

LearnedPlace Place(uint32_t local, float value) {
  LearnedPlace p;
  p.id = PlaceId{1, local};
  p.mean = Eigen::VectorXf::Constant(4, value);
  p.member_count = 3;
  p.samples = CompactViews(Eigen::MatrixXf::Constant(4, 2, value));
  p.detected = {1};
  p.members = {10, 11, 12};
  return p;
}

// Every field a store keeps counts; a place that moved to another position is not unchanged
// (the row at its position holds another place).
TEST(UnchangedPositions, FlagsThePlacesHeldAsTheyWereAtTheirPosition) {
  const std::vector<LearnedPlace> before = {Place(1, 0.1f), Place(2, 0.2f), Place(3, 0.3f),
                                            Place(4, 0.4f), Place(5, 0.5f), Place(6, 0.6f)};
  std::vector<LearnedPlace> after = before;
  after[1].sources = {PlaceId{2, 7}};  // absorbed a peer's place
  after[2].members.push_back(13);
  after[3].mean(0) = 0.41f;
  after[4] = before[5];  // 5 folded away: 6 moved up
  after.pop_back();
  after.push_back(Place(7, 0.7f));  // added past the end of before
  after.push_back(Place(8, 0.8f));
  EXPECT_EQ(UnchangedPositions(before, after), (std::vector<char>{1, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(UnchangedPositions(before, before), std::vector<char>(before.size(), 1));
  LearnedPlace wider = before[0];
  wider.mean = Eigen::VectorXf::Constant(5, 0.1f);
  EXPECT_FALSE(SameStoredPlace(before[0], wider));
  LearnedPlace views = before[0];
  views.samples = CompactViews(Eigen::MatrixXf::Constant(4, 3, 0.1f));
  EXPECT_FALSE(SameStoredPlace(before[0], views));
  LearnedPlace count = before[0];
  count.member_count = 4;
  EXPECT_FALSE(SameStoredPlace(before[0], count));
  LearnedPlace detected = before[0];
  detected.detected = {2};
  EXPECT_FALSE(SameStoredPlace(before[0], detected));
}

// Fingerprints see what a merge changes of a place (its count, its sources, its id) and where
// places moved; a mean changed alone goes unseen, which a merge never does (PlaceFingerprint;
// merge_test's TscdsFormGivesUpOursOnlyWhereTheMergeChangesIt compares both on real merges).
TEST(UnchangedPositions, FingerprintsFlagWhatAMergeChanges) {
  const std::vector<LearnedPlace> before = {Place(1, 0.1f), Place(2, 0.2f), Place(3, 0.3f),
                                            Place(4, 0.4f), Place(5, 0.5f), Place(6, 0.6f)};
  std::vector<LearnedPlace> after = before;
  after[1].sources = {PlaceId{2, 7}};  // absorbed a peer's place
  after[2].member_count += 3;          // absorbed a place of its own robot
  after[3].id = PlaceId{2, 1};         // took the smallest id of its group
  after[4] = before[5];                // 5 folded away: 6 moved up
  after.pop_back();
  after.push_back(Place(7, 0.7f));
  after[0].mean(0) = 0.11f;
  EXPECT_EQ(UnchangedPositions(FingerprintsOf(before), after),
            (std::vector<char>{1, 0, 0, 0, 0, 0}));
  EXPECT_EQ(UnchangedPositions(before, after), (std::vector<char>{0, 0, 0, 0, 0, 0}));
}

}  // namespace
}  // namespace tsc
