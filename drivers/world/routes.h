#pragma once
// Scripted routes through a simulated world: waypoints from room to room through the doors,
// sampled at a fixed step, turning in place at waypoints, and a look-around turn at the centre
// of every room visited on purpose (so a room visit is many frames). Travel turns are brisk
// (a robot turning towards its next waypoint), the look-around is a slow scan: the frames are
// those of a camera sampled every step_m of travel, about 3 per second at 0.5 m/s.

#include <random>
#include <string>
#include <vector>

#include "drivers/world/renderer.h"
#include "drivers/world/world.h"

namespace tsc::sim {

struct RouteOptions {
  double step_m = 0.15;  ///< walking distance between frames, metres
  /// Turning in place towards the next waypoint between frames, degrees (at ~3 frames per
  /// second, 30° is a turn of 90°/s).
  double turn_step_deg = 30.0;
  /// Turning between frames during the look-around at a room's centre, degrees.
  double scan_step_deg = 5.0;
  /// Frames spent looking around at the centre of each room visited on purpose (72 frames at
  /// 5° = one full turn); 0 for none.
  int dwell_frames = 72;
  /// Fraction of the rooms revisited (in reverse order) after the first tour, in [0, 1].
  double revisit_fraction = 0.5;
  /// The route ends where it began: back to the first room's centre, facing as at the first
  /// frame, so a camera that drives it again and again never jumps across the world (a jump
  /// would join the end of one lap and the start of the next into one place no lap sees
  /// again). Appended after the tour; the tour itself is unchanged.
  bool closed = false;
  /// Throws std::invalid_argument naming the bad value.
  void Validate() const;
};

/// One sampled pose with its ground truth.
struct RouteFrame {
  Pose2 pose;
  std::string label;      ///< World::LabelAt(pose): "" in doorways
  double turn_rad = 0.0;  ///< |heading change| since the previous frame (motion blur)
  bool revisit = false;   ///< the label (or, in a doorway, the last label) was seen in an
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
