#pragma once
// When a robot's two places hold one room (docs/decisions.md "Consolidation"). A recognition
// shows it: D is recognised as P while another place Q, a sibling of P in the tree, has its
// views nearest D's points within the vote radius of P's (CostTerms::held_again). One such
// revisit is weak evidence: Q may be the room next door seen through a door, or the
// recognition itself may be wrong, and a fold makes that permanent (docs/calibration.md,
// twenty-first pass). So a pair is folded only once several revisits, none the one before,
// have shown it.

#include <cstddef>
#include <map>
#include <utility>

#include "core/detect/place_detector.h"
#include "core/memory/place_id.h"

namespace tsc {

class CopyEvidence {
 public:
  /// `revisits`: how many detected places must show a pair before it is one place (0: never).
  explicit CopyEvidence(int revisits) : revisits_(revisits) {}

  /// Detected place `m` showed places `a` and `b` holding one room. True when the pair has now
  /// been shown by `revisits` detected places, no two of them consecutive (one pass through a
  /// room often closes two detected places); the pair's evidence is then spent.
  bool Witness(PlaceId a, PlaceId b, DetectedPlaceIndex m);
  size_t pairs() const { return pairs_.size(); }

  /// Pairs remembered at most; beyond, the evidence is forgotten (it only delays a fold).
  static constexpr size_t kMaxPairs = 4096;

 private:
  struct Seen {
    int count = 0;
    DetectedPlaceIndex last = 0;
  };
  int revisits_;
  std::map<std::pair<PlaceId, PlaceId>, Seen> pairs_;
};

}  // namespace tsc
