#pragma once
// Joining by ids (docs/decisions.md, "Merging": joining by ids, canonical ids): what the ids
// of both memories say before any descriptor is compared — incoming places merged before,
// base places one incoming place holds together — and how a merged place takes in another
// place and its ids.

#include <cstdint>
#include <numeric>
#include <span>
#include <unordered_map>
#include <utility>
#include <vector>

#include "core/memory/learned_place.h"
#include "core/memory/place_id.h"
#include "core/memory/place_memory.h"
#include "core/merge/merge.h"

namespace tsc {

/// The incoming places the base already holds, as a place or as an absorbed source: they were
/// merged before and are left as they are (idempotence).
struct KnownIds {
  /// Each id the base holds → the base place holding it (its own id before any source).
  std::unordered_map<PlaceId, int, PlaceIdHash> holder;
  std::vector<char> is_new;    ///< per incoming place: 1 when the base does not hold its id
  std::vector<PlaceId> known;  ///< the incoming places' ids the base holds, in incoming order
  bool anything_new = false;   ///< some incoming place is new
};
/// `incoming`: the incoming memory's places (only their ids and sources are read).
KnownIds KnownToBase(const PlaceMemory& base, std::span<const LearnedPlace> incoming);

/// Base places the incoming memory has never held (a peer's places learned since it last
/// merged ours, when the peer is the base).
struct FreshPlaces {
  std::vector<int> places;       ///< base place indices whose id the incoming never held
  bool base_knows_more = false;  ///< an id, as a place or a source, the incoming never held
};
FreshPlaces FreshBasePlaces(const PlaceMemory& base, std::span<const LearnedPlace> incoming);

/// Base places that are one place: a union-find whose class root is its lowest index, so the
/// result does not depend on the order in which unions are found.
class PlaceUnion {
 public:
  explicit PlaceUnion(size_t n) : holder_(n) { std::iota(holder_.begin(), holder_.end(), 0); }
  int Find(int x);
  void Unite(int a, int b);
  bool united() const { return united_; }
  /// Per place, the place holding it (itself if none).
  std::vector<int> Holders();

 private:
  std::vector<int> holder_;
  bool united_ = false;
};

/// What the incoming memory's records of absorptions (its places' sources) say about the base.
/// A place is one place with every place it shares an id with, whichever robot recognised them:
/// two base places that one incoming place holds are one (`places`), an incoming place new to
/// the base that holds a base place's id is absorbed by it without recognition (`linked`), and
/// ids a known incoming place absorbed become sources of its holder (`learned`). Then every
/// robot ends up with the union of the team's recognitions whatever the order of the exchanges,
/// and the final memories agree.
struct IdJoin {
  PlaceUnion places;
  std::vector<int> linked;  ///< per incoming place new to the base: a base place holding one of
                            ///< its sources, −1 if none
  std::vector<std::pair<int, PlaceId>> learned;  ///< (base place, id) for ids new to the base
};
/// `known` is KnownToBase(base, incoming).holder.
IdJoin JoinByIds(const PlaceMemory& base, std::span<const LearnedPlace> incoming,
                 const std::unordered_map<PlaceId, int, PlaceIdHash>& known);
/// Once every union is known: each base place's holder, with `targets` (base places, −1:
/// none) and `join.learned` moved onto the holders.
std::vector<int> ResolveHolders(IdJoin& join, std::vector<int>& targets);

/// Adds `id` to the sorted sources of `target` unless it is there or is target's own id.
void AddSource(LearnedPlace& target, PlaceId id);
/// Whether `p` carries the smallest id of its group (its own and its sources).
bool CarriesSmallestId(const LearnedPlace& p);
/// Merges the incoming place `p` into `target`: weighted mean by member counts, counts added,
/// ids absorbed, samples pooled and thinned to options.SampleCap of the result (each place
/// absorbed is a visit). Members and detected places index the other robot's stream and are
/// not copied.
void Absorb(LearnedPlace& target, const LearnedPlace& p, const PlaceMemoryOptions& options);
/// Folds the base place `b` into `target` when the peer's records say they are one place: as
/// Absorb, and members and detected places are kept too when both are one robot's places
/// (they index the same stream).
void Fold(LearnedPlace& target, const LearnedPlace& b, const PlaceMemoryOptions& options);

/// Canonical ids: every place of `places` takes the smallest id of its group whichever memory
/// was the base, and the records `absorbed` name the places as they are then (a renamed
/// target's new id absorbed its old one).
void TakeSmallestIds(std::vector<LearnedPlace>& places, std::vector<Absorption>& absorbed);

/// The next local id of robot `robot` after merging into `places`: past `next_local` and every
/// id of its own the team still holds, as a place or as a source.
uint32_t NextLocalId(const std::vector<LearnedPlace>& places, uint32_t robot, uint32_t next_local);

}  // namespace tsc
