#pragma once
// Where the names of places go on a map picture: beside their marker, on the first side where
// the name covers no marker and no name placed before, so that places drawn close together
// (a room's two places, a merged place and its neighbour) keep readable names.

#include <opencv2/core.hpp>
#include <vector>

namespace tsc {

class LabelPlacer {
 public:
  /// `canvas`: the picture's size; a name is kept inside it where a side allows.
  explicit LabelPlacer(cv::Size canvas) : canvas_(canvas) {}

  /// A marker of `radius` pixels at `at`: no name is placed over it. Give every marker before
  /// placing any name.
  void AddMarker(cv::Point at, int radius);

  /// The box a name of `text` size takes beside the marker at `at` (of `radius`): right, left,
  /// below, above, then right and left moved up or down by one to three lines. The first box
  /// inside the canvas that meets no marker and no box placed before is taken; where none is
  /// free, the box on the right. The box is then taken for the names that follow.
  cv::Rect Place(cv::Size text, cv::Point at, int radius);

  /// The first of `candidates` (boxes in order of preference) that lies inside the canvas and
  /// meets no marker and no box placed before; the first where none is free. It is then taken.
  /// Throws std::invalid_argument on an empty list.
  cv::Rect PlaceFirstFree(const std::vector<cv::Rect>& candidates);

 private:
  bool Free(const cv::Rect& box) const;

  cv::Size canvas_;
  std::vector<cv::Rect> taken_;
};

}  // namespace tsc
