#pragma once
// Incremental SLINK (Sibson 1973): single-linkage clustering in pointer representation
// (π, λ), the learning step of section 3.6, (3.13)-(3.14). O(n) time and memory per insertion.

#include <Eigen/Core>
#include <limits>
#include <utility>
#include <vector>

namespace tsc {

class Slink {
 public:
  static constexpr double kInfinity = std::numeric_limits<double>::infinity();

  Slink() = default;
  /// Restores a saved state. Throws std::invalid_argument if it is not a valid pointer
  /// representation (sizes differ, π(i) ≤ i for some i < n−1, last λ finite).
  Slink(std::vector<int> pi, std::vector<double> lambda);

  /// Inserts point n with distances[i] = γ(i, n) for i < n. Throws if the size is not n.
  void Insert(const std::vector<double>& distances);

  int size() const { return static_cast<int>(pi_.size()); }
  /// π(i): the last point of the cluster i joins at height λ(i).
  const std::vector<int>& pi() const { return pi_; }
  /// λ(i): the height at which i stops being the last point of its cluster (∞ for the last).
  const std::vector<double>& lambda() const { return lambda_; }
  /// (λ(i), i) for the points i < n−1 (finite λ), in increasing λ, ties by index. Kept up
  /// to date by Insert in O(n + k log k) for the k heights an insertion changes.
  const std::vector<std::pair<double, int>>& order() const { return order_; }

 private:
  std::vector<int> pi_;
  std::vector<double> lambda_;
  std::vector<std::pair<double, int>> order_;
  std::vector<double> m_;                       // scratch
  std::vector<std::pair<double, int>> fresh_;   // scratch: entries whose λ changed
  std::vector<std::pair<double, int>> merged_;  // scratch
};

/// A binary merge of the single-linkage dendrogram: clusters a and b join at `height`.
/// Cluster ids: 0..n-1 are points, n+i is the cluster made by merge i.
struct DendrogramMerge {
  int a;
  int b;
  double height;
};
/// The n−1 merges of the pointer representation, in increasing height (ties by point index).
std::vector<DendrogramMerge> ToDendrogram(const Slink& slink);

}  // namespace tsc
