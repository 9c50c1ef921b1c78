#pragma once
// The place memory (sections 3.3, 3.5, 3.6): a rooted tree over the learned places, built by
// incremental SLINK and simplified with τ_h; recognition by top-down or hybrid traversal with
// the cost g_N of (3.8), its terms measured on the places' member views
// (core/memory/recognition_cost.h). The one-class SVM discriminants of the thesis are trained
// per node only with memory.svm_vote.

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <optional>
#include <unordered_map>
#include <vector>

#include "core/detect/place_detector.h"
#include "core/memory/discriminant.h"
#include "core/memory/learned_place.h"
#include "core/memory/place_id.h"
#include "core/memory/recognition_cost.h"
#include "core/memory/slink.h"
#include "core/memory/view_basis.h"
#include "core/memory/view_index.h"
#include "core/range.h"

namespace tsc {

/// A node of the simplified tree. Terminals are nodes 0..P−1 (node i holds place i); inner
/// nodes follow; the root is inner and always exists once a place is learned.
struct MemoryNode {
  int parent = -1;            ///< −1 for the root
  std::vector<int> children;  ///< node indices
  int place = -1;             ///< place index for terminals, −1 for inner nodes
  double height = 0.0;        ///< SLINK merge height (0 for terminals)
  int first_leaf = 0;         ///< the node's places are leaf_order()[first_leaf, end_leaf)
  int end_leaf = 0;
  uint64_t set_key = 0;  ///< order-free hash of the node's place set
  bool terminal() const { return place >= 0; }
  int num_places() const { return end_leaf - first_leaf; }
};

struct PlaceMemoryOptions {
  /// τ_r recognition cost threshold (3.11). Calibrated with the terms of
  /// core/memory/recognition_cost.h (docs/calibration.md).
  double tau_r = 2.9;
  int tau_l = 1;        ///< τ_l levels climbed by the hybrid traversal
  double tau_h = 0.25;  ///< τ_h relative merge-height gap folded by simplification, [0, 1)
  /// On the way to a place the topological map joins to the previous place, g_N may exceed
  /// τ_r by this much: the robot more likely enters a neighbour of where it was than any
  /// other place (docs/decisions.md "Recognition cost": map neighbours). 0: τ_r alone.
  double neighbour_margin = 0.3;
  /// Member views kept per visit of a place (core/memory/member_views.h).
  int max_samples_per_place = 32;
  /// A place keeps max_samples_per_place views for each visit (a detected place of its own or
  /// a place it absorbed), of at most this many visits: a room revisited along other paths
  /// keeps views of them, where one visit's cap made revisits lie further from the views the
  /// longer the room and learned it again (docs/decisions.md "Member views"). 1: one visit's.
  int sample_visits = 2;
  /// The member views place `p` may keep (SampleCap ≥ max_samples_per_place).
  int SampleCap(const LearnedPlace& p) const;
  int max_vote_points = 32;  ///< base points of D used for the cost (evenly spaced)
  /// The vote V of (3.8): false, D's points within the vote radius of N¹'s nearest member
  /// view; true, the thesis' one-class SVM d_{N¹}, trained per node (docs/decisions.md
  /// "Recognition cost": it accepted no fresh view at the sizes a place has).
  bool svm_vote = false;
  /// Where N's children are all one place held again (they coincide with N¹), the ratio term
  /// is the one N¹'s node had one level up instead of a lone child's 1 (docs/decisions.md
  /// "Recognition cost": repeat laps).
  bool copies_keep_outer_ratio = true;
  /// A detected place whose g_N passes but whose points name other places (the agreement
  /// fails) is learned as a new place (true, as any unrecognised one), or left without a
  /// place (false; the pipeline's "ambiguous" event): its cost says it is known, only not
  /// which place it is, and learning it adds a copy of a room held already
  /// (docs/decisions.md, "Recognition cost": long runs).
  bool learn_disagreed = false;
  /// A detected place not recognised whose g_N came within this margin of τ_r while at least
  /// near_miss_vote of its points voted for N¹, and N¹ was nearer than another place (ratio
  /// term below 1), is left without a place too (the "ambiguous" event): half of it lies in
  /// a place held already, and learning it adds a copy of that place that later passes,
  /// nearer the original, never recognise. A lone N¹ (a memory of one place) is no such
  /// evidence (docs/decisions.md "Recognition cost": near misses). 0: a place not recognised
  /// is learned, as the thesis does.
  double near_miss_margin = 1.5;
  double near_miss_vote = 0.45;  ///< V of N¹ a near miss needs
  /// Whether g_N = `g` above τ_r with its `terms` is a near miss (near_miss_margin).
  bool NearMiss(double g, const CostTerms& terms) const;
  /// The unit u of the distance term and the vote radius, a squared descriptor distance: 0
  /// takes the memory's median view spacing (adapts to any camera); > 0 fixes it for a
  /// camera kind (a preset, docs/decisions.md "Recognition cost").
  double distance_unit = 0.45e-5;
  /// u is at least this multiple of D's own step, the median squared distance between D's
  /// consecutive base points: a revisit is not expected nearer the memory's views than D's
  /// frames are to each other (real keyframes a metre apart; docs/decisions.md "Recognition
  /// cost"). 0: distance_unit alone.
  double step_unit = 0.5;
  /// Places measured exactly per recognition once the memory holds more: the ones whose
  /// keys in the view index come nearest D (core/memory/view_index.h). 0: every place.
  int shortlist = 32;
  /// Whether recognition among `places` candidate places measures only a shortlist of them.
  bool Shortlists(size_t places) const {
    return shortlist > 0 && places > static_cast<size_t>(shortlist);
  }
  /// Whether the view index reads only its cells nearest D once it holds
  /// ViewIndex::kCellsFrom places (false: every key, the exact index; benchmarks compare).
  bool view_cells = true;
  /// The space member views are kept and measured in (core/memory/view_basis.h); null: the
  /// descriptors' own. Every memory a merge joins must use the same basis.
  std::shared_ptr<const ViewBasis> view_basis;
  RecognitionCostOptions cost;
  DiscriminantOptions discriminant;  ///< d_N, used with svm_vote
  // Valid ranges (also the configuration's, memory.*).
  static constexpr Range kTauRRange{0, 1000, /*min_open=*/true};
  static constexpr Range kTauLRange{0, 1000};
  static constexpr Range kNeighbourMarginRange{0, 1000};
  static constexpr Range kNearMissMarginRange{0, 1000};
  static constexpr Range kNearMissVoteRange{0, 1};
  static constexpr Range kTauHRange{0, 1, false, /*max_open=*/true};
  static constexpr Range kMaxSamplesRange{1, 100000};
  static constexpr Range kSampleVisitsRange{1, 1000};
  static constexpr Range kMaxVotePointsRange{1, 100000};
  static constexpr Range kDistanceUnitRange{0, 1e6};  ///< squared descriptor distance
  static constexpr Range kStepUnitRange{0, 1e6};
  static constexpr Range kShortlistRange{0, 1000000};
  void Validate() const;
  /// The camera's units alone (step_unit, distance_unit): what AdoptUnits takes.
  void ValidateUnits() const;
};

/// D's vote points (evenly spaced base points, at most memory.max_vote_points): in the view
/// space, what distances to member views are measured on, and their mean descriptor, what the
/// centroids of the tree's nodes are compared with.
struct Votes {
  Eigen::MatrixXf views;
  Eigen::VectorXf mean;
};

/// Outcome of one recognition attempt.
struct Recognition {
  std::optional<int> place;  ///< recognised place index β(D), if any
  double cost = 0.0;         ///< g_N at the last node evaluated
  CostTerms terms;           ///< its terms (terms.best: N¹ as a node index)
  bool hybrid = false;       ///< the hybrid traversal recognised it
  /// Recognised with some g_N above τ_r, towards a map neighbour (neighbour_margin).
  bool neighbour = false;
  /// Not recognised, though some descent reached a terminal within its τ: D's points did not
  /// agree with it (memory.min_agreement).
  bool disagreed = false;
  /// Not recognised, but g_N came near τ_r with half of D's points voting for N¹
  /// (PlaceMemoryOptions::near_miss_margin).
  bool near_miss = false;
  std::vector<int> start_nodes;  ///< nodes a descent started from, in order
  std::vector<int> visited;      ///< every inner node whose g_N was evaluated, in order
};

class PlaceMemory {
 public:
  PlaceMemory(uint32_t robot, PlaceMemoryOptions options);

