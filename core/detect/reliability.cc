#include "core/detect/reliability.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/bubble/descriptor.h"

namespace tsc {
void ReliabilityOptions::Validate() const {
  kTauMuRange.Check("detection.tau_mu", tau_mu);
  kTauSigmaRange.Check("detection.tau_sigma", tau_sigma);
  kTauKappaRange.Check("detection.tau_kappa", tau_kappa);
}

const char* BaseStatusName(BaseStatus s) {
  switch (s) {
    case BaseStatus::kGood:
      return "good";
    case BaseStatus::kUninformative:
      return "uninformative";
    case BaseStatus::kIncoherent:
      return "incoherent";
  }
  return "unknown";
}

IntensityStats IntensityStatistics(const BubbleSurface& surface) {
  const int block = surface.features().IndexOf(Feature::kIntensity);
  if (block < 0) {
    throw std::invalid_argument("feature set " + surface.features().ToString() +
                                " has no intensity feature");
  }
  // Over the observed directions only (docs/decisions.md): unobserved ones hold ρ_0.
  const Eigen::MatrixXf& rho = surface.radius(block);
  const auto& observed = surface.observed();
  double sum = 0.0, sum2 = 0.0;
  long count = 0;
  for (Eigen::Index k = 0; k < rho.size(); ++k) {
    if (!observed(k)) continue;
    const double q = rho(k);
    sum += q;
    sum2 += q * q;
    ++count;
  }
  IntensityStats stats;
  if (count == 0) return stats;
  stats.mean = sum / static_cast<double>(count);
  stats.variance = std::max(0.0, sum2 / static_cast<double>(count) - stats.mean * stats.mean);
  return stats;
}

BaseStatus ClassifyBasePoint(const ReliabilityOptions& options, const IntensityStats& intensity,
                             const Eigen::VectorXf& descriptor,
                             const Eigen::VectorXf* previous_descriptor) {
  // ς (appendix C): too dark or too flat to say anything about the place.
  if (intensity.mean <= options.tau_mu || intensity.variance <= options.tau_sigma) {
    return BaseStatus::kUninformative;
  }
  // κ: the view changed too much since the previous base point.
  if (previous_descriptor != nullptr &&
      ChiSquared(descriptor, *previous_descriptor) > options.tau_kappa) {
    return BaseStatus::kIncoherent;
  }
  return BaseStatus::kGood;
}

}  // namespace tsc
