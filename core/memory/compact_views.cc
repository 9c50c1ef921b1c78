#include "core/memory/compact_views.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/memory/simd.h"

namespace tsc {
namespace {

// Views of nothing above 2⁻¹²⁵ round to zero; 2^−140 is still a float, so decoding is exact.
constexpr int kMostShift = 140;
constexpr int kLeastShift = -15;  // the largest coordinate below 2³⁰
constexpr int kMostDrop = 8;      // 2^8 · 127 < 2¹⁵: a row's codes on the 16-bit grid
constexpr double kLargestCode = 127.0;
// The largest coordinate times 2^shift stays below 127.5 · 2^8, so the top row's codes round
// to at most 127 (the 16-bit grid's own limit, 32767.5, let them round to 128).
constexpr double kLargestScaled = 127.5 * 256.0;

// 2^e as a float, built from its bits where it is a normal float (no library call: a training
// set decodes one column at a time, 10⁴ nodes x 128 columns in a merge).
float PowerOfTwo(int e) {
  if (e < -126 || e > 127) return std::ldexp(1.0f, e);
  return std::bit_cast<float>(static_cast<uint32_t>(e + 127) << 23);
}

// x rounded to an integer, ties to even (the default rounding mode), for |x| < 2⁵¹: adding and
// taking away 1.5·2⁵² rounds it, with no library call per coordinate (std::nearbyint and
// std::ldexp made a merge's pooled views a tenth of its time).
double RoundToInteger(double x) {
  constexpr double kRound = 0x1.8p52;
  return (x + kRound) - kRound;
}

// Columns [0, cols) of codes (rows a column) as floats: code · 2^(drop[row] − shift). The
// same floats on every instruction set (a code below 2⁷ times a power of two is exact).
void DecodeColumns(const int8_t* codes, const uint8_t* drop, Eigen::Index rows, Eigen::Index cols,
                   int shift, float* out) {
  if (FastestSimd() == Simd::kAvx2Fma && shift <= 126) {  // every scale a normal float
    avx2::ScaleInt8Rows(codes, drop, rows, cols, shift, out);
    return;
  }
  for (Eigen::Index c = 0; c < cols; ++c) {
    for (Eigen::Index r = 0; r < rows; ++r) {
      out[r + c * rows] = static_cast<float>(codes[r + c * rows]) * PowerOfTwo(drop[r] - shift);
    }
  }
}

}  // namespace

CompactViews::CompactViews(const Eigen::MatrixXf& views) { Encode(views); }

void CompactViews::Encode(const Eigen::MatrixXf& views) {
  const Eigen::Index rows = views.rows(), cols = views.cols();
  // Each row's largest magnitude first (the largest of all sets the shift, each row's its
  // drop), in floats: scaling by 2^shift is exact and keeps their order. A merge encodes the
  // pooled views of every place it absorbs (the scalar passes in double were 6 % of a 10⁴ +
  // 10⁴ merge).
  const bool avx2 = FastestSimd() == Simd::kAvx2Fma;
  std::vector<float> row_most(static_cast<size_t>(rows), 0.0f);
  bool finite = true;
  if (avx2) {
    finite = avx2::RowMagnitudes(views.data(), rows, cols, row_most.data());
  } else {
    for (Eigen::Index k = 0; k < views.size(); ++k) {
      const float x = std::abs(views.data()[k]);
      finite = finite && std::isfinite(x);
      float& m = row_most[static_cast<size_t>(k % rows)];
      m = std::max(m, x);
    }
  }
  if (!finite) throw std::invalid_argument("member view coordinate is not finite");
  const float most = rows == 0 ? 0.0f : *std::max_element(row_most.begin(), row_most.end());
  // Below 127.5 · 2^8 at the least shift, −15: the 16-bit form's range (2^30 · 255/256).
  if (std::ldexp(static_cast<double>(most), kLeastShift) >= kLargestScaled) {
    throw std::invalid_argument("member view coordinate " + std::to_string(most) +
                                " is beyond 2^30 * 255/256");
  }
  std::vector<double> row_scale(static_cast<size_t>(rows), 0.0);
  // Checked, and the storage reserved (nothing where the views held take as many bytes; a
  // larger one fresh, since reserving would copy codes about to be overwritten): from here on
  // nothing throws, and the views held are overwritten.
  drop_.reserve(static_cast<size_t>(rows));
  if (codes_.capacity() < static_cast<size_t>(views.size())) {
    std::vector<int8_t> larger;
    larger.reserve(static_cast<size_t>(views.size()));
    codes_.swap(larger);
  }
  codes_.resize(static_cast<size_t>(views.size()));
  drop_.assign(static_cast<size_t>(rows), 0);
  rows_ = rows;
  cols_ = cols;
  shift_ = 0;
  if (most > 0.0f) {
    int e = 0;
    std::frexp(most, &e);  // most ∈ [2^(e−1), 2^e)
    shift_ = std::min(15 - e, kMostShift);
    if (std::ldexp(static_cast<double>(most), shift_) >= kLargestScaled) --shift_;
  }
  // x · 2^shift is exact in double; each row then takes the least drop that keeps its largest
  // code within 127, and its codes are the scaled coordinates rounded at that drop.
  const double scale = std::ldexp(1.0, shift_);
  for (Eigen::Index r = 0; r < rows_; ++r) {
    // Halving a double is exact here (2^shift · a float's magnitude, at most 8 times), so it
    // is std::ldexp(m, −drop) without a library call per step (a merge encodes every pooled
    // place's 128 rows: std::ldexp was 3 % of a 10⁵ + 10⁵ merge).
    double m = static_cast<double>(row_most[static_cast<size_t>(r)]) * scale;
    double row = scale;
    int drop = 0;
    while (drop < kMostDrop && RoundToInteger(m) > kLargestCode) {
      ++drop;
      m *= 0.5;
      row *= 0.5;
    }
    drop_[static_cast<size_t>(r)] = static_cast<uint8_t>(drop);
    row_scale[static_cast<size_t>(r)] = row;
  }
  if (avx2) {
    avx2::RoundInt8Rows(views.data(), rows_, cols_, row_scale.data(), codes_.data());
    return;
  }
  for (Eigen::Index c = 0; c < cols_; ++c) {  // column by column: the views are column-major
    const float* x = views.data() + c * rows_;
    int8_t* code = codes_.data() + c * rows_;
    for (Eigen::Index r = 0; r < rows_; ++r) {
      code[r] = static_cast<int8_t>(
          RoundToInteger(static_cast<double>(x[r]) * row_scale[static_cast<size_t>(r)]));
    }
  }
}

bool CompactViews::IsEncoding(int shift, int largest) {
  if (largest == 0) return shift == 0 || shift == kMostShift;
  if (shift == kMostShift) return largest < 32768;
  return shift >= kLeastShift && shift < kMostShift && largest >= 16384 && largest < 32768;
}

CompactViews::CompactViews(Eigen::Index rows, Eigen::Index cols, int shift,
                           const std::vector<int16_t>& wide) {
  if (rows < 0 || cols < 0 || static_cast<size_t>(rows * cols) != wide.size()) {
    throw std::invalid_argument("compact views: " + std::to_string(wide.size()) + " values for " +
                                std::to_string(rows) + " x " + std::to_string(cols));
  }
  int most = 0;
  for (int16_t v : wide) most = std::max(most, std::abs(static_cast<int>(v)));
  if (!IsEncoding(shift, most)) {
    throw std::invalid_argument("compact views: largest value " + std::to_string(most) +
                                " at shift " + std::to_string(shift) +
                                " is not what encoding views gives");
  }
  // The coordinates exactly (an integer below 2¹⁵ times a power of two), encoded: the codes
  // Wide gave, or the finer grid's views on this one.
  Eigen::MatrixXf views(rows, cols);
  const float scale = PowerOfTwo(-shift);
  for (Eigen::Index k = 0; k < views.size(); ++k) {
    views.data()[k] = static_cast<float>(wide[static_cast<size_t>(k)]) * scale;
  }
  Encode(views);
}

std::vector<int16_t> CompactViews::Wide() const {
  std::vector<int16_t> wide;
  wide.reserve(codes_.size());
  for (Eigen::Index c = 0; c < cols_; ++c) {
    for (Eigen::Index r = 0; r < rows_; ++r) wide.push_back(WideAt(r, c));
  }
  return wide;
}

void CompactViews::DecodeInto(float* out) const {
  DecodeColumns(codes_.data(), drop_.data(), rows_, cols_, shift_, out);
}

Eigen::MatrixXf CompactViews::Decoded() const {
  Eigen::MatrixXf out(rows_, cols_);
  DecodeInto(out.data());
  return out;
}

Eigen::VectorXf CompactViews::Col(Eigen::Index j) const {
  Eigen::VectorXf out(rows_);
  DecodeColInto(j, out.data());
  return out;
}

void CompactViews::DecodeColInto(Eigen::Index j, float* out) const {
  if (j < 0 || j >= cols_) throw std::out_of_range("member view " + std::to_string(j));
  DecodeColumns(codes_.data() + j * rows_, drop_.data(), rows_, 1, shift_, out);
}

void CompactViews::Append(const CompactViews& more) {
  if (more.cols_ == 0) return;
  if (cols_ == 0) {
    *this = more;
    return;
  }
  if (more.rows_ != rows_) {
    throw std::invalid_argument("appending views of dimension " + std::to_string(more.rows_) +
                                " to views of dimension " + std::to_string(rows_));
  }
  if (more.shift_ != shift_ || more.drop_ != drop_) {
    Eigen::MatrixXf both(rows_, cols_ + more.cols_);
    both << Decoded(), more.Decoded();
    Encode(both);
    return;
  }
  codes_.insert(codes_.end(), more.codes_.begin(), more.codes_.end());
  cols_ += more.cols_;
}

}  // namespace tsc
