#include "core/merge/consolidate.h"

#include <algorithm>
#include <optional>
#include <stdexcept>
#include <utility>

#include "core/memory/single_linkage.h"
#include "core/merge/id_join.h"

namespace tsc {

Consolidation Consolidate(PlaceMemory memory, std::vector<int> group) {
  const int n = static_cast<int>(memory.places().size());
  std::sort(group.begin(), group.end());
  if (group.size() < 2 || std::adjacent_find(group.begin(), group.end()) != group.end() ||
      group.front() < 0 || group.back() >= n) {
    throw std::invalid_argument("consolidation needs two or more distinct places of the memory");
  }
  const int holder = group.front();
  // Old index → new index; the group's places all go to the holder's.
  std::vector<int> index(static_cast<size_t>(n), -1);
  std::vector<char> in_group(static_cast<size_t>(n), 0);
  for (int g : group) in_group[static_cast<size_t>(g)] = 1;
  int next = 0;
  for (int i = 0; i < n; ++i) {
    if (!in_group[static_cast<size_t>(i)] || i == holder) index[static_cast<size_t>(i)] = next++;
  }
  for (int g : group) index[static_cast<size_t>(g)] = index[static_cast<size_t>(holder)];

  // What the places left as they are need not compute again.
  std::vector<std::optional<PlaceMemory::Derived>> derived(static_cast<size_t>(next));
  for (int i = 0; i < n; ++i) {
    if (!in_group[static_cast<size_t>(i)])
      derived[static_cast<size_t>(index[static_cast<size_t>(i)])] = memory.DerivedOf(i);
  }
  std::vector<Link> links;
  for (Link l : LinksOf(memory.slink())) {
    l.a = index[static_cast<size_t>(l.a)];
    l.b = index[static_cast<size_t>(l.b)];
    if (l.a != l.b) links.push_back(l);
  }
  const uint32_t robot = memory.robot();
  const uint32_t next_local = memory.next_local_id();
  const PlaceMemoryOptions options = memory.options();
  std::vector<LearnedPlace> places = std::move(memory).TakePlaces();

  std::vector<PlaceId> ids;  // the group's, before the fold renames the holder
  for (int g : group) ids.push_back(places[static_cast<size_t>(g)].id);
  Consolidation out{PlaceMemory(robot, options), {}, {}};
  LearnedPlace& held = places[static_cast<size_t>(holder)];
  for (size_t k = 1; k < group.size(); ++k) {
    Fold(held, places[static_cast<size_t>(group[k])], options);
  }
  std::vector<LearnedPlace> kept;
  kept.reserve(static_cast<size_t>(next));
  for (int i = 0; i < n; ++i) {
    if (!in_group[static_cast<size_t>(i)] || i == holder) {
      kept.push_back(std::move(places[static_cast<size_t>(i)]));
    }
  }
  std::vector<Absorption> none;
  TakeSmallestIds(kept, none);
  out.holder = kept[static_cast<size_t>(index[static_cast<size_t>(holder)])].id;
  for (const PlaceId& id : ids) {
    if (id != out.holder) out.folded.push_back(id);
  }
  std::sort(out.folded.begin(), out.folded.end());
  out.memory =
      PlaceMemory::Restore(robot, options, std::move(kept), SingleLinkage(next, std::move(links)),
                           next_local, {}, std::move(derived));
  return out;
}

}  // namespace tsc
