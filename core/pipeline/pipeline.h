#pragma once
// The TSC loop (figure 3.1, appendix D.2): frame → bubble descriptor → reliability → place
// detection → recognition or learning → mapping. Pure computation: the caller persists the
// FrameResult (one transaction per result) and publishes its events.

#include <deque>
#include <functional>
#include <optional>
#include <span>
#include <utility>
#include <vector>

#include "core/bubble/descriptor.h"
#include "core/bubble/surface.h"
#include "core/detect/place_detector.h"
#include "core/detect/reliability.h"
#include "core/map/topological_map.h"
#include "core/memory/place_memory.h"
#include "core/pipeline/copy_evidence.h"
#include "core/range.h"

namespace tsc {

/// kAmbiguous: a closed detected place left without a place: g_N would recognise it but its
/// points name other places (memory.min_agreement; when memory.learn_disagreed is false), or
/// g_N nearly did with half of its points voting for N¹ (memory.near_miss_margin).
enum class EventKind { kDetected, kRecognized, kLearned, kMapped, kPruned, kAmbiguous };
const char* EventKindName(EventKind k);

/// One pipeline event; the fields that do not apply keep their defaults.
struct PlaceEvent {
  EventKind kind = EventKind::kDetected;
  BaseIndex frame = 0;  ///< base point at which it happened
  DetectedPlaceIndex detected_place = 0;
  std::optional<PlaceId> place;  ///< recognised / learned / mapped-to place
  std::optional<PlaceId> from;   ///< mapped: the previous place β(D_{m−1})
  /// recognised: g_N of the final decision; learned, ambiguous: the last g_N tried
  double cost = 0.0;
  CostTerms terms;       ///< recognised, learned, ambiguous: the terms of `cost` (why)
  bool partial = false;  ///< recognised on an opened, not yet closed place
  bool hybrid = false;   ///< recognised by the hybrid traversal
  /// Recognised with some g_N above τ_r, towards a map neighbour of the previous place.
  bool neighbour = false;
  /// Ambiguous: g_N failed τ_r narrowly with half of D's points voting for N¹ (a near miss),
  /// not a place whose points name other places.
  bool near_miss = false;
  TransitionRegion transition;  ///< mapped: the region crossed
  int64_t members = 0;          ///< detected / pruned: number of base points
  /// Recognised: the ids of places folded into `place` as it was recognised (they left the
  /// memory; `place` is the id holding them now). Empty without consolidation.
  std::vector<PlaceId> folded;
};

struct BasePointRecord {
  BaseIndex index = 0;
  BaseStatus status = BaseStatus::kGood;
  Eigen::VectorXf descriptor;
  IntensityStats intensity;
};

/// Everything one base point changed.
struct FrameResult {
  BasePointRecord base;  ///< absent for Finish()
  bool has_base = true;
  std::vector<PlaceEvent> events;
  std::vector<DetectedPlace> closed_places;   ///< detected places closed now (with descriptors)
  std::vector<TransitionRegion> transitions;  ///< transition regions closed now
  std::vector<int> changed_places;            ///< place indices learned or updated
  bool memory_changed = false;                ///< tree / discriminants changed
  /// Places left the memory and indices moved (a consolidation): the whole memory and map
  /// replace what was stored of them, as after a merge; changed_places no longer apply.
  bool memory_replaced = false;
  /// The evidence that two places are copies of one room changed (PipelineState::copies).
  bool copies_changed = false;
};

/// What the pipeline needs of one base point: its descriptor and its intensity statistics,
/// and, for a base point observed by a pan sweep, the descriptor of the sweep's first view
/// alone, on which coherence is judged (empty: the descriptor itself; docs/decisions.md,
/// "Pan sweeps").
struct BasePointView {
  Descriptor descriptor;
  IntensityStats intensity;
  Descriptor coherence;
  /// What κ compares with the previous base point's: `coherence`, else `descriptor`.
  const Descriptor& judged() const { return coherence.empty() ? descriptor : coherence; }
};
/// Computes the view of the base point observed in `surface`, then resets the surface for the
/// next base point.
BasePointView FinishBasePoint(BubbleSurface& surface, const DescriptorComputer& computer);
/// The view of the base point observed by `views`: one view, or all the views of a pan sweep
/// in the order taken. Every view goes into the descriptor and the intensity statistics; of a
/// sweep (two views or more) the first view alone also gives the coherence descriptor
/// (docs/decisions.md, "Pan sweeps"). The intensity statistics stay zero when the feature set
/// has no intensity feature (the classifier's sets). Precondition: `surface` holds no view;
/// it is left reset, also when this throws. Throws std::invalid_argument on no views, and
/// what BubbleSurface::Observe throws on a bad view.
BasePointView DescribeBasePoint(std::span<const Observation> views, BubbleSurface& surface,
                                const DescriptorComputer& computer);

/// `options` with member views in the builtin basis.
PlaceMemoryOptions WithBuiltinViewBasis(PlaceMemoryOptions options);

struct PipelineOptions {
  uint32_t robot = 1;
  FeatureSet features = FeatureSet::Recognition();
  BubbleSurfaceOptions surface;
  DescriptorOptions descriptor;
  ReliabilityOptions reliability;
  DetectorOptions detector;
  /// Member views in the builtin basis (core/memory/builtin_view_basis.h), whose axes take
  /// the default features' descriptors: another feature set needs memory.view_basis = none or
  /// a basis of its own (the pipeline refuses a basis of another dimension).
  PlaceMemoryOptions memory = WithBuiltinViewBasis(PlaceMemoryOptions{});
  bool recognize_partial = true;  ///< try recognition when a place opens (extent > τ_p)
  /// Base points of the window on which the robot recognises its whereabouts while a maximal
  /// neighbourhood is still too short to be a place (extent ≤ τ_p; section 3.5's periodic
  /// recognition, without learning). A known place recognised there enters the map, so a
  /// short passage through it is mapped A → P → B instead of A → B. 0: off, the map has only
  /// the edges β(D_{m−1})β(D_m). docs/decisions.md, "Map".
  int whereabouts_points = 0;
  /// Valid range of whereabouts_points (also the configuration's).
  static constexpr Range kWhereaboutsPointsRange{0, 100000};
  /// Known tails: while a place is open, its last τ_p + 1 base points are recognised every
  /// quarter of that length; when they show a learned place that the rest of the open place
  /// is not, the place is split where they begin (PlaceDetector::SplitBefore). A robot that
  /// returns to a known place without a visible transition (a loop closing along a corridor)
  /// then recognises it instead of learning it into a new place with what came before.
  /// docs/decisions.md, "Known tails": off by default, it traded frame-level recall and
  /// corridor boundaries for place-level recall on the calibration worlds.
  bool split_known_tails = false;
  /// Consolidation (docs/decisions.md): two places the robot learned are folded into one once
  /// this many revisits, none the one before, showed them holding one room (CopyEvidence),
  /// where the map does not join them and both are joined to one place. 0: never.
  int consolidate_after = 3;
  static constexpr Range kConsolidateAfterRange{0, 1000};
  void Validate() const;
};

/// Where a pipeline continues from (a fresh start or a reopened store).
struct PipelineState {
  BaseIndex next_base = 0;
  DetectedPlaceIndex next_detected = 1;
  /// β of the last detected place: a hint for hybrid search only. A pipeline continuing from a
  /// state maps no edge from it (the robot may have moved meanwhile; docs/decisions.md, "Map").
  std::optional<PlaceId> previous_place;
  /// Revisits seen so far that showed two places holding one room (CopyEvidence): evidence
  /// that takes several laps to gather, kept across restarts.
  std::vector<CopyWitness> copies;
};

class Pipeline {
 public:
  Pipeline(CameraIntrinsics camera, PipelineOptions options, PlaceMemory memory, TopologicalMap map,
           PipelineState state = {});

