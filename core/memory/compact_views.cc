#include "core/memory/compact_views.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "core/memory/simd.h"

namespace tsc {
namespace {

// Views of nothing above 2⁻¹²⁵ round to zero; 2^−140 is still a float, so decoding is exact.
constexpr int kMostShift = 140;
constexpr int kLeastShift = -15;  // the largest coordinate below 2³⁰

// 2^e as a float, built from its bits where it is a normal float (no library call: a training
// set decodes one column at a time, 10⁴ nodes x 128 columns in a merge).
float PowerOfTwo(int e) {
  if (e < -126 || e > 127) return std::ldexp(1.0f, e);
  return std::bit_cast<float>(static_cast<uint32_t>(e + 127) << 23);
}

// The integers of `v` times 2^−shift, on eight lanes where the CPU has AVX2: the same floats
// either way (an integer below 2¹⁵ times a power of two is exact).
void DecodeRange(const int16_t* v, Eigen::Index n, int shift, float* out) {
  const float scale = PowerOfTwo(-shift);
  if (FastestSimd() == Simd::kAvx2Fma) {
    avx2::ScaleInt16(v, n, scale, out);
    return;
  }
  for (Eigen::Index k = 0; k < n; ++k) out[k] = static_cast<float>(v[k]) * scale;
}

}  // namespace

CompactViews::CompactViews(const Eigen::MatrixXf& views)
    : rows_(views.rows()), cols_(views.cols()), values_(static_cast<size_t>(views.size())) {
  float most = 0.0f;
  for (Eigen::Index k = 0; k < views.size(); ++k) {
    const float x = views.data()[k];
    if (!std::isfinite(x)) throw std::invalid_argument("member view coordinate is not finite");
    most = std::max(most, std::abs(x));
  }
  if (most >= 0x1p30f) {
    throw std::invalid_argument("member view coordinate " + std::to_string(most) +
                                " is beyond 2^30");
  }
  if (most > 0.0f) {
    int e = 0;
    std::frexp(most, &e);  // most ∈ [2^(e−1), 2^e)
    shift_ = std::min(15 - e, kMostShift);
    // The largest must not round up to 2¹⁵, which int16 cannot hold (and decoded, it would
    // choose another shift: encoding decoded views would not give them back).
    if (shift_ < kMostShift && std::ldexp(most, shift_) >= 32767.5f) --shift_;
  }
  // x · 2^shift is exact in double; adding and taking away 1.5·2⁵² rounds it to an integer,
  // ties to even (the default rounding mode): no library call per coordinate (std::nearbyint
  // and std::ldexp made a merge's pooled views a tenth of its time).
  const double scale = std::ldexp(1.0, shift_);
  constexpr double kRound = 0x1.8p52;
  for (Eigen::Index k = 0; k < views.size(); ++k) {
    const double y = static_cast<double>(views.data()[k]) * scale;
    values_[static_cast<size_t>(k)] = static_cast<int16_t>((y + kRound) - kRound);
  }
}

bool CompactViews::IsEncoding(int shift, int largest) {
  if (largest == 0) return shift == 0 || shift == kMostShift;
  if (shift == kMostShift) return largest < 32768;
  return shift >= kLeastShift && shift < kMostShift && largest >= 16384 && largest < 32768;
}

CompactViews::CompactViews(Eigen::Index rows, Eigen::Index cols, int shift,
                           std::vector<int16_t> values)
    : rows_(rows), cols_(cols), shift_(shift), values_(std::move(values)) {
  if (rows_ < 0 || cols_ < 0 || static_cast<size_t>(rows_ * cols_) != values_.size()) {
    throw std::invalid_argument("compact views: " + std::to_string(values_.size()) +
                                " values for " + std::to_string(rows_) + " x " +
                                std::to_string(cols_));
  }
  int most = 0;
  for (int16_t v : values_) most = std::max(most, std::abs(static_cast<int>(v)));
  if (!IsEncoding(shift_, most)) {
    throw std::invalid_argument("compact views: largest value " + std::to_string(most) +
                                " at shift " + std::to_string(shift_) +
                                " is not what encoding views gives");
  }
}

void CompactViews::DecodeInto(float* out) const {
  DecodeRange(values_.data(), size(), shift_, out);
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
  DecodeRange(values_.data() + j * rows_, rows_, shift_, out);
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
  if (more.shift_ != shift_) {
    Eigen::MatrixXf both(rows_, cols_ + more.cols_);
    both << Decoded(), more.Decoded();
    *this = CompactViews(both);
    return;
  }
  values_.insert(values_.end(), more.values_.begin(), more.values_.end());
  cols_ += more.cols_;
}

}  // namespace tsc
