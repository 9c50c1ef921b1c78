#pragma once
// Single linkage over a sparse graph (Kruskal), in SLINK's pointer representation: the merge
// builds the merged memory's tree from the two trees and their cross links with it
// (docs/decisions.md, "Merging").

#include <vector>

#include "core/memory/slink.h"

namespace tsc {

/// An edge of a spanning graph for single linkage: places a and b at squared distance γ.
struct Link {
  double gamma = 0.0;  ///< γ of (3.12), ≥ 0 and finite
  int a = 0;
  int b = 0;
};
/// The pointer representation (π, λ) of the single-linkage dendrogram of the graph on places
/// 0..n−1 with edges `links` (Kruskal: λ(i) is the height at which i stops being the last
/// place of its cluster, π(i) the last place of the cluster it joins). Over all pairs it equals
/// SLINK's state; over a spanning subset it is single linkage of the minimax path distances of
/// that graph. Components the links leave apart are joined at the largest γ. Deterministic
/// (ties by place indices). Throws std::invalid_argument on an index outside [0, n) or a
/// negative or non-finite γ.
Slink SingleLinkage(int n, std::vector<Link> links);
/// The edges of a pointer representation: i–π(i) at λ(i) for every place i but the last, in
/// order of i. They span its places, so SingleLinkage(s.size(), LinksOf(s)) gives s back.
std::vector<Link> LinksOf(const Slink& s);

}  // namespace tsc
