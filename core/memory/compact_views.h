#pragma once
// A learned place's member views kept in 8 bits a coordinate, with a power of two per axis
// (issue 23: tscd's RSS ≤ 200 MB at 10⁴ places holding two visits' views; docs/decisions.md
// "Member views in 8 bits").

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace tsc {

/// A dim x k matrix of member views stored as 8-bit integers, each row (axis of the view
/// basis) times its own power of two. A place's views have one power of two, the *shift*
/// 2^−shift, chosen as before for 16 bits (its largest coordinate an integer in [2¹⁴, 2¹⁵));
/// a row keeps its coordinates on that 16-bit grid coarsened by 2^drop, drop in [0, 8] the
/// least that keeps the row's largest within 127. So every coordinate is within 2⁻⁸ of its
/// row's largest, and no coarser than the 16-bit grid: an axis whose coordinates are small
/// keeps them as 16 bits did. 8 bits with one power of two for all axes moved the recognition
/// costs by more than the calibration allows (docs/calibration.md, thirty-second pass).
/// The views travel and are stored in their 16-bit form (Wide: value · 2^drop at the shift),
/// which protocol 4 and the store's schema already carry. Decoding is exact, and encoding
/// decoded views gives them back bit for bit, so views that travel (wire, store, merges) lose
/// nothing after their first encoding.
class CompactViews {
 public:
  CompactViews() = default;
  /// Throws std::invalid_argument when a coordinate is not finite or its magnitude is
  /// 2³⁰ · 255/256 or more (descriptor coordinates are below 1).
  explicit CompactViews(const Eigen::MatrixXf& views);
  /// Views in their 16-bit form (store/, messages): rows x cols `wide` column-major, a
  /// coordinate value · 2^−shift. Throws std::invalid_argument unless they are what a 16-bit
  /// encoding of some views gives: the sizes agree, and the largest |value| lies in
  /// [2¹⁴, 2¹⁵) (or every value is 0 with shift 0), with shift in [−15, 140] (at 140, of
  /// views below 2⁻¹²⁵, any largest value below 2¹⁵). Views Wide gave come back as they were;
  /// others (the finer grid of tscd before 8 bits) are encoded again.
  CompactViews(Eigen::Index rows, Eigen::Index cols, int shift, const std::vector<int16_t>& wide);
  /// Whether 16-bit integers whose largest |value| is `largest` (≥ 0) at `shift` are what
  /// encoding some views gives: the rule the constructor from parts checks, for callers that
  /// hold the integers elsewhere (a message's rows) and need not copy them to ask.
  static bool IsEncoding(int shift, int largest);
  /// Encodes `views` in place of the views held, as the constructor does, in their storage
  /// where it is large enough: a merge re-encodes every place it absorbs into, and a fresh
  /// 8 KB for each left the old one a hole glibc cannot hand back (issue 23's RSS after a
  /// merge). Throws as the constructor does, before it changes the views held.
  void Encode(const Eigen::MatrixXf& views);

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

  /// The 16-bit form: the shift, and the size() integers (column-major), all of them or one.
  int shift() const { return shift_; }
  std::vector<int16_t> Wide() const;
  /// Precondition: 0 ≤ r < rows(), 0 ≤ c < cols().
  int16_t WideAt(Eigen::Index r, Eigen::Index c) const {
    const auto k = static_cast<std::size_t>(r + c * rows_);
    return static_cast<int16_t>(codes_[k] * (1 << drop_[static_cast<std::size_t>(r)]));
  }
  /// The stored integers (for prefetching: size() of them, then rows() drops) and the bytes
  /// they take.
  const int8_t* codes() const { return codes_.data(); }
  std::size_t bytes() const { return codes_.size() + drop_.size(); }

  /// Appends the columns of `more` (of the same rows, or to an empty matrix): the integers as
  /// they are when both matrices share their powers of two, else the views encoded again.
  void Append(const CompactViews& more);

  bool operator==(const CompactViews&) const = default;

 private:
  Eigen::Index rows_ = 0, cols_ = 0;
  int shift_ = 0;              // a coordinate is code · 2^(drop_[row] − shift_)
  std::vector<int8_t> codes_;  // column-major, |code| ≤ 127
  std::vector<uint8_t> drop_;  // per row, in [0, 8]
};

}  // namespace tsc
