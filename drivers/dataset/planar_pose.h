#pragma once
// A camera's or robot's pose on the floor, and how far two poses lie apart: the travel and
// the turn between them (ground truth, odometry, base-point selection, view overlap).

#include <cmath>
#include <numbers>

namespace tsc {

/// Where the camera is: metres and radians (counter-clockwise), in any fixed frame.
struct PlanarPose {
  double x = 0.0;
  double y = 0.0;
  double heading = 0.0;
};

/// Distance between the two positions, in the poses' unit.
inline double Travel(const PlanarPose& a, const PlanarPose& b) {
  return std::hypot(a.x - b.x, a.y - b.y);
}

/// The smaller angle between the two headings, radians in [0, π] (taken around the circle).
inline double Turn(const PlanarPose& a, const PlanarPose& b) {
  return std::abs(std::remainder(a.heading - b.heading, 2.0 * std::numbers::pi));
}

}  // namespace tsc
