#include "core/memory/recognition_cost.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/median.h"
#include "core/memory/member_views.h"
#include "core/memory/point_agreement.h"
#include "core/memory/simd.h"

namespace tsc {
namespace {

// Per vote point: the nearest view of a candidate (its distance and place), viewed in the
// rows of a NearestTable.
struct Nearest {
  std::span<const double> distance;
  std::span<const int> place;
};

// The Nearest of every child with a measured place, one row each in two flat arrays: a
// merge's recognition measures dozens of children per level, and two vectors a child were a
// tenth of a 10⁴ + 10⁴ merge in the allocator.
class NearestTable {
 public:
  explicit NearestTable(int votes) : n_(static_cast<size_t>(votes)) {}
  size_t size() const { return place_.size() / std::max<size_t>(n_, 1); }
  Nearest operator[](size_t row) const {
    return {std::span<const double>(distance_).subspan(row * n_, n_),
            std::span<const int>(place_).subspan(row * n_, n_)};
  }
  // Appends the row of candidate `c`.
  void Add(const ViewDistances& vd, const CostCandidate& c) {
    const size_t row = size() * n_;
    distance_.resize(row + n_, std::numeric_limits<double>::infinity());
    place_.resize(row + n_, -1);
    double* distance = distance_.data() + row;
    int* place = place_.data() + row;
    for (int p : c.places) {
      if (!vd.measured(p)) continue;  // infinitely far: never nearer
      for (size_t j = 0; j < n_; ++j) {
        const double d = vd.distance(static_cast<int>(j), p);
        if (d < distance[j]) {
          distance[j] = d;
          place[j] = p;
        }
      }
    }
  }

