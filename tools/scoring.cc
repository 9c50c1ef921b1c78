#include "tools/scoring.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <map>
#include <numbers>
#include <set>
#include <stdexcept>
#include <string>
#include <tuple>

#include "core/memory/sequence_localisation.h"
#include "drivers/dataset/planar_pose.h"

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
    hits += std::any_of(r.begin(), r.end(), [&b](int g) { return b.contains(g); });
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

bool ViewsOverlap(const GroundTruthPose& a, const GroundTruthPose& b) {
  constexpr double kNearM = 2.0;                     // DESIGN §7.1b
  constexpr double kNearRad = std::numbers::pi / 4;  // 45°
  constexpr double kSlack = 1e-9;                    // the limits themselves count as near
  return Travel(a, b) <= kNearM + kSlack && Turn(a, b) <= kNearRad + kSlack;
}

bool FramesShareView(const GroundTruth& truth, const std::vector<int>& a,
                     const std::vector<int>& b) {
  const auto pose = [&truth](int f) -> const std::optional<GroundTruthPose>* {
    if (f < 0 || f >= static_cast<int>(truth.poses.size())) return nullptr;
    return truth.poses[static_cast<size_t>(f)] ? &truth.poses[static_cast<size_t>(f)] : nullptr;
  };
  for (int fa : a) {
    const auto* pa = pose(fa);
    if (pa == nullptr) continue;
    for (int fb : b) {
      const auto* pb = pose(fb);
      if (pb != nullptr && ViewsOverlap(**pa, **pb)) return true;
    }
  }
  return false;
}

RecognitionScore ScoreRecognition(const GroundTruth& truth, const std::vector<Assignment>& seq) {
  RecognitionScore s;
  std::map<PlaceId, std::vector<int>> learned;  // frames assigned to each place so far
  for (const Assignment& a : seq) {
    if (a.place) FoldFrames(learned, *a.place, a.folded);
    bool should = false, view_should = false;
    for (const auto& [place, frames] : learned) {
      if (!FramesMatch(truth, a.frames, frames)) continue;
      should = true;
      // Only a matching place that shares a view makes it count for the view recall.
      view_should = truth.has_poses() && FramesShareView(truth, a.frames, frames);
      if (view_should || !truth.has_poses()) break;
    }
    s.should_be_recognized += should;
    s.view_should_be_recognized += view_should;
    bool correct = false;
    if (a.recognized && a.place) {
      ++s.recognitions;
      auto it = learned.find(*a.place);
      correct = it != learned.end() && FramesMatch(truth, a.frames, it->second);
      s.correct += correct;
      s.view_correct += correct && view_should;
    }
    s.verdicts.push_back({should, view_should, correct});
    if (!a.place) continue;
    auto& frames = learned[*a.place];
    frames.insert(frames.end(), a.frames.begin(), a.frames.end());
  }
  if (s.recognitions > 0) s.precision = static_cast<double>(s.correct) / s.recognitions;
  if (s.should_be_recognized > 0) {
    s.recall = static_cast<double>(s.correct) / s.should_be_recognized;
  }
  if (s.view_should_be_recognized > 0) {
    s.view_recall = static_cast<double>(s.view_correct) / s.view_should_be_recognized;
  }
  return s;
}

int SpanDistance(const FrameSpan& a, const FrameSpan& b) {
  return std::max(0, std::max(a.first, b.first) - std::min(a.last, b.last));
}

std::vector<FrameSpan> TrueBoundaries(const std::vector<std::string>& labels) {
  std::vector<FrameSpan> out;
  int previous = -1;  // last labelled frame
  for (int i = 0; i < static_cast<int>(labels.size()); ++i) {
    if (labels[i].empty()) continue;
    if (previous >= 0 && labels[i] != labels[previous]) out.push_back({previous + 1, i});
    previous = i;
  }
  return out;
}

std::vector<FrameSpan> DetectedBoundaries(const std::vector<std::vector<int>>& places) {
  std::vector<FrameSpan> out;
  for (size_t m = 1; m < places.size(); ++m) {
    if (places[m - 1].empty() || places[m].empty()) continue;
    const int closed = places[m - 1].back(), opened = places[m].front();
    out.push_back({std::min(closed, opened), std::max(closed, opened)});
  }
  return out;
}

