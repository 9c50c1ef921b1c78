#pragma once
// Recognition across two memories in a merge (§4.5.2, (4.1)): each new incoming place against
// the base hyper-terminal its own overlaps most, and the base's fresh places the other way
// round. A place recognised with g ≤ τ_r goes into the other memory's place; a robot's own
// places never join (its pipeline already judged them different).

#include <array>
#include <cstddef>
#include <vector>

#include "core/memory/place_memory.h"
#include "core/merge/hyper_terminals.h"
#include "core/merge/id_join.h"

namespace tsc {

/// What recognition found, per incoming place (`target`, `cost`, `nearest`, `nearest_gamma`)
/// and per base place (`fold_cost`).
struct Recognitions {
  /// Nothing recognised yet: the incoming places `linked` by ids (IdJoin) go into their base
  /// place at cost 0.
  Recognitions(std::vector<int> linked, size_t base_count);

  std::vector<int> target;   ///< the base place absorbing it, −1: none
  std::vector<double> cost;  ///< g of (3.8) of its absorption (0: joined by ids)
  std::vector<int> nearest;  ///< the base place nearest to it among N*'s, −1: not measured
  std::vector<double> nearest_gamma;  ///< γ to `nearest` (a cross link of the merged tree)
  std::vector<double> fold_cost;      ///< g of the recognition that folds this base place into
                                      ///< another (a fresh one recognised as a place the base
                                      ///< knows, or that place's copy; 0: joined by ids alone)
};

/// Recognises the new incoming places (KnownIds::is_new) against `base` and the `fresh` base
/// places (FreshBasePlaces) against `incoming`, with threshold `tau_r` on g. A fresh base place
/// recognised joins the base place holding its match in `join`. Up to `threads` threads share
/// the places (each place's recognition depends only on it and its N*): what is found is the
/// same for any number. `terminals`: HyperTerminals of the base ([0]) and of the incoming
/// memory ([1]) where known already, else empty (they are found here then); they are let go
/// on return, before the merge builds its memory.
void Recognise(const PlaceMemory& base, const PlaceMemory& incoming, const KnownIds& known,
               const std::vector<int>& fresh, double tau_r, int threads, IdJoin& join,
               Recognitions& found, std::array<std::vector<HyperTerminal>, 2> terminals);

}  // namespace tsc
