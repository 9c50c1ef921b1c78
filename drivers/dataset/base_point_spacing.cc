#include "drivers/dataset/base_point_spacing.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include "core/pipeline/pipeline.h"

namespace tsc {
namespace {

std::string Metres(double m) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", m);
  return text;
}

}  // namespace

BasePointSpacing ResolveSpacing(double configured, const BasePointSpacing* declared, double fps) {
  if (configured > 0.0) return {configured, "camera.spacing_m"};
  if (declared != nullptr) return *declared;
  const double rate = fps > 0.0 ? fps : 10.0;
  char basis[64];
  std::snprintf(basis, sizeof basis, "%g fps at %g m/s", rate, kAssumedSpeedMps);
  return {kAssumedSpeedMps / rate, basis};
}

bool IsSparse(const BasePointSpacing& spacing) {
  // Half again the calibrated step is still near it; 0.3 m (twice it) is not.
  return !spacing.keyframes && spacing.metres > kCalibratedSpacingM * 1.5;
}

int StrideFor(const BasePointSpacing& frames) {
  if (frames.keyframes || !(frames.metres > 0.0)) return 1;
  // A spacing within 2 % of dividing the calibrated one (0.05, 0.075) takes its quotient, so
  // that a measured spacing's noise does not choose the stride: a Jaguar teleoperated at 0.5
  // m/s with a 10 fps camera measured 0.0496 m in one run and 0.0501 m in the next, one base
  // point in 3 and in 2 without it. The base points then lie up to 2 % beyond 0.15 m.
  const double quotient = kCalibratedSpacingM / frames.metres;
  double stride = std::clamp(std::floor(quotient * (1.0 + kQuotientTolerance)), 1.0, 1e6);
  if (stride * frames.metres < kClosestSpacingM * (1.0 - 1e-9)) stride += 1.0;
  return static_cast<int>(stride);
}

BasePointSpacing EveryNth(const BasePointSpacing& frames, int stride) {
  if (stride < 1) throw std::invalid_argument("base point stride " + std::to_string(stride));
  if (stride == 1) return frames;
  BasePointSpacing out = frames;
  out.metres = frames.metres * stride;
  out.basis = frames.basis + ", frames " + Metres(frames.metres) + " m apart; one in " +
              std::to_string(stride) + " taken";
  return out;
}

BasePoints BasePointsOf(const BasePointSpacing& frames) {
  const int stride = StrideFor(frames);
  return {stride, EveryNth(frames, stride)};
}

void AdaptToSpacing(PipelineOptions& options, const BasePointSpacing& spacing) {
  options.detector.spacing_m = spacing.metres;
  if (!IsSparse(spacing)) return;
  options.detector.tau_w = std::max(1, options.detector.tau_w / 2);
  options.memory.step_unit /= 2.0;
}

std::optional<std::string> SparseCameraNote(const PipelineOptions& adapted,
                                            const BasePointSpacing& spacing) {
  if (!IsSparse(spacing)) return std::nullopt;
  char text[200];
  std::snprintf(text, sizeof text,
                "detection.tau_w %d and memory.step_unit %g, the configured "
                "values halved (they hold for base points %.3g m apart; tau_w at least 1)",
                adapted.detector.tau_w, adapted.memory.step_unit, kCalibratedSpacingM);
  return std::string(text);
}

std::optional<std::string> SpacingCaution(const BasePointSpacing& spacing) {
  if (!IsSparse(spacing)) return std::nullopt;
  char text[320];
  std::snprintf(text, sizeof text,
                "base points %.3g m apart: the defaults were calibrated at %.3g m, and with "
                "base points 0.3-0.6 m apart a few recognitions on simulated routes are wrong "
                "(docs/calibration.md, twenty-first pass); a faster frame rate is safer",
                spacing.metres, kCalibratedSpacingM);
  return std::string(text);
}

}  // namespace tsc
