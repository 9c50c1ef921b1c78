#pragma once
// Whether D's points name the place the recognition cost chose (issue 19, session 39;
// docs/decisions.md "Recognition cost": agreement). g_N judges D by medians over its vote
// points, so a place can be cheapest in the median while almost every point lies nearer some
// other place: a corridor pass between two rooms, each half nearer one room, with a corridor
// place learned impure in the middle. Each point's own nearest place is the frame-level
// evidence the field's loop closure uses (a revisit frame's nearest earlier frame is in its
// room for 0.8-0.9 of frames here, docs/calibration.md "Fifteenth pass").

#include <span>

#include "core/memory/recognition_cost.h"

namespace tsc {

/// The share of D's vote points that agree with `place` (an index into vd's places): a point
/// agrees when its nearest measured place is `place` or one of `copies` (places holding
/// `place`'s place again, as RecognitionCost judges copies), or when `place`'s nearest view
/// lies within `slack` times the nearest place's distance (a near tie is no disagreement).
/// 1 when no point has a measured place. Preconditions: `place` is measured, slack ≥ 1.
double PointAgreement(const ViewDistances& vd, int place, std::span<const int> copies,
                      double slack);

}  // namespace tsc
