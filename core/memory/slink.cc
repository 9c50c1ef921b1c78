#include "core/memory/slink.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>
#include <utility>

#include "core/assert.h"

namespace tsc {
namespace {

// A distance or bound of an insertion: finite and ≥ 0.
void CheckValue(double d, const std::string& what) {
  if (!std::isfinite(d) || d < 0) throw std::invalid_argument("SLINK insert: bad " + what);
}

// An insertion's `values` (a distance or bound per point): n of them, each checked.
void CheckPerPoint(std::span<const double> values, int n, const std::string& what) {
  if (static_cast<int>(values.size()) != n) {
    throw std::invalid_argument("SLINK insert: expected " + std::to_string(n) + " " + what +
                                "s, got " + std::to_string(values.size()));
  }
  for (double d : values) CheckValue(d, what);
}

}  // namespace

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
  CheckPerPoint(distances, n, "distance");
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
  UpdateOrder();
}

void Slink::UpdateOrder() {
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

// M(i) of Sibson's step is min(γ(i, n), the contributions of the points j with π(j) = i),
// where j contributes max(λ(j), M(j)): λ(j) when j joins n (λ(j) ≥ M(j)), else M(j). Points
// proven not to join carry a lower bound of M(j) instead; M(i) is exact once every term that
// could be its smallest is. Depth-first over the pointer tree with an explicit stack (a
// single-linkage chain is as deep as the memory is large).
double Slink::ExactM(int i, std::span<const double> lower,
                     const std::function<double(int)>& distance) {
  auto open = [&](int node) {
    Frame f{node, child_start_[node], kInfinity};
    for (int k = child_start_[node]; k < child_start_[node + 1]; ++k) {
      if (exact_[children_[k]]) f.best = std::min(f.best, contribution_[children_[k]]);
    }
    if (lower[node] < f.best) f.best = std::min(f.best, distance(node));
    return f;
  };
  std::vector<Frame>& stack = stack_;
  stack.clear();
  stack.push_back(open(i));
  for (;;) {
    Frame& f = stack.back();
    bool deeper = false;
    for (; f.next < child_start_[f.node + 1]; ++f.next) {
      const int j = children_[f.next];
      if (exact_[j] || contribution_[j] >= f.best) continue;  // cannot be smaller
      deeper = true;
      break;
    }
    if (deeper) {
      stack.push_back(open(children_[f.next]));
      continue;
    }
    const double m = f.best;
    const int node = f.node;
    stack.pop_back();
    if (stack.empty()) return m;
    // A child resolved here was proven not to join: it contributes M(j) itself.
    contribution_[node] = m;
    exact_[node] = 1;
    stack.back().best = std::min(stack.back().best, m);
    ++stack.back().next;
  }
}

void Slink::InsertBounded(std::span<const double> lower,
                          const std::function<double(int)>& distance) {
  const int n = size();
  CheckPerPoint(lower, n, "bound");
  measured_ = 0;
  auto checked = [this, &distance](int i) {
    ++measured_;
    const double d = distance(i);
    CheckValue(d, "distance");
    return d;
  };
  // The pointer tree's children (j < π(j); the last point points at itself).
  child_start_.assign(static_cast<size_t>(n) + 1, 0);
  for (int j = 0; j + 1 < n; ++j) ++child_start_[pi_[j] + 1];
  std::partial_sum(child_start_.begin(), child_start_.end(), child_start_.begin());
  children_.resize(static_cast<size_t>(std::max(0, n - 1)));
  {
    std::vector<int> at(child_start_.begin(), child_start_.end() - 1);
    for (int j = 0; j + 1 < n; ++j) children_[at[pi_[j]]++] = j;
  }
  contribution_.assign(static_cast<size_t>(n), 0.0);
  exact_.assign(static_cast<size_t>(n), 0);
  pi_.push_back(n);
  lambda_.push_back(kInfinity);
  fresh_.clear();
  for (int i = 0; i < n; ++i) {
    double bound = lower[i];
    for (int k = child_start_[i]; k < child_start_[i + 1]; ++k)
      bound = std::min(bound, contribution_[children_[k]]);
    if (bound > lambda_[i]) {  // M(i) > λ(i): i does not join n, as Insert would find
      contribution_[i] = bound;
      continue;
    }
    const double m = ExactM(i, lower, checked);
    if (lambda_[i] >= m) {
      contribution_[i] = lambda_[i];
      if (lambda_[i] != m) fresh_.push_back({m, i});
      lambda_[i] = m;
      pi_[i] = n;
    } else {
      contribution_[i] = m;
    }
    exact_[i] = 1;
  }
  for (int i = 0; i < n; ++i) {
    if (lambda_[i] >= lambda_[pi_[i]]) pi_[i] = n;
  }
  UpdateOrder();
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
