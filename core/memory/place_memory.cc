#include "core/memory/place_memory.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <span>
#include <stdexcept>
#include <string>

#include "core/assert.h"
#include "core/median.h"
#include "core/memory/descriptor_space_mismatch.h"
#include "core/memory/member_views.h"
#include "core/on_threads.h"
#include "core/split_mix64.h"

namespace tsc {
namespace {

uint64_t PlaceKey(PlaceId id) { return SplitMix64((uint64_t{id.robot} << 32) | id.local); }

}  // namespace

Eigen::VectorXf DetectedPlace::Mean() const {
  if (descriptors.cols() == 0) throw std::invalid_argument("detected place without members");
  return descriptors.rowwise().mean();
}

int PlaceMemoryOptions::SampleCap(const LearnedPlace& p) const {
  const size_t visits = std::max<size_t>(1, p.detected.size() + p.sources.size());
  return max_samples_per_place * static_cast<int>(std::min<size_t>(visits, sample_visits));
}

bool PlaceMemoryOptions::NearMiss(double g, const CostTerms& terms) const {
  return near_miss_margin > 0.0 && g > tau_r && g <= tau_r + near_miss_margin &&
         terms.vote >= near_miss_vote && terms.ratio < 1.0;
}

void PlaceMemoryOptions::Validate() const {
  kTauRRange.Check("memory.tau_r", tau_r);
  kTauLRange.Check("memory.tau_l", tau_l);
  kNeighbourMarginRange.Check("memory.neighbour_margin", neighbour_margin);
  kNearMissMarginRange.Check("memory.near_miss_margin", near_miss_margin);
  kNearMissVoteRange.Check("memory.near_miss_vote", near_miss_vote);
  kTauHRange.Check("memory.tau_h", tau_h);
  kMaxSamplesRange.Check("memory.max_samples_per_place", max_samples_per_place);
  kSampleVisitsRange.Check("memory.sample_visits", sample_visits);
  if (static_cast<int64_t>(max_samples_per_place) * sample_visits > kMaxSamplesRange.max) {
    throw std::invalid_argument("memory.max_samples_per_place x memory.sample_visits exceeds " +
                                std::to_string(static_cast<int64_t>(kMaxSamplesRange.max)) +
                                " member views a place");
  }
  kMaxVotePointsRange.Check("memory.max_vote_points", max_vote_points);
  kShortlistRange.Check("memory.shortlist", shortlist);
  ValidateUnits();
  cost.Validate();
  discriminant.Validate();
}

void PlaceMemoryOptions::ValidateUnits() const {
  kStepUnitRange.Check("memory.step_unit", step_unit);
  kDistanceUnitRange.Check("memory.distance_unit", distance_unit);
}

PlaceMemory::PlaceMemory(uint32_t robot, PlaceMemoryOptions options)
    : robot_(robot), options_(std::move(options)), view_index_(FastestSimd(), options_.view_cells) {
  options_.Validate();
}

std::optional<int> PlaceMemory::Find(PlaceId id) const {
  for (size_t i = 0; i < places_.size(); ++i) {
    if (places_[i].id == id) return static_cast<int>(i);
  }
  return std::nullopt;
}

Eigen::VectorXf PlaceMemory::Centroid(int node) const { return CandidateOf(node).Centroid(); }

CostCandidate PlaceMemory::CandidateOf(int node) const {
  const MemoryNode& nd = nodes_[node];
  CostCandidate c;
  c.places = std::span<const int>(leaf_order_)
                 .subspan(static_cast<size_t>(nd.first_leaf), static_cast<size_t>(nd.num_places()));
  if (nd.terminal()) {
    c.centroid_sum = &places_[nd.place].mean;
  } else {
    c.centroid_sum = &centroid_sums_[node];
    c.centroid_count = static_cast<float>(nd.num_places());
  }
  return c;
}

int PlaceMemory::Depth() const {
  int depth = 0;
  for (size_t i = 0; i < places_.size(); ++i) {
    int d = 0;
    for (int n = static_cast<int>(i); nodes_[n].parent >= 0; n = nodes_[n].parent) ++d;
    depth = std::max(depth, d);
  }
  return depth;
}

Votes PlaceMemory::VotePoints(const DetectedPlace& d) const {
  const Eigen::MatrixXf points = EvenlySpaced(d.descriptors, options_.max_vote_points);
  return Votes{ViewCoordinates(view_basis(), points), points.rowwise().mean()};
}

const Eigen::VectorXf& PlaceMemory::ViewCentre(int place) const {
  return view_basis() ? view_centres_.at(static_cast<size_t>(place))
                      : places_.at(static_cast<size_t>(place)).mean;
}

double PlaceMemory::MedianViewSpacing() const {
  std::vector<double> positive;
  for (double u : spacings_) {
    if (u > 0.0) positive.push_back(u);
  }
  return positive.empty() ? 0.0 : UpperMedian(std::move(positive));
}

void PlaceMemory::AdoptUnits(const PlaceMemoryOptions& camera) {
  camera.ValidateUnits();
  options_.step_unit = camera.step_unit;
  options_.distance_unit = camera.distance_unit;
}

double PlaceMemory::DistanceUnit() const {
  return options_.distance_unit > 0.0 ? options_.distance_unit : MedianViewSpacing();
}

double PlaceMemory::UnitFor(const DetectedPlace& d) const {
  const Eigen::Index n = d.descriptors.cols();
  if (options_.step_unit <= 0.0 || n < 2) return DistanceUnit();
  std::vector<double> steps(static_cast<size_t>(n - 1));
  for (Eigen::Index i = 0; i + 1 < n; ++i) {
    steps[static_cast<size_t>(i)] = (d.descriptors.col(i + 1) - d.descriptors.col(i)).squaredNorm();
  }
  // At least D's own step: a revisit is not expected nearer the memory's views than D's
  // consecutive base points are to each other.
  return std::max(DistanceUnit(), options_.step_unit * UpperMedian(std::move(steps)));
}

ViewDistances PlaceMemory::DistancesOf(const Eigen::MatrixXf& votes, double unit) const {
  std::vector<const LearnedPlace*> all(places_.size(), nullptr);
  std::vector<float> estimates;
  if (options_.Shortlists(places_.size())) {
    estimates = view_index_.Estimate(ViewIndex::Queries(votes));
    for (int p : Shortlist(estimates, options_.shortlist)) {
      all[static_cast<size_t>(p)] = &places_[static_cast<size_t>(p)];
    }
  } else {
    for (size_t p = 0; p < places_.size(); ++p) all[p] = &places_[p];
  }
  // One unit for every place (docs/decisions.md "Recognition cost": a place's own spacing let
  // large, varied places absorb strangers).
  std::vector<double> units(all.size(), unit);
  return ViewDistances(votes, std::move(all), std::move(units), std::move(estimates));
}

CostTerms PlaceMemory::Cost(const ViewDistances& vd, const Votes& votes, int node) const {
  // The children of N, each with the places under it (one contiguous range of leaf_order_).
  const std::vector<int>& children = nodes_[node].children;
  std::vector<CostCandidate> candidates;
  candidates.reserve(children.size());
  for (int child : children) candidates.push_back(CandidateOf(child));
  CostTerms t = RecognitionCost(vd, votes.mean, candidates, options_.cost);
  // No child with a shortlisted place: infinite cost, so the descent stops here.
  if (t.best < 0) return t;
  t.best = children[static_cast<size_t>(t.best)];
  if (options_.svm_vote) {
    // The thesis' vote: the fraction of D's points inside d_{N¹}'s support.
    t.cost -= 1.0 - t.vote;
    t.vote = discriminants_[t.best].VoteFraction(votes.views);
    t.cost += 1.0 - t.vote;
  }
  return t;
}

Recognition PlaceMemory::Descend(const DetectedPlace& d, int start) const {
  const Votes votes = VotePoints(d);
  return Descend(DistancesOf(votes.views, UnitFor(d)), votes, start);
}

Recognition PlaceMemory::Descend(const ViewDistances& vd, const Votes& votes, int start,
                                 const std::vector<char>* towards_neighbour) const {
  Recognition r;
  r.start_nodes.push_back(start);
  // The ratio N¹ had one level up, against its nearest competitor there (1 at the start).
  double outer_ratio = 1.0;
  bool above_tau_r = false;  // some level passed by the neighbour margin alone
  for (int node = start;;) {
    r.visited.push_back(node);
    r.terms = Cost(vd, votes, node);
    if (r.terms.only_copies && options_.copies_keep_outer_ratio) {
      // N's children are one place held several times (DESIGN §3.3 amended: near-tied
      // siblings are one candidate). Choosing among its copies discriminates nothing, so the
      // ratio is not that of a lone child (1) but the one that led into N.
      r.terms.cost += outer_ratio - r.terms.ratio;
      r.terms.ratio = outer_ratio;
    }
    r.cost = r.terms.cost;
    const bool neighbour = towards_neighbour != nullptr && r.terms.best >= 0 &&
                           (*towards_neighbour)[static_cast<size_t>(r.terms.best)] != 0;
    const double tau = options_.tau_r + (neighbour ? options_.neighbour_margin : 0.0);
    if (r.cost > tau) return r;  // (3.11) fails: not recognised
    above_tau_r = above_tau_r || r.cost > options_.tau_r;
    if (nodes_[r.terms.best].terminal()) {
      // A place most of D's points name elsewhere is not recognised, however cheap in the
      // median (core/memory/point_agreement.h).
      if (r.terms.agreement >= options_.cost.min_agreement) {
        r.place = nodes_[r.terms.best].place;
        r.neighbour = above_tau_r;
      } else {
        r.disagreed = true;
      }
      return r;
    }
    outer_ratio = r.terms.ratio;
    node = r.terms.best;
  }
}

Recognition PlaceMemory::Recognize(const DetectedPlace& d, std::optional<int> previous,
                                   const std::vector<int>& neighbours) const {
  Recognition total;
  if (empty()) return total;
  // The neighbours' terminals and their ancestors: N¹ on the way to one may cost up to
  // τ_r + neighbour_margin (a terminal's node index is its place index).
  std::vector<char> towards;
  if (options_.neighbour_margin > 0.0 && !neighbours.empty()) {
    towards.assign(nodes_.size(), 0);
    for (int p : neighbours) {
      if (p < 0 || p >= static_cast<int>(places_.size())) continue;
      for (int n = p; n >= 0 && towards[static_cast<size_t>(n)] == 0; n = nodes_[n].parent) {
        towards[static_cast<size_t>(n)] = 1;
      }
    }
  }
  const std::vector<char>* towards_neighbour = towards.empty() ? nullptr : &towards;
  // Every descent measures against the same views: the distances are computed once.
  const Votes votes = VotePoints(d);
  const ViewDistances vd = DistancesOf(votes.views, UnitFor(d));
  auto absorb = [&total](const Recognition& r) {
    total.start_nodes.insert(total.start_nodes.end(), r.start_nodes.begin(), r.start_nodes.end());
    total.visited.insert(total.visited.end(), r.visited.begin(), r.visited.end());
    total.cost = r.cost;
    total.terms = r.terms;
    total.place = r.place;
    total.neighbour = r.neighbour;
    total.disagreed = total.disagreed || r.disagreed;
  };
  bool root_tried = false;
  if (previous && *previous >= 0 && *previous < static_cast<int>(places_.size())) {
    // Hybrid: start at the parent of β(D_{m−1}) and climb up to τ_l levels.
    int start = nodes_[*previous].parent;
    for (int level = 0; level <= options_.tau_l && start >= 0; ++level) {
      absorb(Descend(vd, votes, start, towards_neighbour));
      root_tried = root_tried || start == root_;
      if (total.place) {
        total.hybrid = true;
        return total;
      }
      start = nodes_[start].parent;
    }
  }
  if (!root_tried) absorb(Descend(vd, votes, root_, towards_neighbour));
  total.near_miss = !total.place && options_.NearMiss(total.cost, total.terms);
  return total;
}

int PlaceMemory::Learn(const DetectedPlace& d) {
  if (d.descriptors.cols() == 0) throw std::invalid_argument("cannot learn an empty place");
  LearnedPlace p;
  p.id = PlaceId{robot_, next_local_};
  p.mean = d.Mean();
  if (!places_.empty() && p.mean.size() != places_.front().mean.size()) {
    throw std::invalid_argument("descriptor dimension " + std::to_string(p.mean.size()) +
                                " differs from the memory's " +
                                std::to_string(places_.front().mean.size()));
  }
  p.member_count = d.descriptors.cols();
  // Thinning compares every pair: a long place is first spaced evenly to twice the cap.
  p.samples = CompactViews(
      ThinViews(ViewCoordinates(view_basis(),
                                EvenlySpaced(d.descriptors, 2 * options_.max_samples_per_place)),
                options_.max_samples_per_place));
  p.detected = {d.index};
  p.members = d.members;
  TrimHistory(p);
  // γ of (3.12) between the new place and every learned place. Without a basis every γ is
  // measured, streamed from the contiguous copy of the means; each column is read as an
  // aligned vector so the value is the same as (places_[i].mean − p.mean).squaredNorm(),
  // which is what the basis's few measured γ read.
  const Eigen::Index dim = p.mean.size();
  const Eigen::Index stride = means_.rows();
  auto gamma = [&](int i) -> double {
    if (means_.size() == 0) return (places_[static_cast<size_t>(i)].mean - p.mean).squaredNorm();
    const Eigen::Map<const Eigen::VectorXf, Eigen::AlignedMax> m(
        means_.data() + static_cast<Eigen::Index>(i) * stride, dim);
    return (m - p.mean).squaredNorm();
  };
  if (view_basis() != nullptr && plain_learnings_ == 0) {
    // Most places are far from the new one and bounds from the means in the basis settle
    // them: at 10⁵ places the means are 480 MB, their coordinates 51 MB (same tree).
    GammaLowerBounds(p.mean, distances_);
    slink_.InsertBounded(distances_, gamma);
    // Where the means lie far outside the basis the bounds settle little, and measuring γ
    // point by point is slower than one stream: the next learnings stream (same tree).
    if (4 * static_cast<size_t>(slink_.measured()) > places_.size()) plain_learnings_ = 64;
  } else {
    if (plain_learnings_ > 0) --plain_learnings_;
    distances_.resize(places_.size());
    for (size_t i = 0; i < places_.size(); ++i) distances_[i] = gamma(static_cast<int>(i));
    slink_.Insert(distances_);
  }
  places_.push_back(std::move(p));
  StoreDerived(static_cast<int>(places_.size()) - 1, static_cast<int>(places_.size()));
  ++next_local_;
  RebuildTree(nullptr);
  return static_cast<int>(places_.size()) - 1;
}

void PlaceMemory::Update(int place, const DetectedPlace& d) {
  LearnedPlace& p = places_.at(place);
  if (d.descriptors.cols() == 0) return;
  const Eigen::VectorXf old_mean = p.mean;
  const auto added = d.descriptors.cols();
  p.mean = (p.mean * static_cast<float>(p.member_count) + d.descriptors.rowwise().sum()) /
           static_cast<float>(p.member_count + added);
  p.member_count += added;
  HoldWithinBounds(p);
  // The kept views first, then this visit's: thinning keeps what the visit shows anew.
  const Eigen::MatrixXf visit =
      ViewCoordinates(view_basis(), EvenlySpaced(d.descriptors, options_.max_samples_per_place));
  Eigen::MatrixXf pool(p.samples.rows(), p.samples.cols() + visit.cols());
  pool << p.samples.Decoded(), visit;
  p.detected.push_back(d.index);
  p.samples.Encode(ThinViews(pool, options_.SampleCap(p)));
  p.members.insert(p.members.end(), d.members.begin(), d.members.end());
  TrimHistory(p);
  StoreDerived(place, place + 1);
  // The place's path to the root: centroids move, discriminants see new members.
  const Eigen::VectorXf delta = p.mean - old_mean;
  RetrainDiscriminant(place);
  for (int n = nodes_[place].parent; n >= 0; n = nodes_[n].parent) {
    centroid_sums_[n] += delta;
    if (n != root_) RetrainDiscriminant(n);
  }
}

Eigen::MatrixXf PlaceMemory::TrainingSet(int node) const {
  const MemoryNode& nd = nodes_[node];
  Eigen::Index total = 0;
  for (int i = nd.first_leaf; i < nd.end_leaf; ++i) total += places_[leaf_order_[i]].samples.cols();
  const Eigen::Index cap = std::min<Eigen::Index>(total, options_.discriminant.max_training);
  Eigen::MatrixXf out(places_.front().samples.rows(), cap);
  // Column j of the result is sample ⌊j·total/cap⌋ of the node's places in leaf order.
  Eigen::Index offset = 0, j = 0;
  for (int i = nd.first_leaf; i < nd.end_leaf && j < cap; ++i) {
    const CompactViews& s = places_[leaf_order_[i]].samples;
    while (j < cap) {
      const Eigen::Index want = j * total / cap;
      if (want >= offset + s.cols()) break;
      s.DecodeColInto(want - offset, out.col(j++).data());
    }
    offset += s.cols();
  }
  return out;
}

void PlaceMemory::GammaLowerBounds(const Eigen::VectorXf& mean, std::vector<double>& out) const {
  const ViewBasis& basis = *view_basis();
  const Eigen::VectorXf c = basis.Coordinates(mean);
  const double norm = mean.norm();
  out.resize(places_.size());
  for (size_t i = 0; i < places_.size(); ++i) {
    const double apart = std::sqrt(static_cast<double>((view_centres_[i] - c).squaredNorm()));
    const double root = basis.DistanceBelow(
        apart, basis.coordinate_error() * (static_cast<double>(mean_norms_[i]) + norm));
    // Less 0.1 %: γ itself is a float sum of 1200 squares, off by up to 1200·u of itself.
    out[i] = (1.0 - 1e-3) * root * root;
  }
}

void PlaceMemory::StoreDerived(int first, int end,
                               const std::vector<std::optional<Derived>>* derived, int threads) {
  if (first >= end) return;
  const Eigen::Index dim = places_[first].mean.size();
  auto given = [&](int p) -> const Derived* {
    if (derived == nullptr || (*derived)[static_cast<size_t>(p)] == std::nullopt) return nullptr;
    return &*(*derived)[static_cast<size_t>(p)];
  };
  if (const ViewBasis* basis = view_basis()) {
    if (static_cast<size_t>(end) > view_centres_.size()) view_centres_.resize(end);
    if (static_cast<size_t>(end) > mean_norms_.size()) mean_norms_.resize(end);
    std::vector<int> todo;
    for (int p = first; p < end; ++p) {
      if (const Derived* d = given(p)) {
        view_centres_[static_cast<size_t>(p)] = d->view_centre;
        mean_norms_[static_cast<size_t>(p)] = d->mean_norm;
      } else {
        todo.push_back(p);
      }
    }
    // In blocks of a few MB, striped over the threads, each reusing its block's buffer;
    // ViewBasis::Coordinates gives a mean the same coordinates whatever block it is in (a
    // 10⁵ + 10⁵ merge takes 87 k changed means into the basis).
    constexpr size_t kBlock = 512;
    const size_t blocks = (todo.size() + kBlock - 1) / kBlock;
    const size_t stripes = std::min(blocks, static_cast<size_t>(std::max(threads, 1)));
    OnThreads(stripes, threads, [&](size_t stripe) {
      Eigen::MatrixXf block(dim, static_cast<Eigen::Index>(std::min(kBlock, todo.size())));
      for (size_t b = stripe * kBlock; b < todo.size(); b += stripes * kBlock) {
        const size_t len = std::min(kBlock, todo.size() - b);
        for (size_t i = 0; i < len; ++i) {
          block.col(static_cast<Eigen::Index>(i)) = places_[todo[b + i]].mean;
        }
        const Eigen::MatrixXf centres =
            basis->Coordinates(block.leftCols(static_cast<Eigen::Index>(len)));
        for (size_t i = 0; i < len; ++i) {
          const auto p = static_cast<size_t>(todo[b + i]);
          view_centres_[p] = centres.col(static_cast<Eigen::Index>(i));
          mean_norms_[p] = places_[p].mean.norm();
        }
      }
    });
  } else {
    // Columns padded to a multiple of 16 floats (64 bytes ≥ EIGEN_MAX_ALIGN_BYTES).
    const Eigen::Index stride = (dim + 15) / 16 * 16;
    if (means_.rows() != stride) means_.resize(stride, 0);
    if (end > means_.cols()) {
      // Grows by half: the cache costs dim·4 bytes per place plus at most 50 % slack.
      const Eigen::Index capacity = std::max<Eigen::Index>(64, means_.cols() + means_.cols() / 2);
      Eigen::MatrixXf grown(stride, std::max<Eigen::Index>(capacity, end));
      grown.leftCols(means_.cols()) = means_;
      grown.rightCols(grown.cols() - means_.cols()).setZero();
      means_.swap(grown);
    }
    for (int p = first; p < end; ++p) means_.col(p).head(dim) = places_[p].mean;
  }
  // The spacings and the index's keys from one set of pairwise view distances (the index
  // keys a place by views ThinViews spreads; thinned already, they are kept as they are).
  // New places are filed in the index's cells once, at the end (a restore appends them all).
  if (static_cast<size_t>(end) > spacings_.size()) spacings_.resize(static_cast<size_t>(end));
  if (static_cast<size_t>(end) > view_radii_.size()) view_radii_.resize(static_cast<size_t>(end));
  // A place appended to the index takes its given keys; one re-keyed is summarised anew.
  const int indexed = view_index_.size();
  TSC_ASSERT(first <= indexed, "places are appended to the view index in order");
  auto keeps_given = [&](int p) { return p >= indexed && given(p) != nullptr; };
  // The summaries first, on the threads (a merge's restore summarises the thousands of places
  // it changed: 0.38 s of a 10⁴ + 10⁴ merge on one thread), then filed in place order; in
  // blocks, so a store of 10⁵ places does not hold all its summaries at once.
  constexpr int kBlock = 4096;
  std::vector<ViewSummary> summaries;
  for (int block = first; block < end; block += kBlock) {
    const int block_end = std::min(end, block + kBlock);
    summaries.assign(static_cast<size_t>(block_end - block), ViewSummary{});
    OnThreads(summaries.size(), threads, [&](size_t k) {
      const int p = block + static_cast<int>(k);
      if (keeps_given(p)) return;
      const Eigen::MatrixXf views = places_[p].samples.Decoded();
      view_radii_[static_cast<size_t>(p)] =
          (views.colwise() - ViewCentre(p)).colwise().norm().maxCoeff();
      summaries[k] = SummariseViews(views, ViewIndex::kKeysPerPlace - 1);
    });
    for (int p = block; p < block_end; ++p) {
      if (keeps_given(p)) {
        const Derived* d = given(p);
        spacings_[static_cast<size_t>(p)] = d->spacing;
        view_radii_[static_cast<size_t>(p)] = d->view_radius;
        view_index_.AppendKeys(d->keys);
        continue;
      }
      const ViewSummary& views = summaries[static_cast<size_t>(p - block)];
      spacings_[static_cast<size_t>(p)] = views.spacing;
      if (p == view_index_.size()) {
        view_index_.Append(ViewCentre(p), views.spread);
      } else {
        view_index_.Set(p, ViewCentre(p), views.spread);
      }
    }
  }
  view_index_.FileAppended(threads);
}

void PlaceMemory::RetrainDiscriminant(int node) {
  if (!TrainsDiscriminants()) return;
  discriminants_[node] = OneClassDiscriminant::Train(TrainingSet(node), options_.discriminant);
}

void PlaceMemory::IndexOldNodes() {
  size_t size = 16;
  while (size < 2 * nodes_.size()) size *= 2;
  key_table_.assign(size, KeySlot{});
  const size_t mask = size - 1;
  auto slot_of = [&](uint64_t key) -> KeySlot& {
    for (size_t h = SplitMix64(key) & mask;; h = (h + 1) & mask) {
      KeySlot& s = key_table_[h];
      if (!s.used() || s.key == key) return s;
    }
  };
  // The first node with a given key wins, as with unordered_map::emplace in node order.
  for (size_t i = 0; i < nodes_.size(); ++i) {
    const bool inner = !nodes_[i].terminal(), trained = discriminants_[i].trained();
    if (!inner && !trained) continue;
    KeySlot& s = slot_of(nodes_[i].set_key);
    s.key = nodes_[i].set_key;
    if (inner && s.sum < 0) s.sum = static_cast<int>(i);
    if (trained && s.discriminant < 0) s.discriminant = static_cast<int>(i);
  }
}

const PlaceMemory::KeySlot* PlaceMemory::FindOldNode(uint64_t key) const {
  if (key_table_.empty()) return nullptr;
  const size_t mask = key_table_.size() - 1;
  for (size_t h = SplitMix64(key) & mask;; h = (h + 1) & mask) {
    const KeySlot& s = key_table_[h];
    if (!s.used()) return nullptr;
    if (s.key == key) return &s;
  }
}

void PlaceMemory::RebuildTree(std::unordered_map<uint64_t, OneClassDiscriminant>* saved) {
  // Keep the discriminants and centroid sums of nodes whose place set does not change: index
  // the old nodes by set key, then move their state out of the old per-node vectors.
  IndexOldNodes();
  old_sums_.swap(centroid_sums_);
  old_discriminants_.swap(discriminants_);
  BuildNodes();
  OrderLeaves();
  FillKeysAndSums();
  // `saved` (Restore) takes precedence over the old nodes; its entries are moved out.
  CarryOrTrainDiscriminants(saved);
}

void PlaceMemory::BuildNodes() {
  const int n = static_cast<int>(places_.size());
  // nodes_ is rebuilt in place: children vectors keep their capacity.
  auto reset = [](MemoryNode& node) {
    node.parent = -1;
    node.children.clear();
    node.place = -1;
    node.height = 0.0;
    node.first_leaf = 0;
    node.end_leaf = 0;
    node.set_key = 0;
  };
  if (n == 1) {
    nodes_.resize(2);
    for (MemoryNode& node : nodes_) reset(node);
    nodes_[0].place = 0;
    nodes_[1].children.push_back(0);
    nodes_[0].parent = 1;
    root_ = 1;
    return;
  }
  const std::vector<DendrogramMerge> merges = ToDendrogram(slink_);
  // Binary dendrogram: clusters 0..n−1 are places, n+i is merge i (heights increase).
  const int total = 2 * n - 1;
  bin_parent_.assign(total, -1);
  for (int i = 0; i < n - 1; ++i) {
    bin_parent_[merges[i].a] = n + i;
    bin_parent_[merges[i].b] = n + i;
  }
  // Simplification (section 3.6): merge node N folds into its parent P when
  // h(P) − h(N) ≤ τ_h·h(P); folding is transitive, the root never folds.
  target_.assign(total, -1);
  for (int c = total - 1; c >= n; --c) {
    const int p = bin_parent_[c];
    if (p < 0) {
      target_[c] = c;
      continue;
    }
    const double hp = merges[p - n].height, hc = merges[c - n].height;
    target_[c] = hp - hc <= options_.tau_h * hp ? target_[p] : c;
  }
  index_.assign(total, -1);
  for (int i = 0; i < n; ++i) index_[i] = i;
  int count = n;
  for (int c = n; c < total; ++c) {
    if (target_[c] == c) index_[c] = count++;
  }
  nodes_.resize(count);
  for (MemoryNode& node : nodes_) reset(node);
  for (int i = 0; i < n; ++i) nodes_[i].place = i;
  for (int c = n; c < total; ++c) {
    if (index_[c] >= 0) nodes_[index_[c]].height = merges[c - n].height;
  }
  for (int c = 0; c < total; ++c) {
    if (index_[c] < 0 || bin_parent_[c] < 0) continue;
    const int parent = index_[target_[bin_parent_[c]]];
    nodes_[index_[c]].parent = parent;
    nodes_[parent].children.push_back(index_[c]);
  }
  root_ = static_cast<int>(nodes_.size()) - 1;
}

void PlaceMemory::OrderLeaves() {
  // Leaf order by depth-first traversal: each node's places are one contiguous range.
  leaf_order_.clear();
  leaf_order_.reserve(places_.size());
  stack_.clear();
  stack_.push_back({root_, false});
  while (!stack_.empty()) {
    auto [node, done] = stack_.back();
    stack_.pop_back();
    MemoryNode& nd = nodes_[node];
    if (done) {
      nd.end_leaf = static_cast<int>(leaf_order_.size());
      continue;
    }
    nd.first_leaf = static_cast<int>(leaf_order_.size());
    if (nd.terminal()) {
      leaf_order_.push_back(nd.place);
      nd.end_leaf = nd.first_leaf + 1;
      continue;
    }
    stack_.push_back({node, true});
    for (auto it = nd.children.rbegin(); it != nd.children.rend(); ++it)
      stack_.push_back({*it, false});
  }
  TSC_ASSERT(leaf_order_.size() == places_.size(), "every place is one leaf of the tree");
}

void PlaceMemory::FillKeysAndSums() {
  // Children precede parents in index order, so one forward pass fills keys and the sums of
  // place means of inner nodes; a node whose place set existed before keeps its sum.
  centroid_sums_.clear();
  centroid_sums_.resize(nodes_.size());  // terminals use their place's mean
  for (size_t i = 0; i < nodes_.size(); ++i) {
    MemoryNode& nd = nodes_[i];
    if (nd.terminal()) {
      nd.set_key = PlaceKey(places_[nd.place].id);
      continue;
    }
    nd.set_key = 0;
    for (int c : nd.children) nd.set_key += nodes_[c].set_key;  // order-free wrapping sum
    const KeySlot* old = FindOldNode(nd.set_key);
    if (old != nullptr && old->sum >= 0 && old_sums_[old->sum].size() > 0) {
      centroid_sums_[i] = std::move(old_sums_[old->sum]);
      continue;
    }
    centroid_sums_[i] = Eigen::VectorXf::Zero(places_.front().mean.size());
    for (int c : nd.children) {
      centroid_sums_[i] += nodes_[c].terminal() ? places_[nodes_[c].place].mean : centroid_sums_[c];
    }
  }
}

void PlaceMemory::CarryOrTrainDiscriminants(
    std::unordered_map<uint64_t, OneClassDiscriminant>* saved) {
  // Only nodes whose place set is new are trained; the root's d_N is never consulted.
  discriminants_.clear();
  discriminants_.resize(nodes_.size());
  for (size_t i = 0; i < nodes_.size(); ++i) {
    if (static_cast<int>(i) == root_) continue;
    const uint64_t key = nodes_[i].set_key;
    if (saved != nullptr && !saved->empty()) {
      auto it = saved->find(key);
      if (it != saved->end()) {
        discriminants_[i] = std::move(it->second);
        continue;
      }
    }
    const KeySlot* old = FindOldNode(key);
    if (old != nullptr && old->discriminant >= 0) {
      discriminants_[i] = std::move(old_discriminants_[old->discriminant]);
    } else {
      RetrainDiscriminant(static_cast<int>(i));
    }
  }
}

std::vector<LearnedPlace> PlaceMemory::TakePlaces() && {
  std::vector<LearnedPlace> out = std::move(places_);
  *this = PlaceMemory(robot_, options_);
  return out;
}

PlaceMemory::Derived PlaceMemory::DerivedOf(int place) const {
  const auto p = static_cast<size_t>(place);
  Derived out;
  if (view_basis() != nullptr) {
    out.view_centre = view_centres_.at(p);
    out.mean_norm = mean_norms_.at(p);
  }
  out.spacing = spacings_.at(p);
  out.view_radius = view_radii_.at(p);
  out.keys = view_index_.KeysOf(place);
  return out;
}

PlaceMemory PlaceMemory::Restore(uint32_t robot, PlaceMemoryOptions options,
                                 std::vector<LearnedPlace> places, Slink slink, uint32_t next_local,
                                 std::unordered_map<uint64_t, OneClassDiscriminant> saved,
                                 std::vector<std::optional<Derived>> derived, int threads) {
  PlaceMemory memory(robot, std::move(options));
  if (static_cast<int>(places.size()) != slink.size()) {
    throw std::invalid_argument("place memory: " + std::to_string(places.size()) +
                                " places but SLINK state of " + std::to_string(slink.size()));
  }
  if (!derived.empty() && derived.size() != places.size()) {
    throw std::invalid_argument("place memory: derived values of " +
                                std::to_string(derived.size()) + " places for " +
                                std::to_string(places.size()));
  }
  if (const ViewBasis* basis = memory.view_basis()) {
    for (const LearnedPlace& p : places) {
      if (p.mean.size() > 0 && p.mean.size() != basis->input_dimension()) {
        throw DescriptorSpaceMismatch(
            "place memory: place " + p.id.ToString() + " has descriptors of dimension " +
            std::to_string(p.mean.size()) + ", but memory.view_basis = " + basis->name() +
            " takes " + std::to_string(basis->input_dimension()) +
            ": the memory was learned with other bubble.features; use the configuration it "
            "was learned with");
      }
    }
    // A memory saved, or sent by a peer, before views were kept in the basis holds them in
    // the descriptors' own space: they are taken into the basis (docs/decisions.md "A
    // principal basis for member views").
    for (LearnedPlace& p : places) {
      if (p.samples.rows() == basis->input_dimension() && p.samples.rows() != basis->dimension()) {
        p.samples = CompactViews(basis->Coordinates(p.samples.Decoded()));
      }
    }
  }
  // Places read from a store (an older tscd kept every member and detected place), and places
  // a merge or a consolidation folded together, keep their latest ones here.
  for (LearnedPlace& p : places) TrimHistory(p);
  for (const LearnedPlace& p : places) {
    if (p.mean.size() == 0 || p.mean.size() != places.front().mean.size() || !p.mean.allFinite() ||
        p.samples.cols() == 0 || p.member_count < 1) {
      throw std::invalid_argument("place memory: place " + p.id.ToString() + " is inconsistent");
    }
    if (p.mean.cwiseAbs().maxCoeff() > LearnedPlace::kMaxMeanValue ||
        p.member_count > LearnedPlace::kMaxMemberCount) {
      throw std::invalid_argument("place memory: place " + p.id.ToString() +
                                  " has a mean value beyond ±1e6 or more than 2^40 members, "
                                  "which no update keeps finite");
    }
    const int view_dim = ViewDimension(memory.view_basis(), static_cast<int>(p.mean.size()));
    if (p.samples.rows() != view_dim) {
      const ViewBasis* basis = memory.view_basis();
      throw DescriptorSpaceMismatch(
          "place memory: place " + p.id.ToString() + " keeps member views of dimension " +
          std::to_string(p.samples.rows()) + ", but memory.view_basis = " +
          (basis ? basis->name() : std::string("none")) + " keeps them in " +
          std::to_string(view_dim) + " (the memory was kept in another view basis)");
    }
    if (p.id.robot == robot && p.id.local >= next_local) {
      throw std::invalid_argument("place memory: place " + p.id.ToString() +
                                  " not below next local id " + std::to_string(next_local));
    }
  }
  // Derived values of another shape (another basis, another dimension) are not the
  // places' own: they are computed instead.
  if (!places.empty()) {
    const ViewBasis* basis = memory.view_basis();
    const int view_dim = ViewDimension(basis, static_cast<int>(places.front().mean.size()));
    for (std::optional<Derived>& d : derived) {
      if (d && (d->view_centre.size() != (basis ? view_dim : 0) || d->keys.dimension != view_dim)) {
        d.reset();
      }
    }
  }
  memory.places_ = std::move(places);
  memory.slink_ = std::move(slink);
  memory.next_local_ = next_local;
  // All at once: the cache is sized once and the means taken into the basis in blocks.
  memory.StoreDerived(0, static_cast<int>(memory.places_.size()),
                      derived.empty() ? nullptr : &derived, threads);
  if (!memory.places_.empty()) memory.RebuildTree(&saved);
  return memory;
}

}  // namespace tsc
