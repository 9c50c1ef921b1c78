#include "core/memory/slink.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>
#include <utility>

#include "core/assert.h"

namespace tsc {

Slink::Slink(std::vector<int> pi, std::vector<double> lambda)
    : pi_(std::move(pi)), lambda_(std::move(lambda)) {
  const int n = static_cast<int>(pi_.size());
  if (lambda_.size() != pi_.size()) {
    throw std::invalid_argument("SLINK state: pi has " + std::to_string(pi_.size()) +
                                " entries, lambda " + std::to_string(lambda_.size()));
  }
  for (int i = 0; i < n; ++i) {
    const bool last = i == n - 1;
    if (last ? (pi_[i] != i || lambda_[i] != kInfinity)
             : (pi_[i] <= i || pi_[i] >= n || !std::isfinite(lambda_[i]) || lambda_[i] < 0)) {
      throw std::invalid_argument("SLINK state: invalid pointer at " + std::to_string(i));
    }
  }
  if (n > 1) {
    order_.resize(n - 1);
    for (int i = 0; i < n - 1; ++i) order_[i] = {lambda_[i], i};
    std::sort(order_.begin(), order_.end());
  }
}

void Slink::Insert(const std::vector<double>& distances) {
  const int n = size();
  if (static_cast<int>(distances.size()) != n) {
    throw std::invalid_argument("SLINK insert: expected " + std::to_string(n) + " distances, got " +
                                std::to_string(distances.size()));
  }
  for (double d : distances) {
    if (!std::isfinite(d) || d < 0) throw std::invalid_argument("SLINK insert: bad distance");
  }
  // Sibson's step: M(i) = d(i, n+1); μ of (3.14) is folded into M as the loop goes.
  m_.assign(distances.begin(), distances.end());
  m_.push_back(kInfinity);
  pi_.push_back(n);
  lambda_.push_back(kInfinity);
  fresh_.clear();
  for (int i = 0; i < n; ++i) {
    const int p = pi_[i];
    if (lambda_[i] >= m_[i]) {
      m_[p] = std::min(m_[p], lambda_[i]);
      if (lambda_[i] != m_[i]) fresh_.push_back({m_[i], i});  // includes the old last point
      lambda_[i] = m_[i];
      pi_[i] = n;
    } else {
      m_[p] = std::min(m_[p], m_[i]);
    }
  }
  for (int i = 0; i < n; ++i) {
    if (lambda_[i] >= lambda_[pi_[i]]) pi_[i] = n;
  }
  // order_: drop the entries whose λ changed, merge in their new values.
  order_.erase(
      std::remove_if(order_.begin(), order_.end(),
                     [&](const std::pair<double, int>& e) { return lambda_[e.second] != e.first; }),
      order_.end());
  std::sort(fresh_.begin(), fresh_.end());
  merged_.resize(order_.size() + fresh_.size());
  std::merge(order_.begin(), order_.end(), fresh_.begin(), fresh_.end(), merged_.begin());
  order_.swap(merged_);
  TSC_ASSERT(order_.size() + 1 == pi_.size(), "every point but the last has a finite λ in order_");
}

std::vector<DendrogramMerge> ToDendrogram(const Slink& slink) {
  const int n = slink.size();
  if (n < 2) return {};
  // Increasing λ, ties by point index (the order of a stable sort on λ), kept by Slink.
  const std::vector<std::pair<double, int>>& order = slink.order();
  // Union-find over points; each set remembers the dendrogram cluster that represents it.
  std::vector<int> parent(n), cluster(n);
  std::iota(parent.begin(), parent.end(), 0);
  std::iota(cluster.begin(), cluster.end(), 0);
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  std::vector<DendrogramMerge> merges;
  merges.reserve(n - 1);
  for (const auto& [height, i] : order) {
    const int ra = find(i), rb = find(slink.pi()[i]);
    TSC_ASSERT(ra != rb, "in increasing λ, each point's link joins two clusters");
    merges.push_back({cluster[ra], cluster[rb], height});
    parent[ra] = rb;
    cluster[rb] = n + static_cast<int>(merges.size()) - 1;
  }
  return merges;
}

}  // namespace tsc
