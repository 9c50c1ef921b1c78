#pragma once
// A robot's place memory and map as LCM portions (DESIGN §4): what tscd publishes on
// TSC_MEMORY_<robot> when its memory changes and when a peer asks for it. The structure
// (place entries, tree, map) comes first; then one portion per place body, named in the
// structure by its digest, so a change of one place changes the structure and that body only.

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "core/map/topological_map.h"
#include "core/memory/place_memory.h"
#include "tsc/announce_t.hpp"
#include "tsc/memory_portion_v2_t.hpp"

namespace tsc {

struct MemorySnapshot {
  int64_t version = 0;
  int64_t digest = 0;                          ///< SnapshotDigest of the structure portions
  std::vector<memory_portion_v2_t> structure;  ///< portions [0, structure_portions)
  int32_t structure_portions = 0;
  /// Place i's body, portion structure_portions + i. Shared with the snapshots built before
  /// and after this one while the place does not change (BuildSnapshot's `previous`), so
  /// consecutive snapshots hold one copy of what they have in common. All null in a snapshot
  /// built without bodies (BuildSnapshotWithoutBodies: SnapshotBodies serves them).
  std::vector<std::shared_ptr<const learned_place_v2_t>> bodies;
  std::vector<int64_t> body_digests;  ///< of place i's body
  /// What every body portion carries besides its body (robot, version, digest, counts).
  memory_portion_v2_t body_header;
  int32_t places = 0;
  int32_t edges = 0;
  int64_t view_basis = 0;  ///< ViewBasisId of the memory's member views

  /// Portions in all: the structure, then one per place body.
  int32_t count() const { return structure_portions + static_cast<int32_t>(bodies.size()); }
  /// Portion `index` as it goes on the wire: a structure portion as held, a body portion
  /// assembled in `scratch` around `body` (by default the one held). Preconditions:
  /// 0 ≤ index < count(); a body portion has a body (given or held).
  const memory_portion_v2_t& Portion(int32_t index, memory_portion_v2_t& scratch,
                                     const learned_place_v2_t* body = nullptr) const;
  /// The same, as a copy (tools and tests).
  memory_portion_v2_t Portion(int32_t index) const;
};

/// Every portion of `snapshot`, in index order (tools and tests; tscd publishes them one by one
/// with MemorySnapshot::Portion).
std::vector<memory_portion_v2_t> AllPortions(const MemorySnapshot& snapshot);

struct SnapshotHeader {
  int32_t robot = 0;
  int64_t boot_id = 0;
  int64_t version = 0;
  int64_t utime = 0;
};

/// Cuts `memory` and `map` into structure portions whose encodings stay within `portion_bytes`
/// and one body portion per place (as large as the place). Deterministic for equal input.
/// `previous` (optional, any earlier snapshot of the same robot): the bodies of places whose
/// content has not changed since are shared with it rather than encoded and hashed again; the
/// result is the same. Precondition: portion_bytes ≥ 4096.
MemorySnapshot BuildSnapshot(const PlaceMemory& memory, const TopologicalMap& map,
                             const SnapshotHeader& header, int portion_bytes,
                             const MemorySnapshot* previous = nullptr);

/// BuildSnapshot for an owner of `memory` that serves the bodies itself (SnapshotBodies) and
/// knows which places changed since `previous` (optional) was built: the snapshot holds no body
/// (it is the memory's structure, digests and counts: a second copy of every body is what made
/// tscd's footprint, issue 23). A place of `previous` (same index) not in `changed` keeps its
/// digest unread; the others are encoded and hashed. Equal to BuildSnapshot but for `bodies`.
/// Precondition: every place of `memory` below previous->places and not in `changed` is the one
/// `previous` was built of, unchanged.
MemorySnapshot BuildSnapshotWithoutBodies(const PlaceMemory& memory, const TopologicalMap& map,
                                          const SnapshotHeader& header, int portion_bytes,
                                          const MemorySnapshot* previous,
                                          const std::unordered_set<int>& changed);

/// Place `place`'s body as a snapshot names it (BodyDigest) and sends it.
learned_place_v2_t BodyOf(const LearnedPlace& place);

/// The bodies of snapshots built without them, for the owner of their memory (tscd's worker
/// thread; not thread-safe): a body is read from the memory while its place is unchanged, and
/// kept, encoded just before the place changes, for as long as a snapshot naming it is alive.
/// So a snapshot serves the portions it named whatever the memory learned since, and the
/// bodies cost one copy (the memory's) plus the places changed since a live snapshot.
/// A memory replaced whole (a merge, a consolidation) withdraws the bodies of every snapshot
/// built before: keeping them was a second copy of the memory (164 MB after a 10⁴-place merge,
/// issue 23), and a peer still assembling such a snapshot moves on to the one the replaced
/// memory is broadcast as, keeping the bodies it received that are unchanged there.
class SnapshotBodies {
 public:
  /// `snapshot` was just built (BuildSnapshotWithoutBodies) of the memory as it is.
  void Track(const std::shared_ptr<const MemorySnapshot>& snapshot);
  /// Place `place` of `memory` is about to change.
  void BeforeUpdate(const PlaceMemory& memory, int place);
  /// The memory is about to be replaced (a merge, a consolidation): the snapshots built so far
  /// no longer serve bodies (Serves is false) nor say what changed since them.
  void BeforeReplace();
  /// Whether `snapshot`'s bodies are still served: it is tracked and the memory it was built of
  /// has not been replaced since.
  bool Serves(const MemorySnapshot& snapshot);
  /// The places of the memory changed since `snapshot` was built (BuildSnapshotWithoutBodies's
  /// `changed`); nullopt when it is not tracked.
  std::optional<std::unordered_set<int>> ChangedSince(const MemorySnapshot& snapshot);
  /// Body `place` of `snapshot` (tracked, alive) as it was built, `memory` being the memory now.
  /// Null when `snapshot` is not served, or when the place changed without BeforeUpdate (its
  /// body no longer has the digest the snapshot named). Precondition: 0 ≤ place < snapshot.places.
  std::shared_ptr<const learned_place_v2_t> Body(const MemorySnapshot& snapshot, int place,
                                                 const PlaceMemory& memory);
  /// Live snapshots tracked (tests).
  size_t tracked();

