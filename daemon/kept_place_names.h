#pragma once
// The ids and sources of the place bodies a receiver keeps of one peer, by body digest. Whether
// a merge leaves our memory as it is depends on those alone (MergeLeavesOurs), and a settled
// team's repeat exchange names mostly bodies kept from the exchange before: with their names at
// hand it is decided without loading those bodies from the store (10⁴ places: ~250 MB read,
// hashed and decoded in 1.5 s, issue 23). Compact, as it stays resident beside the memory:
// 24 bytes a body and 8 a source.

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "core/memory/place_id.h"

namespace tsc {

class KeptPlaceNames {
 public:
  /// One body as it is added.
  struct Named {
    int64_t digest = 0;  ///< BodyDigest
    PlaceId id;
    std::vector<PlaceId> sources;  ///< the places of other robots it absorbed, in any order
  };
  /// What Find gives: the body's place and its sources, sorted.
  struct Name {
    PlaceId id;
    std::span<const PlaceId> sources;
  };

  KeptPlaceNames() = default;
  /// The names of bodies of one memory, whose means have `dims` components. A digest given
  /// twice keeps its first name (equal digests are equal bodies).
  KeptPlaceNames(int32_t dims, std::vector<Named> bodies);

  std::optional<Name> Find(int64_t digest) const;
  /// The dimension of every named body's mean.
  int32_t dims() const { return dims_; }
  size_t size() const { return entries_.size(); }

 private:
  struct Entry {
    int64_t digest;
    PlaceId id;
    uint32_t first_source;
    uint32_t source_count;
  };
  std::vector<Entry> entries_;    // by digest, unique
  std::vector<PlaceId> sources_;  // each entry's, sorted, one after another
  int32_t dims_ = 0;
};

}  // namespace tsc
