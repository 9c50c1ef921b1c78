#pragma once
// A synthetic descriptor stream for pipeline runs in tests and fuzz seeds: clusters of noisy
// sum-normalised vectors (places) separated by sparse vectors far from everything
// (transitions), so that detection closes places and learning has something to learn.
// Deterministic for a seed.

#include <Eigen/Core>
#include <algorithm>
#include <random>
#include <vector>

#include "core/bubble/descriptor.h"

namespace tsc::testing_support {

class DescriptorStream {
 public:
  DescriptorStream(unsigned seed, int dim) : rng_(seed), dim_(dim) {}

  /// A new cluster (a place); returns its number.
  int AddCluster() {
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    Eigen::VectorXf v(dim_);
    for (int i = 0; i < dim_; ++i) v[i] = u(rng_);
    centres_.push_back(v / v.sum());
    return static_cast<int>(centres_.size()) - 1;
  }

  /// `n` frames of cluster `c` with 2 % multiplicative noise, then 3 incoherent frames.
  std::vector<Descriptor> Visit(int c, int n) {
    std::vector<Descriptor> out;
    std::normal_distribution<float> noise(0.0f, 0.02f);
    for (int j = 0; j < n; ++j) {
      Eigen::VectorXf v = centres_[static_cast<size_t>(c)];
      for (int i = 0; i < dim_; ++i) v[i] = std::max(0.0f, v[i] * (1.0f + noise(rng_)));
      out.emplace_back(v / v.sum());
    }
    std::uniform_int_distribution<int> pick(0, dim_ - 1);
    for (int j = 0; j < 3; ++j) {
      Eigen::VectorXf v = Eigen::VectorXf::Zero(dim_);
      for (int s = 0; s < 5; ++s) v[pick(rng_)] = 1.0f;
      out.emplace_back(v / v.sum());
    }
    return out;
  }

 private:
  std::mt19937 rng_;
  int dim_;
  std::vector<Eigen::VectorXf> centres_;
};

}  // namespace tsc::testing_support
