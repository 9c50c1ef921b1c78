#pragma once
// g_N of (3.8) from member views (DESIGN §3.3 amended; docs/decisions.md "Recognition cost"),
// the one implementation recognition (PlaceMemory) and merging (core/merge) share.
//
// Every term is measured from D's vote points x_j to the member views the places keep:
//   δ_j(C)    squared distance from x_j to the nearest view of a place under child C;
//   γ̃(D, C)  median_j δ_j(C): a set distance that means the same at every level of the tree
//              (a node is as near as its nearest place) and for a place seen from several
//              headings (the nearest view, not a mean over headings, counts);
//   term 1    median_j δ_j(N¹) / u_j, u_j the unit of the place whose view is nearest to x_j
//              (PlaceMemory gives every place one unit: memory.distance_unit, a preset per
//              camera kind, or the memory's median view spacing);
//              With a mean unit set (a pan sweep's preset), the smaller of that and
//              ‖Ī_D − c(N¹)‖² / mean_unit;
//   ratio     γ̃(D, N¹) / γ̃(D, N²), where N² skips children that coincide with N¹ (their
//              nearest views lie within N¹'s vote radius of N¹'s: a room held twice is one
//              candidate, so its copies do not lock each other out); 1 with no other child;
//   V         the fraction of x_j with δ_j(N¹) ≤ vote_radius · u_j: the place explains the view.
// docs/decisions.md "Recognition cost" gives the figures behind each choice.

#include <Eigen/Core>
#include <limits>
#include <span>
#include <vector>

#include "core/memory/decoded_views.h"
#include "core/memory/learned_place.h"
#include "core/memory/simd.h"
#include "core/range.h"

namespace tsc {

/// For each vote point and each place: the nearest member view (squared distance and column).
class ViewDistances {
 public:
  /// `votes` dim x n (n ≥ 1); `places` the candidates' places (their `samples` are the views)
  /// with `units` their view spacings (same order). A place with no spacing of its own (one
  /// view) takes the median positive spacing of the others, else D's own (the vote points'
  /// spacing), else the smallest positive float: it is then recognised only on equal views.
  /// Brute force over every view of every place given; a null place is not measured (left
  /// out of a shortlist, core/memory/view_index.h): infinitely far, with no nearest view.
  /// `estimates` (empty, or one per place) stand in for a place that is not measured where
  /// only a rough distance is needed: the ratio's N² (RecognitionCost). `simd`: the
  /// instructions the products run on (the same distances up to rounding; tests compare them).
  /// Per-place inputs are taken over, not copied: at 10⁵ places each is a megabyte.
  /// `decoded` (empty, or one per place, null where none is kept): a place's views already
  /// decoded on `simd` (core/memory/decoded_views.h), used instead of decoding its samples;
  /// the distances are the same floats either way.
  ViewDistances(const Eigen::MatrixXf& votes, std::vector<const LearnedPlace*> places,
                std::vector<double> units, std::vector<float> estimates = {},
                Simd simd = FastestSimd(), std::span<const DecodedViews* const> decoded = {});
  int num_votes() const { return static_cast<int>(distance_.rows()); }
  int num_places() const { return static_cast<int>(places_.size()); }
  /// Infinite for a place that is not measured.
  float distance(int vote, int place) const {
    const int c = column_[static_cast<size_t>(place)];
    return c < 0 ? std::numeric_limits<float>::infinity() : distance_(vote, c);
  }
  /// −1 for a place that is not measured.
  int view(int vote, int place) const {
    const int c = column_[static_cast<size_t>(place)];
    return c < 0 ? -1 : view_(vote, c);
  }
  double unit(int place) const { return units_[static_cast<size_t>(place)]; }
  const LearnedPlace& place(int i) const { return *places_[static_cast<size_t>(i)]; }
  bool measured(int place) const { return column_[static_cast<size_t>(place)] >= 0; }
  /// The measured place whose nearest view is nearest vote point `vote` (the lower index on
  /// ties); −1 when no place is measured.
  int NearestPlace(int vote) const;
  /// A rough squared distance to a place that is not measured (infinite without estimates).
  float estimate(int place) const {
    return estimates_.empty() ? std::numeric_limits<float>::infinity()
                              : estimates_[static_cast<size_t>(place)];
  }

