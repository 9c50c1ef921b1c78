#pragma once
// A camera as the thresholds that follow its lens see it (lens_response.h): the horizontal
// field of view of one view, and how many views make a base point. A forward camera takes one;
// a pan sweep several, which fill the viewing sphere whatever the lens.

namespace tsc {

class CameraIntrinsics;

/// Horizontal field of view of the simulated camera the defaults were calibrated with.
inline constexpr double kCalibratedHfovDeg = 58.0;

/// std::invalid_argument unless `hfov_deg` is a horizontal field of view, in (0, 180) degrees.
void CheckHorizontalFov(double hfov_deg);

class CameraLens {
 public:
  /// The calibrated lens, forward.
  CameraLens() = default;
  /// std::invalid_argument unless `hfov_deg` is in (0, 180) and `views_per_base_point` ≥ 1.
  CameraLens(double hfov_deg, int views_per_base_point);
  /// `camera`'s horizontal field of view, to a millionth of a degree (a camera made from a
  /// field of view gives that field back).
  static CameraLens Of(const CameraIntrinsics& camera, int views_per_base_point);

  double hfov_deg() const { return hfov_deg_; }
  int views_per_base_point() const { return views_; }
  bool forward() const { return views_ == 1; }

 private:
  double hfov_deg_ = kCalibratedHfovDeg;
  int views_ = 1;
};

}  // namespace tsc
