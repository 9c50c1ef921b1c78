#pragma once
// The receiving side of a memory exchange: collects a peer's memory portions (in any order,
// with duplicates and losses), says which are still missing so they can be asked for again,
// and hands over the snapshot only once it is complete and consistent. Every portion is
// checked before it is kept (DESIGN §4): wrong robot, impossible sizes, non-finite numbers,
// totals that disagree between portions; a finished snapshot must match its digest, and each
// body received must match the digest the structure gives it. Bodies the receiver keeps from
// an earlier version of the same peer (`known`: their digests; tscd keeps the bodies in its
// store and Take loads them, or checks them by their names and leaves them to LoadKeptBodies
// until a merge needs them), and those of a version whose assembly a newer one replaced, fill
// in for their portions once the structure names them, so only what changed is asked for
// (issue 23).

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "daemon/kept_place_names.h"
#include "daemon/known_digests.h"
#include "daemon/memory_snapshot.h"

namespace tsc {

/// Place bodies by their digest (BodyDigest), shared between the snapshots that hold them.
using PlaceBodies = std::unordered_map<int64_t, std::shared_ptr<const learned_place_v2_t>>;
/// The kept bodies of `digests` (SnapshotAssembler::Take), each as it was received (checked
/// against its digest by the loader: what it keeps them in can be damaged); those it cannot
/// give are left out.
using BodyLoader = std::function<PlaceBodies(const KnownDigests& digests)>;

/// A peer's memory as it was published, checked for consistency.
struct PeerSnapshot {
  int32_t robot = 0;
  int64_t boot_id = 0;
  int64_t version = 0;
  int64_t digest = 0;
  int64_t view_basis = 0;  ///< memory_portion_v2_t.view_basis
  int32_t next_local = 0;
  std::vector<place_entry_t> entries;  ///< in snapshot order
  /// The body of each entry; null for a kept body Take checked by its name alone (`unloaded`
  /// of them; LoadKeptBodies loads them).
  std::vector<std::shared_ptr<const learned_place_v2_t>> places;
  int32_t unloaded = 0;
  std::vector<memory_node_t> nodes;  ///< in index order
  std::vector<map_edge_t> edges;
};

/// Loads the kept bodies Take left unloaded (`load` as for Take), checking each against its
/// entry. False with `reason` set when one cannot be loaded or is not the entry's place.
bool LoadKeptBodies(PeerSnapshot& snapshot, const BodyLoader& load, std::string* reason);
/// The names of the snapshot's bodies, to check its successor's by (SnapshotAssembler::Take):
/// those it holds and, for those Take left unloaded, their names in `earlier`.
KeptPlaceNames NamesOfBodies(const PeerSnapshot& snapshot, const KeptPlaceNames* earlier);
/// The peer's place memory rebuilt from a snapshot (SLINK state as published, discriminants
/// retrained), every body loaded. The bodies are let go as their places are built, a few hundred at
/// a time, so a snapshot moved in is not held beside the memory it becomes (a peer's bodies take
/// twice its compact places). Throws std::invalid_argument when the places do not make a valid
/// memory. The places' derived data are computed on up to `threads` threads (PlaceMemory::Restore);
/// the memory is the same for any number.
PlaceMemory ToPlaceMemory(PeerSnapshot snapshot, const PlaceMemoryOptions& options,
                          int threads = 1);
/// The peer's places as MergeLeavesOurs reads them (only ids and sources set, the sources sorted
/// as ToPlaceMemory sorts them), when its descriptors are of the kind `ours` holds: member views
/// in the same basis, and means of ours' dimension. Bodies Take left unloaded are read from
/// `kept`. nullopt otherwise, or where `kept` lacks one: ToPlaceMemory and the merge say what
/// is wrong.
std::optional<std::vector<LearnedPlace>> PlaceNamesOf(const PeerSnapshot& snapshot,
                                                      const PlaceMemory& ours,
                                                      const KeptPlaceNames* kept = nullptr);
/// The peer's topological map (edges with traversal counts; no transition regions, which
/// index the peer's own frames).
TopologicalMap ToTopologicalMap(const PeerSnapshot& snapshot);

class SnapshotAssembler {
 public:
  enum class Verdict { kAccepted, kDuplicate, kStale, kRejected };
  struct Result {
    Verdict verdict = Verdict::kRejected;
    std::string reason;  ///< why a portion was rejected or stale
  };

