#include "core/merge/children_distance_bounds.h"

#include <algorithm>
#include <cmath>

namespace tsc {
namespace {

constexpr double kUnit = 0x1p-24;  // float's unit roundoff

double Norm(const Eigen::VectorXf& v) { return std::sqrt(v.cast<double>().squaredNorm()); }

}  // namespace

std::vector<Eigen::VectorXf> NodeCentres(const PlaceMemory& memory) {
  const std::vector<MemoryNode>& nodes = memory.nodes();
  std::vector<Eigen::VectorXf> centre(nodes.size());
  Eigen::VectorXd sum;
  for (size_t n = 0; n < nodes.size(); ++n) {  // children precede their parents
    if (nodes[n].terminal()) continue;
    sum.setZero(memory.places().front().mean.size());
    for (int c : nodes[n].children) {
      const MemoryNode& child = nodes[static_cast<size_t>(c)];
      if (child.terminal()) {
        sum += memory.places()[static_cast<size_t>(child.place)].mean.cast<double>();
      } else {
        sum += centre[static_cast<size_t>(c)].cast<double>() * child.num_places();
      }
    }
    centre[n] = (sum / nodes[n].num_places()).cast<float>();
  }
  return centre;
}

ChildrenDistanceBounds::ChildrenDistanceBounds(const PlaceMemory& base,
                                               const std::vector<Eigen::VectorXf>& centre,
                                               const std::vector<HyperTerminal>& hi, Simd simd)
    : simd_(simd) {
  const ViewBasis* basis = base.view_basis();
  if (basis == nullptr || hi.empty() ||
      hi.front().sphere.centroid.size() != basis->input_dimension()) {
    return;
  }
  basis_ = basis;
  const double k_u = basis->dimension() * kUnit;
  product_error_ = k_u / (1.0 - k_u);
  root_ = base.root();
  const std::vector<MemoryNode>& nodes = base.nodes();
  first_.assign(nodes.size() + 1, 0);
  for (size_t n = 0; n < nodes.size(); ++n) {
    first_[n + 1] = first_[n] + static_cast<Eigen::Index>(nodes[n].children.size());
  }
  // A node's centre in the basis is the mean of its children's (projection is linear), so the
  // columns are filled bottom-up as NodeCentres fills the centres: projecting every node's
  // 1200-dimensional centre would cost a 10⁵-place memory a second. The error of a column
  // is then the mean of its children's, plus the rounding of the centre (≤ u·‖c‖, through
  // the basis' gain) and of the column itself (≤ u·‖column‖).
  std::vector<Eigen::Index> column(nodes.size(), -1);
  for (size_t n = 0; n < nodes.size(); ++n) {
    for (size_t j = 0; j < nodes[n].children.size(); ++j) {
      column[static_cast<size_t>(nodes[n].children[j])] = first_[n] + static_cast<Eigen::Index>(j);
    }
  }
  kids_ = Eigen::MatrixXf::Zero(basis->dimension(), first_.back());
  kid_sq_ = kid_norm_ = kid_error_ = Eigen::ArrayXd::Zero(first_.back());
  Eigen::VectorXd sum(basis->dimension());
  const double rounding = kUnit * (1.0 + 1e-6), gain = basis->max_gain();
  std::vector<double> centre_norm(nodes.size(), 0.0);
  for (size_t n = 0; n < nodes.size(); ++n) {  // children precede their parents
    const Eigen::Index col = column[n];
    if (col < 0) continue;  // the root: measured in full
    if (nodes[n].terminal()) {
      kids_.col(col) = base.ViewCentre(nodes[n].place);
      centre_norm[n] = Norm(base.places()[static_cast<size_t>(nodes[n].place)].mean);
      kid_error_[col] = basis->coordinate_error() * centre_norm[n];
    } else {
      sum.setZero();
      double error = 0.0, mass = 0.0;
      for (int c : nodes[n].children) {
        const Eigen::Index k = column[static_cast<size_t>(c)];
        const MemoryNode& child = nodes[static_cast<size_t>(c)];
        const double weight = child.terminal() ? 1.0 : child.num_places();
        sum += kids_.col(k).cast<double>() * weight;
        error += kid_error_[k] * weight;
        mass += (gain * centre_norm[static_cast<size_t>(c)] + kid_norm_[k]) * weight;
      }
      const double places = nodes[n].num_places();
      kids_.col(col) = (sum / places).cast<float>();
      centre_norm[n] = Norm(centre[n]);
      // The double sums (here and in NodeCentres) are off by less than 1e-9 of their terms'
      // mean norm for any memory below 10⁷ places.
      kid_error_[col] = error / places + rounding * (gain * centre_norm[n] + Norm(kids_.col(col))) +
                        1e-9 * mass / places;
    }
    kid_sq_[col] = kids_.col(col).cast<double>().squaredNorm();
    kid_norm_[col] = std::sqrt(kid_sq_[col]);
  }
  // The incoming centres projected in blocks: one column at a time would read the basis' 600 KB
  // once per centre.
  incoming_.resize(basis->dimension(), static_cast<Eigen::Index>(hi.size()));
  constexpr Eigen::Index kProjected = 512;
  Eigen::MatrixXf block(basis->input_dimension(),
                        std::min<Eigen::Index>(kProjected, incoming_.cols()));
  for (Eigen::Index b = 0; b < incoming_.cols(); b += kProjected) {
    const Eigen::Index len = std::min(kProjected, incoming_.cols() - b);
    for (Eigen::Index i = 0; i < len; ++i) {
      block.col(i) = hi[static_cast<size_t>(b + i)].sphere.centroid;
    }
    incoming_.middleCols(b, len) = basis->Coordinates(block.leftCols(len));
  }
  for (size_t a = 0; a < hi.size(); ++a) {
    const auto col = static_cast<Eigen::Index>(a);
    incoming_sq_.push_back(incoming_.col(col).cast<double>().squaredNorm());
    incoming_norm_.push_back(std::sqrt(incoming_sq_.back()));
    incoming_error_.push_back(basis->coordinate_error() * Norm(hi[a].sphere.centroid));
  }
}

void ChildrenDistanceBounds::BelowChildren(size_t a, size_t node, std::vector<double>& out) const {
  const Eigen::Index first = first_[node], count = first_[node + 1] - first;
  const auto column = static_cast<Eigen::Index>(a);
  if (static_cast<int>(node) == root_) {
    if (root_first_ < 0 || column < root_first_ || column >= root_first_ + kBlock) {
      root_first_ = column;
      const Eigen::Index n = std::min(kBlock, incoming_.cols() - column);
      // With AVX2, the project's kernel: Eigen's product runs on the build's SSE2, and a flat
      // tree's root block is most of the bounds' arithmetic.
      if (simd_ == Simd::kAvx2Fma) {
        root_products_.resize(count, n);
        avx2::ColumnDots(kids_.col(first).data(), static_cast<int>(count),
                         incoming_.col(column).data(), static_cast<int>(n),
                         static_cast<int>(kids_.rows()), root_products_.data(), nullptr);
      } else {
        root_products_.noalias() =
            kids_.middleCols(first, count).transpose() * incoming_.middleCols(column, n);
      }
    }
    products_ = root_products_.col(column - root_first_);
  } else {
    products_.noalias() = kids_.middleCols(first, count).transpose() * incoming_.col(column);
  }
  // ‖a − b‖² = ‖a‖² + ‖b‖² − 2a·b with the norms in double and the float product off by at
  // most γ_k·‖a‖·‖b‖ (the cancellation is covered, not rounded away). Whole arrays at once: a
  // flat tree's root has thousands of children, bounded for every incoming centre.
  apart_ =
      (incoming_sq_[a] + kid_sq_.segment(first, count) - 2.0 * products_.cast<double>().array() -
       (2.0 * product_error_ * incoming_norm_[a]) * kid_norm_.segment(first, count))
          .max(0.0)
          .sqrt();
  out.resize(static_cast<size_t>(count));
  for (Eigen::Index j = 0; j < count; ++j) {
    out[static_cast<size_t>(j)] =
        basis_->DistanceBelow(apart_[j], incoming_error_[a] + kid_error_[first + j]);
  }
}

}  // namespace tsc
