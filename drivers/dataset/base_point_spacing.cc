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

}  // namespace tsc
