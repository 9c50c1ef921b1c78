#include "core/merge/merge.h"

#include <algorithm>
#include <cstdint>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include "core/merge/discriminant_reuse.h"
#include "core/merge/id_join.h"
#include "core/merge/merged_places.h"
#include "core/merge/merged_tree.h"
#include "core/merge/recognition.h"

namespace tsc {
namespace {

void CheckSameDimension(const PlaceMemory& ours, const PlaceMemory& peer) {
  if (!ours.empty() && !peer.empty() &&
      ours.places().front().mean.size() != peer.places().front().mean.size()) {
    throw std::invalid_argument("cannot merge memories of descriptor dimensions " +
                                std::to_string(ours.places().front().mean.size()) + " and " +
                                std::to_string(peer.places().front().mean.size()));
  }
  // Views of different bases are not comparable (core/memory/view_basis.h).
  const ViewBasis* a = ours.view_basis();
  const ViewBasis* b = peer.view_basis();
  if ((a == nullptr) != (b == nullptr) || (a && a->id() != b->id())) {
    throw std::invalid_argument(
        "cannot merge memories whose member views are kept in different "
        "bases (" +
        std::string(a ? a->name() : "none") + " and " + std::string(b ? b->name() : "none") + ")");
  }
}

// Figure 4.4's case of the root spheres (`spheres`), then recognition where they meet (into
// `join` and `found`). Returns the case of the merge: kNothingNew when no incoming place is
// new, even if fresh base places were recognised.
MergeCase CaseAndRecognition(const PlaceMemory& base, const PlaceMemory& incoming,
                             const KnownIds& known, const FreshPlaces& fresh, double tau_r,
                             int threads, IdJoin& join, Recognitions& found, RootSpheres& spheres) {
  if ((known.anything_new || !fresh.places.empty()) && !base.empty() && !incoming.empty()) {
    spheres = CaseOfRootSpheres(base, incoming, tau_r, threads);
    if (RecognitionDecides(spheres.merge_case)) {
      Recognise(base, incoming, known, fresh.places, tau_r, threads, join, found,
                std::move(spheres.terminals));
    }
    return known.anything_new ? spheres.merge_case : MergeCase::kNothingNew;
  }
  // An empty base: everything is added.
  return known.anything_new ? MergeCase::kDisjoint : MergeCase::kNothingNew;
}

// MergeMemories. `ours_owned` / `peer_owned` point at `ours` / `peer` when the caller gave
// them up: their places are then moved into the result instead of copied. `give_up_ours`, when
// not null, hands `ours` over where it is the base and the merge changes it (tscd's form).
MemoryMerge Merge(const PlaceMemory& ours, const PlaceMemory& peer, PlaceMemory* ours_owned,
                  PlaceMemory* peer_owned, int threads,
                  const std::function<PlaceMemory()>* give_up_ours = nullptr) {
  CheckSameDimension(ours, peer);
  // Both robots compute the same place set whichever of them merges.
  const bool peer_into_ours = PeerGoesIntoOurs(ours, peer);
  const PlaceMemory& base = peer_into_ours ? ours : peer;
  const PlaceMemory& incoming = peer_into_ours ? peer : ours;
  PlaceMemory* base_owned = peer_into_ours ? ours_owned : peer_owned;
  PlaceMemory* const incoming_owned = peer_into_ours ? peer_owned : ours_owned;
  // Copies: `ours` may be given up (emptied) before the merged memory is made.
  const PlaceMemoryOptions options = ours.options();
  const uint32_t robot = ours.robot(), next_local = ours.next_local_id();
  MemoryMerge result{
      PlaceMemory(robot, options), MergeCase::kNothingNew, peer_into_ours, {}, {}, {}, 0};

  // What the ids say, then the case of the root spheres and recognition where they meet.
  const KnownIds known = KnownToBase(base, incoming.places());
  result.known = known.known;
  IdJoin join = JoinByIds(base, incoming.places(), known.holder);
  const FreshPlaces fresh = FreshBasePlaces(base, incoming.places());
  Recognitions found(join.linked, base.places().size());
  RootSpheres spheres;
  result.merge_case = CaseAndRecognition(base, incoming, known, fresh, options.tau_r, threads, join,
                                         found, spheres);
  const std::vector<int> holder = ResolveHolders(join, found.target);
  // A memory from before canonical ids (a store written earlier) is renamed by any merge.
  const bool renames = !std::all_of(ours.places().begin(), ours.places().end(), CarriesSmallestId);
  result.changed = known.anything_new || join.places.united() || !join.learned.empty() ||
                   (!peer_into_ours && fresh.base_knows_more) || renames;
  if (!result.changed && peer_into_ours) {       // ours unchanged: no need to rebuild it
    if (give_up_ours != nullptr) return result;  // ours stands as the merged memory
    result.memory = ours_owned != nullptr ? std::move(*ours_owned) : ours;
    return result;
  }

  const Placement placement = PlaceIncoming(base, incoming, known, found.target, holder);
  result.added = placement.added;
  // Taken before the places are moved out of a memory given up by the caller. The SLINK
  // states are small (no descriptors): copies outlive the places' owners.
  ReusableDiscriminants reusable =
      ReusableDiscriminantsOf(base, incoming, placement, known.is_new, found.target);
  const Slink base_tree = base.slink(), incoming_tree = incoming.slink();
  std::vector<std::optional<PlaceMemory::Derived>> derived =
      UnchangedDerived(base, incoming, placement, holder, !peer_into_ours);

  // From here on `base` and `incoming` may be empty (given up): their places are in `places`
  // and `in`.
  std::optional<PlaceMemory> given_up;
  if (give_up_ours != nullptr && peer_into_ours) {
    const size_t count = base.places().size();  // `base` is emptied as it is handed over
    given_up.emplace((*give_up_ours)());
    if (given_up->places().size() != count || given_up->robot() != robot) {
      throw std::logic_error("MergeMemories: give_up_ours handed over another memory");
    }
    base_owned = &*given_up;
  }
  std::vector<LearnedPlace> places = PlacesOf(base, base_owned, threads);
  IncomingPlaces in(incoming, incoming_owned);
  if (!peer_into_ours) PreferOurFresherCopies(places, in);
  AbsorbRecognised(places, in, known.is_new, found, options, threads, result.absorbed);
  FoldJoined(places, holder, found.fold_cost, join.learned, options, result.absorbed);
  AddNewPlaces(places, in, placement);
  Slink tree =
      MergedTree(base_tree, incoming_tree, placement.merged_index, found, holder, spheres, places);
  TakeSmallestIds(places, result.absorbed);
  const uint32_t next = NextLocalId(places, robot, next_local);
  result.memory = PlaceMemory::Restore(robot, options, std::move(places), std::move(tree), next,
                                       std::move(reusable.by_key), std::move(derived), threads);
  result.retrained = Retrained(result.memory, reusable.keys);
  return result;
}

}  // namespace

MemoryMerge MergeMemories(const PlaceMemory& ours, const PlaceMemory& peer, int threads) {
  return Merge(ours, peer, nullptr, nullptr, threads);
}

MemoryMerge MergeMemories(PlaceMemory&& ours, PlaceMemory&& peer, int threads) {
  if (&ours == &peer) return Merge(ours, peer, nullptr, nullptr, threads);
  return Merge(ours, peer, &ours, &peer, threads);
}

MemoryMerge MergeMemories(const PlaceMemory& ours, PlaceMemory&& peer, int threads) {
  if (&ours == &peer) return Merge(ours, peer, nullptr, nullptr, threads);
  return Merge(ours, peer, nullptr, &peer, threads);
}

MemoryMerge MergeMemories(const PlaceMemory& ours, PlaceMemory&& peer, int threads,
                          const std::function<PlaceMemory()>& give_up_ours) {
  if (&ours == &peer) return Merge(ours, peer, nullptr, nullptr, threads);
  return Merge(ours, peer, nullptr, &peer, threads, &give_up_ours);
}

bool MergeLeavesOurs(const PlaceMemory& ours, uint32_t peer_robot,
                     std::span<const LearnedPlace> peer_places) {
  // Merge's own tests, in its order: with nothing new and no fresh base place it recognises
  // nothing, so only the ids can change ours.
  if (!PeerGoesIntoOurs(ours.places().size(), ours.robot(), peer_places.size(), peer_robot)) {
    return false;
  }
  const KnownIds known = KnownToBase(ours, peer_places);
  if (known.anything_new || !FreshBasePlaces(ours, peer_places).places.empty()) return false;
  const IdJoin join = JoinByIds(ours, peer_places, known.holder);
  return !join.places.united() && join.learned.empty() &&
         std::all_of(ours.places().begin(), ours.places().end(), CarriesSmallestId);
}

MemoryMerge OursLeftAsItIs(const PlaceMemory& ours) {
  return MemoryMerge{
      PlaceMemory(ours.robot(), ours.options()), MergeCase::kNothingNew, true, {}, {}, {}};
}

}  // namespace tsc
