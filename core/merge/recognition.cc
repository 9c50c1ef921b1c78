#include "core/merge/recognition.h"

#include <algorithm>
#include <limits>
#include <memory>
#include <numeric>
#include <optional>
#include <span>
#include <utility>

#include "core/memory/decoded_views.h"
#include "core/memory/member_views.h"
#include "core/memory/recognition_cost.h"
#include "core/merge/hyper_terminals.h"
#include "core/on_threads.h"

namespace tsc {
namespace {

// The children of hyper-terminal N* as g_N's candidates and the places under them (the
// columns of ViewDistances): the same for every place recognised against N*, so they are made
// once per N* (making them for every place, centroids included, was a tenth of a 10⁴ + 10⁴
// merge). Only a terminal can absorb a place, so an inner child of N* only enters the ratio.
struct StarCandidates {
  std::vector<const LearnedPlace*> places;
  std::vector<double> units;
  std::vector<int> index;                 // base place index of each column
  std::vector<int> columns;               // 0, 1, ...: each candidate's places are a range of it
  std::vector<CostCandidate> candidates;  // views into `columns`: moved, never copied
  ViewIndex keys;                         // the view index of those places, gathered once per N*
  // The views of the places measured so far, decoded once (`Decoded`): a place is measured
  // for many of the places recognised against N*.
  std::vector<std::unique_ptr<const DecodedViews>> decoded;  // per column, null until measured
  std::size_t decoded_bytes = 0;

