#pragma once
// Scoring rules of DESIGN §7.1b, so every number means the same everywhere.

#include <Eigen/Core>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/map/topological_map.h"
#include "core/memory/place_id.h"
#include "drivers/dataset/dataset.h"

namespace tsc {

/// Per-frame ground truth, frames 0-based in name order.
struct GroundTruth {
  std::vector<std::string> labels;         ///< place label per frame, "" inside transitions
  std::vector<std::vector<int>> revisits;  ///< earlier frames each frame shows again
  /// Camera pose per frame (metres, heading in radians), nullopt where the dataset has none.
  std::vector<std::optional<GroundTruthPose>> poses;
  bool has_labels() const { return !labels.empty(); }
  bool has_revisits() const { return !revisits.empty(); }
  bool has_poses() const { return !poses.empty(); }
};

/// A detected place and the learned place it was assigned to, in detection order.
struct Assignment {
  std::vector<int> frames;  ///< 0-based frames of its member base points
  /// The place it joined or founded; none for an ambiguous detected place (neither
  /// recognised nor learned: a miss where it should be recognised, and no place later
  /// revisits can match).
  std::optional<PlaceId> place;
  bool recognized = false;  ///< recognised (true) or learned (false)
  /// Places that went into `place` as it was recognised (consolidation): their frames count
  /// as `place`'s from this assignment on.
  std::vector<PlaceId> folded{};
};

/// Majority label of `frames` (ignoring unlabelled frames), or "" when none is labelled.
std::string MajorityLabel(const GroundTruth& truth, const std::vector<int>& frames);
/// Two frame sets match when their majority labels agree, or when at least a third of one
/// set's frames revisit frames of the other.
bool FramesMatch(const GroundTruth& truth, const std::vector<int>& a, const std::vector<int>& b);

/// Two camera poses see the same view (DESIGN §7.1b, view-overlap recall): at most 2 m apart
/// and at most 45° apart in heading, the heading difference taken around the circle.
bool ViewsOverlap(const GroundTruthPose& a, const GroundTruthPose& b);
/// Some frame of `a` and some frame of `b` have poses that overlap (ViewsOverlap). False
/// when the ground truth has no poses for them.
bool FramesShareView(const GroundTruth& truth, const std::vector<int>& a,
                     const std::vector<int>& b);

struct RecognitionScore {
  int recognitions = 0;
  int correct = 0;
  int should_be_recognized = 0;
  double precision = 1.0;  ///< correct / recognitions (1 when nothing was recognised)
  double recall = 0.0;     ///< correct / should-be-recognised (0 when nothing should be)
  /// View-overlap recall (with poses): the should-be-recognised places that share a view
  /// with a learned place they match, and the correct recognitions among them.
  int view_should_be_recognized = 0;
  int view_correct = 0;
  double view_recall = 0.0;  ///< view_correct / view_should_be_recognized (0 when none)
  /// How each assignment was judged, in the order given (why a figure is what it is).
  struct Verdict {
    bool should = false;       ///< matches a place learned before it
    bool view_should = false;  ///< and shares a view with it (with poses)
    bool correct = false;      ///< recognised as a place it matches
  };
  std::vector<Verdict> verdicts;
};
/// A detected place should be recognised when it matches some place learned before it; a
/// recognition is correct when the learned place it went to (the frames assigned to that
/// place before it) matches it. With poses, a should-be-recognised place also counts for
/// the view-overlap recall when some place it matches shares a view with it
/// (FramesShareView over the frames assigned to that place before it).
RecognitionScore ScoreRecognition(const GroundTruth& truth, const std::vector<Assignment>& seq);
/// A consolidation folded places `folded` into `into`: their frames in `frames_of` are
/// `into`'s from now on (appended; a folded place without frames is skipped).
void FoldFrames(std::map<PlaceId, std::vector<int>>& frames_of, const PlaceId& into,
                const std::vector<PlaceId>& folded);

/// Places per label (DESIGN §7.1b) of one final memory: the places whose ids (own or absorbed)
/// carry a label, divided by the distinct labels among them; a place's label is the most common
/// one of its ids' labels (ties: the smallest). 1.0 = one place per room; 0 when no place is
/// labelled. `labels` maps every robot's own places to their labels.
double PlacesPerLabel(const std::vector<std::vector<PlaceId>>& groups,
                      const std::map<PlaceId, std::string>& labels);

/// An inclusive range of 0-based frames.
struct FrameSpan {
  int first = 0;
  int last = 0;
  bool operator==(const FrameSpan&) const = default;
};
/// Frames between two spans: 0 when they overlap or touch.
int SpanDistance(const FrameSpan& a, const FrameSpan& b);

/// True boundaries (labels): between two consecutive labelled frames with different labels.
/// A transition (unlabelled frames between them) counts once: the boundary is the span from
/// the first unlabelled frame to the first frame of the new label; without unlabelled frames
/// it is that single frame. Leading and trailing unlabelled frames are no boundary, and a
/// place left and re-entered through unlabelled frames (a, "", a) has none.
std::vector<FrameSpan> TrueBoundaries(const std::vector<std::string>& labels);
/// Detected boundaries: between consecutive detected places (each a non-empty, sorted frame
/// set, in detection order), the span from the frame the earlier place closed on (its last
/// member) to the frame the next one opened on (its first member). Counted once.
std::vector<FrameSpan> DetectedBoundaries(const std::vector<std::vector<int>>& places);

struct BoundaryScore {
  int true_boundaries = 0;
  int detected_boundaries = 0;
  int matched = 0;         ///< one-to-one matched pairs
  int tolerance = 0;       ///< frames, max(3, round(2 % of frames))
  double precision = 1.0;  ///< matched / detected (1 when nothing was detected)
  double recall = 1.0;     ///< matched / true (1 when there is no true boundary)
  double f1 = 0.0;         ///< 2PR / (P + R), 0 when P + R = 0
};
/// Boundary F1 (DESIGN §7.1b). A detected boundary hits a true one when the spans are at most
/// `tolerance` frames apart (SpanDistance). Matching is one-to-one and greedy: candidate
/// pairs in increasing distance (ties: earlier true, then earlier detected boundary) are taken
/// when neither side is matched yet; so one true boundary is never counted twice.
/// `frames` is the length of the sequence (sets the tolerance).
BoundaryScore ScoreBoundaries(const std::vector<FrameSpan>& truth,
                              const std::vector<FrameSpan>& detected, int frames);

/// Unordered pairs of labels adjacent in the ground truth: consecutive distinct labels of
/// the per-frame sequence once unlabelled frames are dropped (so a -> "" -> b is adjacent).
/// Each pair is stored with first < second.
std::vector<std::pair<std::string, std::string>> AdjacentLabels(
    const std::vector<std::string>& labels);

struct EdgeScore {
  int edges = 0;
  int correct = 0;
  double precision = 1.0;  ///< correct / edges (1 for a map without edges)
};
/// Map edge precision (DESIGN §7.1b): an edge is correct when the majority labels of its two
/// places (over the frames assigned to each, `frames_of`) are equal or adjacent in the ground
/// truth (AdjacentLabels). An edge with an unlabelled or unknown place is wrong.
EdgeScore ScoreMapEdges(const GroundTruth& truth,
                        const std::map<PlaceId, std::vector<int>>& frames_of,
                        const TopologicalMap& map);

/// One point of the PR sweep.
struct PrPoint {
  double tau_r = 0.0;
  double precision = 1.0;
  double recall = 0.0;
};
/// The largest recall over the sweep whose precision is 1.0 (0 when none is).
double RecallAtFullPrecision(const std::vector<PrPoint>& curve);

/// One frame-level loop closure (DESIGN §7.1b): frame `frame` of a recognised detected place
/// names one earlier frame, `named` (-1 when the recognised place had no member the
/// evaluation knows of; such a detection is wrong).
struct LoopClosure {
  int frame = 0;
  int named = -1;
  bool operator==(const LoopClosure&) const = default;
};

/// The maximal run of consecutive frames with frame k's label that contains k (k's own
/// visit). Precondition: k is a frame of `labels`.
FrameSpan VisitOf(const std::vector<std::string>& labels, int k);
/// Whether frame k has an earlier revisit in the ground truth: with revisits.csv, a non-empty
/// list of earlier frames; with labels only, an earlier frame of k's (non-empty) label
/// outside k's own visit (VisitOf).
bool HasEarlierRevisit(const GroundTruth& truth, int k);
/// Whether naming frame `named` for frame k is a correct loop closure: `named` is before k
/// and, with revisits.csv, within ±2 frames of one of k's revisited frames; with labels only,
/// before k's own visit and within ±2 frames of a frame of k's (non-empty) label that lies
/// before k's own visit (the same tolerance: a label's edge is as uncertain as a hand-made
/// revisit list).
bool LoopClosureCorrect(const GroundTruth& truth, int k, int named);

/// Whether the ground truth says anything about frame k: with revisits.csv every frame of it
/// (an empty list says "first visit"); with labels only, a labelled frame (an unlabelled one
/// lies in a transition region, where no label tells a revisit from a first visit).
bool LoopClosureJudged(const GroundTruth& truth, int k);

struct LoopClosureScore {
  int detections = 0;  ///< on judged frames (LoopClosureJudged)
  int not_judged = 0;  ///< detections on frames the ground truth says nothing about
  int correct = 0;
  int frames_with_revisit = 0;  ///< frames of the dataset with an earlier revisit
  double precision = 1.0;       ///< correct / detections (1 when nothing was detected)
  double recall = 0.0;          ///< correct / frames_with_revisit (0 when none has one)
};
/// Frame-level loop-closure precision and recall over `frames` frames (DESIGN §7.1b): every
/// detection is one frame naming one earlier frame (LoopClosureCorrect); recall counts every
/// frame of the dataset that has an earlier revisit (HasEarlierRevisit), detected or not.
/// Detections on frames that are not judged (LoopClosureJudged) count in neither precision
/// nor recall, only in `not_judged`.
LoopClosureScore ScoreLoopClosures(const GroundTruth& truth, const std::vector<LoopClosure>& found,
                                   int frames);

/// The member base points of each learned place as the evaluation sees them grow from the
/// pipeline's events (a learned detected place founds a place, a recognised one joins it), so
/// frame-level loop closures are named without reading the place memory's internals, which
/// keep only samples of the members.
class PlaceMembersMirror {
 public:
  /// Place `place` learned from the frames `frames` (descriptor j is column j).
  void Learn(const PlaceId& place, const std::vector<int>& frames,
             const Eigen::MatrixXf& descriptors);
  /// A detected place recognised as `place`: each of its frames names the member frame of
  /// `place` it shows (LocaliseAlongSequence: its neighbourhood against the members'), over
  /// the members as they were before this recognition; then its frames join the place. A
  /// place never learned names -1.
  std::vector<LoopClosure> Recognise(const PlaceId& place, const std::vector<int>& frames,
                                     const Eigen::MatrixXf& descriptors);
  /// Place `from` went into `into` (consolidation): its members are `into`'s, in frame order.
  void Fold(const PlaceId& into, const PlaceId& from);

