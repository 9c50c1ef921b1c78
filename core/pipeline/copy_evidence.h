#pragma once
// When a robot's two places hold one room (docs/decisions.md "Consolidation"). A recognition
// shows it: D is recognised as P while another place Q, a sibling of P in the tree, has its
// views nearest D's points within the vote radius of P's (CostTerms::held_again). One such
// revisit is weak evidence: Q may be the room next door seen through a door, or the
// recognition itself may be wrong, and a fold makes that permanent (docs/calibration.md,
// twenty-first pass). So a pair is folded only once several revisits, none the one before,
// have shown it.

#include <cstddef>
#include <cstdint>
#include <map>
#include <span>
#include <utility>
#include <vector>

#include "core/detect/place_detector.h"
#include "core/memory/place_id.h"

namespace tsc {

/// A pair's evidence so far, as it is kept across restarts (store/): a robot that restarts
/// between the revisits of a room still folds its copies.
struct CopyWitness {
  PlaceId a, b;                 ///< a < b
  int count = 0;                ///< revisits that showed the pair, ≥ 1
  DetectedPlaceIndex last = 0;  ///< the latest of them
  bool operator==(const CopyWitness&) const = default;
};

class CopyEvidence {
 public:
  /// `revisits`: how many detected places must show a pair before it is one place (0: never).
  /// `kept`: the evidence a previous run gathered (Witnesses()); at most kMaxPairs are taken.
  /// Throws std::invalid_argument for a pair of one place or a count below 1.
  explicit CopyEvidence(int revisits, std::span<const CopyWitness> kept = {});

  /// Detected place `m` showed places `a` and `b` holding one room. True when the pair has now
  /// been shown by `revisits` detected places, no two of them consecutive (one pass through a
  /// room often closes two detected places); the pair's evidence is then spent.
  bool Witness(PlaceId a, PlaceId b, DetectedPlaceIndex m);
  size_t pairs() const { return pairs_.size(); }
  /// The evidence held, in pair order.
  std::vector<CopyWitness> Witnesses() const;
  /// Grows whenever the evidence changes (for writers that store it only then).
  uint64_t changes() const { return changes_; }

  /// Pairs remembered at most; beyond, the evidence is forgotten (it only delays a fold).
  static constexpr size_t kMaxPairs = 4096;

 private:
  struct Seen {
    int count = 0;
    DetectedPlaceIndex last = 0;
  };
  int revisits_;
  uint64_t changes_ = 0;
  std::map<std::pair<PlaceId, PlaceId>, Seen> pairs_;
};

}  // namespace tsc
