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

Eigen::MatrixXf ViewIndex::Queries(const Eigen::MatrixXf& votes) {
  if (votes.cols() == 0) throw std::invalid_argument("view index: no vote points to ask with");
  Eigen::MatrixXf queries(votes.rows(), 1 + std::min<Eigen::Index>(2, votes.cols()));
  queries.col(0) = votes.rowwise().mean();
  queries.rightCols(queries.cols() - 1) = EvenlySpaced(votes, 2);
  return queries;
}

Eigen::MatrixXf ViewIndex::Project(const Eigen::MatrixXf& x) const {
  if (simd_ != Simd::kAvx2Fma) return projection_ * x;
  // A few columns at a time (a place's keys, D's queries): Eigen's product packed both sides
  // for every place, a tenth of a 10⁴ + 10⁴ merge's restore.
  Eigen::MatrixXf out(kDimensions, x.cols());
  avx2::ColumnDots(projection_t_.data(), kDimensions, x.data(), static_cast<int>(x.cols()),
                   static_cast<int>(x.rows()), out.data(), nullptr);
  return out;
}

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
  if (place == size()) {
    Append(centre, views);
    FileAppended();
    return;
  }
  Key(place, centre, views);
  const Eigen::Index first = static_cast<Eigen::Index>(place) * kKeysPerPlace;
  if (!cells_.trained() || first >= filed_rows_) return;  // filed when FileAppended runs
  for (int k = 0; k < kKeysPerPlace; ++k)
    cells_.File(keys_, first + k, key_norms_[static_cast<size_t>(first + k)]);
}

void ViewIndex::Append(const Eigen::VectorXf& centre, const Eigen::MatrixXf& views) {
  Key(size(), centre, views);
}

void ViewIndex::FileAppended(int threads) {
  const auto rows = static_cast<Eigen::Index>(key_norms_.size());
  if (!use_cells_ || size() < kCellsFrom) {
    filed_rows_ = rows;
    return;
  }
  // Set trains when the rows reach kCellsFrom places' keys, then each time they double; only
  // the last of those trainings within the appended rows decides the cells.
  Eigen::Index train_at = 0;
  for (Eigen::Index next = cells_.trained() ? 2 * cells_.trained_rows()
                                            : Eigen::Index{kCellsFrom} * kKeysPerPlace;
       next <= rows; next *= 2) {
    train_at = next;
  }
  if (train_at > 0) {
    cells_.Train(keys_, train_at, simd_, threads);
    filed_rows_ = std::max(filed_rows_, train_at);
  }
  cells_.FileRows(keys_, filed_rows_, rows, key_norms_, threads);
  filed_rows_ = rows;
}

void ViewIndex::Key(int place, const Eigen::VectorXf& centre, const Eigen::MatrixXf& views) {
  if (place < 0 || place > size()) {
    throw std::out_of_range("view index: place " + std::to_string(place) + " of " +
                            std::to_string(size()));
  }
  if (centre.size() == 0 || views.cols() == 0 || views.rows() != centre.size()) {
    throw std::invalid_argument("view index: place " + std::to_string(place) + " has no views");
  }
  UseDimension(centre.size());
  Eigen::MatrixXf keys(centre.size(), kKeysPerPlace);
  keys.col(0) = centre;
  const Eigen::MatrixXf spread = ThinViews(views, kKeysPerPlace - 1);
  // A place with fewer views repeats its last one: every place has the same number of keys.
  for (int k = 1; k < kKeysPerPlace; ++k) {
    keys.col(k) = spread.col(std::min<Eigen::Index>(k - 1, spread.cols() - 1));
  }
  const Eigen::MatrixXf projected = Project(keys);
  const Eigen::Index first = static_cast<Eigen::Index>(place) * kKeysPerPlace;
  MakeRoom(place);
  keys_.middleRows(first, kKeysPerPlace) = projected.transpose();
  for (int k = 0; k < kKeysPerPlace; ++k) {
    key_norms_[static_cast<size_t>(first + k)] = projected.col(k).squaredNorm();
  }
}

