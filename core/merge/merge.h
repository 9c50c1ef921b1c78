#pragma once
// Merging of place memories and topological maps (chapter 4, DESIGN §3.6): a RACHET-style
// case analysis on the hyperspheres S(c(N), ρ(N)) of the two trees, recognition of the
// incoming places against the best-overlapping hyper-terminal, and the map union of §4.6.
// The merged tree is single linkage over both memories' SLINK trees and the cross links the
// merge finds (docs/decisions.md, "Merging").

#include <Eigen/Core>
#include <span>
#include <string_view>
#include <vector>

#include "core/map/topological_map.h"
#include "core/memory/place_id.h"
#include "core/memory/place_memory.h"
#include "core/memory/single_linkage.h"

namespace tsc {

/// The hypersphere S(c(N), ρ(N)) of a set of places.
struct NodeStatistics {
  Eigen::VectorXf centroid;  ///< c(N) of (4.3): mean of the places' means
  double radius = 0.0;       ///< ρ(N) = sqrt(mean_p ‖Ī_p − c(N)‖²) (DESIGN's fix of (4.4))
  int num_places = 0;
};

/// c and ρ over the places `places` (indices into memory.places()). Precondition: non-empty.
NodeStatistics StatisticsOf(const PlaceMemory& memory, std::span<const int> places);
/// c and ρ over every place under `node`.
NodeStatistics NodeStatisticsOf(const PlaceMemory& memory, int node);

/// An inner node whose children include terminals; its terminal children form it (§4.5.2).
struct HyperTerminal {
  int node = -1;            ///< the inner node
  std::vector<int> places;  ///< place indices of its terminal children, in child order
  NodeStatistics sphere;    ///< over `places` only
};
/// The hyper-terminals of a memory in node index order (every place belongs to exactly one).
std::vector<HyperTerminal> HyperTerminals(const PlaceMemory& memory);

/// Overlap of two hyperspheres, the monotone proxy for the lens volume of (4.7) we use: the
/// width of the intersection along the line of centres, min(ρa + ρb − d, 2ρa, 2ρb). Positive
/// when they intersect, negative (minus the gap) when they do not.
double Overlap(const NodeStatistics& a, const NodeStatistics& b);

/// For each hyper-terminal of `incoming` (`hi`), the index in `hb` = HyperTerminals(base) of the
/// one with the largest Overlap; ties go to the nearer centre, then to the lower index. Exact,
/// by branch and bound over base's tree (a node's ball bounds the spheres of the
/// hyper-terminals under it), so a merge does not pay |hi|·|hb| distances. Precondition: `hb`
/// is non-empty and comes from `base`.
std::vector<size_t> MatchHyperTerminals(const PlaceMemory& base,
                                        const std::vector<HyperTerminal>& hb,
                                        const std::vector<HyperTerminal>& hi);

/// The case of figure 4.4 that the root spheres fall in.
enum class MergeCase {
  kNothingNew,             ///< every incoming place was merged before (idempotent re-merge)
  kDisjoint,               ///< 4.4a: ‖c_m − c_n‖ > ρ_m + ρ_n: both trees side by side
  kContained,              ///< 4.4b (case 2-1): no hyper-terminal of the larger intersects
  kContainedIntersecting,  ///< 4.4c (case 2-2)
  kIntersecting,           ///< 4.4d (case 3)
};
std::string_view ToString(MergeCase c);

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

/// Whether MergeMemories(ours, peer) merges the peer into ours (ours is the base, so a merge
/// that brings nothing new returns ours unchanged): the smaller memory by place count goes
/// into the larger; on a tie the memory of the lower robot id is the larger (§4.5.2).
bool PeerGoesIntoOurs(const PlaceMemory& ours, const PlaceMemory& peer);

/// T^m + T^n of figure 4.6 from the perspective of `ours` (robot m). The smaller memory (by
/// place count; on a tie, the one of the higher robot id) is merged into the larger, so the
/// result is the same place set whichever robot computes it. Every merged place carries the
/// smallest id of its group (its id and its sources), whichever memory was the base, and
/// Absorption records name the places by those ids. Deterministic; merging the same peer
/// state again changes nothing. Both memories must have the same descriptor dimension
/// (std::invalid_argument).
MemoryMerge MergeMemories(const PlaceMemory& ours, const PlaceMemory& peer);
/// The same merge for a caller that gives up both memories (a daemon replacing its memory by
/// the merge, a peer's snapshot): their places are moved into the result instead of copied
/// (at 10⁴ + 10⁴ places the copies were about a third of the merge). Same result as the
/// copying form; the inputs are left valid but unspecified (their places moved out).
MemoryMerge MergeMemories(PlaceMemory&& ours, PlaceMemory&& peer);

}  // namespace tsc
