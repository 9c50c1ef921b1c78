#pragma once
// Scoring rules of DESIGN §7.1b, so every number means the same everywhere.

#include <optional>
#include <string>
#include <vector>

#include "core/memory/place_id.h"

namespace tsc {

/// Per-frame ground truth, frames 0-based in name order.
struct GroundTruth {
  std::vector<std::string> labels;         ///< place label per frame, "" inside transitions
  std::vector<std::vector<int>> revisits;  ///< earlier frames each frame shows again
  bool has_labels() const { return !labels.empty(); }
  bool has_revisits() const { return !revisits.empty(); }
};

/// A detected place and the learned place it was assigned to, in detection order.
struct Assignment {
  std::vector<int> frames;  ///< 0-based frames of its member base points
  PlaceId place;
  bool recognized = false;  ///< recognised (true) or learned (false)
};

/// Majority label of `frames` (ignoring unlabelled frames), or "" when none is labelled.
std::string MajorityLabel(const GroundTruth& truth, const std::vector<int>& frames);
/// Two frame sets match when their majority labels agree, or when at least a third of one
/// set's frames revisit frames of the other.
bool FramesMatch(const GroundTruth& truth, const std::vector<int>& a, const std::vector<int>& b);

struct RecognitionScore {
  int recognitions = 0;
  int correct = 0;
  int should_be_recognized = 0;
  double precision = 1.0;  ///< correct / recognitions (1 when nothing was recognised)
  double recall = 0.0;     ///< correct / should-be-recognised (0 when nothing should be)
};
/// A detected place should be recognised when it matches some place learned before it; a
/// recognition is correct when the learned place it went to (the frames assigned to that
/// place before it) matches it.
RecognitionScore ScoreRecognition(const GroundTruth& truth, const std::vector<Assignment>& seq);

}  // namespace tsc
