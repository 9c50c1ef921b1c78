#include "core/memory/view_basis.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <utility>

#include "core/split_mix64.h"

namespace tsc {

namespace {

constexpr char kMagic[8] = {'T', 'S', 'C', 'V', 'B', 'A', 'S', '1'};
constexpr size_t kHeaderBytes = sizeof(kMagic) + 8;

uint64_t HashOf(const Eigen::MatrixXf& axes) {
  uint64_t h =
      SplitMix64((static_cast<uint64_t>(axes.rows()) << 32) | static_cast<uint64_t>(axes.cols()));
  for (Eigen::Index i = 0; i < axes.size(); ++i) {
    h = SplitMix64(h ^ std::bit_cast<uint32_t>(axes.data()[i]));
  }
  return h;
}

void PutU32(std::vector<uint8_t>& out, uint32_t v) {
  for (int b = 0; b < 4; ++b) out.push_back(static_cast<uint8_t>(v >> (8 * b)));
}

uint32_t GetU32(const uint8_t* p) {
  return uint32_t{p[0]} | uint32_t{p[1]} << 8 | uint32_t{p[2]} << 16 | uint32_t{p[3]} << 24;
}

}  // namespace

ViewBasis::ViewBasis(Eigen::MatrixXf axes, std::string name, Simd simd)
    : axes_(std::move(axes)), simd_(simd), name_(std::move(name)), id_(HashOf(axes_)) {
  if (axes_.rows() < 1 || axes_.rows() > axes_.cols()) {
    throw std::invalid_argument("view basis " + name_ + ": " + std::to_string(axes_.rows()) +
                                " axes in " + std::to_string(axes_.cols()) + " dimensions");
  }
  // Distances in the basis stand for distances between descriptors only when the axes are
  // orthonormal; a corrupted or mis-built basis would silently shrink or skew them.
  if (!axes_.allFinite()) throw std::invalid_argument("view basis " + name_ + ": axes not finite");
  const Eigen::MatrixXd gram = (axes_.cast<double>() * axes_.cast<double>().transpose());
  const double off =
      (gram - Eigen::MatrixXd::Identity(gram.rows(), gram.cols())).cwiseAbs().maxCoeff();
  if (!(off <= 1e-3)) {
    throw std::invalid_argument("view basis " + name_ + ": axes not orthonormal (off by " +
                                std::to_string(off) + ")");
  }
  max_gain_ = std::sqrt(
      std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(gram, Eigen::EigenvaluesOnly)
                        .eigenvalues()
                        .maxCoeff()));
  // Each coordinate's products go through at most `depth` float roundings: the AVX2 kernel
  // sums 8 lanes of ⌈dim/8⌉ fused products, then the lanes; any other order, through dim.
  const Eigen::Index depth = simd_ == Simd::kAvx2Fma ? (axes_.cols() + 7) / 8 + 7 : axes_.cols();
  const double nu = static_cast<double>(depth) * 0x1p-24;
  coordinate_error_ =
      std::sqrt(static_cast<double>(axes_.rows()) * gram.diagonal().maxCoeff()) * nu / (1.0 - nu);
  if (simd_ == Simd::kAvx2Fma) axes_t_ = axes_.transpose();
}

Eigen::MatrixXf ViewBasis::Coordinates(const Eigen::MatrixXf& descriptors) const {
  if (descriptors.rows() != axes_.cols()) {
    throw std::invalid_argument("view basis " + name_ + " takes descriptors of dimension " +
                                std::to_string(axes_.cols()) + ", given " +
                                std::to_string(descriptors.rows()));
  }
  const Eigen::Index n = descriptors.cols();
  Eigen::MatrixXf out(axes_.rows(), n);
  if (n == 0) return out;
  // One product per column, each summed over the dimensions in one order: a matrix product
  // would block its sums by the number of columns. Restore takes a whole memory's means at
  // once (one product per place was a third of a 10⁴ + 10⁴ merge).
  if (simd_ == Simd::kAvx2Fma) {
    avx2::ColumnDots(axes_t_.data(), static_cast<int>(axes_t_.cols()), descriptors.data(),
                     static_cast<int>(n), static_cast<int>(axes_t_.rows()), out.data(), nullptr);
  } else {
    for (Eigen::Index j = 0; j < n; ++j) out.col(j).noalias() = axes_ * descriptors.col(j);
  }
  return out;
}

