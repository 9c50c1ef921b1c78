#pragma once
// Whether a camera moved since its last base point, by its robot's odometry (tscd) or a
// dataset's poses (tsc eval): a robot standing still adds no base points. Its frames would
// all be "good" (nothing changes), so a stop in a doorway or a corridor makes a place of it
// (nine simulated worlds with a five-second stop every 150 frames: 91 places to recognise
// against 79, boundary F1 0.82 against 0.86; skipped, the figures are those without stops;
// docs/calibration.md, twenty-eighth pass).

#include <optional>

#include "drivers/dataset/planar_pose.h"

namespace tsc {

/// Less than this travel and turn since the last base point is standing still: a resting
/// robot's odometry does not change, and ground-truth poses of a resting camera jitter by
/// millimetres. Any motion a stride covers passes it: on every simulated route measured (at
/// 0.05-0.15 m a frame, their camera shaking by 2 cm and 1°) no frame is taken for still, so
/// their figures are unchanged.
inline constexpr double kStillTravelM = 0.01;
inline constexpr double kStillTurnDeg = 0.5;

class BasePointMotion {
 public:
  /// Whether a frame at `pose` lies beyond standing still from the last base point; true before
  /// the first.
  bool Moved(const PlanarPose& pose) const;
  /// `pose` is where the last base point was taken.
  void Taken(const PlanarPose& pose) { last_ = pose; }

 private:
  std::optional<PlanarPose> last_;
};

}  // namespace tsc