  /// Hybrid when `previous` names a learned place (start at its terminal's parent, climb up
  /// to τ_l levels, descending from each), then top-down from the root. `neighbours`: places
  /// the map joins to the previous one, towards which g_N may reach τ_r + neighbour_margin.
  Recognition Recognize(const DetectedPlace& d, std::optional<int> previous = std::nullopt,
                        const std::vector<int>& neighbours = {}) const;
  /// Top-down descent from `start`: while g_N ≤ τ_r go to N¹; a terminal N¹ recognises.
  /// `towards_neighbour`, when given, marks the nodes on the way to a neighbour (per node).
  Recognition Descend(const DetectedPlace& d, int start) const;
  Recognition Descend(const ViewDistances& vd, const Votes& votes, int start,
                      const std::vector<char>* towards_neighbour = nullptr) const;
  /// g_N(D) of (3.8) at inner node `node` from D's vote points' distances to every place's
  /// member views; `terms.best` is N¹ as a node index.
  CostTerms Cost(const ViewDistances& vd, const Votes& votes, int node) const;
  /// The nearest member views of every place to D's vote points (only of the shortlist's
  /// places once the memory holds more than options().shortlist; the others infinitely far).
  ViewDistances DistancesOf(const Eigen::MatrixXf& votes, double unit) const;
  /// The index over the places' member views (core/memory/view_index.h): what the merge
  /// shortlists a hyper-terminal's places by, and the ratio term's distance to the places it
  /// does not measure (core/merge/recognition.cc).
  const ViewIndex& view_index() const { return view_index_; }
  /// u for D: the larger of DistanceUnit() and step_unit x D's median consecutive squared
  /// step (DistanceUnit() alone when D has one point or step_unit is 0).
  double UnitFor(const DetectedPlace& d) const;
  Votes VotePoints(const DetectedPlace& d) const;
  /// The basis of member views (null: the descriptors' own space).
  const ViewBasis* view_basis() const { return options_.view_basis.get(); }
  /// Place `place`'s mean in the space of member views (the mean itself without a basis).
  const Eigen::VectorXf& ViewCentre(int place) const;
  /// The distance from ViewCentre(place) to its farthest member view: what bounds the place's
  /// views for the merge's root spheres (core/merge/merge_cases.cc), which otherwise decoded
  /// every view of both memories at each merge.
  float ViewRadius(int place) const { return view_radii_.at(static_cast<size_t>(place)); }

