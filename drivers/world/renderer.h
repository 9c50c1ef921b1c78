#pragma once
// Ray-casting renderer of the simulated world: one ray per image column against the walls and
// boxes (all vertical), the column's wall slice filled from the room's texture, floor and
// ceiling as plain colours with a slight gradient. Produces BGR colour and depth (metres along
// the optical axis, 0 where there is no reading, e.g. the sky).

#include <cstdint>
#include <opencv2/core.hpp>
#include <random>
#include <vector>

#include "drivers/world/world.h"

namespace tsc::sim {

/// Planar camera pose: position in metres, heading in radians counter-clockwise from +x.
struct Pose2 {
  double x = 0.0;
  double y = 0.0;
  double heading = 0.0;
};

struct RenderOptions {
  int width = 640;         ///< pixels
  int height = 480;        ///< pixels
  double hfov_deg = 58.0;  ///< horizontal field of view, degrees in (0, 180)
  double camera_height_m = 1.2;
  /// Throws std::invalid_argument naming the bad value.
  void Validate() const;
};

/// Per-frame light: out = gain·((in − 128)·contrast + 128) + noise.
struct Lighting {
  double gain = 1.0;
  double contrast = 1.0;
  double noise_sigma = 2.0;  ///< grey levels

  static Lighting Day() { return {1.0, 1.0, 2.0}; }
  /// Night: darker, lower contrast, noisier.
  static Lighting Dim() { return {0.45, 0.6, 4.0}; }
};

class Renderer {
 public:
  /// Keeps a reference to `world` (which must outlive the renderer). The seed fixes the sensor
  /// noise pattern pool.
  Renderer(const World& world, const RenderOptions& options, std::uint32_t noise_seed);

  const RenderOptions& options() const { return options_; }
  /// Focal length in pixels (square pixels, principal point at the centre).
  double focal_px() const { return focal_; }

  /// Noise-free rendering in full light. `bgr` becomes CV_8UC3 width x height; `depth`, when
  /// not null, CV_32F metres along the optical axis (0 = no reading).
  void Render(const Pose2& pose, cv::Mat* bgr, cv::Mat* depth) const;

  /// Applies `light` to `bgr` in place and adds gaussian sensor noise drawn (through an offset
  /// into a precomputed pool of N(0, 1) samples) from `rng`.
  void ApplyLighting(const Lighting& light, std::mt19937& rng, cv::Mat* bgr) const;

 private:
  const World& world_;
  RenderOptions options_;
  double focal_ = 0.0;
  std::vector<double> column_slope_;     ///< (cx − c)/f: leftward offset per metre forward
  std::vector<float> floor_depth_;       ///< per row below the horizon, metres
  std::vector<float> row_shade_;         ///< per row, floor/ceiling gradient factor
  std::vector<std::int8_t> noise_pool_;  ///< N(0, 1)·16 samples
};

}  // namespace tsc::sim
