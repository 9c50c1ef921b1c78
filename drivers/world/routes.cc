#include "drivers/world/routes.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <numbers>
#include <set>
#include <stdexcept>

namespace tsc::sim {
namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;

double WrapAngle(double a) {
  while (a > std::numbers::pi) a -= 2.0 * std::numbers::pi;
  while (a <= -std::numbers::pi) a += 2.0 * std::numbers::pi;
  return a;
}

/// Samples poses: turns in place towards each waypoint, then walks to it.
class Walker {
 public:
  Walker(const World& world, const RouteOptions& options, Pose2 start)
      : world_(world), options_(options), pose_(start) {
    Emit();
  }

  void TurnTo(double heading) {
    const double delta = WrapAngle(heading - pose_.heading);
    const int n =
        static_cast<int>(std::ceil(std::abs(delta) / (options_.turn_step_deg * kDegToRad) - 1e-9));
    const double h0 = pose_.heading;
    for (int i = 1; i <= n; ++i) {
      pose_.heading = WrapAngle(h0 + delta * i / n);
      Emit();
    }
  }

  void MoveTo(double x, double y) {
    const double dx = x - pose_.x, dy = y - pose_.y;
    const double dist = std::hypot(dx, dy);
    if (dist < 1e-6) return;
    TurnTo(std::atan2(dy, dx));
    const int n = std::max(1, static_cast<int>(std::ceil(dist / options_.step_m - 1e-9)));
    const double x0 = pose_.x, y0 = pose_.y;
    for (int i = 1; i <= n; ++i) {
      pose_.x = x0 + dx * i / n;
      pose_.y = y0 + dy * i / n;
      Emit();
    }
  }

  void Dwell() {
    for (int i = 0; i < options_.dwell_frames; ++i) {
      pose_.heading = WrapAngle(pose_.heading + options_.scan_step_deg * kDegToRad);
      Emit();
    }
  }

  /// Drops the last frame when it is at `pose` (and it is not the only frame).
  void DropLastIfAt(const Pose2& pose) {
    if (frames_.size() < 2) return;
    const Pose2& last = frames_.back().pose;
    if (std::hypot(last.x - pose.x, last.y - pose.y) < 1e-9 &&
        std::abs(WrapAngle(last.heading - pose.heading)) < 1e-9) {
      frames_.pop_back();
    }
  }

  std::vector<RouteFrame> Take() { return std::move(frames_); }

 private:
  void Emit() {
    const double turn =
        frames_.empty() ? 0.0 : std::abs(WrapAngle(pose_.heading - frames_.back().pose.heading));
    frames_.push_back(RouteFrame{pose_, world_.LabelAt(pose_.x, pose_.y), turn, false});
  }