  /// Learns D as a new place p*+1 (SLINK insertion, rebuild, retrain changed nodes).
  int Learn(const DetectedPlace& d);
  /// Adds D to place `place` (members, mean, member views thinned with ThinViews so every
  /// visit is represented) and retrains its path to the root.
  void Update(int place, const DetectedPlace& d);
  /// The view spacing u_p of place `place` (ViewSpacing of its member views).
  double ViewSpacingOf(int place) const { return spacings_.at(static_cast<size_t>(place)); }
  /// The median positive view spacing over the places (0 when none has one).
  double MedianViewSpacing() const;
  /// u of the recognition cost: options().distance_unit, or MedianViewSpacing() when that
  /// is 0 (0 when neither is known yet).
  double DistanceUnit() const;

  uint32_t robot() const { return robot_; }
  const PlaceMemoryOptions& options() const { return options_; }
  /// Takes options().distance_unit and step_unit from `camera`: the units follow the spacing
  /// and the lens of the camera whose base points the memory is now given (AdaptToSpacing,
  /// AdaptToLens), which a stored or received memory does not carry. Throws
  /// std::invalid_argument outside their ranges, changing nothing.
  void AdoptUnits(const PlaceMemoryOptions& camera);
  const std::vector<LearnedPlace>& places() const { return places_; }
  const std::vector<MemoryNode>& nodes() const { return nodes_; }
  const std::vector<OneClassDiscriminant>& discriminants() const { return discriminants_; }
  const std::vector<int>& leaf_order() const { return leaf_order_; }
  const Slink& slink() const { return slink_; }
  int root() const { return root_; }
  bool empty() const { return places_.empty(); }
  uint32_t next_local_id() const { return next_local_; }
  std::optional<int> Find(PlaceId id) const;
  /// c(N): mean of the means of the node's places.
  Eigen::VectorXf Centroid(int node) const;
  /// Node `node` as a candidate of g_N: its places (a range of leaf_order()) and its centroid,
  /// both viewed, valid while the memory is unchanged.
  CostCandidate CandidateOf(int node) const;
  int Depth() const;

  /// Moves the places out and leaves an empty memory of the same robot and options (next
  /// local id back to 1), so a caller rebuilding a memory from them with Restore (core/merge)
  /// copies no descriptors.
  std::vector<LearnedPlace> TakePlaces() &&;

  /// What the memory derives from a place's mean and member views alone: the mean's
  /// coordinates in the view basis and its norm (with a basis), the view spacing and radius,
  /// the view index's keys. A merge hands it to Restore for the places it takes over
  /// unchanged, which would otherwise compute it all again (a sixth of a 10⁴ + 10⁴ merge). It
  /// belongs to the exact mean and views it was taken from.
  struct Derived {
    Eigen::VectorXf view_centre;  // empty without a basis
    float mean_norm = 0.0f;
    double spacing = 0.0;
    float view_radius = 0.0f;
    ViewIndex::PlaceKeys keys;
  };
  Derived DerivedOf(int place) const;

