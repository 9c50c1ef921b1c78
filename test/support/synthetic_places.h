#pragma once
// Detected places on the descriptor scale for tests and benchmarks: positive, sum-normalised
// sites, as a robot's rooms are; each place its site perturbed by 20 %, each of its views by
// `view_noise` more. Deterministic: a place is the same on every visit (its noise is seeded by
// the place), its views differ between visits (seeded by place and visit).

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

#include "core/memory/place_memory.h"

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
  /// Visit `visit` of place p: `views` base points, numbered from p · member_stride.
  DetectedPlace Visit(int p, uint32_t visit, int views, BaseIndex member_stride = 100) const {
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

 private:
  int dim_;
  float view_noise_;
  uint32_t world_;
  std::vector<Eigen::VectorXf> sites_;
};

/// Robot `robot`'s memory of places [first, first + n) of `world`, each a visit of `views`
/// base points (the visit is the robot: its own member noise), ids 1..n. Built at once (SLINK
/// over the means, then one Restore that trains every node) rather than by n Learn()s. With a
/// view basis in `options`, Restore takes the views into it.
inline PlaceMemory SyntheticMemory(uint32_t robot, const SyntheticPlaces& world, int first, int n,
                                   int views, const PlaceMemoryOptions& options = {}) {
  std::vector<LearnedPlace> places;
  Slink slink;
  std::vector<double> distances;
  for (int p = 0; p < n; ++p) {
    const DetectedPlace d = world.Visit(first + p, robot, views, views);
    LearnedPlace lp;
    lp.id = PlaceId{robot, static_cast<uint32_t>(p + 1)};
    lp.mean = d.Mean();
    lp.member_count = d.descriptors.cols();
    lp.samples = d.descriptors.leftCols(
        std::min<Eigen::Index>(options.max_samples_per_place, d.descriptors.cols()));
    lp.detected = {d.index};
    lp.members = d.members;
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

}  // namespace tsc::testing_support
