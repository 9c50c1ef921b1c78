#pragma once
// Incremental SLINK (Sibson 1973): single-linkage clustering in pointer representation
// (π, λ), the learning step of section 3.6, (3.13)-(3.14). O(n) time and memory per insertion.

#include <Eigen/Core>
#include <functional>
#include <limits>
#include <span>
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
  /// The same insertion, the same state after it, with γ(i, n) known first by lower bounds
  /// (`lower[i]` ≤ γ(i, n)) and measured by `distance(i)` only where a bound cannot settle
  /// Sibson's comparison λ(i) ≥ M(i) (issue 23: at 10⁵ places reading every mean is the
  /// learning's cost, and most points are far from the new one). Throws as Insert does.
  void InsertBounded(std::span<const double> lower, const std::function<double(int)>& distance);
  /// How many distances the last InsertBounded measured (benchmarks report the share).
  int measured() const { return measured_; }

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
  // Scratch of InsertBounded: per point, what it adds to M(π(i)) (exact, or a lower bound of
  // M(i) when i is proven not to join), and the pointer tree's children in CSR form.
  std::vector<double> contribution_;
  std::vector<char> exact_;
  std::vector<int> child_start_, children_;
  struct Frame {
    int node;
    int next;     // the next child to look at
    double best;  // the smallest term of M(node) found so far
  };
  std::vector<Frame> stack_;
  int measured_ = 0;
  // Sets exact_ and contribution_ of `i` to M(i), resolving the children it depends on.
  double ExactM(int i, std::span<const double> lower, const std::function<double(int)>& distance);
  // Merges the entries whose λ changed (fresh_) into order_.
  void UpdateOrder();
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
