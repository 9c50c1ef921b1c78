#pragma once
// The topological maps' merge (§4.6), over a merged place memory, and whether a merge brings
// anything new.

#include "core/map/topological_map.h"
#include "core/memory/place_memory.h"
#include "core/merge/merge.h"

namespace tsc {

/// G^m + G^n of §4.6 over the merged memory: every place id (own or absorbed) is replaced by
/// the merged place that holds it, edges are the union, an edge's traversal count the largest
/// count among the edges of both maps that collapse onto it (so the result does not depend on
/// the order of merges), and self-loops are dropped. Transition regions are kept only from `ours`
/// (they index our own base point stream).
TopologicalMap MergeMaps(const TopologicalMap& ours, const TopologicalMap& peer,
                         const PlaceMemory& merged);

/// Whether adopting a merge changes what the robot holding `ours_map` holds: a place, an
/// absorption, an edge, or a larger traversal count. A merge that changes nothing is not
/// adopted, so an unchanged memory is not broadcast again and peers do not fetch it back and
/// forth; one that only raises counts is, so every robot ends with the largest counts.
bool MergeChangesAnything(const MemoryMerge& merged, const TopologicalMap& merged_map,
                          const TopologicalMap& ours_map);

}  // namespace tsc
