#include "drivers/world/sim_options.h"

#include <stdexcept>

namespace tsc::sim {

LightingMode ParseLightingMode(const std::string& name) {
  if (name == "day") return LightingMode::kDay;
  if (name == "dim") return LightingMode::kDim;
  if (name == "flicker") return LightingMode::kFlicker;
  if (name == "mixed") return LightingMode::kMixed;
  throw std::invalid_argument("unknown lighting '" + name + "' (day, dim, flicker or mixed)");
}

void SimOptions::Validate() const {
  render.Validate();
  route.Validate();
  if (robots < 1 || robots > 64) {
    throw std::invalid_argument("robots " + std::to_string(robots) + " must be in [1, 64]");
  }
  if (!(jitter_heading_deg >= 0.0 && jitter_heading_deg <= 10.0) ||
      !(jitter_position_m >= 0.0 && jitter_position_m <= 0.2)) {
    throw std::invalid_argument("camera jitter must be within 10° and 0.2 m");
  }
  if (!(shutter_fraction >= 0.0 && shutter_fraction <= 1.0)) {
    throw std::invalid_argument("shutter fraction " + std::to_string(shutter_fraction) +
                                " must be in [0, 1]");
  }
  if (!(glitch_probability >= 0.0 && glitch_probability <= 1.0)) {
    throw std::invalid_argument("glitch probability " + std::to_string(glitch_probability) +
                                " must be in [0, 1]");
  }
  if (max_frames < 0) {
    throw std::invalid_argument("max frames " + std::to_string(max_frames) + " must be ≥ 0");
  }
  if (frame_every < 1) {
    throw std::invalid_argument("frame_every " + std::to_string(frame_every) + " must be ≥ 1");
  }
}

}  // namespace tsc::sim
