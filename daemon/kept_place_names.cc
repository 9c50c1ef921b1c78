#include "daemon/kept_place_names.h"

#include <algorithm>

namespace tsc {

KeptPlaceNames::KeptPlaceNames(int32_t dims, std::vector<Named> bodies) : dims_(dims) {
  std::stable_sort(bodies.begin(), bodies.end(),
                   [](const Named& a, const Named& b) { return a.digest < b.digest; });
  size_t source_count = 0;
  for (const Named& b : bodies) source_count += b.sources.size();
  entries_.reserve(bodies.size());
  sources_.reserve(source_count);
  for (Named& b : bodies) {
    if (!entries_.empty() && entries_.back().digest == b.digest) continue;
    std::sort(b.sources.begin(), b.sources.end());
    entries_.push_back(Entry{b.digest, b.id, static_cast<uint32_t>(sources_.size()),
                             static_cast<uint32_t>(b.sources.size())});
    sources_.insert(sources_.end(), b.sources.begin(), b.sources.end());
  }
  sources_.shrink_to_fit();  // duplicates left out
}

std::optional<KeptPlaceNames::Name> KeptPlaceNames::Find(int64_t digest) const {
  const auto it = std::lower_bound(entries_.begin(), entries_.end(), digest,
                                   [](const Entry& e, int64_t d) { return e.digest < d; });
  if (it == entries_.end() || it->digest != digest) return std::nullopt;
  return Name{it->id,
              std::span<const PlaceId>(sources_).subspan(it->first_source, it->source_count)};
}

}  // namespace tsc
