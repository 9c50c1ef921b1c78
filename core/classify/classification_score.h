#pragma once
// Scores of a place classification run (thesis section 2.5, appendix B): the ImageCLEF score
// (+1 per correct frame, −1 per wrong frame, 0 per unclassified frame), precision and recall
// over all frames and per place, the confusion matrix, and the precision-recall curve over the
// confidence threshold τ.

#include <Eigen/Core>
#include <vector>

#include "core/classify/place_classifier.h"

namespace tsc {

/// Truth of a frame whose place the classifier was not trained on: every decision on it other
/// than kUnclassified is wrong.
inline constexpr int kUnknownPlace = -1;

struct ClassificationScore {
  int frames = 0;
  int correct = 0;
  int wrong = 0;
  int unclassified = 0;
  int imageclef = 0;       ///< correct − wrong (appendix B)
  double precision = 0.0;  ///< correct / (correct + wrong); 1 when nothing was classified
  double recall = 0.0;     ///< correct / frames
  /// Rows: true place (places, then one row for kUnknownPlace frames); columns: decided place
  /// (places, then one column for kUnclassified).
  Eigen::MatrixXi confusion;
  std::vector<double> place_precision;  ///< per place: correct / decided as it (1 when none)
  std::vector<double> place_recall;     ///< per place: correct / frames of it (0 when none)
};

/// Scores decisions (place index or kUnclassified) against the truth (place index or
/// kUnknownPlace). Throws std::invalid_argument on mismatched sizes or out-of-range indices.
ClassificationScore ScoreClassification(const std::vector<int>& truth,
                                        const std::vector<int>& decided, int num_places);

/// One point of the precision-recall curve over τ.
struct TauPoint {
  double tau = 0.0;
  double precision = 0.0;
  double recall = 0.0;
  int imageclef = 0;
  int unclassified = 0;
};

/// Decides every frame at each τ of `taus` from its probabilities (rows: places, columns:
/// frames) and scores it.
std::vector<TauPoint> SweepTau(const std::vector<int>& truth, const Eigen::MatrixXd& probabilities,
                               const std::vector<double>& taus);

/// τ = 0, 0.05, ..., 1 (the thesis sweeps τ over [0, 1]).
std::vector<double> DefaultTaus();

}  // namespace tsc
