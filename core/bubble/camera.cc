#include "core/bubble/camera.h"

#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>

namespace tsc {

CameraIntrinsics::CameraIntrinsics(int width, int height, double fx, double fy, double cx,
                                   double cy)
    : width_(width), height_(height), fx_(fx), fy_(fy), cx_(cx), cy_(cy) {
  if (width <= 0 || height <= 0) {
    throw std::invalid_argument("camera size must be positive, got " + std::to_string(width) + "x" +
                                std::to_string(height));
  }
  if (!(std::isfinite(fx) && fx > 0.0)) {
    throw std::invalid_argument("camera fx must be positive, got " + std::to_string(fx));
  }
  if (!(std::isfinite(fy) && fy > 0.0)) {
    throw std::invalid_argument("camera fy must be positive, got " + std::to_string(fy));
  }
  // Pixel centres are at integer coordinates, so the image spans [-0.5, size - 0.5].
  if (!(std::isfinite(cx) && cx >= -0.5 && cx <= width - 0.5)) {
    throw std::invalid_argument("camera cx must lie inside the image, got " + std::to_string(cx));
  }
  if (!(std::isfinite(cy) && cy >= -0.5 && cy <= height - 0.5)) {
    throw std::invalid_argument("camera cy must lie inside the image, got " + std::to_string(cy));
  }
}

CameraIntrinsics CameraIntrinsics::FromHorizontalFov(int width, int height, double hfov_deg) {
  if (!(hfov_deg > 0.0 && hfov_deg < 180.0)) {
    throw std::invalid_argument("camera hfov_deg must be in (0, 180), got " +
                                std::to_string(hfov_deg));
  }
  // The field of view spans the whole image width, edge to edge.
  const double f = 0.5 * width / std::tan(0.5 * hfov_deg * std::numbers::pi / 180.0);
  return CameraIntrinsics(width, height, f, f, 0.5 * (width - 1), 0.5 * (height - 1));
}

CameraIntrinsics CameraIntrinsics::Scaled(int new_width, int new_height) const {
  if (new_width <= 0 || new_height <= 0) {
    throw std::invalid_argument("scaled camera size must be positive, got " +
                                std::to_string(new_width) + "x" + std::to_string(new_height));
  }
  const double sx = static_cast<double>(new_width) / width_;
  const double sy = static_cast<double>(new_height) / height_;
  // Pixel-centre convention: the edge -0.5 maps to -0.5.
  return CameraIntrinsics(new_width, new_height, fx_ * sx, fy_ * sy, (cx_ + 0.5) * sx - 0.5,
                          (cy_ + 0.5) * sy - 0.5);
}

std::string CameraIntrinsics::ToString() const {
  std::ostringstream s;
  s << "CameraIntrinsics(" << width_ << "x" << height_ << ", fx=" << fx_ << ", fy=" << fy_
    << ", cx=" << cx_ << ", cy=" << cy_ << ")";
  return s.str();
}

PanSweep::PanSweep(int views, double deg) : views_(views), deg_(deg) {
  if (views < 1 || views > 360) {
    throw std::invalid_argument("sweep views " + std::to_string(views) + " must be in [1, 360]");
  }
  if (!(deg > 0.0 && deg <= 360.0)) {
    throw std::invalid_argument("sweep of " + std::to_string(deg) + "° must be in (0, 360]");
  }
}

PanTilt PanSweep::View(int j) const {
  return PanTilt{deg_ / views_ * j * std::numbers::pi / 180.0, 0.0};
}

}  // namespace tsc
