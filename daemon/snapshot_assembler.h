#pragma once
// The receiving side of a memory exchange: collects a peer's memory portions (in any order,
// with duplicates and losses), says which are still missing so they can be asked for again,
// and hands over the snapshot only once it is complete and consistent. Every portion is
// checked before it is kept (DESIGN §4): wrong robot, impossible sizes, non-finite numbers,
// totals that disagree between portions; a finished snapshot must match its digest.

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "daemon/memory_snapshot.h"

namespace tsc {

/// A peer's memory as it was published, checked for consistency.
struct PeerSnapshot {
  int32_t robot = 0;
  int64_t boot_id = 0;
  int64_t version = 0;
  int64_t digest = 0;
  int32_t next_local = 0;
  std::vector<learned_place_t> places;  ///< in snapshot order
  std::vector<memory_node_t> nodes;     ///< in index order
  std::vector<map_edge_t> edges;
};

/// The peer's place memory rebuilt from a snapshot (SLINK state as published, discriminants
/// retrained). Throws std::invalid_argument when the places do not make a valid memory.
PlaceMemory ToPlaceMemory(const PeerSnapshot& snapshot, const PlaceMemoryOptions& options);
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

  /// Collects the memory of `robot`.
  explicit SnapshotAssembler(int32_t robot) : robot_(robot) {}

  /// Checks and keeps one portion. A portion of a newer version starts the assembly afresh;
  /// one of an older version is stale.
  Result Accept(const memory_portion_t& portion);

  bool started() const { return count_ > 0; }
  int32_t robot() const { return robot_; }
  int64_t version() const { return version_; }
  /// The digest the portions claim (checked by Take).
  int64_t digest() const { return digest_; }
  /// Portion indices not received yet (all of them before the first portion).
  std::vector<int32_t> Missing() const;
  /// Portions kept so far.
  size_t buffered() const { return portions_.size(); }
  bool complete() const { return started() && portions_.size() == static_cast<size_t>(count_); }
  /// The snapshot, once complete: the portions joined in order and checked as a whole (digest,
  /// place ranges, node indices, edge places). nullopt with `reason` set when inconsistent;
  /// the assembler then starts over.
  std::optional<PeerSnapshot> Take(std::string* reason);

  /// Limits on what a portion may claim, so a forged one cannot make us allocate without bound.
  static constexpr int32_t kMaxPortions = 100000;
  static constexpr int32_t kMaxPlaces = 1000000;
  static constexpr int32_t kMaxDims = 100000;

 private:
  void Reset();

  int32_t robot_;
  int64_t version_ = -1;
  int64_t boot_id_ = 0;
  int64_t digest_ = 0;
  int32_t count_ = 0;
  int32_t total_places_ = 0;
  int32_t total_nodes_ = 0;
  int32_t total_edges_ = 0;
  std::map<int32_t, memory_portion_t> portions_;
};

}  // namespace tsc