BoundaryScore ScoreBoundaries(const std::vector<FrameSpan>& truth,
                              const std::vector<FrameSpan>& detected, int frames) {
  BoundaryScore s;
  s.true_boundaries = static_cast<int>(truth.size());
  s.detected_boundaries = static_cast<int>(detected.size());
  s.tolerance = std::max(3, static_cast<int>(std::lround(0.02 * frames)));
  struct Pair {
    int distance, t, d;
  };
  std::vector<Pair> pairs;
  for (int t = 0; t < s.true_boundaries; ++t) {
    for (int d = 0; d < s.detected_boundaries; ++d) {
      const int dist =
          SpanDistance(truth[static_cast<size_t>(t)], detected[static_cast<size_t>(d)]);
      if (dist <= s.tolerance) pairs.push_back({dist, t, d});
    }
  }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) {
    return std::tie(a.distance, a.t, a.d) < std::tie(b.distance, b.t, b.d);
  });
  std::vector<bool> t_used(truth.size(), false), d_used(detected.size(), false);
  for (const Pair& p : pairs) {
    if (t_used[static_cast<size_t>(p.t)] || d_used[static_cast<size_t>(p.d)]) continue;
    t_used[static_cast<size_t>(p.t)] = d_used[static_cast<size_t>(p.d)] = true;
    ++s.matched;
  }
  if (s.detected_boundaries > 0)
    s.precision = static_cast<double>(s.matched) / s.detected_boundaries;
  if (s.true_boundaries > 0) s.recall = static_cast<double>(s.matched) / s.true_boundaries;
  if (s.precision + s.recall > 0) s.f1 = 2 * s.precision * s.recall / (s.precision + s.recall);
  return s;
}

std::vector<std::pair<std::string, std::string>> AdjacentLabels(
    const std::vector<std::string>& labels) {
  std::set<std::pair<std::string, std::string>> pairs;
  const std::string* previous = nullptr;
  for (const std::string& l : labels) {
    if (l.empty()) continue;
    if (previous != nullptr && *previous != l)
      pairs.insert(std::pair<std::string, std::string>(std::minmax(*previous, l)));
    previous = &l;
  }
  return {pairs.begin(), pairs.end()};
}

EdgeScore ScoreMapEdges(const GroundTruth& truth,
                        const std::map<PlaceId, std::vector<int>>& frames_of,
                        const TopologicalMap& map) {
  const auto adjacent = AdjacentLabels(truth.labels);
  const auto label_of = [&](const PlaceId& p) {
    const auto it = frames_of.find(p);
    return it == frames_of.end() ? std::string() : MajorityLabel(truth, it->second);
  };
  EdgeScore s;
  for (const auto& [key, edge] : map.edges()) {
    ++s.edges;
    const std::string a = label_of(edge.a), b = label_of(edge.b);
    if (a.empty() || b.empty()) continue;
    if (a == b || std::binary_search(adjacent.begin(), adjacent.end(),
                                     std::pair<std::string, std::string>(std::minmax(a, b)))) {
      ++s.correct;
    }
  }
  if (s.edges > 0) s.precision = static_cast<double>(s.correct) / s.edges;
  return s;
}

double RecallAtFullPrecision(const std::vector<PrPoint>& curve) {
  double best = 0.0;
  for (const PrPoint& p : curve) {
    if (p.precision >= 1.0) best = std::max(best, p.recall);
  }
  return best;
}

FrameSpan VisitOf(const std::vector<std::string>& labels, int k) {
  FrameSpan visit{k, k};
  const auto& label = labels.at(static_cast<size_t>(k));
  while (visit.first > 0 && labels[static_cast<size_t>(visit.first - 1)] == label) --visit.first;
  while (visit.last + 1 < static_cast<int>(labels.size()) &&
         labels[static_cast<size_t>(visit.last) + 1] == label) {
    ++visit.last;
  }
  return visit;
}

namespace {
// The label of frame k when it has one ("" otherwise, also beyond the labels).
const std::string& LabelOf(const GroundTruth& truth, int k) {
  static const std::string kNone;
  if (k < 0 || k >= static_cast<int>(truth.labels.size())) return kNone;
  return truth.labels[static_cast<size_t>(k)];
}
}  // namespace