  /// Runs the loop on one base point observed by `views`: one view, or every view of a pan
  /// sweep in the order taken (DescribeBasePoint). The caller hands over whole sweeps only: a
  /// sweep missing views would be another base point. Throws std::invalid_argument on no
  /// views or a view the surface refuses; the pipeline is then as before the call.
  FrameResult Process(std::span<const Observation> views);
  /// Runs the loop on a ready descriptor (benchmarks, tests, replay). `coherence`, when not
  /// null, is the descriptor incoherency κ is judged on (a sweep's first view); by default
  /// the descriptor itself.
  FrameResult ProcessDescriptor(const Descriptor& descriptor, const IntensityStats& intensity,
                                const Descriptor* coherence = nullptr);
  /// End of the stream: closes the open window and place.
  FrameResult Finish();

  /// Continues with a merged memory and map (core/merge). The previous place follows the
  /// place that absorbed it. Throws std::invalid_argument when `memory` belongs to another robot.
  void AdoptMerged(PlaceMemory memory, TopologicalMap map);
  /// Hands the memory over to a merge that replaces it (MergeMemories' tscd form): until
  /// AdoptMerged gives the pipeline a memory again it holds no place, and it must not process
  /// frames. Moving it out spares the merge a copy of every place (docs/results.md, session 74).
  PlaceMemory GiveUpMemory();

