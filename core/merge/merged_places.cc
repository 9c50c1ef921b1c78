#include "core/merge/merged_places.h"

#include <algorithm>
#include <unordered_map>
#include <unordered_set>

#include "core/on_threads.h"

namespace tsc {

Placement PlaceIncoming(const PlaceMemory& base, const PlaceMemory& incoming, const KnownIds& known,
                        const std::vector<int>& targets, const std::vector<int>& holder) {
  const size_t base_count = base.places().size();
  Placement out{
      std::vector<int>(incoming.places().size(), -1), std::vector<char>(base_count, 0), {}};
  for (size_t i = 0; i < incoming.places().size(); ++i) {
    if (!known.is_new[i]) {
      out.merged_index[i] = holder[static_cast<size_t>(known.holder.at(incoming.places()[i].id))];
    } else if (targets[i] >= 0) {
      out.merged_index[i] = targets[i];
      out.updated[static_cast<size_t>(targets[i])] = 1;
    } else {
      out.merged_index[i] = static_cast<int>(base_count + out.added.size());
      out.added.push_back(incoming.places()[i].id);
    }
  }
  for (size_t b = 0; b < base_count; ++b) {
    if (holder[b] == static_cast<int>(b)) continue;
    out.updated[b] = 1;
    out.updated[static_cast<size_t>(holder[b])] = 1;
  }
  return out;
}

std::vector<std::optional<PlaceMemory::Derived>> UnchangedDerived(const PlaceMemory& base,
                                                                  const PlaceMemory& incoming,
                                                                  const Placement& placement,
                                                                  const std::vector<int>& holder,
                                                                  bool fresher_copies) {
  const size_t base_count = placement.updated.size();
  std::vector<std::optional<PlaceMemory::Derived>> out(base_count + placement.added.size());
  std::unordered_set<PlaceId, PlaceIdHash> theirs;
  if (fresher_copies) {
    for (const LearnedPlace& p : incoming.places()) theirs.insert(p.id);
  }
  for (size_t b = 0; b < base_count; ++b) {
    if (placement.updated[b] || theirs.contains(base.places()[b].id)) continue;
    out[b] = base.DerivedOf(static_cast<int>(b));
  }
  for (size_t i = 0; i < placement.merged_index.size(); ++i) {
    const auto m = static_cast<size_t>(placement.merged_index[i]);
    if (m >= base_count) out[m] = incoming.DerivedOf(static_cast<int>(i));
  }
  // Folded places leave the list as MergedTree drops them (they carry nothing: updated).
  size_t kept = 0;
  for (size_t i = 0; i < out.size(); ++i) {
    if (i < holder.size() && holder[i] != static_cast<int>(i)) continue;
    out[kept++] = std::move(out[i]);
  }
  out.resize(kept);
  return out;
}

std::vector<LearnedPlace> PlacesOf(const PlaceMemory& memory, PlaceMemory* owned, int threads) {
  if (owned != nullptr) return std::move(*owned).TakePlaces();
  // The copy of a robot's own memory in tscd's merge: 10⁴ places are ~100 MB, and on pages
  // the system has not handed over yet each fault is paid (0.26 s on one thread of the CI
  // machine, a quarter of the merge; 0.16-0.18 s on two). Shared among the merge's threads.
  const std::vector<LearnedPlace>& from = memory.places();
  std::vector<LearnedPlace> out(from.size());
  constexpr size_t kPlacesAPiece = 256;
  OnBlocks(from.size(), kPlacesAPiece, threads, [&](size_t first, size_t end) {
    std::copy(from.begin() + first, from.begin() + end, out.begin() + first);
  });
  return out;
}

IncomingPlaces::IncomingPlaces(const PlaceMemory& memory, PlaceMemory* owned)
    : memory_(memory), owned_(owned != nullptr) {
  if (owned_) taken_ = std::move(*owned).TakePlaces();
}

LearnedPlace IncomingPlaces::Take(size_t i) {
  if (owned_) return std::move(taken_[i]);
  return memory_.places()[i];
}

void PreferOurFresherCopies(std::vector<LearnedPlace>& places, IncomingPlaces& in) {
  std::unordered_map<PlaceId, size_t, PlaceIdHash> mine;
  for (size_t i = 0; i < in.size(); ++i) mine.emplace(in[i].id, i);
  for (LearnedPlace& b : places) {
    const auto it = mine.find(b.id);
    if (it == mine.end()) continue;
    const LearnedPlace& m = in[it->second];
    const bool peer_added_nothing =
        std::includes(m.sources.begin(), m.sources.end(), b.sources.begin(), b.sources.end());
    if (peer_added_nothing && m.member_count >= b.member_count) {
      b = in.Take(it->second);  // a known place: never added below
    } else if (b.members.empty()) {
      b.members = m.members;
      b.detected = m.detected;
    }
  }
}

void AbsorbRecognised(std::vector<LearnedPlace>& places, const IncomingPlaces& in,
                      const std::vector<char>& is_new, const Recognitions& found,
                      const PlaceMemoryOptions& options, int threads,
                      std::vector<Absorption>& absorbed) {
  // The places each target absorbs, in incoming order: targets are absorbed into side by side
  // (pooling and thinning views was a third of a 10⁴ + 10⁴ merge of half-shared memories once
  // recognition ran on two threads), each one's places in order.
  std::vector<std::vector<size_t>> into;
  std::vector<int> group_of(places.size(), -1);
  for (size_t i = 0; i < in.size(); ++i) {
    if (!is_new[i] || found.target[i] < 0) continue;
    int& g = group_of[static_cast<size_t>(found.target[i])];
    if (g < 0) {
      g = static_cast<int>(into.size());
      into.emplace_back();
    }
    into[static_cast<size_t>(g)].push_back(i);
    absorbed.push_back({in[i].id, places[static_cast<size_t>(found.target[i])].id, found.cost[i]});
  }
  OnThreads(into.size(), threads, [&](size_t g) {
    for (size_t i : into[g]) Absorb(places[static_cast<size_t>(found.target[i])], in[i], options);
  });
}

void FoldJoined(std::vector<LearnedPlace>& places, const std::vector<int>& holder,
                const std::vector<double>& fold_cost,
                const std::vector<std::pair<int, PlaceId>>& learned,
                const PlaceMemoryOptions& options, std::vector<Absorption>& absorbed) {
  for (size_t b = 0; b < holder.size(); ++b) {
    const auto h = static_cast<size_t>(holder[b]);
    if (h == b) continue;
    absorbed.push_back({places[b].id, places[h].id, fold_cost[b]});
    Fold(places[h], places[b], options);
  }
  for (const auto& [b, id] : learned) AddSource(places[static_cast<size_t>(b)], id);
}

void AddNewPlaces(std::vector<LearnedPlace>& places, IncomingPlaces& in,
                  const Placement& placement) {
  const size_t base_count = placement.updated.size();
  places.reserve(base_count + placement.added.size());
  for (size_t i = 0; i < in.size(); ++i) {
    if (placement.merged_index[i] >= static_cast<int>(base_count)) places.push_back(in.Take(i));
  }
}

}  // namespace tsc
