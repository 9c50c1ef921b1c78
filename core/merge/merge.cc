#include "core/merge/merge.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <set>
#include <stdexcept>
#include <string>
#include <tuple>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include "core/memory/member_views.h"
#include "core/memory/recognition_cost.h"

namespace tsc {
namespace {

// g of (4.1) for the incoming place `p` against hyper-terminal `h` of `base`: the g_N of
// recognition (core/memory/recognition_cost.h) with p's member views as the vote points and
// N*'s children as the candidates; only a terminal can absorb p, so an inner child of N*
// only enters the ratio. Sets `best` to the nearest terminal place P¹ and `best_gamma` to
// γ(p, P¹) between the means (the distance of the merged SLINK tree); −1, with an infinite
// cost, when no terminal child of N* can take p.
double RecognitionCost(const PlaceMemory& base, const HyperTerminal& h, const LearnedPlace& p,
                       int* best, double* best_gamma) {
  std::vector<const LearnedPlace*> places;
  std::vector<double> units;
  std::vector<int> index;  // base place index of each column
  std::vector<CostCandidate> candidates;
  // Past `shortlist` places under N*'s children, only the nearest by the view index are
  // measured, as recognition does (core/memory/view_index.h): the others enter the ratio's N²
  // by their estimate and cannot be P¹. Measuring every one made the merge quadratic (10⁴ +
  // 10⁴ synthetic places: N* of ~156 terminals, 1.6·10⁶ place measurements, 19 s).
  for (int c : base.nodes()[static_cast<size_t>(h.node)].children) {
    const MemoryNode& child = base.nodes()[static_cast<size_t>(c)];
    CostCandidate candidate;
    candidate.may_be_best = child.terminal();
    candidate.centroid = base.Centroid(c);
    for (int l = child.first_leaf; l < child.end_leaf; ++l) {
      const int place = base.leaf_order()[static_cast<size_t>(l)];
      candidate.places.push_back(static_cast<int>(places.size()));
      places.push_back(&base.places()[static_cast<size_t>(place)]);
      units.push_back(base.DistanceUnit());
      index.push_back(place);
    }
    candidates.push_back(std::move(candidate));
  }
  std::vector<float> estimates;
  const int shortlist = base.options().shortlist;
  if (shortlist > 0 && static_cast<int>(places.size()) > shortlist) {
    estimates = base.EstimatedDistances(p.samples, index);
    std::vector<char> measured(places.size(), 0);
    for (int column : Shortlist(estimates, shortlist)) measured[static_cast<size_t>(column)] = 1;
    for (size_t column = 0; column < places.size(); ++column) {
      if (!measured[column]) places[column] = nullptr;
    }
  }
  const ViewDistances vd(p.samples, places, units, estimates);
  const CostTerms t = RecognitionCost(vd, p.mean, candidates, base.options().cost);
  if (t.best < 0) {  // no terminal child of N* can absorb p (RecognitionCost)
    *best = -1;
    *best_gamma = std::numeric_limits<double>::infinity();
    return std::numeric_limits<double>::infinity();
  }
  *best = index[static_cast<size_t>(candidates[static_cast<size_t>(t.best)].places.front())];
  *best_gamma = (p.mean - base.places()[static_cast<size_t>(*best)].mean).squaredNorm();
  return t.cost;
}

void AddSource(LearnedPlace& target, PlaceId id) {
  if (id == target.id) return;
  auto it = std::lower_bound(target.sources.begin(), target.sources.end(), id);
  if (it == target.sources.end() || *it != id) target.sources.insert(it, id);
}

// The canonical id of a merged place (docs/decisions.md, "Merging": canonical ids): the
// smallest id of its group, its own id and every source. Which memory was the base decides
// which place absorbs which, so without it one settled team held 1:1{2:7,3:1} and
// 2:7{1:1,3:1} for one place. Returns the id it carried before (itself when unchanged).
PlaceId TakeSmallestId(LearnedPlace& p) {
  const PlaceId before = p.id;
  if (p.sources.empty() || !(p.sources.front() < p.id)) return before;
  p.id = p.sources.front();
  p.sources.erase(p.sources.begin());
  p.sources.insert(std::lower_bound(p.sources.begin(), p.sources.end(), before), before);
  return before;
}

bool CarriesSmallestId(const LearnedPlace& p) {
  return p.sources.empty() || p.id < p.sources.front();
}

// Merges the incoming place `p` into `target`: weighted mean by member counts, counts added,
// samples pooled and thinned to the cap, ids absorbed. Members and detected places index the
// other robot's stream and are not copied.
void Absorb(LearnedPlace& target, const LearnedPlace& p, int max_samples) {
  const auto n = static_cast<float>(target.member_count), m = static_cast<float>(p.member_count);
  target.mean = (target.mean * n + p.mean * m) / (n + m);
  target.member_count += p.member_count;
  Eigen::MatrixXf both(target.samples.rows(), target.samples.cols() + p.samples.cols());
  both << target.samples, p.samples;
  target.samples = ThinViews(both, max_samples);
  AddSource(target, p.id);
  for (PlaceId s : p.sources) AddSource(target, s);
}

// Folds the base place `b` into `target` when the peer's records say they are one place:
// as Absorb, and members and detected places are kept too when both are one robot's places
// (they index the same stream).
void Fold(LearnedPlace& target, const LearnedPlace& b, int max_samples) {
  if (target.id.robot == b.id.robot) {
    target.members.insert(target.members.end(), b.members.begin(), b.members.end());
    std::sort(target.members.begin(), target.members.end());
    target.detected.insert(target.detected.end(), b.detected.begin(), b.detected.end());
    std::sort(target.detected.begin(), target.detected.end());
  }
  Absorb(target, b, max_samples);
}

// Base places that are one place: a union-find whose class root is its lowest index, so the
// result does not depend on the order in which unions are found.
class PlaceUnion {
 public:
  explicit PlaceUnion(size_t n) : holder_(n) { std::iota(holder_.begin(), holder_.end(), 0); }
  int Find(int x) {
    while (holder_[static_cast<size_t>(x)] != x) {
      x = holder_[static_cast<size_t>(x)] =
          holder_[static_cast<size_t>(holder_[static_cast<size_t>(x)])];
    }
    return x;
  }
  void Unite(int a, int b) {
    a = Find(a);
    b = Find(b);
    if (a == b) return;
    if (b < a) std::swap(a, b);
    holder_[static_cast<size_t>(b)] = a;
    united_ = true;
  }
  bool united() const { return united_; }
  /// Per place, the place holding it (itself if none).
  std::vector<int> Holders() {
    std::vector<int> out(holder_.size());
    for (size_t i = 0; i < out.size(); ++i) out[i] = Find(static_cast<int>(i));
    return out;
  }