bool HasEarlierRevisit(const GroundTruth& truth, int k) {
  if (truth.has_revisits()) {
    return k >= 0 && k < static_cast<int>(truth.revisits.size()) &&
           !truth.revisits[static_cast<size_t>(k)].empty();
  }
  const std::string& label = LabelOf(truth, k);
  if (label.empty()) return false;
  // Every earlier frame outside k's own visit comes before the visit's first frame.
  const int first = VisitOf(truth.labels, k).first;
  for (int j = 0; j < first; ++j) {
    if (truth.labels[static_cast<size_t>(j)] == label) return true;
  }
  return false;
}

bool LoopClosureCorrect(const GroundTruth& truth, int k, int named) {
  // Ground truth marks a visit's edges only to a frame or two (a doorway, a hand-made list).
  constexpr int kToleranceFrames = 2;         // DESIGN §7.1b
  if (named < 0 || named >= k) return false;  // a loop closure names an earlier frame
  if (truth.has_revisits()) {
    if (k >= static_cast<int>(truth.revisits.size())) return false;
    const auto& earlier = truth.revisits[static_cast<size_t>(k)];
    return std::any_of(earlier.begin(), earlier.end(),
                       [named](int r) { return std::abs(r - named) <= kToleranceFrames; });
  }
  const std::string& label = LabelOf(truth, k);
  const int visit_first = label.empty() ? 0 : VisitOf(truth.labels, k).first;
  if (named >= visit_first) return false;  // never within k's own visit
  for (int j = std::max(0, named - kToleranceFrames);
       j <= std::min(named + kToleranceFrames, visit_first - 1); ++j) {
    if (LabelOf(truth, j) == label) return true;
  }
  return false;
}

namespace {
// The count of HasEarlierRevisit over frames 0..frames-1 in one pass (a long labelled
// sequence would make the per-frame rule quadratic, once per τ_r of the sweep).
int FramesWithEarlierRevisit(const GroundTruth& truth, int frames) {
  int n = 0;
  if (truth.has_revisits()) {
    for (int k = 0; k < frames; ++k) n += HasEarlierRevisit(truth, k);
    return n;
  }
  std::set<std::string> visited;  // labels of the visits that ended before frame k
  for (int k = 0; k < frames; ++k) {
    const std::string& label = LabelOf(truth, k);
    if (k > 0 && LabelOf(truth, k - 1) != label) visited.insert(LabelOf(truth, k - 1));
    n += !label.empty() && visited.contains(label);
  }
  return n;
}
}  // namespace

bool LoopClosureJudged(const GroundTruth& truth, int k) {
  if (truth.has_revisits()) return k >= 0 && k < static_cast<int>(truth.revisits.size());
  return !LabelOf(truth, k).empty();
}

LoopClosureScore ScoreLoopClosures(const GroundTruth& truth, const std::vector<LoopClosure>& found,
                                   int frames) {
  LoopClosureScore s;
  s.frames_with_revisit = FramesWithEarlierRevisit(truth, frames);
  for (const LoopClosure& c : found) {
    if (!LoopClosureJudged(truth, c.frame)) {
      ++s.not_judged;
      continue;
    }
    ++s.detections;
    s.correct += LoopClosureCorrect(truth, c.frame, c.named);
  }
  if (s.detections > 0) s.precision = static_cast<double>(s.correct) / s.detections;
  if (s.frames_with_revisit > 0) {
    s.recall = static_cast<double>(s.correct) / s.frames_with_revisit;
  }
  return s;
}

namespace {
void RequireOneDescriptorPerFrame(const std::vector<int>& frames,
                                  const Eigen::MatrixXf& descriptors) {
  if (descriptors.cols() != static_cast<Eigen::Index>(frames.size())) {
    throw std::invalid_argument("loop closures: " + std::to_string(frames.size()) + " frames but " +
                                std::to_string(descriptors.cols()) + " descriptors");
  }
}
}  // namespace

void PlaceMembersMirror::Append(Members& m, const std::vector<int>& frames,
                                const Eigen::MatrixXf& descriptors) {
  RequireOneDescriptorPerFrame(frames, descriptors);
  for (size_t j = 0; j < frames.size(); ++j) {
    m.frames.push_back(frames[j]);
    m.descriptors.emplace_back(descriptors.col(static_cast<Eigen::Index>(j)));
  }
}