 private:
  // Only the measured places have a column (a shortlist measures a few of 10⁴ places).
  Eigen::MatrixXf distance_;  // votes x measured places
  Eigen::MatrixXi view_;      // column of the nearest view in the place's samples
  std::vector<const LearnedPlace*> places_;
  std::vector<int> column_;    // per place: its column in distance_, −1 when not measured
  std::vector<int> measured_;  // per column: its place, in increasing order
  std::vector<double> units_;
  std::vector<float> estimates_;
};

/// A child of the node g_N is evaluated at: the places under it (indices into the
/// ViewDistances' places) and whether it may be N¹ (merging absorbs only into terminals).
struct CostCandidate {
  /// Viewed, not owned: a node's places are a range of the memory's leaf order (copying them
  /// at every level of the descent was a sixth of a recognition at 10⁵ places).
  std::span<const int> places;
  /// c(C), the mean of its places' means, kept as their sum and count (a node's running sum,
  /// or a place's own mean and 1) and viewed: only N¹'s is read (copying every child's, 1500
  /// terminals of 4.8 KB at 10⁵ places, was half a recognition).
  const Eigen::VectorXf* centroid_sum = nullptr;
  float centroid_count = 1.0f;
  bool may_be_best = true;
  Eigen::VectorXf Centroid() const { return *centroid_sum / centroid_count; }
};

struct CostTerms {
  int best = -1;          ///< index of N¹ in the candidates (−1: none may be)
  double gamma = 0.0;     ///< γ̃(D, N¹): median over D's points of the nearest view's δ
  double distance = 0.0;  ///< term 1: median_j δ_j(N¹)/u_j
  double ratio = 1.0;     ///< γ̃(D,N¹)/γ̃(D,N²)
  double vote = 0.0;      ///< V
  double cost = 0.0;      ///< term 1 + ratio + (1 − V), (3.8)
  /// Every other child holds N¹'s place again (coincides with it): the ratio term is then 1,
  /// as with one child; a descent may take the ratio N¹'s node had one level up instead.
  bool only_copies = false;
  /// Where N¹ is one place: the share of D's points that agree with it
  /// (core/memory/point_agreement.h); 1 where N¹ holds several places.
  double agreement = 1.0;
  /// Children of one place whose views nearest D's points lie, in the median, within the
  /// vote radius of N¹'s (whatever the coincide factor): the place of N¹ held again, the
  /// evidence a robot's copies of a room are one (core/pipeline/copy_evidence.h).
  std::vector<int> held_again;
};

struct RecognitionCostOptions {
  double vote_radius = 2.0;  ///< V counts x_j with δ_j(N¹) ≤ vote_radius · u_j
  /// Unit of ‖Ī_D − c(N¹)‖² when the distance term may also come from the means; 0: views only.
  double mean_unit = 0.0;
  /// Two children coincide (N² skips the copy) when their views nearest D's points lie, in the
  /// median, within the larger of vote_radius and this factor times the distance term (D's
  /// own distance to N¹, in units u). 0: the vote radius alone. Two copies of a room learned
  /// on different laps hold other views of it, often further apart than 2 u, and a revisit
  /// lies at about the distance term from either (docs/decisions.md "Recognition cost").
  double coincide_factor = 2.0;
  /// A place is recognised (or absorbs a place in a merge) only when at least this share of
  /// D's points agree with it (core/memory/point_agreement.h); 0: the cost alone decides.
  double min_agreement = 0.5;
  /// A point also agrees when the place's nearest view lies within this factor of the
  /// nearest place's distance (≥ 1).
  double agreement_slack = 1.5;
  // Valid ranges (also the configuration's, memory.vote_radius, memory.mean_distance_unit,
  // memory.coincide_factor, memory.min_agreement and memory.agreement_slack).
  static constexpr Range kVoteRadiusRange{0, 1000, /*min_open=*/true};
  static constexpr Range kMeanUnitRange{0, 1e6};
  static constexpr Range kCoincideFactorRange{0, 100};
  static constexpr Range kMinAgreementRange{0, 1};
  static constexpr Range kAgreementSlackRange{1, 1000};
  void Validate() const;
};

/// g_N over `candidates` (the children of N) for D with mean `mean`; vd has at least one vote
/// point. With no candidate that may be N¹ and has a measured place, `best` is −1 and the
/// cost infinite: nothing there is recognised.
CostTerms RecognitionCost(const ViewDistances& vd, const Eigen::VectorXf& mean,
                          std::span<const CostCandidate> candidates,
                          const RecognitionCostOptions& options);

}  // namespace tsc