  /// Base points now lie at another spacing (tscd measures it by the robot's odometry): place
  /// detection continues with `detector` (its spacing, τ_p and τ_w; PlaceDetector::Readapt)
  /// and recognition with `step_unit` (memory.step_unit). The memory, map and open place are
  /// kept. Throws std::invalid_argument on invalid options; the pipeline is then unchanged.
  void Readapt(const DetectorOptions& detector, double step_unit);

  /// Called with a learned place's index just before the pipeline changes that place (it
  /// recognised it: PlaceMemory::Update); places are otherwise only appended, or all replaced
  /// by AdoptMerged. tscd keeps there what its snapshots of the memory still serve.
  void set_before_update(std::function<void(int place)> hook) { before_update_ = std::move(hook); }
  /// Called just before a consolidation replaces the places (FrameResult::memory_replaced),
  /// with the memory still as it was.
  void set_before_replace(std::function<void()> hook) { before_replace_ = std::move(hook); }

  /// The dimension of the descriptors the configured features give.
  int descriptor_dimension() const { return descriptor_dimension_; }
  /// Throws DescriptorSpaceMismatch when the memory's places were learned with other features
  /// (a stored memory read under another configuration), whose every frame would be refused.
  /// Not a precondition of construction: ProcessDescriptor takes descriptors from elsewhere.
  void RequireMemoryOfTheseFeatures() const;

  const PlaceMemory& memory() const { return memory_; }
  const TopologicalMap& map() const { return map_; }
  const PipelineOptions& options() const { return options_; }
  const BubbleSurface& surface() const { return surface_; }
  const DescriptorComputer& descriptor_computer() const { return computer_; }
  /// The whole state a pipeline continues from, copy evidence included.
  PipelineState state() const;
  /// The state without its copy evidence (`copies` empty): what a writer needs on every base
  /// point, without copying the evidence, which rarely changes.
  PipelineState position() const;

 private:
  void HandleDetection(const std::vector<DetectionEvent>& events, BaseIndex k, FrameResult& out);
  void RecogniseWhereabouts(BaseIndex k, FrameResult& out);
  void SplitAtKnownTail(BaseIndex k, FrameResult& out);
  // The base points after the last one that showed the whereabouts and before `before`
  // (empty when there are none, or the whereabouts were never seen).
  TransitionRegion SinceWhereabouts(BaseIndex before) const;
  // The map edge from the whereabouts to `to`, and its mapped event at base point k for
  // detected place m (none when `to` is the whereabouts).
  void MapFromWhereabouts(PlaceId to, TransitionRegion region, BaseIndex k, DetectedPlaceIndex m,
                          FrameResult& out);
  DetectedPlace Gather(DetectedPlaceIndex m, const std::vector<BaseIndex>& members) const;
  void TrimDescriptors();
  // Recognised as `place` by detected place m: the copies the recognition showed and whose
  // evidence now suffices are folded into it. Returns the place's index afterwards.
  int Consolidate(int place, const CostTerms& terms, DetectedPlaceIndex m, PlaceEvent& e,
                  FrameResult& out);

  PipelineOptions options_;
  BubbleSurface surface_;
  DescriptorComputer computer_;
  PlaceDetector detector_;
  PlaceMemory memory_;
  int descriptor_dimension_ = 0;
  std::function<void(int place)> before_update_;
  std::function<void()> before_replace_;
  CopyEvidence copies_;
  TopologicalMap map_;
  BaseIndex next_base_;
  std::optional<PlaceId> previous_place_;
  // Where the map last put the robot: β(D_{m−1}), or a known place recognised since then on a
  // window of whereabouts_points base points (RecogniseWhereabouts); and the last base point
  // that showed it. Not stored: after a restart the whereabouts are unknown until a place
  // closes, so the first place after it is not linked to the last one before it (which the
  // robot may have left long ago); previous_place_ still hints hybrid search.
  std::optional<PlaceId> whereabouts_;
  std::optional<BaseIndex> whereabouts_seen_;
  std::optional<Eigen::VectorXf> previous_descriptor_;        // coherence descriptor of x_{k−1}
  std::deque<std::pair<BaseIndex, Eigen::VectorXf>> recent_;  // descriptors not yet closed
  std::optional<int> partial_recognition_;  // place the open place was recognised as
  std::optional<int> known_tail_;           // place the open place's tail showed at the last check
};

}  // namespace tsc
