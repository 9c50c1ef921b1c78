#pragma once
// Consolidation (issues 19, 21 and 23; docs/decisions.md "Consolidation"): a robot folds its
// own copies of a room into one place once revisits have shown them to be one, as a merge
// folds the places a peer's records join. Pure computation on a memory; the pipeline decides
// when the evidence suffices (core/pipeline/copy_evidence.h).

#include <span>
#include <vector>

#include "core/memory/place_id.h"
#include "core/memory/place_memory.h"

namespace tsc {

struct Consolidation {
  PlaceMemory memory;           ///< the memory with the group folded into one place
  PlaceId holder;               ///< the id of the place holding the group now (its smallest)
  std::vector<PlaceId> folded;  ///< the group's other ids, which left the memory (sorted)
};

/// Folds places `group` (indices into `memory`'s places, at least two, distinct) into one:
/// the lowest index holds them (merge's Fold: means weighted by member counts, views pooled
/// and thinned, members and detected places kept, ids as sources) and carries the group's
/// smallest id. The tree contracts the others into it: every merge height stays, so the held
/// place is as near another place as the nearer of the group was (single linkage of the
/// union). Other places keep their order. Throws std::invalid_argument on a bad group.
Consolidation Consolidate(PlaceMemory memory, std::vector<int> group);

}  // namespace tsc
