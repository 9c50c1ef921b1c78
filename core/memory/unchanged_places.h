#pragma once
// Which places a replaced memory kept as they were, so that a store holding the memory before
// rewrites only the others (a merge that changes one place of 10⁴ would otherwise rewrite them
// all: 1.8 s and ~200 MB of writes at 10⁴ places, issue 23).

#include <span>
#include <vector>

#include "core/memory/learned_place.h"

namespace tsc {

/// Whether two places are the same in everything a store keeps of them: id, mean, member
/// count, member views, detected places, members and sources.
bool SameStoredPlace(const LearnedPlace& a, const LearnedPlace& b);

/// One flag per place of `after`: true where `before` holds the same place at the same
/// position (SameStoredPlace).
std::vector<char> UnchangedPositions(std::span<const LearnedPlace> before,
                                     std::span<const LearnedPlace> after);

/// What a merge into a memory changes of the places it keeps (core/merge): absorbing or
/// folding a place into one adds to its member count and its sources, and a group's place
/// takes the smallest id. So where that memory was the merge's base, a place of the result
/// whose fingerprint is the one the memory's place at that position had is unchanged, and
/// the memory need not be kept to tell (tscd gives its memory up to the merge). Taking them
/// for 10⁴ places reads a few hundred KB; SameStoredPlace reads ~130 MB.
struct PlaceFingerprint {
  PlaceId id;
  int64_t member_count = 0;
  std::vector<PlaceId> sources;
  // Sizes only, as further guards: a merge that changed them changed the count above too.
  int64_t views = 0;
  size_t members = 0;
  size_t detected = 0;

  bool operator==(const PlaceFingerprint&) const = default;
};

PlaceFingerprint FingerprintOf(const LearnedPlace& p);
std::vector<PlaceFingerprint> FingerprintsOf(std::span<const LearnedPlace> places);

/// UnchangedPositions against fingerprints taken of `before` (valid for a merge whose base it
/// was: PlaceFingerprint).
std::vector<char> UnchangedPositions(std::span<const PlaceFingerprint> before,
                                     std::span<const LearnedPlace> after);

}  // namespace tsc
