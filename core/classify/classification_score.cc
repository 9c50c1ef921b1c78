#include "core/classify/classification_score.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace tsc {

ClassificationScore ScoreClassification(const std::vector<int>& truth,
                                        const std::vector<int>& decided, int num_places) {
  if (truth.size() != decided.size()) {
    throw std::invalid_argument("scoring " + std::to_string(decided.size()) +
                                " decisions against " + std::to_string(truth.size()) + " truths");
  }
  if (num_places < 1) throw std::invalid_argument("scoring needs at least one place");
  ClassificationScore s;
  s.frames = static_cast<int>(truth.size());
  s.confusion = Eigen::MatrixXi::Zero(num_places + 1, num_places + 1);
  for (size_t i = 0; i < truth.size(); ++i) {
    const int t = truth[i], d = decided[i];
    if (t < kUnknownPlace || t >= num_places) {
      throw std::invalid_argument("frame " + std::to_string(i) + ": true place " +
                                  std::to_string(t) + " out of range");
    }
    if (d < kUnclassified || d >= num_places) {
      throw std::invalid_argument("frame " + std::to_string(i) + ": decided place " +
                                  std::to_string(d) + " out of range");
    }
    const int row = t == kUnknownPlace ? num_places : t;
    const int col = d == kUnclassified ? num_places : d;
    ++s.confusion(row, col);
    if (d == kUnclassified) {
      ++s.unclassified;
    } else if (d == t) {
      ++s.correct;
    } else {
      ++s.wrong;
    }
  }
  s.imageclef = s.correct - s.wrong;
  s.precision =
      s.correct + s.wrong > 0 ? static_cast<double>(s.correct) / (s.correct + s.wrong) : 1.0;
  s.recall = s.frames > 0 ? static_cast<double>(s.correct) / s.frames : 0.0;
  for (int p = 0; p < num_places; ++p) {
    const int hits = s.confusion(p, p);
    const int as_p = s.confusion.col(p).sum();
    const int of_p = s.confusion.row(p).sum();
    s.place_precision.push_back(as_p > 0 ? static_cast<double>(hits) / as_p : 1.0);
    s.place_recall.push_back(of_p > 0 ? static_cast<double>(hits) / of_p : 0.0);
  }
  return s;
}

std::vector<TauPoint> SweepTau(const std::vector<int>& truth, const Eigen::MatrixXd& probabilities,
                               const std::vector<double>& taus) {
  if (static_cast<Eigen::Index>(truth.size()) != probabilities.cols()) {
    throw std::invalid_argument("tau sweep: " + std::to_string(probabilities.cols()) +
                                " frames of probabilities, " + std::to_string(truth.size()) +
                                " truths");
  }
  const int places = static_cast<int>(probabilities.rows());
  std::vector<TauPoint> out;
  std::vector<int> decided(truth.size());
  for (double tau : taus) {
    for (size_t i = 0; i < truth.size(); ++i) {
      decided[i] = Decide(probabilities.col(static_cast<Eigen::Index>(i)), tau);
    }
    const ClassificationScore s = ScoreClassification(truth, decided, places);
    out.push_back({tau, s.precision, s.recall, s.imageclef, s.unclassified});
  }
  return out;
}

std::vector<double> DefaultTaus() {
  std::vector<double> taus;
  for (int i = 0; i <= 20; ++i) taus.push_back(std::round(i * 5.0) / 100.0);
  return taus;
}

}  // namespace tsc
