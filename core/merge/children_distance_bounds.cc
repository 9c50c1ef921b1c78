#include "core/merge/children_distance_bounds.h"

#include <algorithm>
#include <cmath>

namespace tsc {

ChildrenDistanceBounds::ChildrenDistanceBounds(const PlaceMemory& base,
                                               const std::vector<Eigen::VectorXf>& centre,
                                               const std::vector<HyperTerminal>& hi) {
  const ViewBasis* basis = base.view_basis();
  if (basis == nullptr || hi.empty() ||
      hi.front().sphere.centroid.size() != basis->input_dimension()) {
    return;
  }
  // An orthonormal projection shortens every vector (up to the basis' gain), and taking off
  // 1e-4 of the squared lengths (below) covers the rounding of the projections, of the
  // products and of the full distances compared with.
  scale_sq_ = std::pow((1.0 - 1e-4) / basis->max_gain(), 2);
  root_ = base.root();
  const std::vector<MemoryNode>& nodes = base.nodes();
  first_.assign(nodes.size() + 1, 0);
  for (size_t n = 0; n < nodes.size(); ++n) {
    first_[n + 1] = first_[n] + static_cast<Eigen::Index>(nodes[n].children.size());
  }
  // A node's centre in the basis is the mean of its places' (projection is linear), so the
  // columns are filled bottom-up from the places' own coordinates: projecting every node's
  // 1200-dimensional centre would cost a 10⁵-place memory a second.
  std::vector<Eigen::Index> column(nodes.size(), -1);
  for (size_t n = 0; n < nodes.size(); ++n) {
    for (size_t j = 0; j < nodes[n].children.size(); ++j) {
      column[static_cast<size_t>(nodes[n].children[j])] = first_[n] + static_cast<Eigen::Index>(j);
    }
  }
  kids_ = Eigen::MatrixXf::Zero(basis->dimension(), first_.back());
  kid_sq_.assign(static_cast<size_t>(first_.back()), 0.0);
  kid_slack_.assign(static_cast<size_t>(first_.back()), 0.0);
  Eigen::VectorXf sum(basis->dimension());
  for (size_t n = 0; n < nodes.size(); ++n) {  // children precede their parents
    const Eigen::Index col = column[n];
    if (col < 0) continue;  // the root: measured in full
    if (nodes[n].terminal()) {
      kids_.col(col) = base.ViewCentre(nodes[n].place);
      continue;
    }
    sum.setZero();
    for (int c : nodes[n].children) {
      const Eigen::Index k = column[static_cast<size_t>(c)];
      const MemoryNode& child = nodes[static_cast<size_t>(c)];
      sum += kids_.col(k) * static_cast<float>(child.terminal() ? 1 : child.num_places());
    }
    kids_.col(col) = sum / static_cast<float>(nodes[n].num_places());
    kid_sq_[static_cast<size_t>(col)] = kids_.col(col).cast<double>().squaredNorm();
    kid_slack_[static_cast<size_t>(col)] = 1e-4 * centre[n].squaredNorm();
  }
  incoming_.resize(basis->dimension(), static_cast<Eigen::Index>(hi.size()));
  for (size_t a = 0; a < hi.size(); ++a) {
    incoming_.col(static_cast<Eigen::Index>(a)) = basis->Coordinates(hi[a].sphere.centroid);
    incoming_sq_.push_back(
        incoming_.col(static_cast<Eigen::Index>(a)).cast<double>().squaredNorm());
    incoming_slack_.push_back(1e-4 * hi[a].sphere.centroid.squaredNorm());
  }
}

void ChildrenDistanceBounds::BelowChildren(size_t a, size_t node, std::vector<double>& out) const {
  const Eigen::Index first = first_[node], count = first_[node + 1] - first;
  const auto column = static_cast<Eigen::Index>(a);
  if (static_cast<int>(node) == root_) {
    if (root_first_ < 0 || column < root_first_ || column >= root_first_ + kBlock) {
      root_first_ = column;
      const Eigen::Index n = std::min(kBlock, incoming_.cols() - column);
      root_products_.noalias() =
          kids_.middleCols(first, count).transpose() * incoming_.middleCols(column, n);
    }
    products_ = root_products_.col(column - root_first_);
  } else {
    products_.noalias() = kids_.middleCols(first, count).transpose() * incoming_.col(column);
  }
  out.resize(static_cast<size_t>(count));
  for (Eigen::Index j = 0; j < count; ++j) {
    const auto col = static_cast<size_t>(first + j);
    const double sq = incoming_sq_[a] + kid_sq_[col] - 2.0 * static_cast<double>(products_[j]);
    out[static_cast<size_t>(j)] =
        std::sqrt(std::max(0.0, scale_sq_ * sq - incoming_slack_[a] - kid_slack_[col]));
  }
}

}  // namespace tsc
