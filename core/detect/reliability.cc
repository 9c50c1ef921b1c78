#include "core/detect/reliability.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/bubble/descriptor.h"

namespace tsc {
namespace {

void CheckRange(const char* name, double value, double lo, double hi) {
  if (!(std::isfinite(value) && value >= lo && value <= hi)) {
    throw std::invalid_argument(std::string(name) + " must be in [" + std::to_string(lo) + ", " +
                                std::to_string(hi) + "], got " + std::to_string(value));
  }
}

}  // namespace

void ReliabilityOptions::Validate() const {
  CheckRange("detection.tau_mu", tau_mu, 0.0, 1.0);
  CheckRange("detection.tau_sigma", tau_sigma, 0.0, 0.25);  // variance of values in [0,1]
  CheckRange("detection.tau_kappa", tau_kappa, 0.0, 1.0);   // χ² of normalised descriptors
}

const char* SweepCoherenceName(SweepCoherence s) {
  return s == SweepCoherence::kEveryView ? "every_view" : "first_view";
}

SweepCoherence ParseSweepCoherence(const std::string& name) {
  if (name == "first_view") return SweepCoherence::kFirstView;
  if (name == "every_view") return SweepCoherence::kEveryView;
  throw std::invalid_argument("'" + name + "' is not one of first_view | every_view");
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

double Incoherency(std::span<const Eigen::VectorXf> now, std::span<const Eigen::VectorXf> before) {
  if (now.empty() || before.empty()) throw std::invalid_argument("incoherency of no views");
  const size_t views = now.size() == before.size() ? now.size() : 1;
  double sum = 0.0;
  for (size_t j = 0; j < views; ++j) sum += ChiSquared(now[j], before[j]);
  return sum / static_cast<double>(views);
}

BaseStatus ClassifyBasePoint(const ReliabilityOptions& options, const IntensityStats& intensity,
                             std::optional<double> kappa) {
  // ς (appendix C): too dark or too flat to say anything about the place.
  if (intensity.mean <= options.tau_mu || intensity.variance <= options.tau_sigma) {
    return BaseStatus::kUninformative;
  }
  // κ: the view changed too much since the previous base point.
  if (kappa && *kappa > options.tau_kappa) return BaseStatus::kIncoherent;
  return BaseStatus::kGood;
}

BaseStatus ClassifyBasePoint(const ReliabilityOptions& options, const IntensityStats& intensity,
                             const Eigen::VectorXf& descriptor,
                             const Eigen::VectorXf* previous_descriptor) {
  std::optional<double> kappa;
  if (previous_descriptor != nullptr) kappa = ChiSquared(descriptor, *previous_descriptor);
  return ClassifyBasePoint(options, intensity, kappa);
}

}  // namespace tsc