 private:
  std::vector<int> holder_;
  bool united_ = false;
};

// What the incoming memory's records of absorptions (its places' sources) say about the base.
// A place is one place with every place it shares an id with, whichever robot recognised them:
// two base places that one incoming place holds are one (`places`), an incoming place new to
// the base that holds a base place's id is absorbed by it without recognition (`linked`), and
// ids a known incoming place absorbed become sources of its holder (`learned`). Then every
// robot ends up with the union of the team's recognitions whatever the order of the exchanges,
// and the final memories agree (docs/decisions.md, "Merging": joining by ids).
struct IdJoin {
  PlaceUnion places;
  std::vector<int> linked;  ///< per incoming place new to the base: a base place holding one of
                            ///< its sources, −1 if none
  std::vector<std::pair<int, PlaceId>> learned;  ///< (base place, id) for ids new to the base
};

IdJoin JoinByIds(const PlaceMemory& base, const PlaceMemory& incoming,
                 const std::unordered_map<PlaceId, int, PlaceIdHash>& known) {
  IdJoin j{PlaceUnion(base.places().size()), std::vector<int>(incoming.places().size(), -1), {}};
  for (size_t i = 0; i < incoming.places().size(); ++i) {
    const LearnedPlace& p = incoming.places()[i];
    const auto own = known.find(p.id);
    int h = own == known.end() ? -1 : own->second;
    for (PlaceId s : p.sources) {
      const auto k = known.find(s);
      if (k == known.end()) {
        if (own != known.end()) j.learned.emplace_back(own->second, s);
      } else if (h < 0) {
        h = k->second;
      } else {
        j.places.Unite(h, k->second);
      }
    }
    if (own == known.end() && h >= 0) j.linked[i] = h;
  }
  return j;
}

// The places of `memory`: moved out of `owned` (the same memory, given up by the caller) when
// there is one, copied otherwise.
std::vector<LearnedPlace> PlacesOf(const PlaceMemory& memory, PlaceMemory* owned) {
  if (owned != nullptr) return std::move(*owned).TakePlaces();
  return memory.places();
}

// Repeated exchanges: the base may hold places the incoming memory never saw (a peer's places
// learned since it last merged ours, or ours the peer has not merged yet). Nobody compares them
// with the places both memories hold (those are known on both sides), so they are recognised
// here the other way round, against the incoming memory's places the base knows; a match joins
// the two base places in `join` and its g goes to `fold_cost` (docs/decisions.md, "Merging":
// recognition both ways).
void RecogniseFreshBasePlaces(const PlaceMemory& base, const PlaceMemory& incoming,
                              const std::vector<HyperTerminal>& hb,
                              const std::vector<HyperTerminal>& hi, const std::vector<int>& fresh,
                              const std::vector<char>& is_new,
                              const std::unordered_map<PlaceId, int, PlaceIdHash>& known,
                              double tau_r, IdJoin& join, std::vector<double>& fold_cost) {
  const std::vector<size_t> match_of = MatchHyperTerminals(incoming, hi, hb);
  std::vector<char> is_fresh(base.places().size(), 0);
  for (int b : fresh) is_fresh[static_cast<size_t>(b)] = 1;
  for (size_t a = 0; a < hb.size(); ++a) {
    for (int b : hb[a].places) {
      if (!is_fresh[static_cast<size_t>(b)]) continue;
      int match = -1;
      double gamma = 0.0;
      const double g = RecognitionCost(incoming, hi[match_of[a]],
                                       base.places()[static_cast<size_t>(b)], &match, &gamma);
      if (match < 0 || g > tau_r || is_new[static_cast<size_t>(match)]) continue;
      const PlaceId match_id = incoming.places()[static_cast<size_t>(match)].id;
      if (match_id.robot == base.places()[static_cast<size_t>(b)].id.robot) continue;
      const int holder = known.at(match_id);
      // A robot's own places stay apart: the holder may be a place of b's robot that
      // absorbed the match in an earlier merge.
      if (holder != b && base.places()[static_cast<size_t>(holder)].id.robot !=
                             base.places()[static_cast<size_t>(b)].id.robot) {
        join.places.Unite(b, holder);
        fold_cost[static_cast<size_t>(b)] = g;
      }
    }
  }
}

// (4.6)-(4.7): match each incoming hyper-terminal N' to the base hyper-terminal N* of largest
// overlap (ties: nearer centre, then lower node index), then recognise its places new to the
// base against N*'s places with g ≤ τ_r: `target` and `cost` of the absorbed ones, `nearest` and
// `nearest_gamma` of every one measured (−1: none). With no intersecting N*, the largest overlap
// is the smallest gap: the nearest sphere, so recognition still decides.
void RecogniseNewIncomingPlaces(const PlaceMemory& base, const PlaceMemory& incoming,
                                const std::vector<HyperTerminal>& hb,
                                const std::vector<HyperTerminal>& hi,
                                const std::vector<char>& is_new, double tau_r,
                                std::vector<int>& target, std::vector<double>& cost,
                                std::vector<int>& nearest, std::vector<double>& nearest_gamma) {
  const std::vector<size_t> match_of = MatchHyperTerminals(base, hb, hi);
  for (size_t a = 0; a < hi.size(); ++a) {
    const size_t star = match_of[a];
    for (int p : hi[a].places) {
      if (!is_new[static_cast<size_t>(p)] || target[static_cast<size_t>(p)] >= 0) continue;
      int match = -1;
      const double g = RecognitionCost(base, hb[star], incoming.places()[static_cast<size_t>(p)],
                                       &match, &nearest_gamma[static_cast<size_t>(p)]);
      nearest[static_cast<size_t>(p)] = match;
      // A robot's own places stay apart: its pipeline already judged them different.
      if (match >= 0 && g <= tau_r &&
          base.places()[static_cast<size_t>(match)].id.robot !=
              incoming.places()[static_cast<size_t>(p)].id.robot) {
        target[static_cast<size_t>(p)] = match;
        cost[static_cast<size_t>(p)] = g;
      }
    }
  }
}

// MergeMemories. `ours_owned` / `peer_owned` point at `ours` / `peer` when the caller gave
// them up: their places are then moved into the result instead of copied.
MemoryMerge Merge(const PlaceMemory& ours, const PlaceMemory& peer, PlaceMemory* ours_owned,
                  PlaceMemory* peer_owned) {
  if (!ours.empty() && !peer.empty() &&
      ours.places().front().mean.size() != peer.places().front().mean.size()) {
    throw std::invalid_argument("cannot merge memories of descriptor dimensions " +
                                std::to_string(ours.places().front().mean.size()) + " and " +
                                std::to_string(peer.places().front().mean.size()));
  }
  // Both robots compute the same place set whichever of them merges.
  const bool peer_into_ours = PeerGoesIntoOurs(ours, peer);
  const PlaceMemory& base = peer_into_ours ? ours : peer;
  const PlaceMemory& incoming = peer_into_ours ? peer : ours;
  PlaceMemory* const base_owned = peer_into_ours ? ours_owned : peer_owned;
  PlaceMemory* const incoming_owned = peer_into_ours ? peer_owned : ours_owned;
  // Copies: `ours` may be given up (emptied) before the merged memory is made.
  const PlaceMemoryOptions options = ours.options();
  const uint32_t robot = ours.robot(), next_local = ours.next_local_id();

  MemoryMerge result{PlaceMemory(ours.robot(), ours.options()),
                     MergeCase::kNothingNew,
                     peer_into_ours,
                     {},
                     {},
                     {},
                     0};

  // Ids the base already holds, as a place or as an absorbed source: those incoming places
  // were merged before (idempotence).
  // Each maps to the base place holding it (its own id before any source).
  std::unordered_map<PlaceId, int, PlaceIdHash> known;
  known.reserve(base.places().size());
  for (size_t b = 0; b < base.places().size(); ++b) {
    known.emplace(base.places()[b].id, static_cast<int>(b));
  }
  for (size_t b = 0; b < base.places().size(); ++b) {
    for (PlaceId s : base.places()[b].sources) known.emplace(s, static_cast<int>(b));
  }
  std::vector<char> is_new(incoming.places().size(), 0);
  for (size_t i = 0; i < incoming.places().size(); ++i) {
    const PlaceId id = incoming.places()[i].id;
    if (known.contains(id)) {
      result.known.push_back(id);
    } else {
      is_new[i] = 1;
    }
  }
  const bool anything_new = std::find(is_new.begin(), is_new.end(), 1) != is_new.end();
  IdJoin join = JoinByIds(base, incoming, known);
  // Base places the incoming memory has never held (a peer's places learned since it last
  // merged ours, when the peer is the base).
  std::vector<int> fresh;
  // g of a fresh base place recognised as a place the base knows (0: joined by ids alone).
  std::vector<double> fold_cost(base.places().size(), 0.0);
  bool base_knows_more = false;  // an id, as a place or a source, the incoming never held
  {
    std::unordered_set<PlaceId, PlaceIdHash> seen;
    for (const LearnedPlace& p : incoming.places()) {
      seen.insert(p.id);
      seen.insert(p.sources.begin(), p.sources.end());
    }
    for (size_t b = 0; b < base.places().size(); ++b) {
      const LearnedPlace& p = base.places()[b];
      if (!seen.contains(p.id)) fresh.push_back(static_cast<int>(b));
      base_knows_more = base_knows_more || !seen.contains(p.id) ||
                        !std::all_of(p.sources.begin(), p.sources.end(),
                                     [&seen](PlaceId id) { return seen.contains(id); });
    }
  }
  std::vector<int> target = join.linked;  // base place absorbing it, −1: none (yet)
  std::vector<double> cost(incoming.places().size(), 0.0);
  // The base place nearest to each new incoming place among N*'s, and its γ (cross links of
  // the merged tree); −1 where no recognition ran.
  std::vector<int> nearest(incoming.places().size(), -1);
  std::vector<double> nearest_gamma(incoming.places().size(), 0.0);
  // Case analysis on the root spheres (figure 4.4), then recognition where they meet.
  RootSpheres spheres;
  if ((anything_new || !fresh.empty()) && !base.empty() && !incoming.empty()) {
    spheres = CaseOfRootSpheres(base, incoming, options.tau_r);
    if (anything_new) result.merge_case = spheres.merge_case;
    const bool recognise = RecognitionDecides(spheres.merge_case);
    const std::vector<HyperTerminal> hb = recognise ? HyperTerminals(base)
                                                    : std::vector<HyperTerminal>{},
                                     hi = recognise ? HyperTerminals(incoming)
                                                    : std::vector<HyperTerminal>{};
    // (Only a place the base knows can be matched: none known, nothing to do.)
    if (recognise && !fresh.empty() && !result.known.empty()) {
      RecogniseFreshBasePlaces(base, incoming, hb, hi, fresh, is_new, known, options.tau_r, join,
                               fold_cost);
    }
    if (recognise) {
      RecogniseNewIncomingPlaces(base, incoming, hb, hi, is_new, options.tau_r, target, cost,
                                 nearest, nearest_gamma);
    }
  } else if (anything_new) {
    result.merge_case = MergeCase::kDisjoint;  // an empty base: everything is added
  }
  // Every union is known now: each base place's holder, and the targets through them.
  const std::vector<int> holder = join.places.Holders();
  for (int& t : target) {
    if (t >= 0) t = holder[static_cast<size_t>(t)];
  }
  for (auto& [b, unused] : join.learned) b = holder[static_cast<size_t>(b)];
  // A memory from before canonical ids (a store written earlier) is renamed by any merge.
  const bool renames = !std::all_of(ours.places().begin(), ours.places().end(), CarriesSmallestId);
  result.changed = anything_new || join.places.united() || !join.learned.empty() ||
                   (!peer_into_ours && base_knows_more) || renames;
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
    if (!is_new[i]) {
      merged_index[i] = holder[static_cast<size_t>(known.at(incoming.places()[i].id))];
    } else if (target[i] >= 0) {
      merged_index[i] = target[i];
      updated[static_cast<size_t>(target[i])] = 1;
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
      foreign[i] = !is_new[p] || target[p] >= 0;
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
    if (!is_new[i] || target[i] < 0) continue;
    const LearnedPlace& p = in[i];
    Absorb(places[static_cast<size_t>(target[i])], p, options.max_samples_per_place);
    result.absorbed.push_back({p.id, places[static_cast<size_t>(target[i])].id, cost[i]});
  }
  // What the peer's records join (JoinByIds): base places fold into their holder (they leave
  // the list with the tree below), and ids a known incoming place absorbed become sources.
  bool folds = false;
  for (size_t b = 0; b < base_count; ++b) {
    const auto h = static_cast<size_t>(holder[b]);
    if (h == b) continue;
    folds = true;
    result.absorbed.push_back({places[b].id, places[h].id, fold_cost[b]});
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
      if (nearest[i] < 0 || merged_index[i] < base_end) continue;
      links.push_back({nearest_gamma[i], nearest[i], merged_index[i]});
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

  // Every merged place carries the smallest id of its group whichever memory was the base;
  // the absorptions name the places as they are now (a renamed target's new id absorbed its
  // old one).
  std::unordered_map<PlaceId, PlaceId, PlaceIdHash> renamed;
  for (LearnedPlace& p : places) {
    if (const PlaceId before = TakeSmallestId(p); before != p.id) renamed.emplace(before, p.id);
  }
  if (!renamed.empty()) {
    for (Absorption& a : result.absorbed) {
      const auto it = renamed.find(a.target);
      if (it == renamed.end()) continue;
      if (a.source == it->second) a.source = a.target;
      a.target = it->second;
    }
  }

  // A robot whose store was wiped gets its old places back from a peer: its new places are
  // numbered after every id of its own the team still holds, as a place or as a source, so no
  // id is given twice (issue 21 item 5).
  uint32_t next = next_local;
  for (const LearnedPlace& p : places) {
    if (p.id.robot == robot) next = std::max(next, p.id.local + 1);
    for (const PlaceId& s : p.sources) {
      if (s.robot == robot) next = std::max(next, s.local + 1);
    }
  }
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
