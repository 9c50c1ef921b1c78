#pragma once
// Merging of place memories and topological maps (chapter 4, DESIGN §3.6): a RACHET-style
// case analysis on the hyperspheres S(c(N), ρ(N)) of the two trees, recognition of the
// incoming places against the best-overlapping hyper-terminal, and the map union of §4.6.
// The merged tree is single linkage over both memories' SLINK trees and the cross links the
// merge finds (docs/decisions.md, "Merging").
//
// MergeMemories runs the steps in order, each in a file of its own: the cases of the merge
// (merge_cases.h), the join by ids (id_join.h), recognition against hyper-terminals
// (recognition.h, hyper_terminals.h), the merged place list (merged_places.h), the
// discriminants kept (discriminant_reuse.h) and the merged tree (merged_tree.h).

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "core/map/topological_map.h"
#include "core/memory/place_id.h"
#include "core/memory/place_memory.h"
#include "core/memory/single_linkage.h"
#include "core/merge/hyper_terminals.h"
#include "core/merge/merge_cases.h"

namespace tsc {

/// An incoming place recognised as one of the base memory's places and merged into it.
struct Absorption {
  PlaceId source;
  PlaceId target;
  double cost = 0.0;  ///< g of (3.8) against the target's hyper-terminal; 0: joined by ids
};

struct MemoryMerge {
  PlaceMemory memory;  ///< the merged memory, owned by `ours`' robot
  MergeCase merge_case = MergeCase::kNothingNew;
  bool peer_into_ours = true;  ///< the peer was the smaller memory (merged into ours)
  /// Incoming places recognised (in incoming order), then base places folded into another
  /// because the peer's records join them (cost 0).
  std::vector<Absorption> absorbed;
  std::vector<PlaceId> added;  ///< incoming places added as new places, in order
  std::vector<PlaceId> known;  ///< incoming places merged before, left as they are
  int retrained = 0;           ///< discriminants trained (the others were reused)
  /// The merged memory holds a place or an absorption that ours did not (false: it is ours).
  bool changed = false;
};

/// T^m + T^n of figure 4.6 from the perspective of `ours` (robot m). The smaller memory (by
/// place count; on a tie, the one of the higher robot id) is merged into the larger, so the
/// result is the same place set whichever robot computes it. Every merged place carries the
/// smallest id of its group (its id and its sources), whichever memory was the base, and
/// Absorption records name the places by those ids. Deterministic; merging the same peer
/// state again changes nothing. Both memories must have the same descriptor dimension
/// (std::invalid_argument). Recognition and absorption, most of a merge's work, run on up to
/// `threads` threads (values below 1 count as 1: core/on_threads.h); the merge is the
/// same for any number.
MemoryMerge MergeMemories(const PlaceMemory& ours, const PlaceMemory& peer, int threads = 1);
/// The same merge for a caller that gives up both memories (a daemon replacing its memory by
/// the merge, a peer's snapshot): their places are moved into the result instead of copied
/// (at 10⁴ + 10⁴ places the copies were about a third of the merge). Same result as the
/// copying form; the inputs are left valid but unspecified (their places moved out).
MemoryMerge MergeMemories(PlaceMemory&& ours, PlaceMemory&& peer, int threads = 1);
/// The same merge giving up only the peer's memory (a daemon merging a received snapshot keeps
/// its own memory until the merge has succeeded): the peer's places are moved, ours copied.
MemoryMerge MergeMemories(const PlaceMemory& ours, PlaceMemory&& peer, int threads = 1);
/// tscd's form: the peer's memory is given up, and ours only once the merge knows it changes
/// it. Until then the merge only reads `ours`, so one that throws while recognising leaves it
/// whole. Where ours is the base (the larger memory: `peer_into_ours`) and the merge changes
/// it (`changed`), the merge calls `give_up_ours`, which returns `ours` moved out of its owner,
/// and moves its places into the result instead of copying them (on pages fresh from the
/// system the copy of 10⁴ places was 0.1-0.4 s of a 1.0-1.35 s merge; docs/results.md,
/// session 74). Where ours is the base and nothing changes, `give_up_ours` is not called and
/// `memory` is left empty: ours stands as the merged memory. Where ours is the smaller memory
/// it is read and copied from, as by the forms above. An exception after `give_up_ours` was
/// called loses the memory it returned: its caller holds it elsewhere (tscd: in its store).
MemoryMerge MergeMemories(const PlaceMemory& ours, PlaceMemory&& peer, int threads,
                          const std::function<PlaceMemory()>& give_up_ours);

/// Whether MergeMemories(ours, peer) returns ours as it is, told before any descriptor from the
/// peer's robot and its places' ids and sources (`peer_places`: only `id` and `sources` are
/// read): ours is the base (PeerGoesIntoOurs) and holds the id of every peer place, every place
/// of ours is one the peer holds, the peer's records join no two places of ours and name no id
/// ours lacks, and ours carries canonical ids. The merge then recognises nothing and changes
/// nothing. False says nothing: the merge decides. (tscd: most exchanges of a settled team
/// bring nothing new, and building the peer's memory to learn so took 0.65 s of 0.69 s at 10⁴
/// places.)
bool MergeLeavesOurs(const PlaceMemory& ours, uint32_t peer_robot,
                     std::span<const LearnedPlace> peer_places);
/// The merge of a caller that MergeLeavesOurs spared the merge, as the tscd form of
/// MergeMemories returns it where ours stands (nothing new, peer into ours, unchanged, `memory`
/// empty), without the list of known places.
MemoryMerge OursLeftAsItIs(const PlaceMemory& ours);

}  // namespace tsc