  /// Rebuilds a memory saved earlier. Discriminants are taken from `saved` by set key where
  /// present (moved, so pass it as an rvalue to avoid a copy) and retrained otherwise.
  /// `derived` (empty, or one per place): DerivedOf of a memory of the same options, taken
  /// where the place's mean and member views were the very same, used instead of computing
  /// them. The places' coordinates in the view basis and view summaries are computed on up to
  /// `threads` threads; the memory is the same for any number. Throws std::invalid_argument on
  /// inconsistent input.
  static PlaceMemory Restore(uint32_t robot, PlaceMemoryOptions options,
                             std::vector<LearnedPlace> places, Slink slink, uint32_t next_local,
                             std::unordered_map<uint64_t, OneClassDiscriminant> saved,
                             std::vector<std::optional<Derived>> derived = {}, int threads = 1);

 private:
  // An old node's index by set key: the first inner node (its centroid sum) and the first
  // node with a trained discriminant, −1 when there is none. Open addressing, linear probing.
  struct KeySlot {
    uint64_t key = 0;
    int sum = -1;
    int discriminant = -1;
    bool used() const { return sum >= 0 || discriminant >= 0; }
  };

  /// `saved` (may be null): discriminants by set key, moved out of the map when used.
  void RebuildTree(std::unordered_map<uint64_t, OneClassDiscriminant>* saved);
  // RebuildTree's steps: the simplified dendrogram as nodes_ (section 3.6), the leaf ranges,
  // the set keys and centroid sums, the discriminants (carried over or trained).
  void BuildNodes();
  void OrderLeaves();
  void FillKeysAndSums();
  void CarryOrTrainDiscriminants(std::unordered_map<uint64_t, OneClassDiscriminant>* saved);
  void IndexOldNodes();
  const KeySlot* FindOldNode(uint64_t key) const;
  void RetrainDiscriminant(int node);
  Eigen::MatrixXf TrainingSet(int node) const;
  bool TrainsDiscriminants() const { return options_.svm_vote; }
  /// Lower bounds of γ(i, x) between every place's mean and `mean`, from the means'
  /// coordinates in the view basis (which must be set), for Slink::InsertBounded.
  void GammaLowerBounds(const Eigen::VectorXf& mean, std::vector<double>& out) const;
  /// With a view basis, takes the means of places [first, end) into it (view_centres_,
  /// mean_norms_); without one, copies them into their columns of `means_` (growing it as
  /// needed). Then measures their view spacings and radii and re-keys them in the view index.
  /// With `derived` (one per place), a place that has one takes it instead. On up to `threads`
  /// threads.
  void StoreDerived(int first, int end,
                    const std::vector<std::optional<Derived>>* derived = nullptr, int threads = 1);

  uint32_t robot_;
  PlaceMemoryOptions options_;
  std::vector<LearnedPlace> places_;
  Slink slink_;
  std::vector<MemoryNode> nodes_;
  std::vector<OneClassDiscriminant> discriminants_;  // per node; root's is unused
  std::vector<Eigen::VectorXf> centroid_sums_;       // per inner node: Σ place means
  std::vector<int> leaf_order_;
  std::vector<double> spacings_;   // per place: ViewSpacing of its member views
  std::vector<float> view_radii_;  // per place: ViewRadius
  int root_ = -1;
  uint32_t next_local_ = 1;

  // Without a view basis: place means in one contiguous matrix (a cache of places_[i].mean,
  // kept in sync by Learn, Update and Restore) so the SLINK distance pass, which measures
  // every γ, streams memory. Column i holds place i in rows [0, dim); the stride is padded so
  // every column is aligned like a VectorXf, which keeps the distances bit-identical to
  // (places_[i].mean − x).squaredNorm(). With a basis, learning measures few γ and reads
  // them from the places: the cache would be a second copy of every mean (4.8 KB a place).
  Eigen::MatrixXf means_;
  ViewIndex view_index_;  // keys of every place, in place order
  // With a view basis: each place's mean in it (ViewCentre), kept in sync with the means.
  std::vector<Eigen::VectorXf> view_centres_;
  std::vector<float> mean_norms_;  // with a view basis: ‖mean‖ of each place (GammaLowerBounds)
  int plain_learnings_ = 0;        // learnings left that measure every γ (Learn)

  // Scratch reused across rebuilds (no per-learn allocation).
  std::vector<KeySlot> key_table_;
  std::vector<Eigen::VectorXf> old_sums_;
  std::vector<OneClassDiscriminant> old_discriminants_;
  std::vector<int> bin_parent_, target_, index_;
  std::vector<std::pair<int, bool>> stack_;
  std::vector<double> distances_;
};

}  // namespace tsc
