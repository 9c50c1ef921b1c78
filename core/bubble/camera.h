#pragma once
// Camera geometry: how pixels map to viewing directions f = (f1 pan, f2 tilt) on the
// viewing sphere of the bubble space (thesis appendix A).

#include <string>

namespace tsc {

/// Pinhole intrinsics in pixels. Invariants (checked at construction): positive size and
/// focal lengths, principal point inside the image.
class CameraIntrinsics {
 public:
  CameraIntrinsics(int width, int height, double fx, double fy, double cx, double cy);
  /// Square pixels, principal point at the centre, horizontal field of view in degrees (0, 180).
  static CameraIntrinsics FromHorizontalFov(int width, int height, double hfov_deg);

  int width() const { return width_; }
  int height() const { return height_; }
  double fx() const { return fx_; }
  double fy() const { return fy_; }
  double cx() const { return cx_; }
  double cy() const { return cy_; }
  /// Same camera for an image scaled to new_width x new_height.
  CameraIntrinsics Scaled(int new_width, int new_height) const;
  std::string ToString() const;

 private:
  int width_, height_;
  double fx_, fy_, cx_, cy_;
};

/// Where the camera looks relative to the robot's base, in radians. Pan turns about the
/// vertical axis (positive to the left), tilt raises the optical axis above the horizon.
struct PanTilt {
  double pan_rad = 0.0;
  double tilt_rad = 0.0;
};

}  // namespace tsc
