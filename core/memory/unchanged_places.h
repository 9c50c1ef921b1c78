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

}  // namespace tsc
