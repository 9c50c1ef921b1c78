#include "core/merge/merge.h"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include "core/merge/id_join.h"
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
}

// The places of `memory`: moved out of `owned` (the same memory, given up by the caller) when
// there is one, copied otherwise.
std::vector<LearnedPlace> PlacesOf(const PlaceMemory& memory, PlaceMemory* owned) {
  if (owned != nullptr) return std::move(*owned).TakePlaces();
  return memory.places();
}

// Figure 4.4's case of the root spheres (`spheres`), then recognition where they meet (into
// `join` and `found`). Returns the case of the merge: kNothingNew when no incoming place is
// new, even if fresh base places were recognised.
MergeCase CaseAndRecognition(const PlaceMemory& base, const PlaceMemory& incoming,
                             const KnownIds& known, const FreshPlaces& fresh, double tau_r,
                             IdJoin& join, Recognitions& found, RootSpheres& spheres) {
  if ((known.anything_new || !fresh.places.empty()) && !base.empty() && !incoming.empty()) {
    spheres = CaseOfRootSpheres(base, incoming, tau_r);
    if (RecognitionDecides(spheres.merge_case)) {
      Recognise(base, incoming, known, fresh.places, tau_r, join, found);
    }
    return known.anything_new ? spheres.merge_case : MergeCase::kNothingNew;
  }
  // An empty base: everything is added.
  return known.anything_new ? MergeCase::kDisjoint : MergeCase::kNothingNew;
}

