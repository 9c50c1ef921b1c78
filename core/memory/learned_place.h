#pragma once
// The places of chapter 3: a detected place D_m (a run of base points, section 3.4) and a
// learned place p ∈ P (a terminal of the place memory, section 3.3).

#include <Eigen/Core>
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/detect/place_detector.h"
#include "core/keep_latest.h"
#include "core/memory/compact_views.h"
#include "core/memory/place_id.h"

namespace tsc {

/// A detected place D_m with the descriptors of its member base points.
struct DetectedPlace {
  DetectedPlaceIndex index = 0;
  std::vector<BaseIndex> members;
  Eigen::MatrixXf descriptors;  ///< dim x |members|, column j belongs to members[j]
  /// Ī_m of (3.5). Precondition: at least one member.
  Eigen::VectorXf Mean() const;
};

/// A terminal node's place p ∈ P.
struct LearnedPlace {
  PlaceId id;
  Eigen::VectorXf mean;      ///< Ī_p over all member base points
  int64_t member_count = 0;  ///< base points averaged into `mean`
  /// dim x k member views (core/memory/member_views.h): descriptors of member base points
  /// spread over every heading and visit; recognition measures distances to them. Kept in
  /// 16 bits a coordinate (core/memory/compact_views.h).
  CompactViews samples;
  /// Detected places that compose it, the latest kMaxDetected of them (TrimHistory).
  std::vector<DetectedPlaceIndex> detected;
  /// Member base points (this robot's stream), the latest kMaxMembers of them (TrimHistory);
  /// member_count counts every one.
  std::vector<BaseIndex> members;
  /// Ids of other robots' places merged into this one (core/merge), sorted, without `id`.
  std::vector<PlaceId> sources;

  /// A place recognised on every lap of a long run would otherwise hold every base point and
  /// detected place it ever had (0.9 MB of members for one place after an accelerated day,
  /// issue 23; ~1500 detected places a day), and the store rewrites that row on each
  /// recognition. The store thins the oldest base points and detected places anyway.
  static constexpr size_t kMaxMembers = 4096;
  /// Past memory.sample_visits' largest value (1000), so the views a place keeps
  /// (PlaceMemoryOptions::SampleCap) never depend on it.
  static constexpr size_t kMaxDetected = 4096;
  /// Largest |value| of a mean a memory takes in (PlaceMemory::Restore: a store, a peer).
  /// Descriptors lie in [0, 1]; within this bound a mean times kMaxMemberCount, and squared
  /// distances over 10⁵ dimensions, stay finite in float (a stored mean near 10³⁸ made the
  /// next update infinite, and the store could not be loaded again: fuzz_store).
  static constexpr float kMaxMeanValue = 1e6f;
  /// Most base points member_count counts (a century at 30 fps is 10¹¹): Update and Absorb
  /// hold it there (HoldWithinBounds), so no count a store or a peer claims can overflow.
  static constexpr int64_t kMaxMemberCount = int64_t{1} << 40;
};

/// Drops the oldest of `p`'s members and detected places (the lowest indices come first) past
/// kMaxMembers and kMaxDetected.
inline void TrimHistory(LearnedPlace& p) {
  KeepLatest(p.members, LearnedPlace::kMaxMembers);
  KeepLatest(p.detected, LearnedPlace::kMaxDetected);
}

/// Holds `p`'s mean and count within LearnedPlace::kMaxMeanValue and kMaxMemberCount after an
/// update or a merge, which Restore would otherwise refuse: their arithmetic keeps a mean
/// between its inputs but for rounding, and adds counts. Real places never reach either bound.
inline void HoldWithinBounds(LearnedPlace& p) {
  p.mean = p.mean.cwiseMax(-LearnedPlace::kMaxMeanValue).cwiseMin(LearnedPlace::kMaxMeanValue);
  p.member_count = std::min(p.member_count, LearnedPlace::kMaxMemberCount);
}

}  // namespace tsc
