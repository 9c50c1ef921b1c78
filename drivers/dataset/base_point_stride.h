#pragma once
// The frames of a camera denser than the calibrated spacing that become base points
// (StrideFor, drivers/dataset/base_point_spacing.h): every stride-th, counted in base points
// so that a pan sweep's views stay together, and none while the camera stands still
// (BasePointMotion, drivers/dataset/base_point_motion.h).

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
  /// Whether the next view, which closes its base point when `ends_base_point`, is taken. A
  /// base point's first view decides for all its views: the first base point is taken, then
  /// one `stride` base points after the last taken, or the first after that which `moved`
  /// (every stride-th while the camera moves).
  bool Take(bool ends_base_point, bool moved = true) {
    if (at_start_) {
      taking_ = !started_ || (since_taken_ + 1 >= stride_ && moved);
      if (taking_) {
        started_ = true;
        since_taken_ = 0;
      } else {
        ++since_taken_;
      }
    }
    at_start_ = ends_base_point;
    return taking_;
  }

 private:
  int stride_;
  bool started_ = false;
  bool at_start_ = true;       // the next view opens a base point
  bool taking_ = false;        // the current base point is taken
  long long since_taken_ = 0;  // base points passed over since the last taken one
};

}  // namespace tsc