  StarCandidates() = default;
  StarCandidates(StarCandidates&&) = default;  // a moved vector keeps its buffer: views hold
  StarCandidates& operator=(StarCandidates&&) = default;
  StarCandidates(const StarCandidates&) = delete;  // a copy's views would be the original's
  StarCandidates& operator=(const StarCandidates&) = delete;
  ~StarCandidates() = default;
};

StarCandidates CandidatesOf(const PlaceMemory& base, const HyperTerminal& h) {
  StarCandidates out;
  std::vector<size_t> first;  // of each candidate, in `columns`
  for (int c : base.nodes()[static_cast<size_t>(h.node)].children) {
    const MemoryNode& child = base.nodes()[static_cast<size_t>(c)];
    CostCandidate candidate = base.CandidateOf(c);  // its places become columns below
    candidate.may_be_best = child.terminal();
    first.push_back(out.places.size());
    for (int l = child.first_leaf; l < child.end_leaf; ++l) {
      const int place = base.leaf_order()[static_cast<size_t>(l)];
      out.places.push_back(&base.places()[static_cast<size_t>(place)]);
      out.units.push_back(base.DistanceUnit());
      out.index.push_back(place);
    }
    out.candidates.push_back(candidate);
  }
  out.columns.resize(out.places.size());
  out.decoded.resize(out.places.size());
  std::iota(out.columns.begin(), out.columns.end(), 0);
  for (size_t c = 0; c < out.candidates.size(); ++c) {
    const size_t end = c + 1 < first.size() ? first[c + 1] : out.columns.size();
    out.candidates[c].places = std::span<const int>(out.columns).subspan(first[c], end - first[c]);
  }
  if (base.options().Shortlists(out.places.size())) {  // only where RecognitionCost shortlists
    out.keys = base.view_index().Subset(out.index);
  }
  return out;
}

// A star's decoded views stop growing past this many bytes (each thread holds one star's):
// places measured after that are decoded for each use, as before. A 10⁴ + 10⁴ merge's N*
// holds a few MB of them; a crowded N* of a 10⁵-place memory at 64 views could hold 50 MB.
constexpr std::size_t kDecodedBudget = std::size_t{32} << 20;

// The decoded views of each of `places` (columns of `star`; null where not measured), made on
// first use while the budget lasts: null for the others, which ViewDistances decodes itself.
std::vector<const DecodedViews*> Decoded(StarCandidates& star,
                                         const std::vector<const LearnedPlace*>& places) {
  std::vector<const DecodedViews*> out(places.size(), nullptr);
  for (size_t column = 0; column < places.size(); ++column) {
    if (places[column] == nullptr) continue;
    std::unique_ptr<const DecodedViews>& d = star.decoded[column];
    if (d == nullptr && star.decoded_bytes < kDecodedBudget) {
      d = std::make_unique<const DecodedViews>(places[column]->samples);
      star.decoded_bytes += d->bytes();
    }
    out[column] = d.get();
  }
  return out;
}

// The order to recognise by: the indices of `match_of` grouped by the hyper-terminal they
// matched (then in index order), so each N*'s candidates are made once. Every place's
// recognition depends only on itself and N*, so the order decides nothing.
std::vector<size_t> ByStar(const std::vector<size_t>& match_of) {
  std::vector<size_t> order(match_of.size());
  for (size_t a = 0; a < order.size(); ++a) order[a] = a;
  std::stable_sort(order.begin(), order.end(),
                   [&match_of](size_t x, size_t y) { return match_of[x] < match_of[y]; });
  return order;
}

// `order` (ByStar's) cut into its runs [first, last) of one N* each.
std::vector<std::pair<size_t, size_t>> StarGroups(const std::vector<size_t>& order,
                                                  const std::vector<size_t>& match_of) {
  std::vector<std::pair<size_t, size_t>> groups;
  for (size_t k = 0; k < order.size(); ++k) {
    if (k == 0 || match_of[order[k]] != match_of[order[k - 1]]) groups.emplace_back(k, k);
    groups.back().second = k + 1;
  }
  return groups;
}

// Runs `visit(star_index, p, star)` for every place p of the hyper-terminals `own` with
// `wanted(p)`, `star` being the candidates in `against` of the hyper-terminal `stars[star_index]`
// that p's hyper-terminal matched (`match_of`): made once per N*, and only when one of its
// places is wanted. The N*s are shared among up to `threads` threads, one at a time; each
// visit writes only what belongs to its place or its N*.
template <typename Wanted, typename Visit>
void ForEachPlaceByStar(const PlaceMemory& against, const std::vector<HyperTerminal>& stars,
                        const std::vector<HyperTerminal>& own, const std::vector<size_t>& match_of,
                        int threads, const Wanted& wanted, const Visit& visit) {
  const std::vector<size_t> order = ByStar(match_of);
  const std::vector<std::pair<size_t, size_t>> groups = StarGroups(order, match_of);
  OnThreads(groups.size(), threads, [&](size_t group) {
    const size_t s = match_of[order[groups[group].first]];  // the group's N*
    std::optional<StarCandidates> star;
    for (size_t k = groups[group].first; k < groups[group].second; ++k) {
      for (int p : own[order[k]].places) {
        if (!wanted(p)) continue;
        if (!star) star.emplace(CandidatesOf(against, stars[s]));
        visit(s, p, *star);
      }
    }
  });
}

// g of (4.1) for the place `p` against the candidates `star` of a hyper-terminal N* of
// `base`: the g_N of recognition (core/memory/recognition_cost.h) with p's member views as the
// vote points, at most memory.max_vote_points of them evenly spaced, as recognition takes D's
// base points (a place seen twice keeps 64 views: all of them as vote points made a 10⁴ +
// 10⁴ merge of such places 4x the products of one with 32). Sets `best` to the nearest terminal
// place P¹ and `best_gamma` to γ(p, P¹) between the means (the distance of the merged SLINK tree);
// −1, with an infinite cost, when no terminal child of N* can take p.
double RecognitionCost(const PlaceMemory& base, StarCandidates& star, const LearnedPlace& p,
                       int* best, double* best_gamma) {
  // Past `shortlist` places under N*'s children, only the nearest by the view index are
  // measured, as recognition does (core/memory/view_index.h): the others enter the ratio's N²
  // by their estimate and cannot be P¹. Measuring every one made the merge quadratic (10⁴ +
  // 10⁴ synthetic places: N* of ~156 terminals, 1.6·10⁶ place measurements, 19 s).
  std::vector<const LearnedPlace*> places = star.places;
  std::vector<float> estimates;
  const Eigen::MatrixXf views = EvenlySpaced(p.samples, base.options().max_vote_points);
  if (base.options().Shortlists(places.size())) {
    estimates = star.keys.Estimate(ViewIndex::Queries(views));
    std::vector<char> measured(places.size(), 0);
    for (int column : Shortlist(estimates, base.options().shortlist))
      measured[static_cast<size_t>(column)] = 1;
    for (size_t column = 0; column < places.size(); ++column) {
      if (!measured[column]) places[column] = nullptr;
    }
  }
  const std::vector<const DecodedViews*> decoded = Decoded(star, places);
  const ViewDistances vd(views, std::move(places), star.units, std::move(estimates), FastestSimd(),
                         decoded);
  const CostTerms t = RecognitionCost(vd, p.mean, star.candidates, base.options().cost);
  if (t.best < 0) {  // no terminal child of N* can absorb p (RecognitionCost)
    *best = -1;
    *best_gamma = std::numeric_limits<double>::infinity();
    return std::numeric_limits<double>::infinity();
  }
  *best =
      star.index[static_cast<size_t>(star.candidates[static_cast<size_t>(t.best)].places.front())];
  *best_gamma = (p.mean - base.places()[static_cast<size_t>(*best)].mean).squaredNorm();
  // As in recognition: no absorption where most of p's views name another place
  // (core/memory/point_agreement.h); P¹ still places p in the merged tree.
  if (t.agreement < base.options().cost.min_agreement)
    return std::numeric_limits<double>::infinity();
  return t.cost;
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
                              double tau_r, int threads, IdJoin& join,
                              std::vector<double>& fold_cost) {
  const std::vector<size_t> match_of = MatchHyperTerminals(incoming, hi, hb);
  std::vector<char> is_fresh(base.places().size(), 0);
  for (int b : fresh) is_fresh[static_cast<size_t>(b)] = 1;
  // Each N*'s joins, applied below in the order one thread would find them (ByStar's: by N*).
  struct Join {
    int place, holder;
    double cost;
  };
  std::vector<std::vector<Join>> joins(hi.size());
  ForEachPlaceByStar(
      incoming, hi, hb, match_of, threads, [&](int b) { return is_fresh[static_cast<size_t>(b)]; },
      [&](size_t s, int b, StarCandidates& star) {
        int match = -1;
        double gamma = 0.0;
        const double g =
            RecognitionCost(incoming, star, base.places()[static_cast<size_t>(b)], &match, &gamma);
        if (match < 0 || g > tau_r || is_new[static_cast<size_t>(match)]) return;
        const PlaceId match_id = incoming.places()[static_cast<size_t>(match)].id;
        if (match_id.robot == base.places()[static_cast<size_t>(b)].id.robot) return;
        const int holder = known.at(match_id);
        // A robot's own places stay apart: the holder may be a place of b's robot that
        // absorbed the match in an earlier merge.
        if (holder != b && base.places()[static_cast<size_t>(holder)].id.robot !=
                               base.places()[static_cast<size_t>(b)].id.robot) {
          joins[s].push_back({b, holder, g});
        }
      });
  for (const std::vector<Join>& of_star : joins) {
    for (const Join& j : of_star) {
      join.places.Unite(j.place, j.holder);
      // On the place folded: the union keeps the lower index, which may be the fresh place.
      fold_cost[static_cast<size_t>(std::max(j.place, j.holder))] = j.cost;
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
                                const std::vector<char>& is_new, double tau_r, int threads,
                                Recognitions& found) {
  const std::vector<size_t> match_of = MatchHyperTerminals(base, hb, hi);
  // Every incoming place is under one hyper-terminal, so each writes its own entries.
  ForEachPlaceByStar(
      base, hb, hi, match_of, threads,
      [&](int p) {
        const auto i = static_cast<size_t>(p);
        return is_new[i] && found.target[i] < 0;
      },
      [&](size_t, int p, StarCandidates& star) {
        const auto i = static_cast<size_t>(p);
        int match = -1;
        const double g =
            RecognitionCost(base, star, incoming.places()[i], &match, &found.nearest_gamma[i]);
        found.nearest[i] = match;
        // A robot's own places stay apart: its pipeline already judged them different.
        if (match >= 0 && g <= tau_r &&
            base.places()[static_cast<size_t>(match)].id.robot != incoming.places()[i].id.robot) {
          found.target[i] = match;
          found.cost[i] = g;
        }
      });
}

}  // namespace

Recognitions::Recognitions(std::vector<int> linked, size_t base_count)
    : target(std::move(linked)),
      cost(target.size(), 0.0),
      nearest(target.size(), -1),
      nearest_gamma(target.size(), 0.0),
      fold_cost(base_count, 0.0) {}

void Recognise(const PlaceMemory& base, const PlaceMemory& incoming, const KnownIds& known,
               const std::vector<int>& fresh, double tau_r, int threads, IdJoin& join,
               Recognitions& found, std::array<std::vector<HyperTerminal>, 2> terminals) {
  // Each memory's hyper-terminals not known yet, side by side (the spheres of 10⁴ places take
  // ~20 ms). A memory has at least one, so an empty list is one not found yet.
  OnThreads(2, threads, [&](size_t m) {
    if (terminals[m].empty()) terminals[m] = HyperTerminals(m == 0 ? base : incoming);
  });
  const std::vector<HyperTerminal>& hb = terminals[0];
  const std::vector<HyperTerminal>& hi = terminals[1];
  // (Only a place the base knows can be matched: none known, nothing to do.)
  if (!fresh.empty() && !known.known.empty()) {
    RecogniseFreshBasePlaces(base, incoming, hb, hi, fresh, known.is_new, known.holder, tau_r,
                             threads, join, found.fold_cost);
  }
  RecogniseNewIncomingPlaces(base, incoming, hb, hi, known.is_new, tau_r, threads, found);
}

}  // namespace tsc