void ViewIndex::UseDimension(Eigen::Index dim) {
  if (projection_.cols() == dim) return;
  if (size() > 0) {
    throw std::invalid_argument("view index: dimension " + std::to_string(dim) +
                                " differs from the index's " + std::to_string(projection_.cols()));
  }
  projection_ = RademacherProjection(dim);
  projection_t_ = projection_.transpose();
}

void ViewIndex::MakeRoom(int place) {
  if (place != size()) return;
  const Eigen::Index first = static_cast<Eigen::Index>(place) * kKeysPerPlace;
  // Grows by half, as the means cache does: appending one place is amortised O(1) copies.
  if (first + kKeysPerPlace > keys_.rows()) {
    keys_.conservativeResize(
        std::max<Eigen::Index>(64 * kKeysPerPlace, keys_.rows() + keys_.rows() / 2), kDimensions);
  }
  key_norms_.resize(static_cast<size_t>(first + kKeysPerPlace));
}

ViewIndex::PlaceKeys ViewIndex::KeysOf(int place) const {
  if (place < 0 || place >= size()) {
    throw std::out_of_range("view index: keys of place " + std::to_string(place) + " of " +
                            std::to_string(size()));
  }
  const Eigen::Index first = static_cast<Eigen::Index>(place) * kKeysPerPlace;
  PlaceKeys out{keys_.middleRows(first, kKeysPerPlace), {}, projection_.cols()};
  for (int k = 0; k < kKeysPerPlace; ++k) out.norms[k] = key_norms_[static_cast<size_t>(first + k)];
  return out;
}

void ViewIndex::AppendKeys(const PlaceKeys& keys) {
  if (keys.keys.rows() != kKeysPerPlace || keys.keys.cols() != kDimensions) {
    throw std::invalid_argument("view index: keys of " + std::to_string(keys.keys.rows()) + " x " +
                                std::to_string(keys.keys.cols()) + ", not " +
                                std::to_string(kKeysPerPlace) + " x " +
                                std::to_string(kDimensions));
  }
  UseDimension(keys.dimension);
  const int place = size();
  const Eigen::Index first = static_cast<Eigen::Index>(place) * kKeysPerPlace;
  MakeRoom(place);
  keys_.middleRows(first, kKeysPerPlace) = keys.keys;
  for (int k = 0; k < kKeysPerPlace; ++k)
    key_norms_[static_cast<size_t>(first + k)] = keys.norms[k];
}

std::vector<float> ViewIndex::Estimate(const Eigen::MatrixXf& queries) const {
  const int places = size();
  if (filed_rows_ != static_cast<Eigen::Index>(key_norms_.size()))
    throw std::logic_error("view index: estimating before FileAppended");
  const Eigen::MatrixXf q = ProjectQueries(queries);
  const Eigen::RowVectorXf q_norms = q.colwise().squaredNorm();
  if (cells_.trained()) {
    std::vector<float> out = cells_.Estimate(q, q_norms, places, kKeysPerPlace, kProbedKeys);
    for (float& e : out) e = Unprojected(e);
    return out;
  }
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
    // 8 lanes where the CPU has them: Eigen's step ran on 4, a twentieth of a merge.
    LeastDistances(simd_, block_dots.data(), static_cast<int>(len), static_cast<int>(q.cols()),
                   q_norms.data(), nearest.data() + first);
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

ViewIndex ViewIndex::Subset(std::span<const int> places) const {
  ViewIndex out(simd_, false);
  out.projection_ = projection_;
  out.projection_t_ = projection_t_;
  out.keys_.resize(static_cast<Eigen::Index>(places.size()) * kKeysPerPlace, kDimensions);
  out.key_norms_.resize(static_cast<size_t>(out.keys_.rows()));
  out.filed_rows_ = out.keys_.rows();  // no cells
  Eigen::Index row = 0;
  for (int p : places) {
    if (p < 0 || p >= size()) throw std::out_of_range("view index: no place " + std::to_string(p));
    const Eigen::Index first = static_cast<Eigen::Index>(p) * kKeysPerPlace;
    out.keys_.middleRows(row, kKeysPerPlace) = keys_.middleRows(first, kKeysPerPlace);
    for (int k = 0; k < kKeysPerPlace; ++k)
      out.key_norms_[static_cast<size_t>(row + k)] = key_norms_[static_cast<size_t>(first + k)];
    row += kKeysPerPlace;
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
