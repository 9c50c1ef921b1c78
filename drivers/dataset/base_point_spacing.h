#pragma once
// How far apart a camera's base points are taken, in metres of travel: place detection's τ_p
// is a length (detection.tau_p_m) and needs it to count base points, so that one
// configuration serves a 10 fps camera and a keyframe sequence (DESIGN §3.2 amended;
// docs/decisions.md, "Frame rate").

#include <optional>
#include <string>

namespace tsc {

// Only AdaptToSpacing and SparseCameraNote take one: dataset.h and camera_source.h, which
// include this header, need not pull in the pipeline.
struct PipelineOptions;

/// Speed assumed for a camera that declares only its frame rate: the simulated robot's
/// (0.15 m per frame at 10 fps); a walking person is about as fast.
inline constexpr double kAssumedSpeedMps = 1.5;
/// Spacing of a keyframe sequence that does not state it (the real loop of ../shared/data:
/// keyframes about a metre apart, as RTAB-Map and FAB-MAP datasets take them).
inline constexpr double kKeyframeSpacingM = 1.0;
/// The spacing the defaults were calibrated at: the simulated robot's route step
/// (docs/calibration.md).
inline constexpr double kCalibratedSpacingM = 0.15;

/// How far apart a dataset's frames were taken, and on what evidence.
struct BasePointSpacing {
  double metres = kKeyframeSpacingM;
  /// "camera.json spacing_m", "camera.json fps", "camera.json keyframes", "poses (median
  /// step)" or "undeclared: keyframes assumed".
  std::string basis;
  /// A keyframe sequence (declared or assumed): frames kept for what they show, as the real
  /// loop's are, not at a camera's rate.
  bool keyframes = false;
  /// Nothing declared it: a folder without camera.json's spacing and without poses, taken for
  /// a keyframe sequence.
  bool assumed = false;
};

/// The spacing place detection uses: `configured` (camera.spacing_m) when positive, else what
/// the source declares, else that of a camera of `fps` frames per second moving at
/// kAssumedSpeedMps (0.15 m at 10 fps; fps 0, as fast as frames come, counts as 10).
BasePointSpacing ResolveSpacing(double configured, const BasePointSpacing* declared, double fps);

/// A camera (not a keyframe sequence) whose base points lie more than 1.5x the calibrated
/// spacing apart: 0.3 m (5 fps at walking speed) and beyond.
bool IsSparse(const BasePointSpacing& spacing);

/// Base points closer than this change too little between them for the calibrated κ: on
/// simulated worlds, frames 0.1 m apart hold as they are, 0.085 m apart do not
/// (docs/calibration.md, twenty-seventh pass).
inline constexpr double kClosestSpacingM = 0.1;

/// How near a divisor of kCalibratedSpacingM a spacing takes its quotient as the stride
/// (relative): odometry's noise around 0.05 m must not choose between 2 and 3.
inline constexpr double kQuotientTolerance = 0.02;

/// Which of a camera's frames are base points (DESIGN §3.2 amended: "take base points at a
/// fixed spacing"): every stride-th, the largest stride that keeps them at most the calibrated
/// spacing apart, or one more where that leaves them closer than kClosestSpacingM. 1 for a
/// keyframe sequence and a camera at 0.1 m or more; 2 at 0.075 m (20 fps at walking speed) and
/// 0.085 m; 3 at 0.05 m (30 fps). Why: a denser camera changes less between consecutive
/// frames, so κ finds few transitions (nine simulated worlds at 0.05 m: boundary F1 0.42
/// against 0.86 at 0.15 m, 12 right / 2 wrong recognitions against 49 / 0; one frame in three:
/// 0.89, 52 / 2). A spacing within kQuotientTolerance of dividing the calibrated one takes
/// the quotient (0.0501 m: 3).
int StrideFor(const BasePointSpacing& frames);

/// The spacing of every `stride`-th frame of `frames` (stride ≥ 1), its basis saying so.
BasePointSpacing EveryNth(const BasePointSpacing& frames, int stride);

/// The base points of a camera whose frames lie `frames` apart: every `stride`-th frame
/// (StrideFor), `spacing` apart (EveryNth), what place detection is adapted to.
struct BasePoints {
  int stride = 1;
  BasePointSpacing spacing;
};
BasePoints BasePointsOf(const BasePointSpacing& frames);

/// `options`, configured for a camera at the calibrated spacing, for base points `spacing`
/// apart: detection counts τ_p at that spacing (DetectorOptions::spacing_m), and a sparse
/// camera halves τ_w (at least 1) and memory.step_unit. There a door is crossed in one or two
/// base points, so one incoherent base point must make a transition, and a revisit passes
/// within half a step of the stored base points, not a whole one. Chosen on the calibration
/// worlds thinned to 0.3 and 0.6 m and checked on held-out and fresh ones (docs/calibration.md,
/// twenty-first pass). A keyframe sequence keeps the counts: its frames are kept where the view
/// changed, not every so many metres, and the real loop holds with them.
void AdaptToSpacing(PipelineOptions& options, const BasePointSpacing& spacing);

/// What the adaptation made of a sparse camera's τ_w and step_unit, for a log line; nothing
/// when `spacing` is not sparse.
std::optional<std::string> SparseCameraNote(const PipelineOptions& adapted,
                                            const BasePointSpacing& spacing);

/// What a user should know about `spacing` before trusting the recognitions: even adapted, a
/// sparse camera makes a few wrong recognitions on simulated routes where the calibrated
/// spacing makes none (docs/calibration.md, twenty-first pass). Nothing when the spacing is
/// within what was measured to hold.
std::optional<std::string> SpacingCaution(const BasePointSpacing& spacing);

}  // namespace tsc
