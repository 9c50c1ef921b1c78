#pragma once
// The coarse level of the view index (issue 23: recognition ≤ 1 ms at 10⁵ places). An
// estimate read every key of the memory: at 10⁵ places 38 MB from main memory, 5 ms of a 5.4 ms
// recognition. The keys are filed in cells around centroids found by k-means, and an estimate
// reads the keys of the cells whose centroids come nearest D, a few percent of them; every
// other key stands at the distance its nearest unread cell is expected at. An approximate
// search, as the field's large-scale indices are: what it costs in agreement is measured
// (bench/memory_bench.cc, `agrees_with_exact_index`).

#include <Eigen/Core>
#include <utility>
#include <vector>

#include "core/memory/simd.h"

namespace tsc {

class ViewCells {
 public:
  /// Keys filed per cell when trained (cells = keys / kKeysPerCell, a power of two ≥ kMinCells).
  static constexpr int kKeysPerCell = 512;
  static constexpr int kMinCells = 64;

  bool trained() const { return centroids_.cols() > 0; }
  /// Rows of the index's key table the cells were trained on.
  Eigen::Index trained_rows() const { return trained_rows_; }

  /// Finds the centroids by k-means over an even sample of the first `rows` rows of `keys`
  /// (key table, rows x dim, a key per row) and files every one of those rows. Deterministic:
  /// the same rows give the same cells. The rows' nearest cells are found on up to `threads`
  /// threads: the same cells for any number.
  void Train(const Eigen::MatrixXf& keys, Eigen::Index rows, Simd simd, int threads = 1);
  /// Files row `row` of `keys` (its norm `norm`) under its nearest centroid, moving it when it
  /// is filed already. Precondition: trained().
  void File(const Eigen::MatrixXf& keys, Eigen::Index row, float norm);
  /// File for rows first.. end−1 of `keys` (norms `norms`, per key row), a block of rows per
  /// product, the blocks on up to `threads` threads. Precondition: trained().
  void FileRows(const Eigen::MatrixXf& keys, Eigen::Index first, Eigen::Index end,
                const std::vector<float>& norms, int threads = 1);

  /// For each of `groups` groups of `group_size` consecutive key rows (a place's keys), the
  /// smallest ‖k − q‖² over its keys k and the columns q of `queries` (dim x m, norms
  /// `query_norms`), reading the cells nearest the queries until at least `min_keys` keys are
  /// read; a key not read stands at the nearest unread cell's distance from the queries plus
  /// that cell's spread. Precondition: trained().
  std::vector<float> Estimate(const Eigen::MatrixXf& queries, const Eigen::RowVectorXf& query_norms,
                              int groups, int group_size, int min_keys) const;

 private:
  struct Cell {
    Eigen::MatrixXf keys;  // capacity x dim, column-major (RowDots reads it): the filed keys
    std::vector<float> norms;
    std::vector<Eigen::Index> rows;  // the key table's row of each filed key
  };
  int Nearest(const Eigen::RowVectorXf& key) const;
  void Remove(Eigen::Index row);
  void Append(int cell, const Eigen::RowVectorXf& key, float norm, Eigen::Index row);

  Eigen::MatrixXf centroids_;  // dim x cells
  Eigen::VectorXf centroid_norms_;
  // Per cell: the mean squared distance of its training keys to its centroid.
  std::vector<float> spread_;
  std::vector<Cell> cells_;
  std::vector<std::pair<int, int>> slot_;  // per key row: its cell and position, or −1
  Eigen::Index trained_rows_ = 0;
  Simd simd_ = Simd::kPortable;
};

}  // namespace tsc
