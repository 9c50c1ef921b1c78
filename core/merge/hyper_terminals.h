#pragma once
// Hyper-terminals (§4.5.2) and the hyperspheres S(c(N), ρ(N)) of (4.3)-(4.4): the groups of
// terminal places the merge compares across two trees, and the match of each incoming
// hyper-terminal to the base one it overlaps most ((4.6)-(4.7)).

#include <Eigen/Core>
#include <cstddef>
#include <span>
#include <vector>

#include "core/memory/place_memory.h"

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

}  // namespace tsc
