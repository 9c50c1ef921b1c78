#include "drivers/world/scenario.h"

#include <cmath>
#include <numbers>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

namespace tsc::sim {

Scenario MakeScenario(const SimOptions& options) {
  options.Validate();
  std::mt19937 world_rng(options.seed);
  Scenario scenario{World::Generate(options.world, world_rng), {}};
  std::mt19937 route_rng(options.RouteSeed() ^ 0x9e3779b9u);
  if (options.robots == 1) {
    scenario.routes.push_back(
        FollowRooms(scenario.world, SingleRobotTargets(scenario.world, options.route, route_rng),
                    options.route));
    return scenario;
  }
  const auto targets = TeamTargets(scenario.world, options.robots, options.route, route_rng);
  for (const std::vector<int>& t : targets) {
    scenario.routes.push_back(FollowRooms(scenario.world, t, options.route));
  }
  return scenario;
}

std::uint32_t FrameSeed(std::uint32_t seed) { return seed ^ 0x85ebca6bu; }

Pose2 RenderRouteFrame(const World& world, const Renderer& renderer, const RouteFrame& frame,
                       const SimOptions& options, std::mt19937& rng, FrameDistributions& draws,
                       cv::Mat* bgr, cv::Mat* depth) {
  // The same number of draws per frame whatever the options, so frames stay comparable.
  const double jx = draws.normal(rng), jy = draws.normal(rng), jh = draws.normal(rng);
  const double flicker = draws.unit(rng), glitch = draws.unit(rng), glitch_kind = draws.unit(rng);
  Pose2 pose = frame.pose;
  pose.x += options.jitter_position_m * jx;
  pose.y += options.jitter_position_m * jy;
  pose.heading += options.jitter_heading_deg * std::numbers::pi / 180.0 * jh;
  if (world.RoomAt(pose.x, pose.y) < 0) pose = frame.pose;  // never through a wall

  Lighting light = Lighting::Day();
  switch (options.lighting) {
    case LightingMode::kDay:
      break;
    case LightingMode::kDim:
      light = Lighting::Dim();
      break;
    case LightingMode::kFlicker:
      light.gain *= 0.75 + 0.5 * flicker;
      break;
    case LightingMode::kMixed:
      if (frame.revisit) light = Lighting::Dim();
      break;
  }
  const bool glitched = glitch < options.glitch_probability;
  if (glitched && glitch_kind >= 0.5) light.gain *= 0.2;  // a dark frame
  // Motion blur of a turn: the view sweeps shutter_fraction of the heading change.
  const int blur_px = static_cast<int>(
      std::lround(options.shutter_fraction * frame.turn_rad * renderer.focal_px()));

  // One view straight ahead, or the views of a pan sweep side by side, each rendered, blurred
  // and lit on its own (the seams stay sharp).
  std::vector<cv::Mat> views(static_cast<size_t>(options.sweep.views())), depths(views.size());
  for (size_t v = 0; v < views.size(); ++v) {
    Pose2 view_pose = pose;
    // World-aligned: the heading estimate is exact up to the camera's own jitter.
    if (options.sweep_world_aligned) view_pose.heading -= frame.pose.heading;
    view_pose.heading += options.sweep.View(static_cast<int>(v)).pan_rad;
    cv::Mat& bgr_v = views[v];
    renderer.Render(view_pose, &bgr_v, depth != nullptr ? &depths[v] : nullptr);
    if (blur_px >= 2) cv::blur(bgr_v, bgr_v, cv::Size(blur_px, 1));
    if (glitched && glitch_kind < 0.5) {  // a blurred frame
      cv::GaussianBlur(bgr_v, bgr_v, cv::Size(0, 0), renderer.options().width / 80.0);
    }
    renderer.ApplyLighting(light, rng, &bgr_v);
  }
  if (views.size() == 1) {
    *bgr = views[0];
    if (depth != nullptr) *depth = depths[0];
  } else {
    cv::hconcat(views, *bgr);
    if (depth != nullptr) cv::hconcat(depths, *depth);
  }
  return pose;
}

}  // namespace tsc::sim
