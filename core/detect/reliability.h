#pragma once
// Sensory data reliability (thesis appendix C): informativeness ς and coherency κ of a base
// point.

#include <Eigen/Core>
#include <optional>

#include "core/bubble/surface.h"
#include "core/range.h"

namespace tsc {

struct ReliabilityOptions {
  double tau_mu = 0.08;      ///< τ_μ: mean intensity at or below → uninformative, [0,1]
  double tau_sigma = 0.002;  ///< τ_σ: intensity variance at or below → uninformative, [0,0.25]
  double tau_kappa = 0.02;   ///< τ_κ: χ² to the previous descriptor above → incoherent, [0,1]
  // Valid ranges (also the configuration's, detection.*).
  static constexpr Range kTauMuRange{0, 1};
  static constexpr Range kTauSigmaRange{0, 0.25};  ///< variance of values in [0, 1]
  static constexpr Range kTauKappaRange{0, 1};     ///< χ² of normalised descriptors
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

/// ς (informativeness) first, then κ (coherency, against the previous base point's descriptor
/// when there is one).
BaseStatus ClassifyBasePoint(const ReliabilityOptions& options, const IntensityStats& intensity,
                             const Eigen::VectorXf& descriptor,
                             const Eigen::VectorXf* previous_descriptor);

}  // namespace tsc
