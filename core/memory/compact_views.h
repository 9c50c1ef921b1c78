#pragma once
// A learned place's member views kept in 16 bits a coordinate (issue 23: tscd's RSS ≤ 200 MB
// at 10⁴ places holding the 32-view cap; docs/decisions.md "Member views in 16 bits").

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace tsc {

/// A dim x k matrix of member views stored as 16-bit integers times one power of two chosen
/// per matrix, so that its largest coordinate is an integer in [2¹⁴, 2¹⁵): every coordinate is
/// kept to within 2⁻¹⁵ of the largest. Fixed point rather than half floats: the distances
/// recognition measures are between nearby views, where the large coordinates' rounding is
/// what counts (a half keeps 2⁻¹¹ of each: a cost moved by 0.4 % where this moves it 0.03 %).
/// Decoding is exact, and encoding decoded views gives them back bit for bit, so views that
/// travel (wire, store, merges) lose nothing after their first encoding.
class CompactViews {
 public:
  CompactViews() = default;
  /// Throws std::invalid_argument when a coordinate is not finite or its magnitude is 2³⁰
  /// or more (descriptor coordinates are below 1).
  explicit CompactViews(const Eigen::MatrixXf& views);
  /// Views as stored (store/): rows x cols `values` column-major, a coordinate value · 2^−shift.
  /// Throws std::invalid_argument unless they are what encoding some views gives: the sizes
  /// agree, and the largest |value| lies in [2¹⁴, 2¹⁵) (or every value is 0 with shift 0), with
  /// shift in [−15, 140] (at 140, of views below 2⁻¹²⁵, any largest value below 2¹⁵).
  CompactViews(Eigen::Index rows, Eigen::Index cols, int shift, std::vector<int16_t> values);
  /// Whether integers whose largest |value| is `largest` (≥ 0) at `shift` are what encoding some
  /// views gives: the rule the constructor from parts checks, for callers that hold the
  /// integers elsewhere (a message's rows) and need not copy them to ask.
  static bool IsEncoding(int shift, int largest);

  Eigen::Index rows() const { return rows_; }
  Eigen::Index cols() const { return cols_; }
  Eigen::Index size() const { return rows_ * cols_; }

  /// The views as floats.
  Eigen::MatrixXf Decoded() const;
  /// Column j as floats. Precondition: 0 ≤ j < cols().
  Eigen::VectorXf Col(Eigen::Index j) const;
  /// Writes the rows() floats of Col(j) to `out`, allocating nothing.
  void DecodeColInto(Eigen::Index j, float* out) const;
  /// Writes the size() floats of Decoded(), column-major, to `out`.
  void DecodeInto(float* out) const;

  /// The stored integers (for prefetching) and the bytes they take.
  const int16_t* values() const { return values_.data(); }
  int shift() const { return shift_; }
  std::size_t bytes() const { return values_.size() * sizeof(int16_t); }

  /// Appends the columns of `more` (of the same rows, or to an empty matrix): the integers as
  /// they are when both matrices share their power of two, else the views encoded again.
  void Append(const CompactViews& more);

  bool operator==(const CompactViews&) const = default;

 private:
  Eigen::Index rows_ = 0, cols_ = 0;
  int shift_ = 0;  // a coordinate is value · 2^−shift_
  std::vector<int16_t> values_;
};

}  // namespace tsc
