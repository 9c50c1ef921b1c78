#include "core/memory/unchanged_places.h"

namespace tsc {

bool SameStoredPlace(const LearnedPlace& a, const LearnedPlace& b) {
  // Sizes first: Eigen compares vectors of one size only.
  return a.id == b.id && a.member_count == b.member_count && a.mean.size() == b.mean.size() &&
         a.mean == b.mean && a.samples == b.samples && a.detected == b.detected &&
         a.members == b.members && a.sources == b.sources;
}

std::vector<char> UnchangedPositions(std::span<const LearnedPlace> before,
                                     std::span<const LearnedPlace> after) {
  std::vector<char> out(after.size(), 0);
  for (size_t i = 0; i < after.size() && i < before.size(); ++i) {
    out[i] = SameStoredPlace(before[i], after[i]) ? 1 : 0;
  }
  return out;
}

PlaceFingerprint FingerprintOf(const LearnedPlace& p) {
  return {p.id, p.member_count, p.sources, p.samples.cols(), p.members.size(), p.detected.size()};
}

std::vector<PlaceFingerprint> FingerprintsOf(std::span<const LearnedPlace> places) {
  std::vector<PlaceFingerprint> out;
  out.reserve(places.size());
  for (const LearnedPlace& p : places) out.push_back(FingerprintOf(p));
  return out;
}

std::vector<char> UnchangedPositions(std::span<const PlaceFingerprint> before,
                                     std::span<const LearnedPlace> after) {
  std::vector<char> out(after.size(), 0);
  for (size_t i = 0; i < after.size() && i < before.size(); ++i) {
    out[i] = FingerprintOf(after[i]) == before[i] ? 1 : 0;
  }
  return out;
}

}  // namespace tsc
