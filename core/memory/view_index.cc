#include "core/memory/view_index.h"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <utility>

#include "core/memory/member_views.h"
#include "core/split_mix64.h"

namespace tsc {
namespace {

Eigen::MatrixXf RademacherProjection(Eigen::Index dim) {
  Eigen::MatrixXf p(ViewIndex::kDimensions, dim);
  for (Eigen::Index c = 0; c < dim; ++c) {
    for (Eigen::Index r = 0; r < p.rows(); ++r) {
      const uint64_t bits = SplitMix64(static_cast<uint64_t>(c * p.rows() + r));
      p(r, c) = (bits & 1) ? 1.0f : -1.0f;
    }
  }
  return p;
}

}  // namespace

Eigen::MatrixXf ViewIndex::Project(const Eigen::MatrixXf& x) const { return projection_ * x; }

Eigen::MatrixXf ViewIndex::ProjectQueries(const Eigen::MatrixXf& queries) const {
  if (queries.cols() == 0 || queries.rows() != projection_.cols()) {
    throw std::invalid_argument("view index: queries of dimension " +
                                std::to_string(queries.rows()) + " for an index of " +
                                std::to_string(projection_.cols()));
  }
  return Project(queries);
}

float ViewIndex::Unprojected(float projected) {
  // ±1 entries multiply squared distances by the projection's dimension on average.
  return std::max(0.0f, projected / static_cast<float>(kDimensions));
}

void ViewIndex::Set(int place, const Eigen::VectorXf& centre, const Eigen::MatrixXf& views) {
  if (place < 0 || place > size()) {
    throw std::out_of_range("view index: place " + std::to_string(place) + " of " +
                            std::to_string(size()));
  }
  if (centre.size() == 0 || views.cols() == 0 || views.rows() != centre.size()) {
    throw std::invalid_argument("view index: place " + std::to_string(place) + " has no views");
  }
  if (projection_.cols() != centre.size()) {
    if (size() > 0) {
      throw std::invalid_argument("view index: dimension " + std::to_string(centre.size()) +
                                  " differs from the index's " +
                                  std::to_string(projection_.cols()));
    }
    projection_ = RademacherProjection(centre.size());
  }
  Eigen::MatrixXf keys(centre.size(), kKeysPerPlace);
  keys.col(0) = centre;
  const Eigen::MatrixXf spread = ThinViews(views, kKeysPerPlace - 1);
  // A place with fewer views repeats its last one: every place has the same number of keys.
  for (int k = 1; k < kKeysPerPlace; ++k) {
    keys.col(k) = spread.col(std::min<Eigen::Index>(k - 1, spread.cols() - 1));
  }
  const Eigen::MatrixXf projected = Project(keys);
  const Eigen::Index first = static_cast<Eigen::Index>(place) * kKeysPerPlace;
  if (place == size()) {
    // Grows by half, as the means cache does: appending one place is amortised O(1) copies.
    if (first + kKeysPerPlace > keys_.rows()) {
      keys_.conservativeResize(
          std::max<Eigen::Index>(64 * kKeysPerPlace, keys_.rows() + keys_.rows() / 2), kDimensions);
    }
    key_norms_.resize(static_cast<size_t>(first + kKeysPerPlace));
  }
  keys_.middleRows(first, kKeysPerPlace) = projected.transpose();
  for (int k = 0; k < kKeysPerPlace; ++k) {
    key_norms_[static_cast<size_t>(first + k)] = projected.col(k).squaredNorm();
  }
}

std::vector<float> ViewIndex::Estimate(const Eigen::MatrixXf& queries) const {
  const int places = size();
  const Eigen::MatrixXf q = ProjectQueries(queries);
  const Eigen::RowVectorXf q_norms = q.colwise().squaredNorm();
  // ‖k − q‖² = ‖k‖² + ‖q‖² − 2 kᵀq; the key norms are kept, the rest is computed here.
  const Eigen::Index n = static_cast<Eigen::Index>(places) * kKeysPerPlace;
  // Over blocks of keys that stay in cache, so the keys are read from memory once: portably
  // query by query, a column-major block times a vector streams each dimension's column and
  // vectorises without reductions (a product of matrices repacked every key first; 10⁴
  // places, 3x); the AVX2 kernel takes every query in one pass over the block.
  constexpr Eigen::Index kBlock = 1024;
  Eigen::VectorXf nearest(n);
  Eigen::MatrixXf dots(kBlock, q.cols());  // one block's kᵀq: len x queries, leading dim len
  for (Eigen::Index first = 0; first < n; first += kBlock) {
    const Eigen::Index len = std::min(kBlock, n - first);
    Eigen::Map<Eigen::MatrixXf> block_dots(dots.data(), len, q.cols());
    if (simd_ == Simd::kAvx2Fma) {
      avx2::RowDots(keys_.data() + first, keys_.rows(), static_cast<int>(len), kDimensions,
                    q.data(), static_cast<int>(q.cols()), block_dots.data());
    } else {
      for (Eigen::Index j = 0; j < q.cols(); ++j)
        block_dots.col(j).noalias() = keys_.middleRows(first, len) * q.col(j);
    }
    auto block_nearest = nearest.segment(first, len);
    block_nearest.setConstant(std::numeric_limits<float>::infinity());
    for (Eigen::Index j = 0; j < q.cols(); ++j) {
      block_nearest =
          block_nearest.cwiseMin((q_norms[j] - 2.0f * block_dots.col(j).array()).matrix());
    }
  }
  std::vector<float> out(static_cast<size_t>(places));
  for (int p = 0; p < places; ++p) {
    const auto i = static_cast<Eigen::Index>(p) * kKeysPerPlace;
    float e = std::numeric_limits<float>::infinity();
    for (int k = 0; k < kKeysPerPlace; ++k)
      e = std::min(e, key_norms_[static_cast<size_t>(i + k)] + nearest[i + k]);
    out[static_cast<size_t>(p)] = e;
  }
  for (float& e : out) e = Unprojected(e);
  return out;
}

std::vector<float> ViewIndex::Estimate(const Eigen::MatrixXf& queries,
                                       std::span<const int> places) const {
  const Eigen::MatrixXf q = ProjectQueries(queries);
  const Eigen::RowVectorXf q_norms = q.colwise().squaredNorm();
  const Eigen::Index m = q.cols();
  std::vector<float> out;
  out.reserve(places.size());
  std::vector<float> dots(
      static_cast<size_t>(kKeysPerPlace * m));  // kᵀq, key k of query j at k + K·j
  for (int p : places) {
    if (p < 0 || p >= size()) throw std::out_of_range("view index: no place " + std::to_string(p));
    const Eigen::Index first = static_cast<Eigen::Index>(p) * kKeysPerPlace;
    // Each product summed over the dimensions in order, in a loop of its own: an Eigen product
    // per place (packing, a matrix allocated) was a tenth of a 10⁴ + 10⁴ merge. (Its sums ran
    // in the same order: the estimates are the same to the bit.)
    std::fill(dots.begin(), dots.end(), 0.0f);
    for (Eigen::Index e = 0; e < kDimensions; ++e) {
      const float* key = keys_.data() + e * keys_.rows() + first;
      for (Eigen::Index j = 0; j < m; ++j) {
        const float qe = q(e, j);
        for (int k = 0; k < kKeysPerPlace; ++k)
          dots[static_cast<size_t>(k + kKeysPerPlace * j)] += key[k] * qe;
      }
    }
    // The smallest of the kKeysPerPlace x m squared distances in the projection.
    float nearest = std::numeric_limits<float>::infinity();
    for (Eigen::Index j = 0; j < m; ++j) {
      for (int k = 0; k < kKeysPerPlace; ++k) {
        const float d = (-2.0f * dots[static_cast<size_t>(k + kKeysPerPlace * j)] + q_norms[j]) +
                        key_norms_[static_cast<size_t>(first + k)];
        nearest = std::min(nearest, d);
      }
    }
    out.push_back(Unprojected(nearest));
  }
  return out;
}

std::vector<int> Shortlist(const std::vector<float>& estimates, int count) {
  std::vector<int> out;
  if (count >= static_cast<int>(estimates.size())) {
    out.resize(estimates.size());
    std::iota(out.begin(), out.end(), 0);
    return out;
  }
  if (count <= 0) return out;
  // One pass keeping the `count` nearest so far in a max-heap of (estimate, place): a later
  // place enters only when strictly nearer than the farthest kept (on a tie the kept place has
  // the lower index). Few do, so the test is predictable, where selecting through comparisons
  // of random estimates mispredicted half of them (10⁴ random estimates: 105 → 8 µs).
  std::vector<std::pair<float, int>> kept;
  kept.reserve(static_cast<size_t>(count));
  for (int p = 0; p < count; ++p) kept.emplace_back(estimates[static_cast<size_t>(p)], p);
  std::make_heap(kept.begin(), kept.end());
  for (size_t p = static_cast<size_t>(count); p < estimates.size(); ++p) {
    if (!(estimates[p] < kept.front().first)) continue;
    std::pop_heap(kept.begin(), kept.end());
    kept.back() = {estimates[p], static_cast<int>(p)};
    std::push_heap(kept.begin(), kept.end());
  }
  out.reserve(kept.size());
  for (const auto& [e, p] : kept) out.push_back(p);
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace tsc