Eigen::MatrixXf PrincipalAxes(const Eigen::MatrixXf& descriptors, int k, double* retained) {
  const Eigen::Index dim = descriptors.rows(), n = descriptors.cols();
  if (n < 2 || k < 1 || k > dim) {
    throw std::invalid_argument("principal axes: " + std::to_string(k) + " axes of " +
                                std::to_string(n) + " descriptors in " + std::to_string(dim) +
                                " dimensions");
  }
  const Eigen::MatrixXd x = descriptors.cast<double>();
  const Eigen::MatrixXd centred = x.colwise() - x.rowwise().mean();
  const Eigen::MatrixXd covariance = centred * centred.transpose() / static_cast<double>(n - 1);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(covariance);
  if (solver.info() != Eigen::Success) throw std::runtime_error("principal axes: no eigenvectors");
  // Eigen sorts the eigenvalues in increasing order: the last k columns, reversed.
  Eigen::MatrixXf axes(k, dim);
  for (int i = 0; i < k; ++i) {
    Eigen::VectorXd v = solver.eigenvectors().col(dim - 1 - i);
    Eigen::Index largest = 0;
    v.cwiseAbs().maxCoeff(&largest);
    if (v(largest) < 0) v = -v;
    axes.row(i) = v.cast<float>().transpose();
  }
  if (retained) {
    const double total = solver.eigenvalues().sum();
    *retained = total > 0 ? solver.eigenvalues().tail(k).sum() / total : 1.0;
  }
  return axes;
}

std::vector<uint8_t> ViewBasisBytes(const Eigen::MatrixXf& axes) {
  std::vector<uint8_t> out(kMagic, kMagic + sizeof(kMagic));
  PutU32(out, static_cast<uint32_t>(axes.rows()));
  PutU32(out, static_cast<uint32_t>(axes.cols()));
  out.reserve(out.size() + 4 * static_cast<size_t>(axes.size()));
  for (Eigen::Index r = 0; r < axes.rows(); ++r) {
    for (Eigen::Index c = 0; c < axes.cols(); ++c) PutU32(out, std::bit_cast<uint32_t>(axes(r, c)));
  }
  return out;
}

ViewBasis ParseViewBasis(std::span<const uint8_t> bytes, std::string name) {
  if (bytes.size() < kHeaderBytes || std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0) {
    throw std::invalid_argument("view basis " + name + ": not a view basis (no TSCVBAS1 header)");
  }
  const uint32_t k = GetU32(bytes.data() + 8), dim = GetU32(bytes.data() + 12);
  // Bounded before anything is allocated: a header may claim any size.
  if (k < 1 || k > 4096 || dim < 1 || dim > 65536 ||
      bytes.size() != kHeaderBytes + 4 * size_t{k} * dim) {
    throw std::invalid_argument("view basis " + name + ": " + std::to_string(k) + " x " +
                                std::to_string(dim) + " axes do not fit its " +
                                std::to_string(bytes.size()) + " bytes");
  }
  Eigen::MatrixXf axes(k, dim);
  const uint8_t* p = bytes.data() + kHeaderBytes;
  for (uint32_t r = 0; r < k; ++r) {
    for (uint32_t c = 0; c < dim; ++c, p += 4) axes(r, c) = std::bit_cast<float>(GetU32(p));
  }
  return ViewBasis(std::move(axes), std::move(name));
}

Eigen::MatrixXf ViewCoordinates(const ViewBasis* basis, const Eigen::MatrixXf& descriptors) {
  return basis ? basis->Coordinates(descriptors) : descriptors;
}

int ViewDimension(const ViewBasis* basis, int descriptor_dimension) {
  return basis ? basis->dimension() : descriptor_dimension;
}

}  // namespace tsc