  const World& world_;
  const RouteOptions& options_;
  Pose2 pose_;
  std::vector<RouteFrame> frames_;
};

/// Doors on a shortest path (fewest doors) from room a to room b.
std::vector<int> DoorPath(const World& world, int a, int b) {
  const int n = static_cast<int>(world.rooms().size());
  std::vector<int> via(static_cast<size_t>(n), -1);  // door used to reach the room
  std::vector<bool> seen(static_cast<size_t>(n), false);
  std::deque<int> queue = {a};
  seen[static_cast<size_t>(a)] = true;
  while (!queue.empty()) {
    const int r = queue.front();
    queue.pop_front();
    if (r == b) break;
    for (int d = 0; d < static_cast<int>(world.doors().size()); ++d) {
      const Door& door = world.doors()[static_cast<size_t>(d)];
      const int other = door.room_a == r ? door.room_b : door.room_b == r ? door.room_a : -1;
      if (other < 0 || seen[static_cast<size_t>(other)]) continue;
      seen[static_cast<size_t>(other)] = true;
      via[static_cast<size_t>(other)] = d;
      queue.push_back(other);
    }
  }
  if (!seen[static_cast<size_t>(b)]) {
    throw std::invalid_argument("room '" + world.rooms()[static_cast<size_t>(b)].label +
                                "' cannot be reached");
  }
  std::vector<int> doors;
  for (int r = b; r != a;) {
    const int d = via[static_cast<size_t>(r)];
    doors.push_back(d);
    const Door& door = world.doors()[static_cast<size_t>(d)];
    r = door.room_a == r ? door.room_b : door.room_a;
  }
  std::reverse(doors.begin(), doors.end());
  return doors;
}

/// A point 0.8 m (at most 40 % of the room's depth) into room r in front of the door.
cv::Point2d Approach(const World& world, const Door& door, int r) {
  const Room& room = world.rooms()[static_cast<size_t>(r)];
  if (door.vertical_wall) {
    const double sign = room.cx() > door.line ? 1.0 : -1.0;
    return {door.line + sign * std::min(0.8, 0.4 * (room.x1 - room.x0)), door.cy()};
  }
  const double sign = room.cy() > door.line ? 1.0 : -1.0;
  return {door.cx(), door.line + sign * std::min(0.8, 0.4 * (room.y1 - room.y0))};
}

std::vector<int> NearestNeighbourTour(const World& world, std::vector<int> rooms, int start) {
  std::vector<int> tour = {start};
  rooms.erase(std::remove(rooms.begin(), rooms.end(), start), rooms.end());
  while (!rooms.empty()) {
    const Room& last = world.rooms()[static_cast<size_t>(tour.back())];
    auto best = std::min_element(rooms.begin(), rooms.end(), [&](int a, int b) {
      const Room& ra = world.rooms()[static_cast<size_t>(a)];
      const Room& rb = world.rooms()[static_cast<size_t>(b)];
      return std::hypot(ra.cx() - last.cx(), ra.cy() - last.cy()) <
             std::hypot(rb.cx() - last.cx(), rb.cy() - last.cy());
    });
    tour.push_back(*best);
    rooms.erase(best);
  }
  return tour;
}

/// Tour then revisits of ⌈fraction·n⌉ tour rooms in reverse tour order.
std::vector<int> TourWithRevisits(const World& world, const std::vector<int>& rooms, int start,
                                  double fraction, std::mt19937& rng) {
  std::vector<int> tour = NearestNeighbourTour(world, rooms, start);
  const int n = static_cast<int>(tour.size());
  const int k = std::min(n, static_cast<int>(std::ceil(fraction * n - 1e-9)));
  std::vector<int> order(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) order[static_cast<size_t>(i)] = i;
  std::shuffle(order.begin(), order.end(), rng);
  order.resize(static_cast<size_t>(k));
  std::sort(order.rbegin(), order.rend());  // reverse tour order
  std::vector<int> targets = tour;
  for (int i : order) {
    const int room = tour[static_cast<size_t>(i)];
    if (room == targets.back()) {
      // Visit another room in between so the revisit is a return, not a stay.
      targets.push_back(tour[static_cast<size_t>(i == 0 ? 1 % n : i - 1)]);
      if (targets.back() == room) continue;
    }
    targets.push_back(room);
  }
  return targets;
}

std::vector<int> NonTransit(const World& world) {
  std::vector<int> out;
  for (int i = 0; i < static_cast<int>(world.rooms().size()); ++i) {
    if (!world.rooms()[static_cast<size_t>(i)].transit) out.push_back(i);
  }
  if (out.empty()) {
    for (int i = 0; i < static_cast<int>(world.rooms().size()); ++i) out.push_back(i);
  }
  return out;
}

}  // namespace

void RouteOptions::Validate() const {
  if (!(step_m > 0.0 && step_m <= 2.0)) {
    throw std::invalid_argument("route step " + std::to_string(step_m) + " m must be in (0, 2]");
  }
  if (!(turn_step_deg > 0.0 && turn_step_deg <= 90.0)) {
    throw std::invalid_argument("turn step " + std::to_string(turn_step_deg) +
                                "° must be in (0, 90]");
  }
  if (!(scan_step_deg > 0.0 && scan_step_deg <= 90.0)) {
    throw std::invalid_argument("scan step " + std::to_string(scan_step_deg) +
                                "° must be in (0, 90]");
  }
  if (dwell_frames < 0 || dwell_frames > 10000) {
    throw std::invalid_argument("frames per room " + std::to_string(dwell_frames) +
                                " must be in [0, 10000]");
  }
  if (!(revisit_fraction >= 0.0 && revisit_fraction <= 1.0)) {
    throw std::invalid_argument("revisit fraction " + std::to_string(revisit_fraction) +
                                " must be in [0, 1]");
  }
}

