#include "drivers/dataset/base_point_spacing.h"

#include <cstdio>

namespace tsc {

BasePointSpacing ResolveSpacing(double configured, const BasePointSpacing* declared, double fps) {
  if (configured > 0.0) return {configured, "camera.spacing_m"};
  if (declared != nullptr) return *declared;
  const double rate = fps > 0.0 ? fps : 10.0;
  char basis[64];
  std::snprintf(basis, sizeof basis, "%g fps at %g m/s", rate, kAssumedSpeedMps);
  return {kAssumedSpeedMps / rate, basis};
}

std::optional<std::string> SpacingCaution(const BasePointSpacing& spacing) {
  // Half again the calibrated step is still near it; 0.3 m (twice it) already loses precision.
  if (spacing.keyframes || spacing.metres <= kCalibratedSpacingM * 1.5) return std::nullopt;
  char text[320];
  std::snprintf(text, sizeof text,
                "base points %.3g m apart: the defaults were calibrated at %.3g m, and cameras "
                "whose base points lie 0.3 m apart or more make wrong recognitions on simulated "
                "routes (docs/calibration.md, twentieth pass); a faster frame rate is safer",
                spacing.metres, kCalibratedSpacingM);
  return std::string(text);
}

}  // namespace tsc
