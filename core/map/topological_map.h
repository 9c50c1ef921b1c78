#pragma once
// The topological map (section 3.7): an undirected graph G = {P, E} over learned places; each
// edge remembers how often it was traversed and the transition regions that crossed it.

#include <cstdint>
#include <map>
#include <set>
#include <utility>
#include <vector>

#include "core/detect/place_detector.h"
#include "core/memory/place_id.h"

namespace tsc {

struct MapEdge {
  PlaceId a;  ///< a < b
  PlaceId b;
  int64_t traversals = 0;  ///< every traversal, also those whose region is no longer kept
  /// The latest kMaxTransitions regions at most (oldest first once trimmed).
  std::vector<TransitionRegion> transitions;

  /// A robot crosses an edge without end over months of laps (an accelerated day: up to 981
  /// times), and the edge's row is rewritten at every crossing; the regions are history (the
  /// store thins the base points they name), so an edge keeps the latest only.
  static constexpr size_t kMaxTransitions = 256;
  /// Beyond kMaxTransitions regions, keeps the latest (by first base point), oldest first.
  void TrimTransitions();
};

class TopologicalMap {
 public:
  void AddPlace(PlaceId p);
  /// Records β(D_{m−1})β(D_m). A transition from a place to itself adds no edge and returns
  /// false.
  bool RecordTransition(PlaceId from, PlaceId to, TransitionRegion region);
  /// Restores an edge read from storage. Throws std::invalid_argument if a == b.
  void RestoreEdge(MapEdge edge);

  const std::set<PlaceId>& places() const { return places_; }
  const std::map<std::pair<PlaceId, PlaceId>, MapEdge>& edges() const { return edges_; }
  const MapEdge* Find(PlaceId x, PlaceId y) const;
  /// The places an edge joins to `p`, in increasing order (none for an unknown place).
  std::vector<PlaceId> Neighbours(PlaceId p) const;

 private:
  std::set<PlaceId> places_;
  std::map<std::pair<PlaceId, PlaceId>, MapEdge> edges_;
};

}  // namespace tsc
