#include "core/memory/view_cells.h"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <vector>

#include "core/on_threads.h"

namespace tsc {
namespace {

constexpr int kSamplesPerCell = 32;  // k-means runs on this many sampled keys a cell
constexpr int kIterations = 8;
constexpr Eigen::Index kBlock = 4096;  // keys filed per product when training

// Column of the smallest ‖c‖² − 2 cᵀk per row of `dots` (rows x cells: kᵀc), the first on ties.
// Column by column, each a contiguous run: row by row read `dots` a column stride apart
// (16 KB for a block of keys), the restore of a 10⁵ + 10⁵ merge's most sampled function.
void NearestPerRow(const Eigen::MatrixXf& dots, const Eigen::VectorXf& centroid_norms,
                   std::vector<int>& out) {
  const Eigen::Index rows = dots.rows();
  out.assign(static_cast<size_t>(rows), 0);
  Eigen::VectorXf best = (centroid_norms[0] - 2.0f * dots.col(0).array()).matrix();
  int* const at = out.data();
  for (Eigen::Index c = 1; c < dots.cols(); ++c) {
    const float norm = centroid_norms[c];
    const float* d = dots.col(c).data();
    float* b = best.data();
    for (Eigen::Index r = 0; r < rows; ++r) {
      const float v = norm - 2.0f * d[r];
      const bool nearer = v < b[r];  // strictly: the first column keeps a tie
      b[r] = nearer ? v : b[r];
      at[r] = nearer ? static_cast<int>(c) : at[r];
    }
  }
}

// The nearest centroid (NearestPerRow) of each of rows first..end−1 of `keys`, a product per
// block of kBlock rows from `first`, the blocks on up to `threads` threads: each block is
// computed as on one thread, so the cells are the same for any number.
std::vector<int> NearestRows(const Eigen::MatrixXf& keys, Eigen::Index first, Eigen::Index end,
                             const Eigen::MatrixXf& centroids,
                             const Eigen::VectorXf& centroid_norms, int threads) {
  std::vector<int> out(static_cast<size_t>(std::max<Eigen::Index>(0, end - first)));
  OnBlocks(out.size(), static_cast<size_t>(kBlock), threads, [&](size_t from, size_t to) {
    const Eigen::Index at = first + static_cast<Eigen::Index>(from);
    const auto len = static_cast<Eigen::Index>(to - from);
    const Eigen::MatrixXf dots = keys.middleRows(at, len) * centroids;
    std::vector<int> nearest;
    NearestPerRow(dots, centroid_norms, nearest);
    std::copy(nearest.begin(), nearest.end(), out.begin() + (at - first));
  });
  return out;
}

}  // namespace

void ViewCells::Train(const Eigen::MatrixXf& keys, Eigen::Index rows, Simd simd, int threads) {
  if (rows <= 0 || rows > keys.rows()) throw std::invalid_argument("view cells: no keys to train");
  simd_ = simd;
  const Eigen::Index dim = keys.cols();
  int cells = std::max<int>(
      kMinCells, static_cast<int>(std::bit_floor(static_cast<uint64_t>(rows / kKeysPerCell))));
  const Eigen::Index step =
      std::max<Eigen::Index>(1, rows / (static_cast<Eigen::Index>(cells) * kSamplesPerCell));
  const Eigen::Index m = (rows + step - 1) / step;
  cells = static_cast<int>(std::min<Eigen::Index>(cells, m));
  Eigen::MatrixXf sample(m, dim);  // a key per row
  for (Eigen::Index i = 0; i < m; ++i) sample.row(i) = keys.row(i * step);
  // Evenly spaced samples as the first centroids, then Lloyd's iterations.
  centroids_.resize(dim, cells);
  for (int c = 0; c < cells; ++c) centroids_.col(c) = sample.row(c * m / cells).transpose();
  std::vector<int> nearest;
  Eigen::MatrixXf dots;
  for (int it = 0; it <= kIterations; ++it) {
    centroid_norms_ = centroids_.colwise().squaredNorm().transpose();
    dots.noalias() = sample * centroids_;
    NearestPerRow(dots, centroid_norms_, nearest);
    if (it == kIterations) break;
    Eigen::MatrixXf sums = Eigen::MatrixXf::Zero(dim, cells);
    std::vector<int> counts(static_cast<size_t>(cells), 0);
    for (Eigen::Index i = 0; i < m; ++i) {
      sums.col(nearest[static_cast<size_t>(i)]) += sample.row(i).transpose();
      ++counts[static_cast<size_t>(nearest[static_cast<size_t>(i)])];
    }
    for (int c = 0; c < cells; ++c) {  // a cell that drew no sample keeps its centroid
      if (counts[static_cast<size_t>(c)] > 0)
        centroids_.col(c) = sums.col(c) / static_cast<float>(counts[static_cast<size_t>(c)]);
    }
  }
  spread_.assign(static_cast<size_t>(cells), 0.0f);
  std::vector<int> counts(static_cast<size_t>(cells), 0);
  for (Eigen::Index i = 0; i < m; ++i) {
    const auto c = static_cast<size_t>(nearest[static_cast<size_t>(i)]);
    spread_[c] +=
        (sample.row(i).transpose() - centroids_.col(static_cast<Eigen::Index>(c))).squaredNorm();
    ++counts[c];
  }
  for (size_t c = 0; c < spread_.size(); ++c) {
    if (counts[c] > 0) spread_[c] /= static_cast<float>(counts[c]);
  }
  // File every key: the nearest cells on the threads, then filed in row order.
  cells_.assign(static_cast<size_t>(cells), Cell{});
  slot_.assign(static_cast<size_t>(rows), {-1, -1});
  nearest = NearestRows(keys, 0, rows, centroids_, centroid_norms_, threads);
  for (Eigen::Index r = 0; r < rows; ++r) {
    const Eigen::RowVectorXf key = keys.row(r);
    Append(nearest[static_cast<size_t>(r)], key, key.squaredNorm(), r);
  }
  trained_rows_ = rows;
}

int ViewCells::Nearest(const Eigen::RowVectorXf& key) const {
  const Eigen::MatrixXf dots = key * centroids_;
  std::vector<int> nearest;
  NearestPerRow(dots, centroid_norms_, nearest);
  return nearest.front();
}

void ViewCells::Append(int cell, const Eigen::RowVectorXf& key, float norm, Eigen::Index row) {
  Cell& c = cells_[static_cast<size_t>(cell)];
  const auto n = static_cast<Eigen::Index>(c.rows.size());
  if (n == c.keys.rows()) c.keys.conservativeResize(std::max<Eigen::Index>(16, 2 * n), key.size());
  c.keys.row(n) = key;
  c.norms.push_back(norm);
  c.rows.push_back(row);
  if (row >= static_cast<Eigen::Index>(slot_.size()))
    slot_.resize(static_cast<size_t>(row) + 1, {-1, -1});
  slot_[static_cast<size_t>(row)] = {cell, static_cast<int>(n)};
}

void ViewCells::Remove(Eigen::Index row) {
  if (row >= static_cast<Eigen::Index>(slot_.size())) return;
  const auto [cell, at] = slot_[static_cast<size_t>(row)];
  if (cell < 0) return;
  // The cell's last key takes the freed position.
  Cell& c = cells_[static_cast<size_t>(cell)];
  const auto last = static_cast<Eigen::Index>(c.rows.size()) - 1;
  if (at != last) {
    c.keys.row(at) = c.keys.row(last);
    c.norms[static_cast<size_t>(at)] = c.norms.back();
    c.rows[static_cast<size_t>(at)] = c.rows.back();
    slot_[static_cast<size_t>(c.rows.back())] = {cell, at};
  }
  c.norms.pop_back();
  c.rows.pop_back();
  slot_[static_cast<size_t>(row)] = {-1, -1};
}

void ViewCells::File(const Eigen::MatrixXf& keys, Eigen::Index row, float norm) {
  if (!trained()) throw std::logic_error("view cells: filing before training");
  const Eigen::RowVectorXf key = keys.row(row);
  Remove(row);
  Append(Nearest(key), key, norm, row);
}

void ViewCells::FileRows(const Eigen::MatrixXf& keys, Eigen::Index first, Eigen::Index end,
                         const std::vector<float>& norms, int threads) {
  if (!trained()) throw std::logic_error("view cells: filing before training");
  const std::vector<int> nearest =
      NearestRows(keys, first, end, centroids_, centroid_norms_, threads);
  for (Eigen::Index r = first; r < end; ++r) {
    Remove(r);
    Append(nearest[static_cast<size_t>(r - first)], keys.row(r), norms[static_cast<size_t>(r)], r);
  }
}

std::vector<float> ViewCells::Estimate(const Eigen::MatrixXf& queries,
                                       const Eigen::RowVectorXf& query_norms, int groups,
                                       int group_size, int min_keys) const {
  if (!trained()) throw std::logic_error("view cells: estimating before training");
  const auto cells = static_cast<int>(cells_.size());
  const Eigen::Index m = queries.cols();
  // Each cell's distance from D: its centroid's from the nearest query.
  const Eigen::MatrixXf cq = centroids_.transpose() * queries;  // cells x m
  std::vector<float> reach(static_cast<size_t>(cells));
  for (int c = 0; c < cells; ++c) {
    float d = std::numeric_limits<float>::infinity();
    for (Eigen::Index j = 0; j < m; ++j)
      d = std::min(d, centroid_norms_[c] + query_norms[j] - 2.0f * cq(c, j));
    reach[static_cast<size_t>(c)] = std::max(0.0f, d);
  }
  std::vector<int> order(static_cast<size_t>(cells));
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&reach](int a, int b) {
    return reach[static_cast<size_t>(a)] < reach[static_cast<size_t>(b)];
  });
  std::vector<float> out(static_cast<size_t>(groups), std::numeric_limits<float>::infinity());
  std::vector<uint8_t> read(static_cast<size_t>(groups), 0);  // keys of each group read
  Eigen::MatrixXf dots;
  std::vector<float> least;  // per key of a cell: its least ‖q‖² − 2kᵀq over the queries
  size_t next = 0;
  for (long long done = 0; next < order.size() && done < min_keys; ++next) {
    const Cell& c = cells_[static_cast<size_t>(order[next])];
    const auto n = static_cast<Eigen::Index>(c.rows.size());
    if (n == 0) continue;
    dots.resize(n, m);
    if (simd_ == Simd::kAvx2Fma) {
      avx2::RowDots(c.keys.data(), c.keys.rows(), static_cast<int>(n),
                    static_cast<int>(queries.rows()), queries.data(), static_cast<int>(m),
                    dots.data());
    } else {
      dots.noalias() = c.keys.topRows(n) * queries;
    }
    least.resize(static_cast<size_t>(n));
    LeastDistances(simd_, dots.data(), static_cast<int>(n), static_cast<int>(m), query_norms.data(),
                   least.data());
    for (Eigen::Index i = 0; i < n; ++i) {
      const float d = least[static_cast<size_t>(i)];
      const auto g = static_cast<size_t>(c.rows[static_cast<size_t>(i)] / group_size);
      out[g] = std::min(out[g], c.norms[static_cast<size_t>(i)] + d);
      ++read[g];
    }
    done += n;
  }
  // The keys not read: no nearer than the nearest unread cell is expected to hold them.
  float unread = std::numeric_limits<float>::infinity();
  for (size_t k = next; k < order.size(); ++k) {
    const auto c = static_cast<size_t>(order[k]);
    if (!cells_[c].rows.empty()) unread = std::min(unread, reach[c] + spread_[c]);
  }
  for (size_t g = 0; g < out.size(); ++g) {
    if (read[g] < group_size) out[g] = std::min(out[g], unread);
  }
  return out;
}

}  // namespace tsc