void FoldFrames(std::map<PlaceId, std::vector<int>>& frames_of, const PlaceId& into,
                const std::vector<PlaceId>& folded) {
  for (const PlaceId& f : folded) {
    const auto it = frames_of.find(f);
    if (it == frames_of.end() || f == into) continue;
    std::vector<int> moved = std::move(it->second);
    frames_of.erase(it);
    std::vector<int>& frames = frames_of[into];
    frames.insert(frames.end(), moved.begin(), moved.end());
  }
}

double PlacesPerLabel(const std::vector<std::vector<PlaceId>>& groups,
                      const std::map<PlaceId, std::string>& labels) {
  int labelled = 0;
  std::set<std::string> distinct;
  for (const std::vector<PlaceId>& g : groups) {
    std::map<std::string, int> count;
    for (const PlaceId& id : g) {
      const auto it = labels.find(id);
      if (it != labels.end() && !it->second.empty()) ++count[it->second];
    }
    if (count.empty()) continue;
    const auto best =
        std::max_element(count.begin(), count.end(), [](const auto& a, const auto& b) {
          return a.second < b.second;  // the first of equal counts: the smallest label
        });
    ++labelled;
    distinct.insert(best->first);
  }
  return distinct.empty() ? 0.0
                          : static_cast<double>(labelled) / static_cast<double>(distinct.size());
}

void PlaceMembersMirror::Fold(const PlaceId& into, const PlaceId& from) {
  const auto it = places_.find(from);
  if (it == places_.end() || from == into) return;
  Members b = std::move(it->second);
  places_.erase(it);
  Members a = std::move(places_[into]);
  Members& out = places_[into];
  out = Members{};
  size_t i = 0, j = 0;  // both in frame order: merge them
  while (i < a.frames.size() || j < b.frames.size()) {
    const bool take_a = j == b.frames.size() || (i < a.frames.size() && a.frames[i] <= b.frames[j]);
    Members& src = take_a ? a : b;
    size_t& k = take_a ? i : j;
    out.frames.push_back(src.frames[k]);
    out.descriptors.push_back(std::move(src.descriptors[k]));
    ++k;
  }
}

void PlaceMembersMirror::Learn(const PlaceId& place, const std::vector<int>& frames,
                               const Eigen::MatrixXf& descriptors) {
  Append(places_[place], frames, descriptors);
}

std::vector<LoopClosure> PlaceMembersMirror::Recognise(const PlaceId& place,
                                                       const std::vector<int>& frames,
                                                       const Eigen::MatrixXf& descriptors) {
  RequireOneDescriptorPerFrame(frames, descriptors);
  std::vector<LoopClosure> out;
  const auto it = places_.find(place);
  Eigen::MatrixXf members;
  if (it != places_.end() && !it->second.descriptors.empty()) {
    const Members& m = it->second;
    members.resize(descriptors.rows(), static_cast<Eigen::Index>(m.descriptors.size()));
    for (size_t i = 0; i < m.descriptors.size(); ++i) {
      members.col(static_cast<Eigen::Index>(i)) = m.descriptors[i];
    }
  }
  const std::vector<int> shown = LocaliseAlongSequence(descriptors, members);
  for (size_t j = 0; j < frames.size(); ++j) {
    out.push_back(LoopClosure{
        frames[j], shown[j] < 0 ? -1 : it->second.frames[static_cast<size_t>(shown[j])]});
  }
  // Joins only after naming: P as it was when recognised.
  Append(places_[place], frames, descriptors);
  return out;
}

