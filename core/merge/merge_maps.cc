#include "core/merge/merge_maps.h"

#include <algorithm>
#include <map>
#include <set>
#include <unordered_map>
#include <utility>

namespace tsc {

TopologicalMap MergeMaps(const TopologicalMap& ours, const TopologicalMap& peer,
                         const PlaceMemory& merged) {
  // Which merged place holds an id: its own id first, else the place that absorbed it.
  std::unordered_map<PlaceId, PlaceId, PlaceIdHash> holder;
  for (const LearnedPlace& p : merged.places()) {
    for (PlaceId s : p.sources) holder.emplace(s, p.id);
  }
  for (const LearnedPlace& p : merged.places()) holder[p.id] = p.id;
  auto resolve = [&holder](PlaceId id) {
    auto it = holder.find(id);
    return it == holder.end() ? id : it->second;
  };
  using Edges = std::map<std::pair<PlaceId, PlaceId>, MapEdge>;
  std::set<PlaceId> places;
  // An edge's count is the largest count of the edges that collapse onto it, within a map as
  // between the two maps. Between maps counts cannot add up: memories travel back and forth,
  // so the peer's map already holds the counts it took from ours, and adding them would
  // double every count on each exchange (the soak saw them overflow int64 within minutes).
  // Within a map they used to add up, but a map's edges are themselves edges collapsed by
  // earlier merges, so the sum depended on which places had been joined when (3 robots
  // settling on different counts in different orders). The largest count is idempotent,
  // commutative and associative: once the team agrees on which ids are one place, every
  // robot holds the largest count any robot's own edge between those places has, whatever
  // the order of the merges (docs/decisions.md, "Merging": traversal counts).
  auto collapse = [&](const TopologicalMap& map, bool keep_transitions) {
    Edges edges;
    for (PlaceId p : map.places()) places.insert(resolve(p));
    for (const auto& [unused, e] : map.edges()) {
      PlaceId a = resolve(e.a), b = resolve(e.b);
      if (a == b) continue;  // both ends collapsed onto one place
      if (b < a) std::swap(a, b);
      MapEdge& out = edges.try_emplace({a, b}, MapEdge{a, b, 0, {}}).first->second;
      out.traversals = std::max(out.traversals, e.traversals);
      if (keep_transitions) {
        out.transitions.insert(out.transitions.end(), e.transitions.begin(), e.transitions.end());
      }
    }
    return edges;
  };
  Edges edges = collapse(ours, true);
  for (auto& [key, e] : collapse(peer, false)) {
    auto [it, fresh] = edges.try_emplace(key, std::move(e));
    if (!fresh) it->second.traversals = std::max(it->second.traversals, e.traversals);
  }
  TopologicalMap out;
  for (PlaceId p : places) out.AddPlace(p);
  for (auto& [unused, e] : edges) out.RestoreEdge(std::move(e));
  return out;
}

bool MergeChangesAnything(const MemoryMerge& merged, const TopologicalMap& merged_map,
                          const TopologicalMap& ours_map) {
  if (merged.changed) return true;
  const auto& a = merged_map.edges();
  const auto& b = ours_map.edges();
  return !std::equal(a.begin(), a.end(), b.begin(), b.end(), [](const auto& x, const auto& y) {
    return x.first == y.first && x.second.traversals == y.second.traversals;
  });
}

}  // namespace tsc