 private:
  struct Members {
    std::vector<int> frames;
    std::vector<Eigen::VectorXf> descriptors;
  };
  void Append(Members& m, const std::vector<int>& frames, const Eigen::MatrixXf& descriptors);
  std::map<PlaceId, Members> places_;
};

/// Merge scoring for a team (DESIGN §7.1b). Each robot's own places carry the majority label
/// of their frames; each robot's final memory groups place ids (a place and the peer places it
/// absorbed). A merge is a pair of places of different robots in one group, counted once
/// however many robots made it; it is correct when their labels agree (and are not empty).
/// recall = correct merges / pairs of places of different robots with the same label.
///
/// Beside merges, a robot's pipeline can recognise a peer's place it received (it then learns
/// no place of its own there, so no pair exists to merge): `peer_recognitions` counts those
/// detected places, correct when the peer place's label agrees with the detected place's.
struct TeamMemoryForScoring {
  std::map<PlaceId, std::string> own_labels;  ///< this robot's own places and their labels
  std::vector<std::vector<PlaceId>> groups;   ///< per place of its final memory: id + sources
  /// Detected places this robot's pipeline assigned to a peer's place: (that place, label).
  std::vector<std::pair<PlaceId, std::string>> peer_recognitions;
  /// Poses of the frames of each own place (none without poses in the ground truth).
  std::map<PlaceId, std::vector<GroundTruthPose>> own_poses;
};
struct MergeScore {
  int merges = 0;
  int correct = 0;
  int same_label_pairs = 0;
  double precision = 1.0;  ///< correct / merges (1 when nothing was merged)
  /// correct / same_label_pairs. Null (NaN) when there are none: a team whose pipelines
  /// recognised every room a teammate learned first leaves nothing to merge, which is not a
  /// recall of 0.
  double recall = std::numeric_limits<double>::quiet_NaN();
  /// Per place, like recognition recall: places that have a place of another robot with
  /// their label (a namesake), and of those, the ones merged with a namesake. A robot that
  /// learned one room as two places (two headings) makes four pairs with a peer's two, of
  /// which merging each place with its own view merges two.
  int places_with_namesake = 0;
  int places_merged_with_namesake = 0;
  /// places_merged_with_namesake / places_with_namesake; null (NaN) when no place has a
  /// namesake, as `recall`.
  double place_recall = std::numeric_limits<double>::quiet_NaN();
  /// The same counted only over places that share a view with a namesake (some frame of each
  /// within 2 m and 45°: ViewsOverlap), as view-overlap recall counts recognitions: a forward
  /// camera that crossed a room the other way saw other walls. Null (NaN) without poses, or
  /// when no place shares a view with a namesake.
  int view_places_with_namesake = 0;
  int view_places_merged_with_namesake = 0;
  double view_place_recall = std::numeric_limits<double>::quiet_NaN();
  int peer_recognitions = 0;          ///< detected places recognised as a peer's place
  int peer_recognitions_correct = 0;  ///< of those, with the peer place's label
  /// The others, in robot order: which peer place was recognised on frames of which label.
  struct WrongPeerRecognition {
    PlaceId place;
    std::string place_label;  ///< empty: the place has no label
    std::string frames_label;
  };
  std::vector<WrongPeerRecognition> wrong_peer_recognitions;
};
MergeScore ScoreMerges(const std::vector<TeamMemoryForScoring>& robots);

}  // namespace tsc