 private:
  size_t n_;
  std::vector<double> distance_;
  std::vector<int> place_;
};

// Up to this many values, a median counts ranks (avx2::UpperMedian, O(n²)): g_N takes one
// over D's vote points (at most memory.max_vote_points, 32 by default) for every measured child,
// and std::nth_element's were a twentieth of a merge.
constexpr size_t kRankedMedian = 64;

// The median of `values` (the element at size / 2 once sorted); may reorder them.
double MedianInPlace(std::vector<double>& values) {
  if (values.size() <= kRankedMedian && FastestSimd() == Simd::kAvx2Fma)
    return avx2::UpperMedian(values.data(), static_cast<int>(values.size()));
  return UpperMedianInPlace(values);
}

// The median of `v`, through `scratch`.
double MedianOf(std::span<const double> v, std::vector<double>& scratch) {
  scratch.assign(v.begin(), v.end());
  return MedianInPlace(scratch);
}

// Whether candidate `other` coincides with N¹ for D: the views of `other` nearest to D's
// points lie, in the median, within the vote radius of N¹'s nearest views (N¹'s vote would
// accept them), so the two hold the same place. Decided as soon as more than half of the
// pairs fall on one side, and a pair of views that several of D's points share is measured
// once: a crowded N* (a 10⁵ + 10⁵ merge) holds tens of copies of N¹ to check, each of D's 32
// points a product of two views.
bool Coincides(const ViewDistances& vd, const Nearest& best, const Nearest& other,
               double vote_radius, Eigen::VectorXf& a, Eigen::VectorXf& b) {
  if (other.place.empty()) return false;  // not measured: no nearest view to compare
  const int n = vd.num_votes();
  int pairs = 0;
  for (int j = 0; j < n; ++j) {
    pairs += best.place[static_cast<size_t>(j)] >= 0 && other.place[static_cast<size_t>(j)] >= 0;
  }
  if (pairs == 0) return false;
  // The median (the element at pairs / 2 once sorted) is within the radius when more than
  // pairs / 2 of them are, and beyond it when at least pairs − pairs / 2 are.
  const int needed_within = pairs / 2 + 1, needed_beyond = pairs - pairs / 2;
  struct Pair {
    int pa, va, pb, vb;
    bool within;
  };
  std::vector<Pair> seen;
  int within = 0, beyond = 0;
  for (int j = 0; j < n; ++j) {
    const int pa = best.place[static_cast<size_t>(j)], pb = other.place[static_cast<size_t>(j)];
    if (pa < 0 || pb < 0) continue;
    const int va = vd.view(j, pa), vb = vd.view(j, pb);
    const auto known = std::find_if(seen.begin(), seen.end(), [&](const Pair& s) {
      return s.pa == pa && s.va == va && s.pb == pb && s.vb == vb;
    });
    bool in;
    if (known != seen.end()) {
      in = known->within;
    } else {
      a.resize(vd.place(pa).samples.rows());
      b.resize(vd.place(pb).samples.rows());
      vd.place(pa).samples.DecodeColInto(va, a.data());
      vd.place(pb).samples.DecodeColInto(vb, b.data());
      in = static_cast<double>((a - b).squaredNorm()) / vd.unit(pa) <= vote_radius;
      seen.push_back({pa, va, pb, vb, in});
    }
    if (in ? ++within >= needed_within : ++beyond >= needed_beyond) return in;
  }
  return false;  // unreachable: within + beyond reaches pairs
}

// The children N² is looked for among (every one with places but N¹), in order of γ̃ then
// index, up to the first that cannot be a copy of N¹: copies are found only among the children
// with a measured place (`measured`, in increasing index), so the order is theirs, sorted,
// with the nearest unmeasured child (`unmeasured`, or none: candidates.size()) put in its
// place and nothing after it. A sort of a few dozen: rescanning every child for each copy
// made a 10⁵ + 10⁵ merge quadratic in its crowded hyper-terminals (1500 children, tens of
// copies: a fifth of its CPU).
std::vector<size_t> OrderOfSecond(size_t candidates, const std::vector<double>& gamma,
                                  const std::vector<size_t>& measured, size_t unmeasured,
                                  size_t best) {
  const auto before = [&gamma](size_t a, size_t b) {
    return gamma[a] < gamma[b] || (gamma[a] == gamma[b] && a < b);
  };
  std::vector<size_t> order;
  order.reserve(measured.size());
  for (size_t c : measured) {
    if (c != best) order.push_back(c);
  }
  std::sort(order.begin(), order.end(), before);
  if (unmeasured < candidates) {
    const auto at =
        std::find_if(order.begin(), order.end(), [&](size_t c) { return before(unmeasured, c); });
    order.erase(at, order.end());
    order.push_back(unmeasured);
  }
  return order;
}

}  // namespace

ViewDistances::ViewDistances(const Eigen::MatrixXf& votes, std::vector<const LearnedPlace*> places,
                             std::vector<double> units, std::vector<float> estimates, Simd simd,
                             std::span<const DecodedViews* const> decoded)
    : places_(std::move(places)),
      column_(places_.size(), -1),
      units_(std::move(units)),
      estimates_(std::move(estimates)) {
  if (votes.cols() == 0) throw std::invalid_argument("view distances of no vote points");
  if (units_.size() != places_.size()) throw std::invalid_argument("one unit per place needed");
  if (!estimates_.empty() && estimates_.size() != places_.size())
    throw std::invalid_argument("one estimate per place needed");
  if (!decoded.empty() && decoded.size() != places_.size())
    throw std::invalid_argument("one decoded view set (or none) per place needed");
  std::vector<int> measured;  // the measured places, in increasing order: their columns
  for (size_t p = 0; p < places_.size(); ++p) {
    if (places_[p] == nullptr) continue;
    const CompactViews& s = places_[p]->samples;
    if (s.rows() != votes.rows() || s.cols() == 0) {
      throw std::invalid_argument("place " + places_[p]->id.ToString() + " has " +
                                  std::to_string(s.cols()) + " views of dimension " +
                                  std::to_string(s.rows()) + " for vote points of dimension " +
                                  std::to_string(votes.rows()));
    }
    if (!decoded.empty() && decoded[p] != nullptr &&
        (decoded[p]->simd() != simd || decoded[p]->views().rows() != s.rows() ||
         decoded[p]->views().cols() != s.cols())) {
      throw std::invalid_argument("the decoded views of place " + places_[p]->id.ToString() +
                                  " are not its views on this instruction set");
    }
    column_[p] = static_cast<int>(measured.size());
    measured.push_back(static_cast<int>(p));
  }
  distance_.resize(votes.cols(), static_cast<Eigen::Index>(measured.size()));
  view_.resize(votes.cols(), static_cast<Eigen::Index>(measured.size()));
  const Eigen::Index n = votes.cols();
  const Eigen::VectorXf vote_sq = votes.colwise().squaredNorm().transpose();
  // The vote points as rows, column-major: the products' left side in the layout Eigen packs
  // fastest (sᵀ·votes packed a row-major sᵀ for every place). The AVX2 kernel reads votes.
  const Eigen::MatrixXf votes_t =
      simd == Simd::kPortable ? Eigen::MatrixXf(votes.transpose()) : Eigen::MatrixXf();
  auto samples_of = [this, &measured](size_t c) -> const CompactViews& {
    return places_[static_cast<size_t>(measured[c])]->samples;
  };
  auto decoded_of = [&decoded, &measured](size_t c) -> const DecodedViews* {
    return decoded.empty() ? nullptr : decoded[static_cast<size_t>(measured[c])];
  };
  Eigen::Index most = 0;
  for (size_t c = 0; c < measured.size(); ++c) most = std::max(most, samples_of(c).cols());
  Eigen::MatrixXf dots(n, most);  // votes x views of one place, reused for every place
  Eigen::RowVectorXf view_sq(most);
  Eigen::MatrixXf views(votes.rows(), most);  // one place's views decoded, reused
  for (size_t c = 0; c < measured.size(); ++c) {
    const CompactViews& compact = samples_of(c);
    const Eigen::Index k = compact.cols();
    const DecodedViews* given = decoded_of(c);
    if (given == nullptr) compact.DecodeInto(views.data());
    const float* s = given != nullptr ? given->views().data() : views.data();
    if (given != nullptr) view_sq.head(k) = given->squared_norms();
    auto xs = dots.leftCols(k);
    if (simd == Simd::kAvx2Fma) {
      // The next place's views are fetched from memory while this one's products run: its
      // floats where they are given, else its 8-bit codes (`next_floats` counts 4-byte words).
      const float* next = nullptr;
      std::ptrdiff_t next_floats = 0;
      if (c + 1 < measured.size()) {
        if (const DecodedViews* d = decoded_of(c + 1); d != nullptr) {
          next = d->views().data();
          next_floats = d->views().size();
        } else {
          next = reinterpret_cast<const float*>(samples_of(c + 1).codes());
          next_floats = static_cast<std::ptrdiff_t>(samples_of(c + 1).size() / 4);
        }
      }
      avx2::ColumnDots(votes.data(), static_cast<int>(n), s, static_cast<int>(k),
                       static_cast<int>(votes.rows()), xs.data(),
                       given != nullptr ? nullptr : view_sq.data(), next, next_floats);
    } else {
      const Eigen::Map<const Eigen::MatrixXf> place_views(s, votes.rows(), k);
      if (given == nullptr) view_sq.head(k) = place_views.colwise().squaredNorm();
      xs.noalias() = votes_t * place_views;
    }
    // ‖s − x‖² = ‖s‖² + ‖x‖² − 2 sᵀx; the first nearest view on ties.
    float* nearest = distance_.col(static_cast<Eigen::Index>(c)).data();
    int* at = view_.col(static_cast<Eigen::Index>(c)).data();
    if (simd == Simd::kAvx2Fma) {
      // Eight vote points at a time: the scalar loop was a sixth of a 10⁴ + 10⁴ merge.
      avx2::NearestColumns(xs.data(), static_cast<int>(n), static_cast<int>(k), view_sq.data(),
                           vote_sq.data(), nearest, at);
    } else {
      for (Eigen::Index j = 0; j < n; ++j) {
        nearest[j] = (-2.0f * xs(j, 0) + view_sq[0]) + vote_sq[j];
        at[j] = 0;
        for (Eigen::Index v = 1; v < k; ++v) {
          const float d = (-2.0f * xs(j, v) + view_sq[v]) + vote_sq[j];
          if (d < nearest[j]) {
            nearest[j] = d;
            at[j] = static_cast<int>(v);
          }
        }
      }
    }
    for (Eigen::Index j = 0; j < n; ++j) nearest[j] = std::max(0.0f, nearest[j]);
  }
  measured_ = std::move(measured);  // NearestPlace's columns
  // Units for places of one view (docs/decisions.md "Recognition cost").
  if (std::all_of(units_.begin(), units_.end(), [](double u) { return u > 0.0; })) return;
  std::vector<double> positive;
  for (double u : units_) {
    if (u > 0.0) positive.push_back(u);
  }
  double fallback = positive.empty() ? ViewSpacing(votes) : UpperMedianInPlace(positive);
  if (!(fallback > 0.0)) fallback = std::numeric_limits<float>::min();
  for (double& u : units_) {
    if (!(u > 0.0)) u = fallback;
  }
}

int ViewDistances::NearestPlace(int vote) const {
  if (measured_.empty()) return -1;
  Eigen::Index column = 0;
  distance_.row(vote).minCoeff(&column);  // the first minimum: the lower place index
  return measured_[static_cast<size_t>(column)];
}

void RecognitionCostOptions::Validate() const {
  kVoteRadiusRange.Check("memory.vote_radius", vote_radius);
  kMeanUnitRange.Check("memory.mean_distance_unit", mean_unit);
  kCoincideFactorRange.Check("memory.coincide_factor", coincide_factor);
  kMinAgreementRange.Check("memory.min_agreement", min_agreement);
  kAgreementSlackRange.Check("memory.agreement_slack", agreement_slack);
}

CostTerms RecognitionCost(const ViewDistances& vd, const Eigen::VectorXf& mean,
                          std::span<const CostCandidate> candidates,
                          const RecognitionCostOptions& options) {
  // Per-point nearest views only of the children with a measured place (a merge's N* has
  // ~1500 children, a few dozen measured): `nearest_of` is a child's entry in `nearest`, or −1.
  NearestTable nearest(vd.num_votes());
  std::vector<double> scratch;  // the medians' copies
  // One pass over the children: a crowded N*'s 1500 were scanned three times per place.
  std::vector<int> nearest_of(candidates.size(), -1);
  std::vector<double> gamma(candidates.size(), std::numeric_limits<double>::infinity());
  std::vector<size_t> measured;           // the children with a measured place, in order
  size_t unmeasured = candidates.size();  // the first of the nearest other children with places
  // Its γ̃, in a register: read back through gamma[unmeasured] it was most of this loop, which
  // runs over every child of a crowded N* (1500 in a 10⁵ + 10⁵ merge) for each place.
  double unmeasured_gamma = std::numeric_limits<double>::infinity();
  for (size_t c = 0; c < candidates.size(); ++c) {
    const std::span<const int> places = candidates[c].places;
    // A child with no place in the shortlist: no nearest view, so it never coincides with N¹,
    // and its rough distance, good enough for N² (it is never N¹, and the places nearest D
    // are the ones measured).
    double estimate = std::numeric_limits<double>::infinity();
    bool any_measured = false;
    for (int p : places) {
      if (vd.measured(p)) {
        any_measured = true;
        break;
      }
      estimate = std::min<double>(estimate, vd.estimate(p));
    }
    if (any_measured) {
      nearest_of[c] = static_cast<int>(nearest.size());
      nearest.Add(vd, candidates[c]);
      gamma[c] = MedianOf(nearest[nearest.size() - 1].distance, scratch);
      measured.push_back(c);
      continue;
    }
    gamma[c] = estimate;
    if (!places.empty() && (unmeasured == candidates.size() || estimate < unmeasured_gamma)) {
      unmeasured = c;
      unmeasured_gamma = estimate;
    }
  }
  CostTerms t;
  for (size_t c : measured) {
    if (!candidates[c].may_be_best) continue;
    if (t.best < 0 || gamma[c] < gamma[static_cast<size_t>(t.best)]) t.best = static_cast<int>(c);
  }
  if (t.best < 0) {  // none may be N¹, or none has a place measured
    t.cost = std::numeric_limits<double>::infinity();
    return t;
  }
  const Nearest best = nearest[static_cast<size_t>(nearest_of[static_cast<size_t>(t.best)])];
  t.gamma = gamma[static_cast<size_t>(t.best)];
  std::vector<double>& scaled = scratch;
  scaled.clear();
  int accepted = 0;
  for (int j = 0; j < vd.num_votes(); ++j) {
    const double u = vd.unit(best.place[static_cast<size_t>(j)]);
    const double d = best.distance[static_cast<size_t>(j)];
    scaled.push_back(d / u);
    if (d <= options.vote_radius * u) ++accepted;
  }
  t.distance = MedianInPlace(scaled);
  t.vote = static_cast<double>(accepted) / vd.num_votes();
  // The distance term from the means too, where a camera kind sets their unit: a pan sweep's
  // base points see the whole room, and a revisit along another path through it is far from
  // every kept view yet near the room's mean (docs/decisions.md "Recognition cost").
  if (options.mean_unit > 0.0) {
    const double to_mean =
        (mean - candidates[static_cast<size_t>(t.best)].Centroid()).squaredNorm();
    t.distance = std::min(t.distance, to_mean / options.mean_unit);
  }
  // N²: the nearest other child that is not the same place held again, looked for in order
  // of γ̃ (then index).
  // The radius within which two children's nearest views hold one place: the vote radius,
  // or, when D itself lies further from N¹, that distance times the factor (two copies of a
  // room are no nearer each other than a revisit is to either).
  const double radius = std::max(options.vote_radius, options.coincide_factor * t.distance);
  double second = std::numeric_limits<double>::infinity();
  Eigen::VectorXf view_a, view_b;  // Coincides' decoded views
  std::vector<int> copies;         // the places of the children that coincide with N¹
  for (const size_t next :
       OrderOfSecond(candidates.size(), gamma, measured, unmeasured, static_cast<size_t>(t.best))) {
    if (nearest_of[next] >= 0) {
      const Nearest& other = nearest[static_cast<size_t>(nearest_of[next])];
      if (Coincides(vd, best, other, radius, view_a, view_b)) {
        t.only_copies = true;
        const std::span<const int> held = candidates[next].places;
        copies.insert(copies.end(), held.begin(), held.end());
        // Within the vote radius itself: the evidence a fold asks for (CopyEvidence).
        if (held.size() == 1 && (radius <= options.vote_radius ||
                                 Coincides(vd, best, other, options.vote_radius, view_a, view_b))) {
          t.held_again.push_back(held.front());
        }
        continue;
      }
    }
    t.only_copies = false;
    second = gamma[next];
    break;
  }
  // (3.8); no other child: the ratio term is 1; γ̃(D,N²) = 0 implies γ̃(D,N¹) = 0: ratio 1.
  // An inner child nearer than every eligible one (merging) makes the ratio exceed 1.
  t.ratio = std::isinf(second) || second <= 0.0 ? 1.0 : t.gamma / second;
  t.cost = t.distance + t.ratio + (1.0 - t.vote);
  const std::span<const int> best_places = candidates[static_cast<size_t>(t.best)].places;
  if (best_places.size() == 1) {
    t.agreement = PointAgreement(vd, best_places.front(), copies, options.agreement_slack);
  }
  return t;
}

}  // namespace tsc
