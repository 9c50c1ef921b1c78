// LabelPlacer (tools/label_placer.h): the names of places drawn close together on a map
// picture do not cover each other or any marker.

#include "tools/label_placer.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

namespace tsc {
namespace {

bool Overlap(const cv::Rect& a, const cv::Rect& b) { return (a & b).area() > 0; }

cv::Rect MarkerBox(cv::Point at, int radius) {
  return {at.x - radius, at.y - radius, 2 * radius + 1, 2 * radius + 1};
}

TEST(LabelPlacerTest, ALoneMarkerIsNamedOnItsRight) {
  LabelPlacer labels({400, 300});
  labels.AddMarker({100, 100}, 10);
  const cv::Rect box = labels.Place({60, 14}, {100, 100}, 10);
  EXPECT_GT(box.x, 110);
  EXPECT_LE(box.y, 100);
  EXPECT_GT(box.y + box.height, 100);
}

// Four places of one room drawn a few pixels apart (as on the team map of `scripts/demo`,
// where two places of room 7 sat on each other): every name is clear of every marker and of
// every other name.
TEST(LabelPlacerTest, NamesOfPlacesDrawnCloseTogetherCoverNothing) {
  LabelPlacer labels({400, 300});
  const std::vector<cv::Point> at = {{200, 150}, {204, 156}, {196, 146}, {230, 150}};
  constexpr int kRadius = 11;
  for (const cv::Point& p : at) labels.AddMarker(p, kRadius);
  std::vector<cv::Rect> boxes;
  for (const cv::Point& p : at) boxes.push_back(labels.Place({90, 14}, p, kRadius));
  for (size_t i = 0; i < boxes.size(); ++i) {
    for (size_t j = 0; j < at.size(); ++j) {
      EXPECT_FALSE(Overlap(boxes[i], MarkerBox(at[j], kRadius)))
          << "name " << i << ", marker " << j;
    }
    for (size_t j = 0; j < i; ++j) EXPECT_FALSE(Overlap(boxes[i], boxes[j])) << i << " and " << j;
    EXPECT_TRUE((boxes[i] & cv::Rect(0, 0, 400, 300)) == boxes[i]) << "name " << i << " leaves";
  }
}

// At the canvas' right edge the name goes to the marker's left rather than off the picture.
TEST(LabelPlacerTest, ANameStaysInsideThePicture) {
  LabelPlacer labels({300, 200});
  labels.AddMarker({290, 100}, 8);
  const cv::Rect box = labels.Place({80, 14}, {290, 100}, 8);
  EXPECT_LT(box.x + box.width, 282);
  EXPECT_GE(box.x, 0);
}

// With no free side the name still gets a box (on the right), and it is taken afterwards.
TEST(LabelPlacerTest, WithNoFreeSideTheNameGoesRight) {
  LabelPlacer labels({60, 40});
  labels.AddMarker({30, 20}, 18);
  const cv::Rect box = labels.Place({50, 14}, {30, 20}, 18);
  EXPECT_EQ(box.x, 30 + 18 + 3);
}

// A room's name takes the first of its places that no marker covers (DrawRoomLabels offers the
// room's centre, then places above and below it).
TEST(LabelPlacerTest, ARoomNameTakesTheFirstPlaceNoMarkerCovers) {
  LabelPlacer labels({400, 300});
  labels.AddMarker({200, 100}, 12);
  const std::vector<cv::Rect> offered = {{180, 95, 50, 20}, {180, 60, 50, 20}, {180, 130, 50, 20}};
  EXPECT_EQ(labels.PlaceFirstFree(offered), offered[1]);
  // Taken now: a name offered the same places gets the third.
  EXPECT_EQ(labels.PlaceFirstFree(offered), offered[2]);
  // None free: the first.
  EXPECT_EQ(labels.PlaceFirstFree(offered), offered[0]);
  EXPECT_THROW(labels.PlaceFirstFree({}), std::invalid_argument);
}

}  // namespace
}  // namespace tsc
