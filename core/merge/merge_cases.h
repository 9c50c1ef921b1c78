#pragma once
// The cases of the merge (figure 4.4, §4.5.2): which memory goes into which, and how the root
// spheres of the two trees lie, which decides whether recognition runs at all.

#include <array>
#include <string_view>
#include <vector>

#include "core/memory/place_memory.h"
#include "core/merge/hyper_terminals.h"

namespace tsc {

/// The case of figure 4.4 that the root spheres fall in.
enum class MergeCase {
  kNothingNew,             ///< every incoming place was merged before (idempotent re-merge)
  kDisjoint,               ///< 4.4a: ‖c_m − c_n‖ > ρ_m + ρ_n: both trees side by side
  kContained,              ///< 4.4b (case 2-1): no hyper-terminal of the larger intersects
  kContainedIntersecting,  ///< 4.4c (case 2-2)
  kIntersecting,           ///< 4.4d (case 3)
};
std::string_view ToString(MergeCase c);

/// Whether MergeMemories(ours, peer) merges the peer into ours (ours is the base, so a merge
/// that brings nothing new returns ours unchanged): the smaller memory by place count goes
/// into the larger; on a tie the memory of the lower robot id is the larger (§4.5.2).
bool PeerGoesIntoOurs(const PlaceMemory& ours, const PlaceMemory& peer);
/// The same rule from the place counts and robots of the two memories.
bool PeerGoesIntoOurs(size_t ours_places, uint32_t ours_robot, size_t peer_places,
                      uint32_t peer_robot);

/// The root spheres of the base and of the incoming memory (over all their places) and the
/// case of figure 4.4 they fall in.
struct RootSpheres {
  NodeStatistics base;
  NodeStatistics incoming;
  MergeCase merge_case = MergeCase::kNothingNew;
  /// HyperTerminals of the base ([0]) and of the incoming memory ([1]) where telling a
  /// contained case apart took them (the larger memory's), else empty: recognition takes them
  /// (moved: they need not outlive it) rather than finding them again (~20 ms at 10⁴ places).
  std::array<std::vector<HyperTerminal>, 2> terminals;
};
/// The root spheres of two non-empty memories and their case, each sphere reaching a
/// recognition radius (from `tau_r`) further so that places close enough to be recognised as
/// one never count as apart. Measured on up to `threads` threads (the same for any number).
RootSpheres CaseOfRootSpheres(const PlaceMemory& base, const PlaceMemory& incoming, double tau_r,
                              int threads = 1);
/// Whether places of both memories may coincide in case `c` (4.4c, 4.4d), so that recognition
/// decides; in the other cases every incoming place is added.
bool RecognitionDecides(MergeCase c);

}  // namespace tsc