std::vector<RouteFrame> FollowRooms(const World& world, const std::vector<int>& targets,
                                    const RouteOptions& options) {
  options.Validate();
  if (targets.empty()) return {};
  const auto& rooms = world.rooms();
  const Room& first = rooms.at(static_cast<size_t>(targets[0]));
  Walker walker(world, options, Pose2{first.cx(), first.cy(), 0.0});
  walker.Dwell();
  int at = targets[0];
  // Through the fewest doors to the centre of `target`.
  const auto walk_to = [&](int target) {
    for (int d : DoorPath(world, at, target)) {
      const Door& door = world.doors()[static_cast<size_t>(d)];
      const int next = door.room_a == at ? door.room_b : door.room_a;
      const cv::Point2d in = Approach(world, door, at);
      const cv::Point2d out = Approach(world, door, next);
      walker.MoveTo(in.x, in.y);
      walker.MoveTo(door.cx(), door.cy());
      walker.MoveTo(out.x, out.y);
      at = next;
    }
    const Room& room = rooms[static_cast<size_t>(target)];
    walker.MoveTo(room.cx(), room.cy());
  };
  for (size_t i = 1; i < targets.size(); ++i) {
    const int target = targets[i];
    if (target == at) continue;
    walk_to(target);
    if (!rooms[static_cast<size_t>(target)].transit) walker.Dwell();
  }
  if (options.closed) {
    // Back to the first pose, which a looping camera takes next; no look-around there, the
    // route's first frames are one.
    walk_to(targets[0]);
    walker.TurnTo(0.0);
    walker.DropLastIfAt(Pose2{first.cx(), first.cy(), 0.0});
  }
  std::vector<RouteFrame> frames = walker.Take();
  // Revisit flags: a label is revisited once it appears again after another label.
  std::set<std::string> done;  // labels of finished visits
  std::string current;
  bool revisit = false;
  for (RouteFrame& f : frames) {
    if (!f.label.empty() && f.label != current) {
      if (!current.empty()) done.insert(current);
      current = f.label;
      revisit = done.count(current) > 0;
    }
    f.revisit = revisit;
  }
  return frames;
}

std::vector<int> SingleRobotTargets(const World& world, const RouteOptions& options,
                                    std::mt19937& rng) {
  options.Validate();
  const std::vector<int> rooms = NonTransit(world);
  const int start = rooms[std::uniform_int_distribution<size_t>(0, rooms.size() - 1)(rng)];
  std::vector<int> targets = TourWithRevisits(world, rooms, start, options.revisit_fraction, rng);
  // Rooms the route never passes through (e.g. a dead-end corridor) become targets.
  std::set<std::string> seen;
  RouteOptions tour = options;  // the way back of a closed route is no visit
  tour.closed = false;
  for (const RouteFrame& f : FollowRooms(world, targets, tour)) seen.insert(f.label);
  for (int i = 0; i < static_cast<int>(world.rooms().size()); ++i) {
    if (seen.count(world.rooms()[static_cast<size_t>(i)].label) == 0) targets.push_back(i);
  }
  return targets;
}

std::vector<std::vector<int>> TeamTargets(const World& world, int robots,
                                          const RouteOptions& options, std::mt19937& rng) {
  options.Validate();
  if (robots < 1) throw std::invalid_argument("robots " + std::to_string(robots) + " must be ≥ 1");
  std::vector<int> rooms = NonTransit(world);
  std::shuffle(rooms.begin(), rooms.end(), rng);
  const size_t shared = std::max<size_t>(1, rooms.size() / 3);
  std::vector<std::vector<int>> own(static_cast<size_t>(robots));
  for (size_t i = shared; i < rooms.size(); ++i) own[(i - shared) % own.size()].push_back(rooms[i]);
  std::vector<std::vector<int>> out;
  for (int k = 0; k < robots; ++k) {
    std::vector<int> mine(rooms.begin(), rooms.begin() + static_cast<long>(shared));
    mine.insert(mine.end(), own[static_cast<size_t>(k)].begin(), own[static_cast<size_t>(k)].end());
    const int start = mine[std::uniform_int_distribution<size_t>(0, mine.size() - 1)(rng)];
    out.push_back(TourWithRevisits(world, mine, start, options.revisit_fraction, rng));
  }
  return out;
}

}  // namespace tsc::sim
