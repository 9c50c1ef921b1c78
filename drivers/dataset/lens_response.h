#pragma once
// How a forward camera's thresholds follow its lens (docs/decisions.md, "Lens"). τ_κ and
// memory.distance_unit were calibrated on simulated worlds seen through a 58° lens. A narrower
// lens observes less of the viewing sphere, so its bubble descriptors change less between
// consecutive base points and lie nearer each other; a wider one, more. Left as configured,
// a 45° camera found few place boundaries and recognised wrongly half the time (nine
// calibration worlds: boundary F1 0.53, 14 right / 17 wrong), and a 90° one recognised fewer
// places than it could. So the distance unit is scaled by how much consecutive descriptors
// differ at the camera's lens, as measured on those worlds, and τ_κ by how much their χ²
// differs, for lenses narrower than 58° only (wider ones detect as well unscaled).

#include <optional>
#include <string>

namespace tsc {

class CameraIntrinsics;
struct PipelineOptions;

/// Horizontal field of view of the simulated camera the defaults were calibrated with.
inline constexpr double kCalibratedHfovDeg = 58.0;

/// How much a forward camera's descriptors change at a lens, relative to the calibrated one:
/// `kappa`, the median χ² between consecutive base points (what τ_κ compares; 1 from 58° up,
/// see above), and `unit`, their median squared distance (what memory.distance_unit measures
/// in).
struct LensResponse {
  double hfov_deg = kCalibratedHfovDeg;
  double kappa = 1.0;
  double unit = 1.0;
};

/// The response at `hfov_deg` (in (0, 180); std::invalid_argument otherwise): interpolated
/// log-log between the lenses measured on the calibration worlds (45°, 50°, 58°, 75°, 90°),
/// and the nearer end's outside them.
LensResponse LensResponseAt(double hfov_deg);

/// Whether recognition was measured with lenses of `hfov_deg`: 45° to 100°.
bool WithinMeasuredLenses(double hfov_deg);

/// The horizontal field of view of `camera`, degrees (to a millionth).
double HorizontalFovDeg(const CameraIntrinsics& camera);

/// `options`, configured for the calibrated lens, for a camera of `hfov_deg` that takes
/// `views_per_base_point` views: a forward camera (one view) has τ_κ and a fixed
/// memory.distance_unit scaled by LensResponseAt. A pan sweep keeps its preset: its surface is
/// filled by the sweep, not by one lens, and its units were calibrated as such.
void AdaptToLens(PipelineOptions& options, double hfov_deg, int views_per_base_point);

/// What AdaptToLens made of τ_κ and distance_unit, for a log line; nothing when it changed
/// neither (a pan sweep, the calibrated 58° lens).
std::optional<std::string> LensNote(const PipelineOptions& adapted, double hfov_deg,
                                    int views_per_base_point);

/// A caution for a forward camera whose lens lies outside the measured ones (recognition there
/// is unmeasured, and below 45° known to be poor). Nothing otherwise.
std::optional<std::string> LensCaution(double hfov_deg, int views_per_base_point);

}  // namespace tsc
