#pragma once
// Sensory data reliability (thesis appendix C): informativeness ς and coherency κ of a base
// point.

#include <Eigen/Core>
#include <optional>
#include <span>
#include <string>

#include "core/bubble/surface.h"

namespace tsc {

/// What κ of a base point observed by a pan sweep is judged on (docs/decisions.md, "Pan
/// sweeps"): the sweep's first view, as a forward camera's; or every view, each against the
/// same view of the previous sweep, κ being the mean of their χ².
enum class SweepCoherence { kFirstView, kEveryView };
const char* SweepCoherenceName(SweepCoherence s);
/// "first_view" or "every_view"; throws std::invalid_argument naming the choices otherwise.
SweepCoherence ParseSweepCoherence(const std::string& name);

struct ReliabilityOptions {
  double tau_mu = 0.08;      ///< τ_μ: mean intensity at or below → uninformative, [0,1]
  double tau_sigma = 0.002;  ///< τ_σ: intensity variance at or below → uninformative, [0,0.25]
  double tau_kappa = 0.02;   ///< τ_κ: χ² to the previous descriptor above → incoherent, [0,1]
  SweepCoherence sweep_coherence = SweepCoherence::kFirstView;
  void Validate() const;
};

/// Why a base point is or is not usable.
enum class BaseStatus { kGood = 0, kUninformative = 1, kIncoherent = 2 };
const char* BaseStatusName(BaseStatus s);

/// Mean and variance of the intensity surface over the directions observed so far.
struct IntensityStats {
  double mean = 0.0;
  double variance = 0.0;
};
/// Throws std::invalid_argument if the surface has no intensity feature.
IntensityStats IntensityStatistics(const BubbleSurface& surface);

/// κ between two base points judged on several views each: the mean over views j of
/// χ²(now_j, before_j). When the view counts differ (another camera), the first views alone.
/// Throws std::invalid_argument on no views or views of different dimensions.
double Incoherency(std::span<const Eigen::VectorXf> now, std::span<const Eigen::VectorXf> before);

/// ς (informativeness) first, then κ (coherency) when there is a previous base point to judge
/// it against (`kappa` empty for the first one).
BaseStatus ClassifyBasePoint(const ReliabilityOptions& options, const IntensityStats& intensity,
                             std::optional<double> kappa);
/// The same with κ the χ² between the descriptor and the previous base point's, if any.
BaseStatus ClassifyBasePoint(const ReliabilityOptions& options, const IntensityStats& intensity,
                             const Eigen::VectorXf& descriptor,
                             const Eigen::VectorXf* previous_descriptor);

}  // namespace tsc
