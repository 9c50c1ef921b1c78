#pragma once
// A simulated scenario: the world of a seed, the scripted route of every robot, and the
// per-frame camera effects (jitter, lighting, glitches). Shared by the dataset writer
// (`tsc sim`) and the live simulated camera (drivers/camera/sim_camera.h), so both see the
// same world and the same routes for the same seed.

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "drivers/world/renderer.h"
#include "drivers/world/routes.h"
#include "drivers/world/sim_options.h"
#include "drivers/world/world.h"

namespace tsc::sim {

/// The world and the scripted routes of options.seed (options.world, options.robots,
/// options.route): route k is robot k's (0-based). With one robot it is the single-robot tour
/// with revisits; with K > 1 the team routes that share some rooms.
struct Scenario {
  World world;
  std::vector<std::vector<RouteFrame>> routes;
};

/// Builds the scenario of options (validated first). Throws std::invalid_argument naming the
/// bad option.
Scenario MakeScenario(const SimOptions& options);

/// Seed of the per-frame random stream (jitter, lighting noise) of a dataset written from
/// options.seed; robot k's live camera uses FrameSeed(seed) + k.
std::uint32_t FrameSeed(std::uint32_t seed);

/// The distributions of the per-frame perturbations. One per robot's stream, kept across its
/// frames: a normal distribution carries a cached draw from one call to the next.
struct FrameDistributions {
  std::normal_distribution<double> normal{0.0, 1.0};
  std::uniform_real_distribution<double> unit{0.0, 1.0};
};

/// Renders one frame of a route the way the dataset writer does: draws the per-frame
/// perturbations from `rng` through `draws` (always the same number of draws), jitters the
/// pose (never through a wall), renders, applies the lighting mode (mixed: revisits dim) and
/// an occasional blurred or dark frame, then sensor noise. `depth` may be null. Returns the
/// pose rendered.
Pose2 RenderRouteFrame(const World& world, const Renderer& renderer, const RouteFrame& frame,
                       const SimOptions& options, std::mt19937& rng, FrameDistributions& draws,
                       cv::Mat* bgr, cv::Mat* depth);

}  // namespace tsc::sim
