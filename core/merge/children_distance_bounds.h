#pragma once
// Distances no larger than the true ones from the centres of the incoming hyper-terminals to
// the centres of each base node's children, measured in the memory's view basis (128
// dimensions for 1200), all children of a node in one product: what MatchHyperTerminals
// bounds a node's overlap with before measuring it in full. A flat tree (a memory of many
// rooms held once or twice) gives the root thousands of children, and measuring each of them
// in 1200 dimensions for every incoming hyper-terminal took 5 of the 6 s of a 10⁴ + 10⁴
// merge of such memories.

#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "core/memory/place_memory.h"
#include "core/merge/hyper_terminals.h"

namespace tsc {

class ChildrenDistanceBounds {
 public:
  /// `centre`: c(N) of every inner node of `base` (any value for terminals); `incoming`: the
  /// hyper-terminals to match. Without a view basis in `base` (or with descriptors of another
  /// dimension) nothing is bounded: available() is false.
  ChildrenDistanceBounds(const PlaceMemory& base, const std::vector<Eigen::VectorXf>& centre,
                         const std::vector<HyperTerminal>& incoming);
  bool available() const { return incoming_.size() > 0; }
  /// For each child of `node` (in its order), a distance from incoming centre `a` to the
  /// child's centre no larger than the true one (for an inner child; terminals: unspecified).
  void BelowChildren(size_t a, size_t node, std::vector<double>& out) const;

 private:
  std::vector<Eigen::Index> first_;  // per node: its children's first column in kids_
  Eigen::MatrixXf kids_, incoming_;
  std::vector<double> kid_sq_, kid_slack_, incoming_sq_, incoming_slack_;
  // BelowChildren's products: the root's children against a block of incoming centres at once
  // (every match starts at the root: one matrix product instead of one per centre), any
  // other node's against one centre.
  static constexpr Eigen::Index kBlock = 256;
  int root_ = -1;
  mutable Eigen::MatrixXf root_products_;  // root's children x incoming [root_first_, +kBlock)
  mutable Eigen::Index root_first_ = -1;
  mutable Eigen::VectorXf products_;
  double scale_sq_ = 0.0;
};

}  // namespace tsc
