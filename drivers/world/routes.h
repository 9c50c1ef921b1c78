#pragma once
// Scripted routes through a simulated world: waypoints from room to room through the doors,
// sampled at a fixed step, turning in place at waypoints, and a look-around turn at the centre
// of every room visited on purpose (so a room visit is many frames).

#include <random>
#include <string>
#include <vector>

#include "drivers/world/renderer.h"
#include "drivers/world/world.h"

namespace tsc::sim {

struct RouteOptions {
  double step_m = 0.15;         ///< walking distance between frames, metres
  double turn_step_deg = 15.0;  ///< turning in place between frames, degrees
  /// Frames spent turning in place at the centre of each room visited on purpose (24 frames
  /// at 15° = one full turn); 0 for none.
  int dwell_frames = 24;
  /// Fraction of the rooms revisited (in reverse order) after the first tour, in [0, 1].
  double revisit_fraction = 0.5;
  /// Throws std::invalid_argument naming the bad value.
  void Validate() const;
};

/// One sampled pose with its ground truth.
struct RouteFrame {
  Pose2 pose;
  std::string label;     ///< World::LabelAt(pose): "" in doorways
  bool revisit = false;  ///< the label (or, in a doorway, the last label) was seen in an
                         ///< earlier visit
};

/// Frames of a route visiting `targets` (room indices) in order, starting at the centre of
/// the first one; consecutive rooms are joined by the fewest doors (breadth-first search).
/// Throws std::invalid_argument when a target cannot be reached.
std::vector<RouteFrame> FollowRooms(const World& world, const std::vector<int>& targets,
                                    const RouteOptions& options);

/// Single robot: every non-transit room in a nearest-neighbour tour from a random start (plus
/// any room the tour does not pass through), then ⌈revisit_fraction·n⌉ of them again in
/// reverse tour order.
std::vector<int> SingleRobotTargets(const World& world, const RouteOptions& options,
                                    std::mt19937& rng);

/// K robots: a third of the non-transit rooms (at least one) is shared by all, the others are
/// dealt round-robin; each robot tours its rooms from its own start and revisits as above.
std::vector<std::vector<int>> TeamTargets(const World& world, int robots,
                                          const RouteOptions& options, std::mt19937& rng);

}  // namespace tsc::sim
