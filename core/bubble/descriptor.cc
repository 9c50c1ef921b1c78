#include "core/bubble/descriptor.h"

#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <string>

namespace tsc {

Descriptor::Descriptor(Eigen::VectorXf values) : values_(std::move(values)) {
  for (Eigen::Index k = 0; k < values_.size(); ++k) {
    if (!std::isfinite(values_[k]) || values_[k] < 0.0f) {
      throw std::invalid_argument("descriptor entry " + std::to_string(k) +
                                  " must be finite and >= 0, got " + std::to_string(values_[k]));
    }
  }
}

double ChiSquared(const Eigen::VectorXf& a, const Eigen::VectorXf& b) {
  if (a.size() != b.size()) {
    throw std::invalid_argument("chi-squared of descriptors of dimensions " +
                                std::to_string(a.size()) + " and " + std::to_string(b.size()));
  }
  double sum = 0.0;
  for (Eigen::Index k = 0; k < a.size(); ++k) {
    const double s = static_cast<double>(a[k]) + b[k];
    if (s > 0.0) {
      const double d = static_cast<double>(a[k]) - b[k];
      sum += d * d / s;
    }
  }
  return 0.5 * sum;
}

void DescriptorOptions::Validate() const {
  kHarmonicsRange.Check("descriptor.harmonics_pan (H1)", h1);
  kHarmonicsRange.Check("descriptor.harmonics_tilt (H2)", h2);
}

void DescriptorOptions::CheckGrid(const ViewingGrid& grid) const {
  const auto degrees = [&grid] {
    char text[32];
    std::snprintf(text, sizeof text, "%g", grid.d_phi_rad() * 180.0 / std::numbers::pi);
    return std::string(text);
  };
  if (2 * h1 >= grid.n_pan()) {
    throw std::invalid_argument("descriptor.harmonics_pan (H1) = " + std::to_string(h1) +
                                " needs more than " + std::to_string(2 * h1) +
                                " pan steps; bubble.d_phi_deg = " + degrees() + " gives " +
                                std::to_string(grid.n_pan()));
  }
  if (h2 >= grid.n_tilt()) {
    throw std::invalid_argument("descriptor.harmonics_tilt (H2) = " + std::to_string(h2) +
                                " needs more than " + std::to_string(h2) +
                                " tilt steps; bubble.d_phi_deg = " + degrees() + " gives " +
                                std::to_string(grid.n_tilt()));
  }
}

DescriptorComputer::DescriptorComputer(const ViewingGrid& grid, DescriptorOptions options)
    : grid_(grid), options_(options) {
  options_.Validate();
  options_.CheckGrid(grid_);
  const int n_pan = grid_.n_pan(), n_tilt = grid_.n_tilt();
  cos1_.resize(options_.h1 + 1, n_pan);
  sin1_.resize(options_.h1 + 1, n_pan);
  for (int i = 0; i < n_pan; ++i) {
    for (int h = 0; h <= options_.h1; ++h) {
      // Reduce h·i modulo the period first, so the table of every pan shift holds exactly
      // the same values: a shift by whole steps is then an exact symmetry of the quadrature.
      const double angle = 2.0 * std::numbers::pi * ((h * i) % n_pan) / n_pan;
      cos1_(h, i) = static_cast<float>(std::cos(angle));  // float-rounded, as ever
      sin1_(h, i) = static_cast<float>(std::sin(angle));
    }
  }
  // I_{00} of ρ ≡ 1 on the whole sphere: z_00 = (1/π²)·Σ d_phi² = 2 (the grid covers 2π × π).
  const double full_dc = 2.0;
  full_sphere_dc_ = options_.amplitude ? full_dc : full_dc * full_dc;
  cos2_.resize(options_.h2 + 1, n_tilt);
  sin2_.resize(options_.h2 + 1, n_tilt);
  for (int j = 0; j < n_tilt; ++j) {
    for (int h = 0; h <= options_.h2; ++h) {
      cos2_(h, j) = static_cast<float>(std::cos(h * grid_.f2(j)));
      sin2_(h, j) = static_cast<float>(std::sin(h * grid_.f2(j)));
    }
  }
}

Eigen::VectorXf DescriptorComputer::RawBlock(const BubbleSurface& surface,
                                             int feature_block) const {
  if (surface.grid().n_pan() != grid_.n_pan() || surface.grid().n_tilt() != grid_.n_tilt()) {
    throw std::invalid_argument(
        "surface grid " + std::to_string(surface.grid().n_tilt()) + "x" +
        std::to_string(surface.grid().n_pan()) + " does not match the descriptor grid " +
        std::to_string(grid_.n_tilt()) + "x" + std::to_string(grid_.n_pan()));
  }
  if (feature_block < 0 || feature_block >= surface.features().size()) {
    throw std::invalid_argument("feature block " + std::to_string(feature_block) + " outside [0, " +
                                std::to_string(surface.features().size()) + ")");
  }
  const Eigen::MatrixXf& rho = surface.radius(feature_block);
  const int n_pan = grid_.n_pan(), n_tilt = grid_.n_tilt();
  const int n1 = options_.h1 + 1, n2 = options_.h2 + 1;

  // (A.4) by quadrature, separable. Stage 1: for every tilt row j, the pan sums
  //   c(j, h1) = Σ_i ρ(j, i) cos(h1 f1_i),  s(j, h1) = Σ_i ρ(j, i) sin(h1 f1_i).
  // ρ is column-major (one pan column is contiguous in tilt), so walk it column by column.
  // Cells with ρ = 0 (every unobserved one when ρ_0 = 0) add nothing and are skipped, and
  // so are columns no view reached and rows that end up empty. Accumulation in double keeps the
  // pan-shift symmetry exact to ~1e-7.
  Eigen::MatrixXd c = Eigen::MatrixXd::Zero(n1, n_tilt);
  Eigen::MatrixXd s = Eigen::MatrixXd::Zero(n1, n_tilt);
  std::vector<uint8_t> row_used(static_cast<size_t>(n_tilt), 0);
  for (int i = 0; i < n_pan; ++i) {
    // Typical: outside every view. (A column of rho_0 = 0 adds nothing.)
    if (!surface.ColumnObserved(i) && surface.rest_radius() == 0.0f) continue;
    const float* column = rho.col(i).data();
    for (int j = 0; j < n_tilt; ++j) {
      const double r = column[j];
      if (r == 0.0) continue;
      row_used[j] = 1;
      // Element by element (products, then sums; no fused multiply-add on the baseline): the
      // same doubles as a scalar loop, on whole vectors.
      c.col(j).noalias() += r * cos1_.col(i);
      s.col(j).noalias() += r * sin1_.col(i);
    }
  }
  // Stage 2: the tilt sums, giving the four components of z_{h1h2} (A.4):
  //   [Σ_j c cos(h2 f2_j), Σ_j s cos(h2 f2_j), Σ_j c sin(h2 f2_j), Σ_j s sin(h2 f2_j)].
  Eigen::MatrixXd cc = Eigen::MatrixXd::Zero(n2, n1), sc = cc, cs = cc, ss = cc;  // (h2, h1)
  for (int j = 0; j < n_tilt; ++j) {
    if (!row_used[j]) continue;
    const auto cos_j = cos2_.col(j);
    const auto sin_j = sin2_.col(j);
    for (int h1 = 0; h1 < n1; ++h1) {
      const double cj = c(h1, j), sj = s(h1, j);
      cc.col(h1).noalias() += cj * cos_j;
      sc.col(h1).noalias() += sj * cos_j;
      cs.col(h1).noalias() += cj * sin_j;
      ss.col(h1).noalias() += sj * sin_j;
    }
  }
  // Quadrature weight d_phi² per cell and the factor 1/π² of (A.4).
  const double d_phi = grid_.d_phi_rad();
  const double scale = d_phi * d_phi / (std::numbers::pi * std::numbers::pi);
  // (A.7) I = zᵀz. A pan shift by α rotates the pairs (z1, z2) and (z3, z4) by h1·α, so zᵀz
  // does not change: the heading invariance. The λ_{h1h2} of (A.5) only weight the
  // reconstruction of ρ from z; they are not part of z (A.4) and do not enter I. (A constant
  // factor per (h1, h2) would in any case cancel in the ratio of the invariance check.)
  Eigen::VectorXf out(n1 * n2);
  for (int h1 = 0; h1 < n1; ++h1) {
    for (int h2 = 0; h2 < n2; ++h2) {
      const double energy = cc(h2, h1) * cc(h2, h1) + sc(h2, h1) * sc(h2, h1) +
                            cs(h2, h1) * cs(h2, h1) + ss(h2, h1) * ss(h2, h1);
      out[h1 * n2 + h2] = static_cast<float>(scale * scale * energy);  // (A.6): h1 major
    }
  }
  return out;
}

Descriptor DescriptorComputer::Compute(const BubbleSurface& surface) const {
  const int nv = surface.features().size();
  const int b = block_size();
  Eigen::VectorXf values(nv * b);
  for (int i = 0; i < nv; ++i) {
    Eigen::VectorXd block = RawBlock(surface, i).cast<double>();
    if (options_.amplitude) block = block.cwiseSqrt();
    // Normalisation (docs/decisions.md): each feature block sums to 1/N_v, so the whole
    // descriptor sums to 1 and χ² lies in [0, 1]; a block that saw nothing stays zero.
    if (options_.block_sum) {
      const double sum = block.sum();
      if (sum > 0.0) block *= 1.0 / (nv * sum);
    } else {
      block *= 1.0 / (nv * full_sphere_dc_);
    }
    values.segment(i * b, b) = block.cast<float>();
  }
  return Descriptor(std::move(values));
}

}  // namespace tsc
