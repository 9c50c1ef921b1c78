#pragma once
// How a forward camera's thresholds follow its lens (docs/decisions.md, "Lens"). τ_κ and
// memory.distance_unit were calibrated on simulated worlds seen through a 58° lens. A narrower
// lens observes less of the viewing sphere, so its bubble descriptors change less between
// consecutive base points and lie nearer each other; a wider one, more. Left as configured,
// a 45° camera found few place boundaries and recognised wrongly half the time (nine
// calibration worlds: boundary F1 0.53, 14 right / 17 wrong), and a 90° one recognised fewer
// places than it could. So the distance unit is scaled by how much consecutive descriptors
// differ at the camera's lens, as measured on those worlds, and τ_κ by how much their χ²
// differs, for lenses narrower than 58° only (wider ones detect as well unscaled). The
// assumed-keyframes caution, another amount of χ², follows the lens too.

#include <optional>
#include <string>

#include "drivers/dataset/camera_lens.h"

namespace tsc {

struct PipelineOptions;

/// How much a forward camera's descriptors change between consecutive base points at a lens,
/// relative to the calibrated one, in the medians measured on the calibration worlds: `chi2`
/// (what τ_κ and the assumed-keyframes caution compare) and `squared_distance` (what
/// memory.distance_unit measures in).
struct LensResponse {
  double hfov_deg = kCalibratedHfovDeg;
  double chi2 = 1.0;
  double squared_distance = 1.0;
};

/// The response at `hfov_deg` (in (0, 180); std::invalid_argument otherwise): interpolated
/// log-log between the lenses measured (45°, 50°, 58°, 75°, 90°), the nearer end's outside
/// them.
LensResponse LensResponseAt(double hfov_deg);

/// How much consecutive base points' χ² changes with `lens` against the calibrated lens: its
/// LensResponse for a forward camera, 1 for a pan sweep (whose views fill the sphere).
double ChangeResponse(const CameraLens& lens);

/// `options`, configured for the calibrated lens, for `lens`: a forward camera has a fixed
/// memory.distance_unit scaled by the squared-distance response, and, narrower than 58°, τ_κ by
/// the χ² response. A pan sweep keeps its preset: its surface is filled by the sweep, not by one
/// lens, and its units were calibrated as such.
void AdaptToLens(PipelineOptions& options, const CameraLens& lens);

/// What AdaptToLens made of τ_κ and distance_unit, for a log line; nothing when it changed
/// neither (a pan sweep, the calibrated 58° lens).
std::optional<std::string> LensNote(const PipelineOptions& adapted, const CameraLens& lens);

/// A caution for a forward camera whose lens lies outside the measured ones (recognition there
/// is unmeasured, and below 45° known to be poor). Nothing otherwise.
std::optional<std::string> LensCaution(const CameraLens& lens);

}  // namespace tsc