  /// Collects the memory of `robot`; bodies whose digest is in `known` need not be sent again
  /// (Take loads them).
  explicit SnapshotAssembler(int32_t robot, std::shared_ptr<const KnownDigests> known = nullptr)
      : robot_(robot), known_(std::move(known)) {}

  /// Checks and keeps one portion. A portion of a newer version starts the assembly afresh;
  /// one of an older version is stale.
  Result Accept(const memory_portion_v2_t& portion);

  bool started() const { return count_ > 0; }
  int32_t robot() const { return robot_; }
  int64_t version() const { return version_; }
  /// The digest the portions claim (checked by Take).
  int64_t digest() const { return digest_; }
  /// Portion indices to ask for: structure portions not received, and bodies neither received
  /// nor known (while the structure is incomplete, with known bodies, no body: the structure
  /// will say which are known). Empty before the first portion.
  std::vector<int32_t> Missing() const;
  /// Portions kept so far (received, not filled in from known bodies).
  size_t buffered() const { return structure_.size() + received_bodies_; }
  /// Every structure portion is in.
  bool structure_complete() const {
    return started() && structure_.size() == static_cast<size_t>(structure_portions_);
  }
  bool complete() const { return structure_complete() && bodies_present_ == total_places_; }
  /// Once the structure is complete: the digests it gives the bodies, what the receiver keeps
  /// to ask only for changes next time.
  KnownDigests Named() const;
  /// The snapshot, once complete: the portions joined in order and checked as a whole (digest,
  /// place ranges, node indices, edge places), the known bodies it names loaded by `load`;
  /// or, where `names` names every one of them, checked against their names and left
  /// unloaded (PeerSnapshot::unloaded). nullopt with `reason` set when inconsistent or when a
  /// known body cannot be loaded (the receiver then fetches the memory whole); the assembler
  /// then starts over.
  std::optional<PeerSnapshot> Take(std::string* reason, const BodyLoader& load = {},
                                   const KeptPlaceNames* names = nullptr);

  /// Limits on what a portion may claim, so a forged one cannot make us allocate without bound.
  static constexpr int32_t kMaxPortions = 100000;
  static constexpr int32_t kMaxPlaces = 1000000;
  static constexpr int32_t kMaxDims = 100000;
  /// Largest |value| of a descriptor component: (2·10⁶)² · kMaxDims is finite in float, so
  /// distances between a peer's views cannot overflow to infinity (found by fuzzing: views of
  /// ~10³⁸ made every distance infinite and broke view thinning).
  /// The bound a memory takes means in at (PlaceMemory::Restore), for views too.
  static constexpr float kMaxDescriptorValue = LearnedPlace::kMaxMeanValue;

 private:
  void Reset();    // everything, for a snapshot taken or refused
  void Restart();  // for a newer version: what Carry kept stays
  Result Keep(const memory_portion_v2_t& p);
  bool knows_bodies() const;
  /// f(place index, its entry) for every entry of the structure portions kept.
  template <typename F>
  void ForEachEntry(F f) const;
  void FillKnownBodies();
  void Carry();

  int32_t robot_;
  std::shared_ptr<const KnownDigests> known_;
  int64_t version_ = -1;
  int64_t boot_id_ = 0;
  int64_t digest_ = 0;
  int64_t view_basis_ = 0;
  int32_t count_ = 0;
  int32_t structure_portions_ = 0;
  int32_t total_places_ = 0;
  int32_t total_nodes_ = 0;
  int32_t total_edges_ = 0;
  std::map<int32_t, memory_portion_v2_t> structure_;
  std::vector<std::shared_ptr<const learned_place_v2_t>> bodies_;  ///< by place index
  std::vector<bool> received_;    ///< body i came in a portion (its digest is still to check)
  std::vector<bool> kept_;        ///< body i is a known one, loaded by Take
  std::vector<int64_t> digests_;  ///< of body i when it was filled in (known or carried)
  PlaceBodies carried_;           ///< bodies of the version this assembly replaced
  int32_t bodies_present_ = 0;
  size_t received_bodies_ = 0;
};

}  // namespace tsc
