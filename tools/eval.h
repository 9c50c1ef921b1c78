#pragma once
// `tsc eval`: runs the TSC pipeline over a dataset on a fresh memory and scores it with the
// rules of DESIGN §7.1b (tools/scoring.h): place detection (boundary F1, with labels),
// recognition precision / recall at the configured τ_r and over a sweep of τ_r (PR curve,
// recall at full precision; with poses also the view-overlap recall), frame-level loop
// closure (the measure of DBoW2, FAB-MAP, RTAB-Map: each frame of a recognised place names
// its nearest member frame of that place), map edge precision (with labels) and timing.
//
// Each frame's descriptor and intensity statistics are computed once (BubbleSurface +
// DescriptorComputer + IntensityStatistics, timed); then a fresh Pipeline replays them with
// ProcessDescriptor for the configured τ_r (the main figures) and for each τ_r of the sweep.
// Frames are 0-based: on a fresh pipeline base point k is frame k of the dataset.

#include <map>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "core/pipeline/pipeline.h"
#include "drivers/dataset/camera_lens.h"
#include "drivers/dataset/dataset.h"
#include "settings/settings.h"
#include "tools/scoring.h"

namespace tsc {

struct EvalOptions {
  /// τ_r values of the PR sweep: from, from + step, ... up to `sweep_to` (inclusive, within
  /// step/1000). An empty sweep (sweep_step = 0) uses only the configured τ_r.
  // Around the default τ_r (2.9): where precision breaks on the calibration worlds.
  double sweep_from = 1.5;
  double sweep_to = 3.5;
  double sweep_step = 0.1;
  /// Throws std::invalid_argument naming the bad field (negative values, from > to, a step
  /// that gives more than 10⁴ points).
  void Validate() const;
  /// The τ_r values of the sweep, in increasing order.
  std::vector<double> SweepValues() const;
};

/// A detected place of one run, in detection order.
struct EvalDetectedPlace {
  DetectedPlaceIndex index = 0;
  std::vector<int> frames;  ///< 0-based member frames, increasing
  /// Learned place it was assigned to; none when ambiguous (EventKind::kAmbiguous).
  std::optional<PlaceId> place;
  bool recognized = false;  ///< recognised (true) or learned (false)
  double cost = 0.0;        ///< g_N of the decision (recognised), or the last one tried
  CostTerms terms;          ///< its terms
  /// The recognition tried when the place opened (pipeline.recognize_partial), if it named one.
  std::optional<PlaceId> partial_place;
  double partial_cost = 0.0;
  bool neighbour = false;       ///< recognised only through memory.neighbour_margin
  std::vector<PlaceId> folded;  ///< places folded into `place` as it was recognised
};

/// One pass of the pipeline over the stored descriptors, at one τ_r.
struct EvalRun {
  double tau_r = 0.0;
  std::vector<EvalDetectedPlace> detected;
  std::vector<TransitionRegion> transitions;      ///< regions between detected places
  std::map<PlaceId, std::vector<int>> frames_of;  ///< frames assigned to each learned place
  RecognitionScore recognition;
  std::vector<LoopClosure> loop_closures;  ///< one per frame of each recognised place
  LoopClosureScore loop_closure;
  int learned_places = 0;
  /// Places per label of the final memory (DESIGN §7.1b, PlacesPerLabel): each place labelled
  /// by the majority of the frames assigned to it; 0 without labels.
  double places_per_label = 0.0;
  TopologicalMap map;
  std::optional<PlaceMemory> memory;  ///< kept for the main run only
};

/// How a dataset's frames were taken as base points (PrepareDataset), for the JSON.
struct EvalSpacing {
  BasePointSpacing base_points;  ///< how far apart the base points are, and on what evidence
  int stride = 1;                ///< every stride-th frame (StrideFor)
  int dataset_frames = 0;        ///< frames in the folder (EvalResult::frames: base points)
  /// SpacingCaution, or AssumedKeyframesCaution of the consecutive change.
  std::optional<std::string> caution;
};

/// The lens the thresholds were adapted to (AdaptToLens), for the JSON.
struct EvalLens {
  CameraLens lens;
  std::optional<std::string> caution;  ///< LensCaution
};

struct EvalResult {
  std::string dataset;
  int frames = 0;
  PipelineOptions options;
  EvalOptions eval;
  std::vector<BaseStatus> status;  ///< per frame
  int good = 0, uninformative = 0, incoherent = 0;
  EvalRun main;                   ///< at options.memory.tau_r
  std::vector<PrPoint> pr_curve;  ///< one point per sweep value, in τ_r order
  /// The counts behind each point of pr_curve (a precision of 0 hides how many were wrong;
  /// calibration sums them over worlds: scripts/calibrate).
  struct SweepCount {
    double tau_r = 0.0;
    int recognitions = 0, correct = 0, should_be_recognized = 0;
  };
  std::vector<SweepCount> sweep_counts;
  double recall_at_full_precision = 0.0;
  /// The same sweep with the view-overlap recall (meaningful when truth.has_poses()).
  std::vector<PrPoint> view_pr_curve;
  double view_recall_at_full_precision = 0.0;
  /// The same sweep at frame level (loop closures).
  std::vector<PrPoint> loop_closure_pr_curve;
  double loop_closure_recall_at_full_precision = 0.0;
  std::optional<BoundaryScore> boundaries;  ///< with labels
  std::optional<EdgeScore> edges;           ///< with labels
  GroundTruth truth;
  /// Median χ² between consecutive base points' coherence descriptors (what κ compares with
  /// τ_κ): how much the view changes from one base point to the next (0 with one frame).
  double consecutive_chi2_median = 0.0;
  double descriptor_ms_median = 0.0;   ///< bubble surface + descriptor + intensity, per frame
  double frame_ms_median = 0.0;        ///< descriptor + pipeline step of the main run, per frame
  std::optional<EvalSpacing> spacing;  ///< set by the caller that prepared the dataset
  std::optional<EvalLens> lens;        ///< likewise
};

/// How the offline tools read a dataset: images bounded by camera.max_image_pixels, as tscd's
/// cameras are.
DatasetOptions DatasetOptionsOf(const Settings& settings);

/// A dataset as the pipeline takes it, and the options it takes it with.
struct PreparedDataset {
  Dataset dataset;           ///< the frames that are base points (all but for a dense camera)
  PipelineOptions options;   ///< `settings`' pipeline, adapted to those frames' spacing
  BasePointSpacing spacing;  ///< how far apart those frames are, and on what evidence
  int stride = 1;            ///< every stride-th frame of the folder (StrideFor)
  EvalLens lens;             ///< the lens `options` were adapted to (AdaptToLens)
};

/// `opened` as `settings` run it: the frames' spacing is camera.spacing_m when set, else what
/// the dataset declares (Dataset::spacing); a camera denser than the calibrated spacing gives
/// every StrideFor-th frame as a base point (Dataset::EveryNth), and place detection counts
/// τ_p in base points at their spacing (AdaptToSpacing); a forward camera's τ_κ and distance
/// unit follow its lens (AdaptToLens). Writes the spacing, its basis, τ_p and the lens's
/// thresholds to `say` unless it is null. Throws DatasetError when the configured features
/// need depth and the dataset has none.
PreparedDataset PrepareDataset(const Settings& settings, const Dataset& opened, std::ostream* say);

/// Runs and scores. Throws DatasetError (naming the frame and file) for unreadable frames,
/// std::invalid_argument for bad options.
EvalResult Evaluate(const Dataset& dataset, const PipelineOptions& options,
                    const EvalOptions& eval);

/// The result as one JSON object with nested objects (keys of DESIGN §7.2):
///   {"dataset", "frames", "base_points": {"good","uninformative","incoherent",
///                   "consecutive_chi2_median"},
///    "detected_places", "learned_places",
///    "detection": {"boundary_f1","precision","recall","true_boundaries",
///                  "detected_boundaries","tolerance_frames"}   (with labels),
///    "recognition": {"tau_r","recognitions","correct","should_be_recognized","precision",
///                    "recall","recall_at_full_precision","pr_curve": [[τ_r,P,R],...],
///                    "sweep_counts": [[τ_r,recognitions,correct,should_be_recognized],...],
///                    with poses also "view_should_be_recognized","view_correct",
///                    "view_recall","view_recall_at_full_precision",
///                    "view_pr_curve": [[τ_r,P,view R],...]},
///    "loop_closure": {"detections","correct","not_judged","frames_with_revisit",
///                     "precision","recall","recall_at_full_precision",
///                     "pr_curve": [[τ_r,P,R],...]}
///                    (with labels or revisits),
///    "decisions": [{"detected_place","first_frame","last_frame","base_points","label" (with
///                   labels),"decision","place","cost","terms":{"distance","ratio","vote"},
///                   "partial":{"place","cost"} (when recognised on opening),
///                   "should_be_recognized","view_should_be_recognized" (with poses),
///                   "correct"}, ...] (the main run, in decision order),
///    "map": {"places","edges","edge_precision","correct_edges" (with labels)},
///    "timing": {"descriptor_ms_median","frame_ms_median"},
///    "config": {every configuration key: value}, "sweep": {"from","to","step"}}
/// Non-finite numbers are written as null.
void WriteEvalJson(std::ostream& out, const EvalResult& result);

/// Median of `v` (0 for an empty vector).
double MedianOf(std::vector<double> v);

}  // namespace tsc