// MergeMemories. `ours_owned` / `peer_owned` point at `ours` / `peer` when the caller gave
// them up: their places are then moved into the result instead of copied.
MemoryMerge Merge(const PlaceMemory& ours, const PlaceMemory& peer, PlaceMemory* ours_owned,
                  PlaceMemory* peer_owned) {
  CheckSameDimension(ours, peer);
  // Both robots compute the same place set whichever of them merges.
  const bool peer_into_ours = PeerGoesIntoOurs(ours, peer);
  const PlaceMemory& base = peer_into_ours ? ours : peer;
  const PlaceMemory& incoming = peer_into_ours ? peer : ours;
  PlaceMemory* const base_owned = peer_into_ours ? ours_owned : peer_owned;
  PlaceMemory* const incoming_owned = peer_into_ours ? peer_owned : ours_owned;
  // Copies: `ours` may be given up (emptied) before the merged memory is made.
  const PlaceMemoryOptions options = ours.options();
  const uint32_t robot = ours.robot(), next_local = ours.next_local_id();
  MemoryMerge result{
      PlaceMemory(robot, options), MergeCase::kNothingNew, peer_into_ours, {}, {}, {}, 0};

  // What the ids say, then the case of the root spheres and recognition where they meet.
  const KnownIds known = KnownToBase(base, incoming);
  result.known = known.known;
  IdJoin join = JoinByIds(base, incoming, known.holder);
  const FreshPlaces fresh = FreshBasePlaces(base, incoming);
  Recognitions found(join.linked, base.places().size());
  RootSpheres spheres;
  result.merge_case =
      CaseAndRecognition(base, incoming, known, fresh, options.tau_r, join, found, spheres);
  const std::vector<int> holder = ResolveHolders(join, found.target);
  // A memory from before canonical ids (a store written earlier) is renamed by any merge.
  const bool renames = !std::all_of(ours.places().begin(), ours.places().end(), CarriesSmallestId);
  result.changed = known.anything_new || join.places.united() || !join.learned.empty() ||
                   (!peer_into_ours && fresh.base_knows_more) || renames;
  if (!result.changed && peer_into_ours) {  // ours unchanged: no need to rebuild it
    result.memory = ours_owned != nullptr ? std::move(*ours_owned) : ours;
    return result;
  }

  // Which merged place stands for each incoming place in the merged place list (the base's
  // places, then the added incoming places in their order): the base place that knew or
  // absorbed it, or its own copy when added.
  const size_t base_count = base.places().size();
  std::vector<int> merged_index(incoming.places().size(), -1);
  std::vector<char> updated(base_count, 0);
  for (size_t i = 0; i < incoming.places().size(); ++i) {
    if (!known.is_new[i]) {
      merged_index[i] = holder[static_cast<size_t>(known.holder.at(incoming.places()[i].id))];
    } else if (found.target[i] >= 0) {
      merged_index[i] = found.target[i];
      updated[static_cast<size_t>(found.target[i])] = 1;
    } else {
      merged_index[i] = static_cast<int>(base_count + result.added.size());
      result.added.push_back(incoming.places()[i].id);
    }
  }

  for (size_t b = 0; b < base_count; ++b) {
    if (holder[b] == static_cast<int>(b)) continue;
    updated[b] = 1;
    updated[static_cast<size_t>(holder[b])] = 1;
  }

  // Discriminants whose training set did not change are reused by set key: the base's nodes
  // not on the path of an updated place, and the incoming nodes all of whose places were
  // added as they are (children precede parents in node order). Taken before the places are
  // moved out of a memory given up by the caller (the copies share the trained models).
  std::unordered_map<uint64_t, OneClassDiscriminant> saved;
  auto keep = [&saved](const PlaceMemory& m, const std::vector<char>& skip) {
    for (size_t i = 0; i < m.nodes().size(); ++i) {
      if (skip[i]) continue;
      if (m.discriminants()[i].trained()) {
        saved.try_emplace(m.nodes()[i].set_key, m.discriminants()[i]);
      }
    }
  };
  std::vector<char> foreign(incoming.nodes().size(), 0);
  for (size_t i = 0; i < incoming.nodes().size(); ++i) {
    const MemoryNode& nd = incoming.nodes()[i];
    if (nd.terminal()) {
      const auto p = static_cast<size_t>(nd.place);
      foreign[i] = !known.is_new[p] || found.target[p] >= 0;
    } else {
      for (int c : nd.children) foreign[i] = foreign[i] || foreign[static_cast<size_t>(c)];
    }
  }
  std::vector<char> stale(base.nodes().size(), 0);
  for (size_t p = 0; p < updated.size(); ++p) {
    if (!updated[p]) continue;
    for (int n = static_cast<int>(p); n >= 0 && !stale[static_cast<size_t>(n)];
         n = base.nodes()[static_cast<size_t>(n)].parent) {
      stale[static_cast<size_t>(n)] = 1;
    }
  }
  keep(base, stale);
  keep(incoming, foreign);
  std::unordered_set<uint64_t> reused_keys;
  reused_keys.reserve(saved.size());
  for (const auto& [key, unused] : saved) reused_keys.insert(key);
  // The SLINK states are small (no descriptors): copies outlive the places' owners.
  const Slink base_slink = base.slink(), incoming_slink = incoming.slink();

  // The merged place list: the base's places (updated by what they absorb), then the added
  // incoming places. From here on `base` and `incoming` may be empty (given up): their places
  // are in `places` and `in`.
  std::vector<LearnedPlace> places = PlacesOf(base, base_owned);
  std::vector<LearnedPlace> taken;
  if (incoming_owned != nullptr) taken = std::move(*incoming_owned).TakePlaces();
  const std::vector<LearnedPlace>& in = incoming_owned != nullptr ? taken : incoming.places();
  // Copies an incoming place, or moves it when the caller gave up its memory.
  auto take = [&](size_t i) -> LearnedPlace {
    if (incoming_owned != nullptr) return std::move(taken[i]);
    return in[i];
  };
  // When ours goes into the larger peer memory, the peer may hold copies of our places taken
  // from an earlier snapshot of ours. Our own copy is fresher (it may have learned more since)
  // and only ours has its members, which index our frames: take it, unless the peer has since
  // absorbed something into its copy, in which case only the members are taken.
  if (!result.peer_into_ours) {
    std::unordered_map<PlaceId, size_t, PlaceIdHash> mine;
    for (size_t i = 0; i < in.size(); ++i) mine.emplace(in[i].id, i);
    for (LearnedPlace& b : places) {
      const auto it = mine.find(b.id);
      if (it == mine.end()) continue;
      const LearnedPlace& m = in[it->second];
      const bool peer_added_nothing =
          std::includes(m.sources.begin(), m.sources.end(), b.sources.begin(), b.sources.end());
      if (peer_added_nothing && m.member_count >= b.member_count) {
        b = take(it->second);  // a known place: never added below
      } else if (b.members.empty()) {
        b.members = m.members;
        b.detected = m.detected;
      }
    }
  }
  for (size_t i = 0; i < in.size(); ++i) {
    if (!known.is_new[i] || found.target[i] < 0) continue;
    const LearnedPlace& p = in[i];
    Absorb(places[static_cast<size_t>(found.target[i])], p, options.max_samples_per_place);
    result.absorbed.push_back(
        {p.id, places[static_cast<size_t>(found.target[i])].id, found.cost[i]});
  }
  // What the peer's records join (JoinByIds): base places fold into their holder (they leave
  // the list with the tree below), and ids a known incoming place absorbed become sources.
  bool folds = false;
  for (size_t b = 0; b < base_count; ++b) {
    const auto h = static_cast<size_t>(holder[b]);
    if (h == b) continue;
    folds = true;
    result.absorbed.push_back({places[b].id, places[h].id, found.fold_cost[b]});
    Fold(places[h], places[b], options.max_samples_per_place);
  }
  for (const auto& [b, id] : join.learned) AddSource(places[static_cast<size_t>(b)], id);
  // Incoming places that are neither known nor absorbed are added; when ours is the smaller
  // memory, our own places already known to the peer are dropped (the peer's place holds them).
  places.reserve(base_count + result.added.size());
  for (size_t i = 0; i < in.size(); ++i) {
    if (merged_index[i] >= static_cast<int>(base_count)) places.push_back(take(i));
  }
  // The merged tree: single linkage over the base's SLINK tree, the incoming SLINK tree with
  // each incoming place standing for the merged place that holds it, and cross links between
  // the two (docs/decisions.md, "Merging"). Inserting every added place into the base's SLINK
  // would need γ to every earlier place, |added|·|places|·dim operations.
  Slink slink = base_slink;
  if (places.size() > base_count || folds) {
    std::vector<Link> links = LinksOf(base_slink);
    links.reserve(places.size() * 2);
    // Between two base places the base's own links rule: the incoming tree links added ones.
    const int base_end = static_cast<int>(base_count);
    for (const Link& l : LinksOf(incoming_slink)) {
      const int a = merged_index[static_cast<size_t>(l.a)];
      const int b = merged_index[static_cast<size_t>(l.b)];
      if (a != b && (a >= base_end || b >= base_end)) links.push_back({l.gamma, a, b});
    }
    bool crossed = false;
    for (size_t i = 0; i < in.size(); ++i) {
      if (found.nearest[i] < 0 || merged_index[i] < base_end) continue;
      links.push_back({found.nearest_gamma[i], found.nearest[i], merged_index[i]});
      crossed = true;
    }
    if (!crossed && base_count > 0 && places.size() > base_count) {
      // Figure 4.4a/b: the trees join as wholes. The link runs between the base place nearest
      // the incoming centroid and the added place nearest the base centroid; contained
      // (4.4b), it joins at the base root's height so the smaller tree hangs under that root;
      // disjoint (4.4a), no lower than either root, so it makes a new root.
      auto nearest_to = [&places](const Eigen::VectorXf& c, size_t first, size_t end) {
        size_t best = first;
        double best_gamma = std::numeric_limits<double>::infinity();
        for (size_t j = first; j < end; ++j) {
          const double g = (places[j].mean - c).squaredNorm();
          if (g < best_gamma) {
            best_gamma = g;
            best = j;
          }
        }
        return best;
      };
      const size_t a = nearest_to(spheres.incoming.centroid, 0, base_count);
      const size_t b = nearest_to(spheres.base.centroid, base_count, places.size());
      auto top = [](const Slink& tree) {
        return tree.order().empty() ? 0.0 : tree.order().back().first;
      };
      double gamma = std::max(top(base_slink), top(incoming_slink));
      if (result.merge_case == MergeCase::kDisjoint) {
        gamma =
            std::max(gamma, static_cast<double>((places[a].mean - places[b].mean).squaredNorm()));
      }
      links.push_back({gamma, static_cast<int>(a), static_cast<int>(b)});
    }
    if (folds) {  // a folded base place stands for its holder in every link
      std::vector<int> index(places.size(), -1);
      std::vector<LearnedPlace> kept;
      kept.reserve(places.size());
      for (size_t i = 0; i < places.size(); ++i) {
        if (i < base_count && holder[i] != static_cast<int>(i)) continue;
        index[i] = static_cast<int>(kept.size());
        kept.push_back(std::move(places[i]));
      }
      // Holders precede the places folded into them.
      for (size_t b = 0; b < base_count; ++b) index[b] = index[static_cast<size_t>(holder[b])];
      for (Link& l : links) {
        l.a = index[static_cast<size_t>(l.a)];
        l.b = index[static_cast<size_t>(l.b)];
      }
      places = std::move(kept);
    }
    slink = SingleLinkage(static_cast<int>(places.size()), std::move(links));
  }

  TakeSmallestIds(places, result.absorbed);
  const uint32_t next = NextLocalId(places, robot, next_local);
  result.memory = PlaceMemory::Restore(robot, options, std::move(places), std::move(slink), next,
                                       std::move(saved));
  // Count the non-root nodes whose key was not among the reusable discriminants.
  for (size_t i = 0; i < result.memory.nodes().size(); ++i) {
    if (static_cast<int>(i) == result.memory.root()) continue;
    if (!reused_keys.contains(result.memory.nodes()[i].set_key)) ++result.retrained;
  }
  return result;
}

}  // namespace

MemoryMerge MergeMemories(const PlaceMemory& ours, const PlaceMemory& peer) {
  return Merge(ours, peer, nullptr, nullptr);
}

MemoryMerge MergeMemories(PlaceMemory&& ours, PlaceMemory&& peer) {
  if (&ours == &peer) return Merge(ours, peer, nullptr, nullptr);
  return Merge(ours, peer, &ours, &peer);
}

}  // namespace tsc
