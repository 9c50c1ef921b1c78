#include "core/merge/discriminant_reuse.h"

namespace tsc {
namespace {

// Saves the trained discriminants of the nodes of `m` that `skip` leaves out.
void Keep(const PlaceMemory& m, const std::vector<char>& skip,
          std::unordered_map<uint64_t, OneClassDiscriminant>& saved) {
  for (size_t i = 0; i < m.nodes().size(); ++i) {
    if (skip[i]) continue;
    if (m.discriminants()[i].trained())
      saved.try_emplace(m.nodes()[i].set_key, m.discriminants()[i]);
  }
}

}  // namespace

ReusableDiscriminants ReusableDiscriminantsOf(const PlaceMemory& base, const PlaceMemory& incoming,
                                              const Placement& placement,
                                              const std::vector<char>& is_new,
                                              const std::vector<int>& targets) {
  // Incoming nodes over a place that is known or absorbed (children precede parents in node
  // order).
  std::vector<char> foreign(incoming.nodes().size(), 0);
  for (size_t i = 0; i < incoming.nodes().size(); ++i) {
    const MemoryNode& nd = incoming.nodes()[i];
    if (nd.terminal()) {
      const auto p = static_cast<size_t>(nd.place);
      foreign[i] = !is_new[p] || targets[p] >= 0;
    } else {
      for (int c : nd.children) foreign[i] = foreign[i] || foreign[static_cast<size_t>(c)];
    }
  }
  // Base nodes on the path of an updated place (a place's terminal node has its index).
  const std::vector<char>& updated = placement.updated;
  std::vector<char> stale(base.nodes().size(), 0);
  for (size_t p = 0; p < updated.size(); ++p) {
    if (!updated[p]) continue;
    for (int n = static_cast<int>(p); n >= 0 && !stale[static_cast<size_t>(n)];
         n = base.nodes()[static_cast<size_t>(n)].parent) {
      stale[static_cast<size_t>(n)] = 1;
    }
  }
  ReusableDiscriminants out;
  Keep(base, stale, out.by_key);
  Keep(incoming, foreign, out.by_key);
  out.keys.reserve(out.by_key.size());
  for (const auto& [key, unused] : out.by_key) out.keys.insert(key);
  return out;
}

int Retrained(const PlaceMemory& merged, const std::unordered_set<uint64_t>& reused) {
  // Without the SVM vote no node trains a discriminant (`tsc merge` said "retrained 21" there).
  if (!merged.options().svm_vote) return 0;
  int retrained = 0;
  for (size_t i = 0; i < merged.nodes().size(); ++i) {
    if (static_cast<int>(i) == merged.root()) continue;
    if (!reused.contains(merged.nodes()[i].set_key)) ++retrained;
  }
  return retrained;
}

}  // namespace tsc
