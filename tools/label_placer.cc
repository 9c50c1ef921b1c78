#include "tools/label_placer.h"

#include <algorithm>
#include <stdexcept>

namespace tsc {

void LabelPlacer::AddMarker(cv::Point at, int radius) {
  taken_.emplace_back(at.x - radius, at.y - radius, 2 * radius + 1, 2 * radius + 1);
}

bool LabelPlacer::Free(const cv::Rect& box) const {
  if (box.x < 0 || box.y < 0 || box.x + box.width > canvas_.width ||
      box.y + box.height > canvas_.height) {
    return false;
  }
  return std::none_of(taken_.begin(), taken_.end(),
                      [&](const cv::Rect& t) { return (t & box).area() > 0; });
}

cv::Rect LabelPlacer::PlaceFirstFree(const std::vector<cv::Rect>& candidates) {
  if (candidates.empty()) throw std::invalid_argument("LabelPlacer: no place offered for a name");
  const auto free = std::find_if(candidates.begin(), candidates.end(),
                                 [this](const cv::Rect& box) { return Free(box); });
  const cv::Rect chosen = free != candidates.end() ? *free : candidates.front();
  taken_.push_back(chosen);
  return chosen;
}

cv::Rect LabelPlacer::Place(cv::Size text, cv::Point at, int radius) {
  const int gap = radius + 3;
  const int line = text.height + 2;
  const cv::Rect right(at.x + gap, at.y - text.height / 2, text.width, text.height);
  const cv::Rect left(at.x - gap - text.width, right.y, text.width, text.height);
  std::vector<cv::Rect> candidates = {
      right, left, cv::Rect(at.x - text.width / 2, at.y + gap, text.width, text.height),
      cv::Rect(at.x - text.width / 2, at.y - gap - text.height, text.width, text.height)};
  for (int k = 1; k <= 3; ++k) {
    for (const int dy : {-k * line, k * line}) {
      candidates.push_back(right + cv::Point(0, dy));
      candidates.push_back(left + cv::Point(0, dy));
    }
  }
  return PlaceFirstFree(candidates);
}

}  // namespace tsc
