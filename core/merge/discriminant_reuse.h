#pragma once
// Discriminants a merge keeps: a node's one-class discriminant depends only on the set of
// places under it, so the merged memory reuses, by set key, every trained discriminant whose
// set the merge leaves as it was instead of training it again.

#include <cstdint>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "core/memory/discriminant.h"
#include "core/memory/place_memory.h"
#include "core/merge/merged_places.h"

namespace tsc {

struct ReusableDiscriminants {
  std::unordered_map<uint64_t, OneClassDiscriminant> by_key;  ///< for PlaceMemory::Restore
  std::unordered_set<uint64_t> keys;                          ///< the keys of `by_key`
};
/// The trained discriminants of the base's nodes not on the path of an updated place, and of
/// the incoming nodes all of whose places were added as they are. Take them before the
/// places are moved out of a memory given up by the caller (the copies share the models).
ReusableDiscriminants ReusableDiscriminantsOf(const PlaceMemory& base, const PlaceMemory& incoming,
                                              const Placement& placement,
                                              const std::vector<char>& is_new,
                                              const std::vector<int>& targets);
/// The non-root nodes of `merged` whose key was not among the `reused` ones: the discriminants
/// trained anew. 0 where `merged` trains none (memory.svm_vote off, the default).
int Retrained(const PlaceMemory& merged, const std::unordered_set<uint64_t>& reused);

}  // namespace tsc
