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
#include "core/memory/simd.h"
#include "core/merge/hyper_terminals.h"

namespace tsc {

/// c(N) of every inner node of `memory` (empty for terminals): the mean of the place means
/// under it, each node's summed in double from its children's (a terminal: its place's mean;
/// an inner node: its own c, weighted by its places) and rounded once. The bounds below hold
/// for exactly these centres: their error in the basis follows the same recursion.
std::vector<Eigen::VectorXf> NodeCentres(const PlaceMemory& memory);

class ChildrenDistanceBounds {
 public:
  /// `centre`: NodeCentres(base); `incoming`: the hyper-terminals to match. Without a view
  /// basis in `base` (or with descriptors of another dimension) nothing is bounded:
  /// available() is false. `simd`: the instructions the root's products run on (the same
  /// bounds up to rounding).
  ChildrenDistanceBounds(const PlaceMemory& base, const std::vector<Eigen::VectorXf>& centre,
                         const std::vector<HyperTerminal>& incoming, Simd simd = FastestSimd());
  bool available() const { return basis_ != nullptr; }
  /// For each child of `node` (in its order), a distance from incoming centre `a` to the
  /// child's centre no larger than the true one and than its float computation (a terminal
  /// child's centre: its place's mean).
  void BelowChildren(size_t a, size_t node, std::vector<double>& out) const;

 private:
  const ViewBasis* basis_ = nullptr;
  std::vector<Eigen::Index> first_;  // per node: its children's first column in kids_
  Eigen::MatrixXf kids_, incoming_;
  // Per column: squared norm, norm, and how far the coordinates may lie from the centre's
  // exact ones (bounded, not estimated).
  Eigen::ArrayXd kid_sq_, kid_norm_, kid_error_;
  std::vector<double> incoming_sq_, incoming_norm_, incoming_error_;
  mutable Eigen::ArrayXd apart_;  // BelowChildren's distances between coordinates
  // BelowChildren's products: the root's children against a block of incoming centres at once
  // (every match starts at the root: one matrix product instead of one per centre), any
  // other node's against one centre.
  static constexpr Eigen::Index kBlock = 256;
  int root_ = -1;
  mutable Eigen::MatrixXf root_products_;  // root's children x incoming [root_first_, +kBlock)
  mutable Eigen::Index root_first_ = -1;
  mutable Eigen::VectorXf products_;
  Simd simd_;
  double product_error_ = 0.0;  // γ_k: a float product of k coordinates is off by γ_k·‖a‖·‖b‖
};

}  // namespace tsc
