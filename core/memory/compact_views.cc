#include "core/memory/compact_views.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/memory/simd.h"

namespace tsc {
namespace {

constexpr int kMostShift = 200;  // views of nothing above 2⁻¹⁸⁵ round to zero

// The integers of `v` times 2^−shift, on eight lanes where the CPU has AVX2: the same floats
// either way (an integer below 2¹⁵ times a power of two is exact).
void DecodeRange(const int16_t* v, Eigen::Index n, int shift, float* out) {
  const float scale = std::ldexp(1.0f, -shift);
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
  for (Eigen::Index k = 0; k < views.size(); ++k) {
    // Ties to even (the default rounding): deterministic on every machine.
    values_[static_cast<size_t>(k)] =
        static_cast<int16_t>(std::nearbyint(std::ldexp(views.data()[k], shift_)));
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
  if (j < 0 || j >= cols_) throw std::out_of_range("member view " + std::to_string(j));
  Eigen::VectorXf out(rows_);
  DecodeRange(values_.data() + j * rows_, rows_, shift_, out.data());
  return out;
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
