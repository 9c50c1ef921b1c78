#pragma once
// Detected places on the descriptor scale for tests and benchmarks: positive, sum-normalised
// sites, as a robot's rooms are; each place its site perturbed by 20 %, each of its views by
// `view_noise` more. Deterministic: a place is the same on every visit (its noise is seeded by
// the place), its views differ between visits (seeded by place and visit).

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <memory>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

#include "core/memory/place_memory.h"
#include "core/memory/view_basis.h"

namespace tsc::testing_support {

class SyntheticPlaces {
 public:
  /// `sites` sites of dimension `dim` drawn from `seed`; `world` shifts every place's own noise
  /// (two worlds of the same sites hold different places).
  SyntheticPlaces(uint32_t seed, int dim, int sites, float view_noise, uint32_t world = 0)
      : dim_(dim), view_noise_(view_noise), world_(world) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (int s = 0; s < sites; ++s) {
      Eigen::VectorXf c(dim);
      for (int i = 0; i < dim; ++i) c[i] = u(rng);
      sites_.push_back(c / c.sum());
    }
  }
  /// Makes every descriptor lie in `basis`'s span but for `residual` of its distance from it,
  /// as real descriptors do (the builtin basis keeps 98.8-99.6 % of their energy, docs/
  /// decisions.md): these places' own noise spreads over every dimension, real ones' does not.
  void LieIn(std::shared_ptr<const ViewBasis> basis, float residual) {
    basis_ = std::move(basis);
    residual_ = residual;
  }
  /// Visit `visit` of place p: `views` base points, numbered from p · member_stride.
  DetectedPlace Visit(int p, uint32_t visit, int views, BaseIndex member_stride = 100) const {
    DetectedPlace d = Drawn(p, visit, views, member_stride);
    if (basis_ != nullptr) {
      const Eigen::MatrixXf inside =
          basis_->axes().transpose() * basis_->Coordinates(d.descriptors);
      d.descriptors = inside + residual_ * (d.descriptors - inside);
    }
    return d;
  }

 private:
  DetectedPlace Drawn(int p, uint32_t visit, int views, BaseIndex member_stride) const {
    std::mt19937 place_rng(world_ * 1000003u + static_cast<uint32_t>(p) * 7919u + 1u);
    std::mt19937 view_rng(static_cast<uint32_t>(p) * 104729u + visit);
    std::normal_distribution<float> place_noise(0.0f, 0.2f), view_noise(0.0f, view_noise_);
    Eigen::VectorXf centre = sites_[static_cast<size_t>(p) % sites_.size()];
    for (int i = 0; i < dim_; ++i) centre[i] *= std::max(0.0f, 1.0f + place_noise(place_rng));
    DetectedPlace d;
    d.index = p + 1;
    d.descriptors.resize(dim_, views);
    for (int j = 0; j < views; ++j) {
      d.members.push_back(static_cast<BaseIndex>(p) * member_stride + j);
      for (int i = 0; i < dim_; ++i)
        d.descriptors(i, j) = std::max(0.0f, centre[i] * (1.0f + view_noise(view_rng)));
    }
    return d;
  }

  int dim_;
  float view_noise_;
  uint32_t world_;
  std::vector<Eigen::VectorXf> sites_;
  std::shared_ptr<const ViewBasis> basis_;
  float residual_ = 1.0f;
};

/// Place `first + p` of `world` as robot `robot` learned it (id robot:p+1): its first
/// max_samples_per_place views kept, in `options.view_basis` when it is set.
/// `visits`: the detected places it holds, which set how many views it keeps (SampleCap).
inline LearnedPlace SyntheticLearnedPlace(uint32_t robot, const SyntheticPlaces& world, int first,
                                          int p, int views, const PlaceMemoryOptions& options,
                                          int visits = 1) {
  const DetectedPlace d = world.Visit(first + p, robot, views, views);
  LearnedPlace lp;
  lp.id = PlaceId{robot, static_cast<uint32_t>(p + 1)};
  lp.mean = d.Mean();
  lp.member_count = d.descriptors.cols();
  for (int v = 0; v < visits; ++v) lp.detected.push_back(d.index + v);
  lp.samples = CompactViews(ViewCoordinates(
      options.view_basis.get(),
      d.descriptors.leftCols(std::min<Eigen::Index>(options.SampleCap(lp), d.descriptors.cols()))));
  lp.members = d.members;
  return lp;
}

