#include "core/pipeline/copy_evidence.h"

#include <algorithm>

namespace tsc {

bool CopyEvidence::Witness(PlaceId a, PlaceId b, DetectedPlaceIndex m) {
  if (revisits_ <= 0 || a == b) return false;
  const std::pair key{std::min(a, b), std::max(a, b)};
  auto it = pairs_.find(key);
  if (it == pairs_.end()) {
    if (pairs_.size() >= kMaxPairs) pairs_.clear();
    it = pairs_.emplace(key, Seen{}).first;
  } else if (m <= it->second.last + 1) {
    return false;  // the same pass through the room
  }
  it->second.last = m;
  if (++it->second.count < revisits_) return false;
  pairs_.erase(it);
  return true;
}

}  // namespace tsc
