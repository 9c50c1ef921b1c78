#include "tools/scoring.h"

#include <algorithm>
#include <map>
#include <set>

namespace tsc {

std::string MajorityLabel(const GroundTruth& truth, const std::vector<int>& frames) {
  std::map<std::string, int> votes;
  for (int f : frames) {
    if (f >= 0 && f < static_cast<int>(truth.labels.size()) && !truth.labels[f].empty()) {
      ++votes[truth.labels[f]];
    }
  }
  std::string best;
  int most = 0;
  for (const auto& [label, n] : votes) {
    if (n > most) most = n, best = label;  // ties: the smallest label, deterministic
  }
  return best;
}

namespace {
// Frames of `a` that revisit some frame of `b`, at least a third of |a|.
bool RevisitsThird(const GroundTruth& truth, const std::vector<int>& a, const std::set<int>& b) {
  if (a.empty()) return false;
  int hits = 0;
  for (int f : a) {
    if (f < 0 || f >= static_cast<int>(truth.revisits.size())) continue;
    const auto& r = truth.revisits[f];
    hits += std::any_of(r.begin(), r.end(), [&b](int g) { return b.count(g) > 0; });
  }
  return 3 * hits >= static_cast<int>(a.size());
}
}  // namespace

bool FramesMatch(const GroundTruth& truth, const std::vector<int>& a, const std::vector<int>& b) {
  if (truth.has_labels()) {
    const std::string la = MajorityLabel(truth, a);
    if (!la.empty() && la == MajorityLabel(truth, b)) return true;
  }
  if (truth.has_revisits()) {
    const std::set<int> sa(a.begin(), a.end()), sb(b.begin(), b.end());
    return RevisitsThird(truth, a, sb) || RevisitsThird(truth, b, sa);
  }
  return false;
}

RecognitionScore ScoreRecognition(const GroundTruth& truth, const std::vector<Assignment>& seq) {
  RecognitionScore s;
  std::map<PlaceId, std::vector<int>> learned;  // frames assigned to each place so far
  for (const Assignment& a : seq) {
    const bool should = std::any_of(learned.begin(), learned.end(), [&](const auto& kv) {
      return FramesMatch(truth, a.frames, kv.second);
    });
    s.should_be_recognized += should;
    if (a.recognized) {
      ++s.recognitions;
      auto it = learned.find(a.place);
      if (it != learned.end() && FramesMatch(truth, a.frames, it->second)) ++s.correct;
    }
    auto& frames = learned[a.place];
    frames.insert(frames.end(), a.frames.begin(), a.frames.end());
  }
  if (s.recognitions > 0) s.precision = static_cast<double>(s.correct) / s.recognitions;
  if (s.should_be_recognized > 0) {
    s.recall = static_cast<double>(s.correct) / s.should_be_recognized;
  }
  return s;
}

}  // namespace tsc