 private:
  struct Tracked {
    std::weak_ptr<const MemorySnapshot> snapshot;
    int places = 0;
    std::unordered_map<int, std::shared_ptr<const learned_place_v2_t>> kept;  ///< changed since
  };
  Tracked* Find(const MemorySnapshot& snapshot);
  void Prune();
  std::vector<Tracked> tracked_;
};

/// First 8 bytes (big endian) of SHA-256 over the encodings of the structure portions among
/// `portions` (index below structure_portions), in order, each taken with utime, boot_id,
/// version and digest zero and no HMAC (content only): what BuildSnapshot puts in `digest`
/// and receivers check. The structure names every body by its digest, so this covers them.
int64_t SnapshotDigest(const std::vector<memory_portion_v2_t>& portions);

/// First 8 bytes (big endian) of SHA-256 over the body's LCM encoding (without fingerprint).
int64_t BodyDigest(const learned_place_v2_t& body);
/// The body's LCM encoding (without fingerprint): what BodyDigest hashes.
std::vector<uint8_t> EncodeBody(const learned_place_v2_t& body);
/// The body `bytes` encode (EncodeBody), when they hash to `digest`; nullopt otherwise.
std::optional<learned_place_v2_t> DecodeBody(std::span<const uint8_t> bytes, int64_t digest);

/// Portion indices 0 .. n−1: a whole snapshot (n = its portions) or its structure.
std::vector<int32_t> PortionsBelow(int32_t n);

/// The structure portions of `snapshot` and the bodies whose digest is not in `known` (what a
/// receiver holding the bodies `known` needs), in index order.
std::vector<int32_t> PortionsBeyond(const MemorySnapshot& snapshot,
                                    const std::unordered_set<int64_t>& known);

/// What the exchange calls a view basis (memory_portion_v2_t.view_basis, announce_t.view_basis):
/// its id, 0 for none (views kept as descriptors).
int64_t ViewBasisId(const ViewBasis* basis);

/// Sets the fields of an announce that describe `snapshot` (memory_version, memory_digest,
/// portions, structure_portions, view_basis): what a peer needs to decide to fetch it and what
/// to ask for.
void DescribeInAnnounce(const MemorySnapshot& snapshot, announce_t& a);

}  // namespace tsc
