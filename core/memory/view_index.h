#pragma once
// An index over the places' member views (issue 19: recognition ≤ 1 ms at 10⁴ places). The
// recognition cost measures D's vote points against every kept view of every place, which is
// linear in the memory (~115 ms at 10⁴ places of 12 views, 700 dimensions). The index keeps a
// few keys per place (its mean and its most spread views) in a fixed random projection to a
// few dozen dimensions, and names the places whose keys come nearest D; only those are then
// measured exactly. The SLINK tree stays the memory's organisation: the traversal runs as
// before, with the places left out of the shortlist infinitely far.

#include <Eigen/Core>
#include <array>
#include <span>
#include <vector>

#include "core/memory/simd.h"
#include "core/memory/view_cells.h"

namespace tsc {

/// The `count` places with the smallest estimates (all when there are fewer), in increasing
/// place index. Deterministic: equal estimates go to the lower index.
std::vector<int> Shortlist(const std::vector<float>& estimates, int count);

class ViewIndex {
 public:
  static constexpr int kKeysPerPlace = 3;  ///< the mean and two spread member views
  /// Of the projection: 10⁴ places' keys are 3.8 MB, read once per recognition.
  static constexpr int kDimensions = 32;

  /// From this many places on, an estimate reads only the cells of keys nearest D
  /// (core/memory/view_cells.h): below it every key is read, as fast as the cells at 10⁴ places
  /// (0.8 ms a recognition) and exact. The cells are trained here and again at each doubling.
  static constexpr int kCellsFrom = 16384;
  /// Keys an estimate reads at least, with cells: whole cells nearest D (3 % at 10⁵ places).
  static constexpr int kProbedKeys = 8192;

  /// `simd`: the instructions Estimate runs on (the same estimates up to rounding). `cells`:
  /// false reads every key whatever the size (the exact index the cells are measured against).
  explicit ViewIndex(Simd simd = FastestSimd(), bool cells = true)
      : simd_(simd), use_cells_(cells) {}

  /// Keys place `place` (re-keys it when already indexed; appends when place == size()) by
  /// `centre`, its mean in the space of its member views `views` (dim x k, k ≥ 1;
  /// core/memory/view_basis.h), and two spread views. Precondition: place ≤ size().
  void Set(int place, const Eigen::VectorXf& centre, const Eigen::MatrixXf& views);
  /// Keys a new place (place size()) as Set does but leaves the cells to FileAppended, which a
  /// run of appends then calls once: the cells end as Set one place at a time leaves them,
  /// trained once where Set would train last and the later keys filed in blocks (restoring a
  /// merged 2·10⁵ places trained them four times and filed 4·10⁵ keys one by one: a tenth of
  /// a 10⁵ + 10⁵ merge). Estimate requires every appended place filed.
  void Append(const Eigen::VectorXf& centre, const Eigen::MatrixXf& views);
  /// A place's keys as Set wrote them (kKeysPerPlace x kDimensions) and their squared norms:
  /// what AppendKeys takes to key the same place in another index without projecting again.
  struct PlaceKeys {
    Eigen::MatrixXf keys;
    std::array<float, kKeysPerPlace> norms{};
    Eigen::Index dimension = 0;  // of the views the keys were projected from
  };
  PlaceKeys KeysOf(int place) const;
  /// Appends a place keyed by `keys` (KeysOf of an index of the same dimension), as Append
  /// would key the views they came from. Throws std::invalid_argument on keys of another shape
  /// or dimension.
  void AppendKeys(const PlaceKeys& keys);
  /// Files the appended places' keys in the cells, finding their cells on up to `threads`
  /// threads (the same cells for any number).
  void FileAppended(int threads = 1);
  int size() const { return static_cast<int>(key_norms_.size() / kKeysPerPlace); }

  /// What D asks the index with, from its vote points (dim x n, n ≥ 1): the index keys each
  /// place by its mean and spread views, so D asks by its mean and two of its points, and a
  /// revisit along part of a place still finds it.
  static Eigen::MatrixXf Queries(const Eigen::MatrixXf& votes);

  /// For every place, an estimate of its squared distance to D: the smallest over its keys
  /// and the columns of `queries` (dim x m, m ≥ 1) in the projection, scaled back to the
  /// descriptor's units (about ±25 % of the true key distance at 32 dimensions). With cells, a
  /// key in a cell not read stands at that cell's expected distance.
  std::vector<float> Estimate(const Eigen::MatrixXf& queries) const;
  /// An index of the places `places` only (indices below size()), in their order, without
  /// cells: its Estimate gives theirs as reading every key does. The merge estimates many places
  /// against the same hyper-terminal's places; their keys gathered once are then read in blocks
  /// like a whole memory's.
  ViewIndex Subset(std::span<const int> places) const;

 private:
  // Writes place `place`'s keys (place ≤ size()), leaving the cells as they are.
  void Key(int place, const Eigen::VectorXf& centre, const Eigen::MatrixXf& views);
  // Room for the keys of place `place` (≤ size()): the rows grow by half when it is new.
  void MakeRoom(int place);
  // Fixes the projection for views of dimension `dim` (the first place's); throws when the
  // index already keys places of another.
  void UseDimension(Eigen::Index dim);
  Eigen::MatrixXf Project(const Eigen::MatrixXf& x) const;
  // Project(queries) after checking them (dim x m, m ≥ 1, the index's dimension).
  Eigen::MatrixXf ProjectQueries(const Eigen::MatrixXf& queries) const;
  // A squared distance in the projection back in the descriptor's units (≥ 0).
  static float Unprojected(float projected);

  // kDimensions x dim, entries ±1 from a fixed seed: a Johnson-Lindenstrauss map, the same
  // for every memory of that dimension, so no basis has to be learned or kept in step.
  Eigen::MatrixXf projection_;
  Eigen::MatrixXf projection_t_;  // transposed: each row of the map a contiguous column
  Eigen::MatrixXf keys_;  // capacity x kDimensions; the first kKeysPerPlace · size() rows are keys
  std::vector<float> key_norms_;
  Simd simd_;
  bool use_cells_;
  ViewCells cells_;              // trained once kCellsFrom places are keyed
  Eigen::Index filed_rows_ = 0;  // key rows the cells are up to date with (FileAppended)
};

}  // namespace tsc
