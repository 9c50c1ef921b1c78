#include "core/pipeline/copy_evidence.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace tsc {

CopyEvidence::CopyEvidence(int revisits, std::span<const CopyWitness> kept) : revisits_(revisits) {
  for (const CopyWitness& w : kept) {
    const std::string pair = "copy evidence: pair " + w.a.ToString() + " " + w.b.ToString();
    if (!(w.a < w.b)) throw std::invalid_argument(pair + " is not two places in order");
    if (w.count < 1) throw std::invalid_argument(pair + " was seen no time");
    if (pairs_.size() == kMaxPairs) break;
    pairs_[{w.a, w.b}] = Seen{w.count, w.last};
  }
}

std::vector<CopyWitness> CopyEvidence::Witnesses() const {
  std::vector<CopyWitness> out;
  out.reserve(pairs_.size());
  for (const auto& [key, seen] : pairs_)
    out.push_back({key.first, key.second, seen.count, seen.last});
  return out;
}

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
  ++changes_;
  it->second.last = m;
  if (++it->second.count < revisits_) return false;
  pairs_.erase(it);
  return true;
}

}  // namespace tsc
