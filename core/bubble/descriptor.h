#pragma once
// Bubble descriptors I(x, t) (A.3-A.7): rotation (heading) invariant holistic vectors.

#include <Eigen/Core>
#include <array>
#include <vector>

#include "core/bubble/surface.h"
#include "core/range.h"

namespace tsc {

/// A bubble descriptor on the normalised scale every threshold uses: finite, non-negative,
/// N_v blocks of (H1+1)(H2+1) values, each block summing to 1/N_v (or all zero when the
/// feature saw nothing), so the whole vector sums to at most 1.
class Descriptor {
 public:
  Descriptor() = default;
  /// Throws std::invalid_argument if any value is negative or not finite.
  explicit Descriptor(Eigen::VectorXf values);
  const Eigen::VectorXf& values() const { return values_; }
  int dim() const { return static_cast<int>(values_.size()); }
  bool empty() const { return values_.size() == 0; }

 private:
  Eigen::VectorXf values_;
};

/// χ² distance ½ Σ (a−b)²/(a+b) over entries where a+b > 0 (appendix C).
double ChiSquared(const Eigen::VectorXf& a, const Eigen::VectorXf& b);

struct DescriptorOptions {
  int h1 = 9;  ///< harmonics in pan
  int h2 = 9;  ///< harmonics in tilt
  /// true: entries are sqrt(z^T z) (amplitude); false: z^T z as in (A.7) (energy).
  /// Normalisation per block follows either way. See docs/decisions.md.
  bool amplitude = true;
  /// true: each feature block scaled to sum 1/N_v (drops each feature's absolute level);
  /// false: a fixed scale, the (0,0) entry of a unit sphere, over N_v, so the level of a
  /// feature (a room's colour) stays in the descriptor. See docs/decisions.md.
  bool block_sum = true;
  /// Valid range of h1 and h2 (also the configuration's, descriptor.harmonics_*).
  static constexpr Range kHarmonicsRange{0, 64};
  void Validate() const;
  /// Throws std::invalid_argument, naming the keys, unless `grid` resolves h1 and h2 (beyond
  /// 2·h1 ≥ n_pan or h2 ≥ n_tilt the grid aliases the harmonics).
  void CheckGrid(const ViewingGrid& grid) const;
};

/// Computes descriptors from bubble surfaces by quadrature of (A.4) over the viewing grid.
/// Tables of the trigonometric basis are built once per grid.
class DescriptorComputer {
 public:
  DescriptorComputer(const ViewingGrid& grid, DescriptorOptions options = {});
  int block_size() const { return (options_.h1 + 1) * (options_.h2 + 1); }
  /// Normalised descriptor of dimension N_v·(H1+1)(H2+1).
  Descriptor Compute(const BubbleSurface& surface) const;
  /// Raw I_{i,h1h2} = z^T z of one feature block (A.7), before any normalisation.
  Eigen::VectorXf RawBlock(const BubbleSurface& surface, int feature_block) const;

 private:
  ViewingGrid grid_;
  DescriptorOptions options_;
  // The quadrature's trigonometric tables, float-rounded values held as doubles so the sums
  // (in double) run on whole vectors without a conversion per term.
  Eigen::MatrixXd cos1_, sin1_;  // (H1+1) x n_pan
  Eigen::MatrixXd cos2_, sin2_;  // (H2+1) x n_tilt
  double full_sphere_dc_ = 1.0;  // I_00 of a unit sphere, the fixed scale without block_sum
};

}  // namespace tsc
