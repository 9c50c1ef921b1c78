#include "core/memory/single_linkage.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>

namespace tsc {

Slink SingleLinkage(int n, std::vector<Link> links) {
  if (n < 0) throw std::invalid_argument("single linkage over " + std::to_string(n) + " places");
  for (const Link& l : links) {
    if (l.a < 0 || l.a >= n || l.b < 0 || l.b >= n) {
      throw std::invalid_argument("single linkage: link " + std::to_string(l.a) + "-" +
                                  std::to_string(l.b) + " outside places 0.." +
                                  std::to_string(n - 1));
    }
    if (!std::isfinite(l.gamma) || l.gamma < 0) {
      throw std::invalid_argument("single linkage: link " + std::to_string(l.a) + "-" +
                                  std::to_string(l.b) + " has gamma " + std::to_string(l.gamma));
    }
  }
  auto key = [](const Link& l) {
    return std::tuple(l.gamma, std::min(l.a, l.b), std::max(l.a, l.b));
  };
  std::sort(links.begin(), links.end(),
            [&key](const Link& x, const Link& y) { return key(x) < key(y); });
  std::vector<int> pi(static_cast<size_t>(n)), parent(static_cast<size_t>(n)),
      last(static_cast<size_t>(n));
  std::vector<double> lambda(static_cast<size_t>(n), Slink::kInfinity);
  std::iota(pi.begin(), pi.end(), 0);
  std::iota(parent.begin(), parent.end(), 0);
  std::iota(last.begin(), last.end(), 0);
  auto find = [&parent](int x) {
    while (parent[static_cast<size_t>(x)] != x) {
      x = parent[static_cast<size_t>(x)] =
          parent[static_cast<size_t>(parent[static_cast<size_t>(x)])];
    }
    return x;
  };
  // Clusters ra and rb join at γ: the one whose last place is lower stops being last there.
  auto join = [&](int ra, int rb, double gamma) {
    const int la = last[static_cast<size_t>(ra)], lb = last[static_cast<size_t>(rb)];
    const int lo = std::min(la, lb), hi = std::max(la, lb);
    pi[static_cast<size_t>(lo)] = hi;
    lambda[static_cast<size_t>(lo)] = gamma;
    parent[static_cast<size_t>(ra)] = rb;
    last[static_cast<size_t>(rb)] = hi;
  };
  double top = 0.0;
  for (const Link& l : links) {
    const int ra = find(l.a), rb = find(l.b);
    if (ra == rb) continue;
    join(ra, rb, l.gamma);
    top = l.gamma;
  }
  // Components the links left apart join at the largest γ, in order of their last places.
  std::vector<std::pair<int, int>> roots;  // (last place, root)
  for (int i = 0; i < n; ++i) {
    if (find(i) == i) roots.push_back({last[static_cast<size_t>(i)], i});
  }
  std::sort(roots.begin(), roots.end());
  for (size_t k = 1; k < roots.size(); ++k) join(find(roots[k - 1].second), roots[k].second, top);
  return Slink(std::move(pi), std::move(lambda));
}

std::vector<Link> LinksOf(const Slink& s) {
  std::vector<Link> links;
  links.reserve(static_cast<size_t>(std::max(s.size() - 1, 0)));
  for (int i = 0; i + 1 < s.size(); ++i) {
    links.push_back({s.lambda()[static_cast<size_t>(i)], i, s.pi()[static_cast<size_t>(i)]});
  }
  return links;
}

}  // namespace tsc
