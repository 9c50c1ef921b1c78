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
#include "drivers/world/world.h"

namespace tsc::sim {

enum class LightingMode {
  kDay,
  kDim,      ///< night
  kFlicker,  ///< day light with a per-frame brightness modulation
  kMixed,    ///< first visits of a place in day light, revisits dim
};

/// "day" | "dim" | "flicker" | "mixed"; throws std::invalid_argument naming the bad value.
LightingMode ParseLightingMode(const std::string& name);

struct SimOptions {
  WorldKind world = WorldKind::kOffice;
  std::uint32_t seed = 1;
  /// Seed of the routes and the per-frame noise when it differs from the world's: the same
  /// world walked along another route (training and test passes of chapter 2). Unset: `seed`.
  std::optional<std::uint32_t> route_seed;
  std::uint32_t RouteSeed() const { return route_seed.value_or(seed); }
  int robots = 1;  ///< K ≥ 1; K > 1 writes robots/<id>/ sub-datasets
  LightingMode lighting = LightingMode::kDay;
  bool depth = false;  ///< also write depth/<stem>.png
  bool png = false;    ///< colour frames as PNG instead of JPEG
  RenderOptions render;
  /// A pan sweep per frame (a pan-tilt camera turning through `sweep.views()` views at every
  /// base point): the views are written side by side into one image per frame, and
  /// camera.json says so (drivers/dataset/dataset.h). One view: a fixed forward camera.
  PanSweep sweep;
  /// With a sweep: take its views at fixed headings of the world (a sweep started from the
  /// robot's heading estimate, odometry or compass) instead of relative to the robot, so a
  /// turn on the spot leaves the views where they were. The pans written and tagged stay
  /// relative to the first view.
  bool sweep_world_aligned = false;
  RouteOptions route;
  double jitter_heading_deg = 1.0;   ///< standard deviation of the camera heading noise
  double jitter_position_m = 0.02;   ///< standard deviation of the camera position noise
  double glitch_probability = 0.02;  ///< per frame: a blurred or a dark frame
  /// Fraction of the time between frames the shutter is open: a frame taken while the robot
  /// turns by Δ between frames is blurred horizontally over shutter_fraction·Δ of view (box
  /// kernel). 0.1 at ~3 frames per second is a 30 ms exposure; 0 for no motion blur.
  double shutter_fraction = 0.1;
  int max_frames = 0;  ///< per robot; 0 = the whole route (tests use short routes)
  /// Throws std::invalid_argument naming the bad value.
  void Validate() const;
};

/// What was written.
struct SimSummary {
  std::vector<int> frames;                      ///< per robot
  std::vector<std::string> labels;              ///< labels of the world's rooms
  std::vector<std::filesystem::path> datasets;  ///< the dataset folder of each robot
};

/// Renders `route` (truncated to options.max_frames) into `folder` (created if missing).
/// Throws std::runtime_error naming the file that cannot be written.
int WriteRobotDataset(const std::filesystem::path& folder, const World& world,
                      const std::vector<RouteFrame>& route, const SimOptions& options,
                      std::mt19937& rng);

/// Generates the world and the routes from options.seed and writes everything under `out`,
/// which must not exist or be empty. Throws std::invalid_argument for bad options and
/// std::runtime_error for I/O failures, naming the option or file.
SimSummary WriteSimulatedDataset(const std::filesystem::path& out, const SimOptions& options);

}  // namespace tsc::sim
