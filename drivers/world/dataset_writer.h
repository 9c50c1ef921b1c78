#pragma once
// Writes simulated datasets in the folder layout of DESIGN §7.1:
//
//   OUT/000001.jpg ...        colour frames (JPEG quality 90, or PNG), 1-based, zero-padded
//   OUT/depth/000001.png ...  with depth: 16-bit PNG, millimetres, 0 = no reading (sky)
//   OUT/camera.json           {"width":W,"height":H,"hfov_deg":F}, with a pan sweep also
//                             "sweep_views":K,"sweep_deg":D (each image is K views wide)
//   OUT/groundtruth.csv       frame,place,x,y,heading   (frame 1-based; place "" in doorways;
//                             x, y in metres, heading in radians CCW from +x, world.json frame)
//   OUT/world.json            the floor plan, format in drivers/world/world.h (World::ToJson)
//
// With K > 1 robots: OUT/world.json and OUT/robots/<id>/ for id = 1..K, each a full dataset
// as above (same world, so place labels are shared across robots).

#include <cstdint>
#include <filesystem>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "core/bubble/camera.h"
#include "drivers/world/renderer.h"
#include "drivers/world/routes.h"
#include "drivers/world/sim_options.h"
#include "drivers/world/world.h"

namespace tsc::sim {

/// What was written.
struct SimSummary {
  std::vector<int> frames;                      ///< per robot
  std::vector<std::string> labels;              ///< labels of the world's rooms
  std::vector<std::filesystem::path> datasets;  ///< the dataset folder of each robot
};

/// Renders `route` (every options.frame_every-th frame, truncated to options.max_frames) into
/// `folder` (created if missing).
/// Throws std::runtime_error naming the file that cannot be written.
int WriteRobotDataset(const std::filesystem::path& folder, const World& world,
                      const std::vector<RouteFrame>& route, const SimOptions& options,
                      std::mt19937& rng);

/// Generates the world and the routes from options.seed and writes everything under `out`,
/// which must not exist or be empty. Throws std::invalid_argument for bad options and
/// std::runtime_error for I/O failures, naming the option or file.
SimSummary WriteSimulatedDataset(const std::filesystem::path& out, const SimOptions& options);

}  // namespace tsc::sim
