#include "core/map/topological_map.h"

#include <algorithm>
#include <stdexcept>

#include "core/keep_latest.h"

namespace tsc {
namespace {
std::pair<PlaceId, PlaceId> Key(PlaceId x, PlaceId y) {
  return x < y ? std::make_pair(x, y) : std::make_pair(y, x);
}
}  // namespace

void MapEdge::TrimTransitions() {
  if (transitions.size() <= kMaxTransitions) return;
  std::stable_sort(
      transitions.begin(), transitions.end(),
      [](const TransitionRegion& x, const TransitionRegion& y) { return x.first < y.first; });
  KeepLatest(transitions, kMaxTransitions);
}

void TopologicalMap::AddPlace(PlaceId p) { places_.insert(p); }

bool TopologicalMap::RecordTransition(PlaceId from, PlaceId to, TransitionRegion region) {
  if (from == to) return false;
  places_.insert(from);
  places_.insert(to);
  const auto key = Key(from, to);
  auto [it, inserted] = edges_.try_emplace(key, MapEdge{key.first, key.second, 0, {}});
  ++it->second.traversals;
  if (!region.empty()) {
    it->second.transitions.push_back(region);
    it->second.TrimTransitions();
  }
  return true;
}

void TopologicalMap::RestoreEdge(MapEdge edge) {
  if (edge.a == edge.b) {
    throw std::invalid_argument("map edge from place " + edge.a.ToString() + " to itself");
  }
  const auto key = Key(edge.a, edge.b);
  edge.a = key.first;
  edge.b = key.second;
  places_.insert(edge.a);
  places_.insert(edge.b);
  edge.TrimTransitions();  // a merge joins the regions of the edges it collapses
  edges_[key] = std::move(edge);
}

const MapEdge* TopologicalMap::Find(PlaceId x, PlaceId y) const {
  auto it = edges_.find(Key(x, y));
  return it == edges_.end() ? nullptr : &it->second;
}

std::vector<PlaceId> TopologicalMap::Neighbours(PlaceId p) const {
  std::vector<PlaceId> out;
  // Edges are keyed (a, b) with a < b: those with a == p are one range, those with b == p
  // are spread over the keys below it. A scan: it runs once per closed place, not per frame.
  for (const auto& [key, edge] : edges_) {
    if (key.first == p) out.push_back(key.second);
    if (key.second == p) out.push_back(key.first);
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace tsc
