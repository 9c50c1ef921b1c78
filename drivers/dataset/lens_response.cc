#include "drivers/dataset/lens_response.h"

#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>

#include "core/bubble/camera.h"
#include "core/pipeline/pipeline.h"

namespace tsc {
namespace {

// Medians over the nine calibration worlds (seeds 31, 32, 41; office, corridors, outdoor;
// 160x120, 0.15 m apart) of each world's ratio to its 58° run: consecutive χ² for kappa,
// consecutive squared distance for unit (docs/calibration.md, thirtieth pass). τ_κ follows
// only narrower lenses: scaled by the wide lenses' response (1.12 at 75°, 1.31 at 90°)
// detection found no more boundaries and recognition made more wrong ones, while the unit's
// scaling recognised more there and no more wrongly.
constexpr std::array<LensResponse, 5> kMeasured{{
    {45.0, 0.616, 0.554},
    {50.0, 0.799, 0.742},
    {kCalibratedHfovDeg, 1.0, 1.0},
    {75.0, 1.0, 1.223},
    {90.0, 1.0, 1.405},
}};
// Lenses recognition was measured with: beyond them a caution.
constexpr double kNarrowestMeasuredDeg = 45.0;
constexpr double kWidestMeasuredDeg = 100.0;

double Interpolated(double x, double x0, double y0, double x1, double y1) {
  const double t = (std::log(x) - std::log(x0)) / (std::log(x1) - std::log(x0));
  return std::exp(std::log(y0) + t * (std::log(y1) - std::log(y0)));
}

bool IsForward(int views_per_base_point) { return views_per_base_point <= 1; }

}  // namespace

LensResponse LensResponseAt(double hfov_deg) {
  if (!(hfov_deg > 0.0 && hfov_deg < 180.0)) {
    throw std::invalid_argument("a lens's horizontal field of view must be in (0, 180) degrees");
  }
  const LensResponse& narrowest = kMeasured.front();
  const LensResponse& widest = kMeasured.back();
  if (hfov_deg <= narrowest.hfov_deg) return {hfov_deg, narrowest.kappa, narrowest.unit};
  if (hfov_deg >= widest.hfov_deg) return {hfov_deg, widest.kappa, widest.unit};
  size_t i = 1;
  while (kMeasured[i].hfov_deg < hfov_deg) ++i;
  const LensResponse& a = kMeasured[i - 1];
  const LensResponse& b = kMeasured[i];
  return {hfov_deg, Interpolated(hfov_deg, a.hfov_deg, a.kappa, b.hfov_deg, b.kappa),
          Interpolated(hfov_deg, a.hfov_deg, a.unit, b.hfov_deg, b.unit)};
}

bool WithinMeasuredLenses(double hfov_deg) {
  return hfov_deg >= kNarrowestMeasuredDeg && hfov_deg <= kWidestMeasuredDeg;
}

double HorizontalFovDeg(const CameraIntrinsics& camera) {
  const double deg = 2.0 * std::atan(0.5 * camera.width() / camera.fx()) * 180.0 / std::numbers::pi;
  // To a millionth of a degree: a camera made from a field of view gives that field back.
  return std::round(deg * 1e6) / 1e6;
}

void AdaptToLens(PipelineOptions& options, double hfov_deg, int views_per_base_point) {
  if (!IsForward(views_per_base_point)) return;
  const LensResponse r = LensResponseAt(hfov_deg);
  options.reliability.tau_kappa *= r.kappa;
  // 0 is the memory's own median view spacing, which follows the lens by itself.
  options.memory.distance_unit *= r.unit;
}

std::optional<std::string> LensNote(const PipelineOptions& adapted, double hfov_deg,
                                    int views_per_base_point) {
  if (!IsForward(views_per_base_point) || hfov_deg == kCalibratedHfovDeg) return std::nullopt;
  char text[240];
  std::snprintf(text, sizeof text,
                "a %.3g° lens: detection.tau_kappa %.3g and memory.distance_unit %.3g, the "
                "configured values (for %.3g°) scaled as descriptors change at that lens",
                hfov_deg, adapted.reliability.tau_kappa, adapted.memory.distance_unit,
                kCalibratedHfovDeg);
  return std::string(text);
}

std::optional<std::string> LensCaution(double hfov_deg, int views_per_base_point) {
  if (!IsForward(views_per_base_point) || WithinMeasuredLenses(hfov_deg)) return std::nullopt;
  char text[260];
  std::snprintf(text, sizeof text,
                "a %.3g° lens is outside the lenses recognition was measured with (%.3g° to "
                "%.3g°)%s: expect fewer places and wrong recognitions",
                hfov_deg, kNarrowestMeasuredDeg, kWidestMeasuredDeg,
                hfov_deg < kNarrowestMeasuredDeg ? "; its thresholds are a 45° lens's" : "");
  return std::string(text);
}

}  // namespace tsc
