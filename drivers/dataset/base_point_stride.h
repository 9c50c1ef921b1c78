#pragma once
// The frames of a camera denser than the calibrated spacing that become base points
// (StrideFor, drivers/dataset/base_point_spacing.h): every stride-th, counted in base points
// so that a pan sweep's views stay together.

#include <stdexcept>
#include <string>

namespace tsc {

class BasePointStride {
 public:
  /// Throws std::invalid_argument unless stride ≥ 1.
  explicit BasePointStride(int stride) : stride_(stride) {
    if (stride < 1) throw std::invalid_argument("base point stride " + std::to_string(stride));
  }
  int stride() const { return stride_; }
  /// Whether the next view, which closes its base point when `ends_base_point`, is taken:
  /// every view of base points 0, stride, 2·stride, ...
  bool Take(bool ends_base_point) {
    const bool take = seen_ % stride_ == 0;
    if (ends_base_point) ++seen_;
    return take;
  }

 private:
  int stride_;
  long long seen_ = 0;  // base points closed so far
};

}  // namespace tsc
