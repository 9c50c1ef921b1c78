#pragma once
// The true pose that `tsc jaguar-sim --pose-file` writes (one line "x y heading_rad", metres
// and radians, rewritten as the simulated board moves), read back by tests that drive it.

#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>

namespace tsc::testing_support {

struct SimPose {
  double x = 0, y = 0;  ///< metres, world frame
  double heading = 0;   ///< radians
};

/// The pose in `file`, or nothing while the simulator has not written a whole line yet.
inline std::optional<SimPose> ReadSimPose(const std::filesystem::path& file) {
  std::ifstream in(file);
  SimPose p;
  if (!(in >> p.x >> p.y >> p.heading)) return std::nullopt;
  return p;
}

/// Distance in the plane between two poses, metres.
inline double Distance(const SimPose& a, const SimPose& b) {
  return std::hypot(a.x - b.x, a.y - b.y);
}

}  // namespace tsc::testing_support
