#pragma once
// The space member views are kept and measured in (docs/decisions.md "A principal basis for
// member views"). A place keeps up to 32 views; in the descriptor's own 1200 dimensions that
// is ~154 KB a place, 1.5 GB at 10⁴ places, and the view products of one recognition alone
// take ~1 ms. A fixed orthonormal basis fitted once, offline, on the base points of simulated
// calibration worlds keeps nearly all of the descriptors' variance in 128 dimensions; views
// kept as their coordinates there cost ~9x less memory and arithmetic, and distances between
// them are the descriptor distances less what lies outside the basis. Every robot of a team
// must measure in the same basis: its `id` travels with the memory (daemon/exchange).

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "core/memory/simd.h"

namespace tsc {

class ViewBasis {
 public:
  /// `axes`: k x dim, orthonormal rows (1 ≤ k ≤ dim); `name` says which basis it is in the
  /// configuration ("builtin"). Throws std::invalid_argument when the rows are not
  /// orthonormal to 1e-3 or not finite. `simd`: the instructions Coordinates runs on (the
  /// same coordinates up to rounding).
  ViewBasis(Eigen::MatrixXf axes, std::string name, Simd simd = FastestSimd());

  /// Dimension of the descriptors it takes.
  int input_dimension() const { return static_cast<int>(axes_.cols()); }
  /// Dimension of the coordinates it gives (the dimension of member views).
  int dimension() const { return static_cast<int>(axes_.rows()); }
  const std::string& name() const { return name_; }
  /// Identifies the axes' contents (a 64-bit hash of their bits): two robots whose views
  /// carry the same id measure in the same space.
  uint64_t id() const { return id_; }
  const Eigen::MatrixXf& axes() const { return axes_; }
  /// The largest ‖axes·x‖ / ‖x‖ (1 for exactly orthonormal axes, within 1e-3 of it for any
  /// accepted basis): a squared distance between coordinates divided by its square is at most
  /// the squared distance between the descriptors.
  double max_gain() const { return max_gain_; }
  /// Coordinates(x) lies within coordinate_error()·‖x‖ of axes·x: each coordinate is a float
  /// sum of input_dimension() products whose terms go through at most h roundings, so it is
  /// off by at most γ_h·‖axis‖·‖x‖ (γ_h = h·u / (1 − h·u), u = 2⁻²⁴).
  double coordinate_error() const { return coordinate_error_; }
  /// A distance no larger than ‖x − y‖ (and than its float computation) from `apart`, the
  /// distance between coordinates that stand for x and y up to `error` together (e.g.
  /// coordinate_error()·(‖x‖ + ‖y‖)): an orthonormal projection only shortens, by at most
  /// max_gain(). 1e-4 of `apart` is given up to the rounding of distances summed in float
  /// (`apart` itself, or the full distance the bound is compared with).
  double DistanceBelow(double apart, double error) const {
    return std::max(0.0, apart * (1.0 - 1e-4) - error) / max_gain_;
  }

  /// The coordinates of descriptors (input_dimension() x n) in the basis: dimension() x n.
  /// Linear, so the coordinates of a mean are the mean of the coordinates. Each column's
  /// coordinates depend on that column alone, not on the others given with it: a place's
  /// mean gets the same bits whether it is taken alone (Learn) or with the whole memory
  /// (Restore).
  Eigen::MatrixXf Coordinates(const Eigen::MatrixXf& descriptors) const;

 private:
  Eigen::MatrixXf axes_;
  Eigen::MatrixXf axes_t_;  // axes_ transposed: each axis one contiguous column (the kernel's)
  Simd simd_;
  std::string name_;
  uint64_t id_;
  double max_gain_ = 1.0;
  double coordinate_error_ = 0.0;
};

/// The principal axes of `descriptors` (dim x n, n ≥ 2): the `k` unit eigenvectors of their
/// covariance with the largest eigenvalues, in decreasing order, each signed so that its
/// largest component is positive (the same axes on every machine). `retained` (optional)
/// receives the share of the variance they hold. Precondition: 1 ≤ k ≤ dim.
Eigen::MatrixXf PrincipalAxes(const Eigen::MatrixXf& descriptors, int k,
                              double* retained = nullptr);

/// The file form of a basis: "TSCVBAS1", k and dim as little-endian uint32, then the axes as
/// little-endian float32, row by row. ParseViewBasis throws std::invalid_argument on anything
/// else (wrong magic, sizes that disagree with the length, more than 4096 x 65536 values).
std::vector<uint8_t> ViewBasisBytes(const Eigen::MatrixXf& axes);
ViewBasis ParseViewBasis(std::span<const uint8_t> bytes, std::string name);

/// The basis views are kept in when `basis` is set, else the descriptors themselves (null).
/// These helpers let callers treat "no basis" as the identity.
Eigen::MatrixXf ViewCoordinates(const ViewBasis* basis, const Eigen::MatrixXf& descriptors);
int ViewDimension(const ViewBasis* basis, int descriptor_dimension);

}  // namespace tsc
