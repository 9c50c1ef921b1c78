#include "core/merge/merged_tree.h"

#include <algorithm>
#include <limits>
#include <utility>

#include "core/memory/single_linkage.h"

namespace tsc {
namespace {

// The base tree's links, the incoming tree's over the merged places, and the cross links
// recognition measured; `crossed` says whether there was any of the last.
std::vector<Link> TreeLinks(const Slink& base_tree, const Slink& incoming_tree,
                            const std::vector<int>& merged_index, const Recognitions& found,
                            int base_end, size_t place_count, bool* crossed) {
  std::vector<Link> links = LinksOf(base_tree);
  links.reserve(place_count * 2);
  // Between two base places the base's own links rule: the incoming tree links added ones.
  for (const Link& l : LinksOf(incoming_tree)) {
    const int a = merged_index[static_cast<size_t>(l.a)];
    const int b = merged_index[static_cast<size_t>(l.b)];
    if (a != b && (a >= base_end || b >= base_end)) links.push_back({l.gamma, a, b});
  }
  *crossed = false;
  for (size_t i = 0; i < merged_index.size(); ++i) {
    if (found.nearest[i] < 0 || merged_index[i] < base_end) continue;
    links.push_back({found.nearest_gamma[i], found.nearest[i], merged_index[i]});
    *crossed = true;
  }
  return links;
}

// Figure 4.4a/b: the trees join as wholes. The link runs between the base place nearest the
// incoming centroid and the added place nearest the base centroid; contained (4.4b), it joins
// at the base root's height so the smaller tree hangs under that root; disjoint (4.4a), no
// lower than either root, so it makes a new root.
Link WholeTreeLink(const std::vector<LearnedPlace>& places, size_t base_count,
                   const RootSpheres& spheres, const Slink& base_tree, const Slink& incoming_tree) {
  auto nearest_to = [&places](const Eigen::VectorXf& c, size_t first, size_t end) {
    size_t best = first;
    double best_gamma = std::numeric_limits<double>::infinity();
    for (size_t j = first; j < end; ++j) {
      const double g = (places[j].mean - c).squaredNorm();
      if (g < best_gamma) {
        best_gamma = g;
        best = j;
      }
    }
    return best;
  };
  const size_t a = nearest_to(spheres.incoming.centroid, 0, base_count);
  const size_t b = nearest_to(spheres.base.centroid, base_count, places.size());
  auto top = [](const Slink& tree) {
    return tree.order().empty() ? 0.0 : tree.order().back().first;
  };
  double gamma = std::max(top(base_tree), top(incoming_tree));
  if (spheres.merge_case == MergeCase::kDisjoint) {
    gamma = std::max(gamma, static_cast<double>((places[a].mean - places[b].mean).squaredNorm()));
  }
  return {gamma, static_cast<int>(a), static_cast<int>(b)};
}

// A folded base place stands for its holder in every link, and leaves `places`.
void DropFolded(const std::vector<int>& holder, std::vector<LearnedPlace>& places,
                std::vector<Link>& links) {
  const size_t base_count = holder.size();
  std::vector<int> index(places.size(), -1);
  std::vector<LearnedPlace> kept;
  kept.reserve(places.size());
  for (size_t i = 0; i < places.size(); ++i) {
    if (i < base_count && holder[i] != static_cast<int>(i)) continue;
    index[i] = static_cast<int>(kept.size());
    kept.push_back(std::move(places[i]));
  }
  // Holders precede the places folded into them.
  for (size_t b = 0; b < base_count; ++b) index[b] = index[static_cast<size_t>(holder[b])];
  for (Link& l : links) {
    l.a = index[static_cast<size_t>(l.a)];
    l.b = index[static_cast<size_t>(l.b)];
  }
  places = std::move(kept);
}

}  // namespace

Slink MergedTree(const Slink& base_tree, const Slink& incoming_tree,
                 const std::vector<int>& merged_index, const Recognitions& found,
                 const std::vector<int>& holder, const RootSpheres& spheres,
                 std::vector<LearnedPlace>& places) {
  const size_t base_count = holder.size();
  bool folds = false;
  for (size_t b = 0; b < base_count; ++b) folds = folds || holder[b] != static_cast<int>(b);
  if (places.size() <= base_count && !folds) return base_tree;
  bool crossed = false;
  std::vector<Link> links = TreeLinks(base_tree, incoming_tree, merged_index, found,
                                      static_cast<int>(base_count), places.size(), &crossed);
  if (!crossed && base_count > 0 && places.size() > base_count) {
    links.push_back(WholeTreeLink(places, base_count, spheres, base_tree, incoming_tree));
  }
  if (folds) DropFolded(holder, places, links);
  return SingleLinkage(static_cast<int>(places.size()), std::move(links));
}

}  // namespace tsc
