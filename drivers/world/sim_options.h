#pragma once
// What a simulated dataset or camera is made of: the world kind and seed, the routes, the
// lighting, the rendering, the camera's sweep and noise (tsc sim, the sim camera, tests).

#include <cstdint>
#include <optional>
#include <string>

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
  /// A camera with this many times fewer frames on the same route (a slower frame rate): the
  /// route's first frame, then every frame_every-th; camera.json's spacing_m is as many route
  /// steps. 1: every route frame.
  int frame_every = 1;
  /// Throws std::invalid_argument naming the bad value.
  void Validate() const;
};

}  // namespace tsc::sim
