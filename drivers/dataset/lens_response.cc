#include "drivers/dataset/lens_response.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>

#include "core/pipeline/pipeline.h"

namespace tsc {
namespace {

// Medians over the nine calibration worlds (seeds 31, 32, 41; office, corridors, outdoor;
// 160x120, 0.15 m apart) of each world's ratio to its 58° run: consecutive χ² and
// consecutive squared distance (docs/calibration.md, thirtieth pass).
constexpr std::array<LensResponse, 5> kMeasured{{
    {45.0, 0.616, 0.554},
    {50.0, 0.799, 0.742},
    {kCalibratedHfovDeg, 1.0, 1.0},
    {75.0, 1.123, 1.223},
    {90.0, 1.306, 1.405},
}};
// Lenses recognition was measured with: beyond them a caution.
constexpr double kNarrowestMeasuredDeg = 45.0;
constexpr double kWidestMeasuredDeg = 100.0;

double Interpolated(double x, double x0, double y0, double x1, double y1) {
  const double t = (std::log(x) - std::log(x0)) / (std::log(x1) - std::log(x0));
  return std::exp(std::log(y0) + t * (std::log(y1) - std::log(y0)));
}

bool WithinMeasuredLenses(double hfov_deg) {
  return hfov_deg >= kNarrowestMeasuredDeg && hfov_deg <= kWidestMeasuredDeg;
}

}  // namespace

LensResponse LensResponseAt(double hfov_deg) {
  CheckHorizontalFov(hfov_deg);
  const LensResponse& narrowest = kMeasured.front();
  const LensResponse& widest = kMeasured.back();
  if (hfov_deg <= narrowest.hfov_deg) {
    return {hfov_deg, narrowest.chi2, narrowest.squared_distance};
  }
  if (hfov_deg >= widest.hfov_deg) return {hfov_deg, widest.chi2, widest.squared_distance};
  size_t i = 1;
  while (kMeasured[i].hfov_deg < hfov_deg) ++i;
  const LensResponse& a = kMeasured[i - 1];
  const LensResponse& b = kMeasured[i];
  return {hfov_deg, Interpolated(hfov_deg, a.hfov_deg, a.chi2, b.hfov_deg, b.chi2),
          Interpolated(hfov_deg, a.hfov_deg, a.squared_distance, b.hfov_deg, b.squared_distance)};
}

double ChangeResponse(const CameraLens& lens) {
  return lens.forward() ? LensResponseAt(lens.hfov_deg()).chi2 : 1.0;
}

void AdaptToLens(PipelineOptions& options, const CameraLens& lens) {
  if (!lens.forward()) return;
  const LensResponse r = LensResponseAt(lens.hfov_deg());
  // Scaled up for wide lenses (1.12 at 75°, 1.31 at 90°) detection found no more boundaries
  // and recognition made more wrong ones; the configured τ_κ already detects there.
  options.reliability.tau_kappa *= std::min(r.chi2, 1.0);
  // 0 is the memory's own median view spacing, which follows the lens by itself.
  // Within the key's range, which a unit configured near its top would otherwise leave.
  options.memory.distance_unit = std::min(options.memory.distance_unit * r.squared_distance,
                                          PlaceMemoryOptions::kDistanceUnitRange.max);
}

std::optional<std::string> LensNote(const PipelineOptions& adapted, const CameraLens& lens) {
  if (!lens.forward() || lens.hfov_deg() == kCalibratedHfovDeg) return std::nullopt;
  char text[260];
  std::snprintf(text, sizeof text,
                "a %.3g° lens: detection.tau_kappa %.3g (%s) and memory.distance_unit %.3g, "
                "scaled from the configured values (for %.3g°) as descriptors change at that "
                "lens",
                lens.hfov_deg(), adapted.reliability.tau_kappa,
                lens.hfov_deg() < kCalibratedHfovDeg ? "scaled" : "as configured",
                adapted.memory.distance_unit, kCalibratedHfovDeg);
  return std::string(text);
}

std::optional<std::string> LensCaution(const CameraLens& lens) {
  const double hfov_deg = lens.hfov_deg();
  if (!lens.forward() || WithinMeasuredLenses(hfov_deg)) return std::nullopt;
  char text[260];
  std::snprintf(text, sizeof text,
                "a %.3g° lens is outside the lenses recognition was measured with (%.3g° to "
                "%.3g°)%s: expect fewer places and wrong recognitions",
                hfov_deg, kNarrowestMeasuredDeg, kWidestMeasuredDeg,
                hfov_deg < kNarrowestMeasuredDeg ? "; its thresholds are a 45° lens's" : "");
  return std::string(text);
}

}  // namespace tsc