/// Robot `robot`'s memory of places [first, first + n) of `world`, each a visit of `views`
/// base points (the visit is the robot: its own member noise), ids 1..n. Built at once (SLINK
/// over the means, then one Restore that trains every node) rather than by n Learn()s.
inline PlaceMemory SyntheticMemory(uint32_t robot, const SyntheticPlaces& world, int first, int n,
                                   int views, const PlaceMemoryOptions& options = {},
                                   int visits = 1) {
  std::vector<LearnedPlace> places;
  Slink slink;
  std::vector<double> distances;
  for (int p = 0; p < n; ++p) {
    LearnedPlace lp = SyntheticLearnedPlace(robot, world, first, p, views, options, visits);
    distances.resize(places.size());
    for (size_t i = 0; i < places.size(); ++i) {
      distances[i] = (places[i].mean - lp.mean).squaredNorm();
    }
    slink.Insert(distances);
    places.push_back(std::move(lp));
  }
  return PlaceMemory::Restore(robot, options, std::move(places), std::move(slink),
                              static_cast<uint32_t>(n + 1), {});
}

/// SyntheticMemory at 10⁵ places (issue 23), where n² descriptor distances would take the
/// fixture hours: the same places with their views already in `options.view_basis` (required),
/// and the SLINK state computed over the means' coordinates in that basis, by blocks of matrix
/// products. Its tree is therefore close to, not exactly, the descriptor-space SLINK tree of
/// the same means; the operations a benchmark times run on the memory as they would on any.
/// The memory size from which the benchmarks build their fixtures with LargeSyntheticMemory.
inline constexpr int kLargeMemory = 100000;
inline PlaceMemory LargeSyntheticMemory(uint32_t robot, const SyntheticPlaces& world, int first,
                                        int n, int views, const PlaceMemoryOptions& options,
                                        int visits = 1) {
  if (options.view_basis == nullptr) throw std::invalid_argument("a view basis is needed");
  const ViewBasis& basis = *options.view_basis;
  std::vector<LearnedPlace> places;
  places.reserve(static_cast<size_t>(n));
  Eigen::MatrixXf centres(basis.dimension(), n);
  for (int p = 0; p < n; ++p) {
    LearnedPlace lp = SyntheticLearnedPlace(robot, world, first, p, views, options, visits);
    centres.col(p) = basis.Coordinates(lp.mean);
    places.push_back(std::move(lp));
  }
  const Eigen::VectorXf norms = centres.colwise().squaredNorm().transpose();
  Slink slink;
  std::vector<double> distances;
  constexpr int kBlock = 256;
  for (int s = 0; s < n; s += kBlock) {
    const int len = std::min(kBlock, n - s);
    // Column r: place s + r against places [0, s + len).
    const Eigen::MatrixXf dots = centres.leftCols(s + len).transpose() * centres.middleCols(s, len);
    for (int r = 0; r < len; ++r) {
      const int i = s + r;
      distances.resize(static_cast<size_t>(i));
      for (int j = 0; j < i; ++j) {
        distances[static_cast<size_t>(j)] =
            std::max(0.0, static_cast<double>(norms[i]) + norms[j] - 2.0 * dots(j, r));
      }
      slink.Insert(distances);
    }
  }
  return PlaceMemory::Restore(robot, options, std::move(places), std::move(slink),
                              static_cast<uint32_t>(n + 1), {});
}

}  // namespace tsc::testing_support