namespace {

// Merge place recall over the places that share a view with a namesake (MergeScore).
template <typename SameLabel>
void ScoreViewNamesakes(const std::vector<TeamMemoryForScoring>& robots,
                        const std::vector<PlaceId>& ids, const SameLabel& same_label,
                        const std::set<PlaceId>& merged_with_namesake, MergeScore& s) {
  std::map<PlaceId, const std::vector<GroundTruthPose>*> poses;
  for (const TeamMemoryForScoring& r : robots) {
    for (const auto& [id, p] : r.own_poses) {
      if (!p.empty()) poses[id] = &p;
    }
  }
  if (poses.empty()) return;  // no poses: the figure is undefined
  const auto share_view = [&poses](const PlaceId& a, const PlaceId& b) {
    const auto pa = poses.find(a), pb = poses.find(b);
    if (pa == poses.end() || pb == poses.end()) return false;
    for (const GroundTruthPose& x : *pa->second) {
      for (const GroundTruthPose& y : *pb->second) {
        if (ViewsOverlap(x, y)) return true;
      }
    }
    return false;
  };
  std::set<PlaceId> with_view_namesake;
  for (size_t i = 0; i < ids.size(); ++i) {
    for (size_t j = i + 1; j < ids.size(); ++j) {
      if (ids[i].robot != ids[j].robot && same_label(ids[i], ids[j]) &&
          share_view(ids[i], ids[j])) {
        with_view_namesake.insert({ids[i], ids[j]});
      }
    }
  }
  s.view_places_with_namesake = static_cast<int>(with_view_namesake.size());
  for (const PlaceId& id : with_view_namesake) {
    s.view_places_merged_with_namesake += static_cast<int>(merged_with_namesake.count(id));
  }
  if (s.view_places_with_namesake > 0) {
    s.view_place_recall =
        static_cast<double>(s.view_places_merged_with_namesake) / s.view_places_with_namesake;
  }
}

}  // namespace

MergeScore ScoreMerges(const std::vector<TeamMemoryForScoring>& robots) {
  std::map<PlaceId, std::string> label;
  for (const TeamMemoryForScoring& r : robots)
    label.insert(r.own_labels.begin(), r.own_labels.end());
  auto same_label = [&](const PlaceId& a, const PlaceId& b) {
    const auto la = label.find(a), lb = label.find(b);
    return la != label.end() && lb != label.end() && !la->second.empty() &&
           la->second == lb->second;
  };
  std::set<std::pair<PlaceId, PlaceId>> merged;
  for (const TeamMemoryForScoring& r : robots) {
    for (const std::vector<PlaceId>& g : r.groups) {
      for (size_t i = 0; i < g.size(); ++i) {
        for (size_t j = i + 1; j < g.size(); ++j) {
          if (g[i].robot != g[j].robot) merged.insert(std::minmax(g[i], g[j]));
        }
      }
    }
  }
  // Per place, as recognition recall counts it: a place with a namesake of another robot
  // should end up with one of them in its group, i.e. be one end of a correct merge.
  std::set<PlaceId> with_namesake, merged_with_namesake;
  MergeScore s;
  s.merges = static_cast<int>(merged.size());
  for (const auto& [a, b] : merged) {
    if (!same_label(a, b)) continue;
    ++s.correct;
    merged_with_namesake.insert({a, b});
  }
  std::vector<PlaceId> ids;
  ids.reserve(label.size());
  for (const auto& [id, l] : label) ids.push_back(id);
  for (size_t i = 0; i < ids.size(); ++i) {
    for (size_t j = i + 1; j < ids.size(); ++j) {
      if (ids[i].robot != ids[j].robot && same_label(ids[i], ids[j])) {
        ++s.same_label_pairs;
        with_namesake.insert({ids[i], ids[j]});
      }
    }
  }
  s.places_with_namesake = static_cast<int>(with_namesake.size());
  s.places_merged_with_namesake = static_cast<int>(merged_with_namesake.size());
  ScoreViewNamesakes(robots, ids, same_label, merged_with_namesake, s);
  for (const TeamMemoryForScoring& r : robots) {
    for (const auto& [place, l] : r.peer_recognitions) {
      ++s.peer_recognitions;
      const auto it = label.find(place);
      if (it != label.end() && !l.empty() && it->second == l) {
        ++s.peer_recognitions_correct;
      } else {
        s.wrong_peer_recognitions.push_back({place, it == label.end() ? "" : it->second, l});
      }
    }
  }
  if (s.merges > 0) s.precision = static_cast<double>(s.correct) / s.merges;
  if (s.same_label_pairs > 0) s.recall = static_cast<double>(s.correct) / s.same_label_pairs;
  if (s.places_with_namesake > 0) {
    s.place_recall = static_cast<double>(s.places_merged_with_namesake) / s.places_with_namesake;
  }
  return s;
}

}  // namespace tsc
