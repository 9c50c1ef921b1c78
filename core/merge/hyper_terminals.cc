#include "core/merge/hyper_terminals.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

#include "core/merge/children_distance_bounds.h"

namespace tsc {
namespace {

// Each inner node's ball over the hyper-terminals under it: centre c(N) (NodeCentres), reach
// R(N) ≥ ‖c_b − c(N)‖ + ρ_b for every hyper-terminal b under N (−1: none), bottom-up (children
// precede parents), widened by a relative 1e-5 against float rounding. Then for an incoming
// sphere a at distance d from c(N), Overlap(a, b) ≤ min(2ρ_a, ρ_a + R(N) − d) for every b
// under N: the bound MatchHyperTerminals prunes by.
struct Balls {
  std::vector<Eigen::VectorXf> centre;
  std::vector<double> reach;
};

Balls BallsOf(const PlaceMemory& base, const std::vector<HyperTerminal>& hb,
              const std::vector<int>& ht_of) {
  const size_t nodes = base.nodes().size();
  Balls balls{NodeCentres(base), std::vector<double>(nodes, -1.0)};
  std::vector<Eigen::VectorXf>& centre = balls.centre;
  std::vector<double>& reach = balls.reach;
  for (size_t i = 0; i < nodes; ++i) {
    const MemoryNode& nd = base.nodes()[i];
    if (nd.terminal()) continue;
    double r = -1.0;
    if (ht_of[i] >= 0) {
      const NodeStatistics& s = hb[static_cast<size_t>(ht_of[i])].sphere;
      r = (s.centroid - centre[i]).norm() + s.radius;
    }
    for (int c : nd.children) {
      const auto ci = static_cast<size_t>(c);
      if (reach[ci] >= 0) r = std::max(r, (centre[ci] - centre[i]).norm() + reach[ci]);
    }
    reach[i] = r < 0 ? r : r * (1.0 + 1e-5) + 1e-12;
  }
  return balls;
}

}  // namespace

NodeStatistics StatisticsOf(const PlaceMemory& memory, std::span<const int> places) {
  if (places.empty()) throw std::invalid_argument("node statistics of no places");
  NodeStatistics s;
  s.num_places = static_cast<int>(places.size());
  s.centroid = Eigen::VectorXf::Zero(memory.places()[static_cast<size_t>(places[0])].mean.size());
  for (int p : places) s.centroid += memory.places()[static_cast<size_t>(p)].mean;  // (4.3)
  s.centroid /= static_cast<float>(places.size());
  double sum = 0.0;
  for (int p : places) {
    sum += (memory.places()[static_cast<size_t>(p)].mean - s.centroid).squaredNorm();
  }
  s.radius = std::sqrt(sum / static_cast<double>(places.size()));  // (4.4), DESIGN §3.6
  return s;
}

NodeStatistics NodeStatisticsOf(const PlaceMemory& memory, int node) {
  const MemoryNode& nd = memory.nodes().at(static_cast<size_t>(node));
  const std::vector<int>& order = memory.leaf_order();
  return StatisticsOf(memory, std::span<const int>(order.data() + nd.first_leaf,
                                                   static_cast<size_t>(nd.num_places())));
}

std::vector<HyperTerminal> HyperTerminals(const PlaceMemory& memory) {
  std::vector<HyperTerminal> out;
  for (size_t i = 0; i < memory.nodes().size(); ++i) {
    const MemoryNode& nd = memory.nodes()[i];
    if (nd.terminal()) continue;
    HyperTerminal h;
    h.node = static_cast<int>(i);
    for (int c : nd.children) {
      const MemoryNode& child = memory.nodes()[static_cast<size_t>(c)];
      if (child.terminal()) h.places.push_back(child.place);
    }
    if (h.places.empty()) continue;
    h.sphere = StatisticsOf(memory, h.places);
    out.push_back(std::move(h));
  }
  return out;
}

double Overlap(const NodeStatistics& a, const NodeStatistics& b) {
  const double d = (a.centroid - b.centroid).norm();
  return std::min({a.radius + b.radius - d, 2.0 * a.radius, 2.0 * b.radius});
}

std::vector<size_t> MatchHyperTerminals(const PlaceMemory& base,
                                        const std::vector<HyperTerminal>& hb,
                                        const std::vector<HyperTerminal>& hi) {
  if (hb.empty()) throw std::invalid_argument("matching hyper-terminals against none");
  std::vector<int> ht_of(base.nodes().size(), -1);
  for (size_t k = 0; k < hb.size(); ++k)
    ht_of[static_cast<size_t>(hb[k].node)] = static_cast<int>(k);
  const Balls balls = BallsOf(base, hb, ht_of);
  const std::vector<Eigen::VectorXf>& centre = balls.centre;
  const std::vector<double>& reach = balls.reach;
  const ChildrenDistanceBounds basis_bounds(base, centre, hi);
  const bool bounded = basis_bounds.available();
  std::vector<double> below;  // BelowChildren's distances
  // Whether a node has children with balls (terminals have none; a crowded hyper-terminal has
  // 1500 of them), once: a flat tree's root is popped for every incoming hyper-terminal.
  std::vector<char> any_ball(base.nodes().size(), 0);
  for (size_t n = 0; n < any_ball.size(); ++n) {
    for (int c : base.nodes()[n].children) any_ball[n] |= reach[static_cast<size_t>(c)] >= 0;
  }
  std::vector<size_t> out(hi.size(), 0);
  std::vector<std::pair<double, int>> heap;  // (bound, node), largest bound first
  for (size_t a = 0; a < hi.size(); ++a) {
    const NodeStatistics& sa = hi[a].sphere;
    const double ra = sa.radius;
    double best = -std::numeric_limits<double>::infinity(),
           best_d = std::numeric_limits<double>::infinity();
    size_t star = hb.size();
    // The bound on the overlap of `a` with any hyper-terminal under `node`, from a distance
    // to its centre no larger than the true one; `gap`: no such hyper-terminal's centre is
    // nearer than it.
    auto bound = [&](size_t node, double d, double* gap) {
      *gap = d - reach[node];
      return std::min(2.0 * ra, ra + reach[node] - d);
    };
    // Worth a visit: a bound above the best, or equal to it with a centre possibly nearer.
    auto promising = [&](double b, double gap) { return b > best || (b == best && gap <= best_d); };
    // Queues `node` when its exact bound is promising; `near`, a distance no larger than its
    // true one (the basis' bound), spares measuring it in full when that already is not.
    auto queue = [&](size_t node, double near) {
      double gap = 0.0;
      if (!promising(bound(node, near, &gap), gap)) return;
      const double b = bound(node, (sa.centroid - centre[node]).norm(), &gap);
      if (promising(b, gap)) heap.push_back({b, static_cast<int>(node)});
    };
    // Hyper-terminal k as N*: kept when it overlaps more, or as much with a nearer centre (then
    // the lower index).
    auto consider = [&](size_t k) {
      const NodeStatistics& sb = hb[k].sphere;
      const double d = (sa.centroid - sb.centroid).norm();
      const double overlap = std::min({ra + sb.radius - d, 2.0 * ra, 2.0 * sb.radius});
      if (overlap > best || (overlap == best && (d < best_d || (d == best_d && k < star)))) {
        best = overlap;
        best_d = d;
        star = k;
      }
    };
    heap.clear();
    const auto root = static_cast<size_t>(base.root());
    if (reach[root] >= 0) queue(root, 0.0);
    while (!heap.empty()) {
      std::pop_heap(heap.begin(), heap.end());
      const auto node = static_cast<size_t>(heap.back().second);
      heap.pop_back();
      if (const int k = ht_of[node]; k >= 0) consider(static_cast<size_t>(k));
      const std::vector<int>& children = base.nodes()[node].children;
      const bool any = any_ball[node] != 0;
      // Without the basis' bounds every child is queued at 0; BelowChildren sizes `below`.
      if (any && !bounded) below.assign(children.size(), 0.0);
      if (any && bounded) {
        basis_bounds.BelowChildren(a, node, below);
        // The hyper-terminal child nearest in the basis measured first: a real candidate, so
        // its overlap lets the basis' bounds rule out its siblings before any is measured in
        // full (a flat node's thousands, best being still unknown).
        size_t probe = children.size();
        for (size_t j = 0; j < children.size(); ++j) {
          const auto c = static_cast<size_t>(children[j]);
          if (reach[c] < 0 || ht_of[c] < 0) continue;
          if (probe == children.size() || below[j] < below[probe]) probe = j;
        }
        if (probe < children.size()) {
          consider(static_cast<size_t>(ht_of[static_cast<size_t>(children[probe])]));
        }
      }
      // Many children queued (a flat node's): append them and make the heap again, O(size);
      // a few: push each, O(log size) apiece.
      const size_t before = heap.size();
      for (size_t j = 0; any && j < children.size(); ++j) {
        const auto c = static_cast<size_t>(children[j]);
        if (reach[c] >= 0) queue(c, below[j]);
      }
      if ((heap.size() - before) * 16 > heap.size()) {
        std::make_heap(heap.begin(), heap.end());
      } else {
        for (size_t i = before + 1; i <= heap.size(); ++i) {
          std::push_heap(heap.begin(), heap.begin() + static_cast<std::ptrdiff_t>(i));
        }
      }
      // The largest bound queued fell below the best: nothing left can win.
      if (!heap.empty() && heap.front().first < best) heap.clear();
    }
    out[a] = star;
  }
  return out;
}

}  // namespace tsc
