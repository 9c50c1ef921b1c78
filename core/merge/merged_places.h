#pragma once
// The merged place list of T^m + T^n (figure 4.6): the base's places, updated by what they
// absorb and fold, then the incoming places added as new places in their order.

#include <cstddef>
#include <optional>
#include <utility>
#include <vector>

#include "core/memory/learned_place.h"
#include "core/memory/place_memory.h"
#include "core/merge/id_join.h"
#include "core/merge/merge.h"
#include "core/merge/recognition.h"

namespace tsc {

/// Where each incoming place ends up in the merged place list.
struct Placement {
  /// Per incoming place, the merged place standing for it: the base place that knew or
  /// absorbed it, or its own copy (past the base's places) when added.
  std::vector<int> merged_index;
  std::vector<char> updated;   ///< per base place: it absorbs, folds or is folded
  std::vector<PlaceId> added;  ///< incoming places added as new places, in order
};
/// `targets` and `holder` as ResolveHolders left them.
Placement PlaceIncoming(const PlaceMemory& base, const PlaceMemory& incoming, const KnownIds& known,
                        const std::vector<int>& targets, const std::vector<int>& holder);

/// Per place of the merged memory (base places but those folded into another, then the added
/// ones), what its memory derived from it (PlaceMemory::DerivedOf) where the merge takes it
/// over unchanged: a base place that absorbs and folds nothing, and an incoming place added as
/// it is. None for the rest, and with `fresher_copies` (PreferOurFresherCopies will run) none
/// for a base place the incoming memory also holds. Read before either memory is given up.
std::vector<std::optional<PlaceMemory::Derived>> UnchangedDerived(const PlaceMemory& base,
                                                                  const PlaceMemory& incoming,
                                                                  const Placement& placement,
                                                                  const std::vector<int>& holder,
                                                                  bool fresher_copies);

/// The places of `memory`: moved out of `owned` (the same memory, given up by the caller) when
/// there is one, copied otherwise, on up to `threads` threads.
std::vector<LearnedPlace> PlacesOf(const PlaceMemory& memory, PlaceMemory* owned, int threads);

/// The incoming memory's places, read where they are or, when the caller gave the memory up
/// (`owned`), moved out of it at construction; Take copies or moves a place out. A merge copies
/// only what it keeps (at 10⁴ + 10⁴ places the copies were about a third of the merge).
class IncomingPlaces {
 public:
  IncomingPlaces(const PlaceMemory& memory, PlaceMemory* owned);
  IncomingPlaces(const IncomingPlaces&) = delete;
  IncomingPlaces& operator=(const IncomingPlaces&) = delete;

  size_t size() const { return places().size(); }
  const LearnedPlace& operator[](size_t i) const { return places()[i]; }
  /// Place i, moved out when the memory was given up (read it no more then).
  LearnedPlace Take(size_t i);

 private:
  const std::vector<LearnedPlace>& places() const { return owned_ ? taken_ : memory_.places(); }

  const PlaceMemory& memory_;
  const bool owned_;
  std::vector<LearnedPlace> taken_;
};

/// When ours goes into the larger peer memory, the peer (`in`) may hold copies of our places
/// (`places`) taken from an earlier snapshot of ours. Our own copy is fresher (it may have
/// learned more since) and only ours has its members, which index our frames: take it, unless
/// the peer has since absorbed something into its copy, in which case only the members are
/// taken.
void PreferOurFresherCopies(std::vector<LearnedPlace>& places, IncomingPlaces& in);

/// The recognised incoming places go into their base places, recorded in `absorbed` in
/// incoming order; up to `threads` threads absorb into different base places side by side
/// (each base place takes its incoming places in order: the same result for any number).
void AbsorbRecognised(std::vector<LearnedPlace>& places, const IncomingPlaces& in,
                      const std::vector<char>& is_new, const Recognitions& found,
                      const PlaceMemoryOptions& options, int threads,
                      std::vector<Absorption>& absorbed);

/// What the peer's records join (JoinByIds): base places fold into their holder (they leave
/// the list with the merged tree), recorded in `absorbed`, and ids a known incoming place
/// absorbed (`learned`) become sources.
void FoldJoined(std::vector<LearnedPlace>& places, const std::vector<int>& holder,
                const std::vector<double>& fold_cost,
                const std::vector<std::pair<int, PlaceId>>& learned,
                const PlaceMemoryOptions& options, std::vector<Absorption>& absorbed);

/// Incoming places that are neither known nor absorbed are added after the base's places.
/// (When ours is the smaller memory, our own places already known to the peer are not: the
/// peer's place holds them.)
void AddNewPlaces(std::vector<LearnedPlace>& places, IncomingPlaces& in,
                  const Placement& placement);

}  // namespace tsc
