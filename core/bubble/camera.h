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

/// A pan sweep of a pan-tilt camera at one base point (section 2.2: the bubble surface is
/// accumulated over the views of a sweep): `views` frames, `deg / views` degrees apart,
/// counter-clockwise (to the left) from straight ahead. One view is no sweep. Invariants
/// (checked at construction): views in [1, 360], deg in (0, 360].
class PanSweep {
 public:
  explicit PanSweep(int views = 1, double deg = 360.0);
  int views() const { return views_; }
  double deg() const { return deg_; }
  /// Pan of view j (0-based), radians.
  PanTilt View(int j) const;

 private:
  int views_;
  double deg_;
};

}  // namespace tsc
