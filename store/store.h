#pragma once
// SQLite persistence of the TSC knowledge base (appendix D.2, DESIGN §5): base points,
// detected places, transition regions, place memory, learned places, topological map.
// WAL mode, one transaction per pipeline result, a schema version table with migrations.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <unordered_set>
#include <utility>
#include <vector>

#include "core/pipeline/pipeline.h"
#include "store/store_options.h"

struct sqlite3;  // <sqlite3.h>, included by store.cc only

namespace tsc {

/// Everything needed to continue a robot's pipeline where it stopped.
struct StoredState {
  PlaceMemory memory;
  TopologicalMap map;
  PipelineState pipeline;
};

/// A teammate's memory merged into ours: which robot, the version and digest merged, when.
struct PeerMerge {
  uint32_t robot = 0;
  int64_t version = 0;
  int64_t digest = 0;
  int64_t utime = 0;
};

/// Thrown with a message naming the database file and what failed.
class StoreError : public std::runtime_error {
 public:
  /// `file_system`: the failure came from below SQLite (an I/O error, a read-only or vanished
  /// file system), so the connection is best closed and the file opened again later.
  explicit StoreError(const std::string& what, bool file_system = false)
      : std::runtime_error(what), file_system_(file_system) {}
  bool file_system() const { return file_system_; }

 private:
  bool file_system_ = false;
};

/// What Store::ReplaySpill took in.
struct SpillReplay {
  int64_t base_points = 0;  ///< base point records the spill held
  BaseIndex next_base = 0;  ///< where the pipeline continues now
  size_t places = 0;        ///< learned places of the memory now
  size_t edges = 0;         ///< map edges now
};

/// What one Store::Maintain step did.
struct MaintenanceStep {
  int64_t base_points_deleted = 0;  ///< oldest base point records deleted (one transaction)
  /// Detected place records deleted with them (none of their base points kept; same transaction)
  int64_t detected_places_deleted = 0;
  int64_t pages_released = 0;  ///< free pages handed back to the file system
  int64_t bytes_used = 0;      ///< pages in use after the step x page size
  bool more = false;           ///< another step has work to do now
};

class Store {
 public:
  /// Schema version this code writes; Open() migrates older databases up to it and refuses
  /// newer ones.
  static constexpr int kSchemaVersion = 6;

  /// Opens or creates the database; creates or migrates the schema. Throws StoreError.
  static Store Open(const std::filesystem::path& path);
  /// Opens a database that must exist already, as Open() does otherwise. When the file is not
  /// there it throws a file-system StoreError and creates nothing: a process that holds a
  /// memory reopening its store after a failure must not start a new database where its file
  /// system has not been mounted again yet (the new file would be hidden under the mount).
  static Store OpenExisting(const std::filesystem::path& path);
  Store(Store&&) noexcept;
  Store& operator=(Store&&) noexcept;
  ~Store();

  /// Loads the saved state (an empty memory for a new database). `robot` must match the
  /// database's robot id when one is recorded (throws StoreError otherwise); a memory learned
  /// in another descriptor space than `options` throws DescriptorSpaceMismatch. The places'
  /// derived values are computed on up to `threads` threads (PlaceMemory::Restore): the same
  /// memory for any number.
  StoredState Load(uint32_t robot, const PlaceMemoryOptions& options, int threads = 1);
  /// Writes one pipeline result in one transaction: base point, closed detected places,
  /// transitions, changed learned places, the tree and discriminants when they changed, map
  /// edges of mapped events, and the pipeline position. Throws StoreError (rolled back).
  void Commit(const FrameResult& result, const Pipeline& pipeline);
  /// Writes `results`, kept while the store failed, in ONE transaction that takes the database
  /// from its last committed state to `pipeline`'s current one (only the current memory
  /// exists, so committing them one by one would store a tree ahead of its places if the
  /// process died in between). With `replace_knowledge` or a `peer` merge, the whole memory and
  /// map are written as ReplaceKnowledge does (needed after a merge, or when results were
  /// dropped and their changes are known only from the memory). `unchanged` (with those only;
  /// one flag per place of the memory, core/memory/unchanged_places.h) names the places the
  /// database holds already at their position, which are then not written again: for a caller
  /// whose database held exactly the memory that was replaced. Throws StoreError (rolled
  /// back).
  void CommitPending(std::span<const FrameResult> results, const Pipeline& pipeline,
                     bool replace_knowledge, const std::optional<PeerMerge>& peer,
                     const std::vector<char>* unchanged = nullptr);

  /// Writes what a stopping tscd holds and could not commit to `spill`, a new database of its
  /// own: the whole memory and map of `pipeline`, the records of `results`, the pipeline
  /// position, the `peer` merge not stored yet, and `continues`, the next base point of the
  /// database it continues (nullopt: the writer never loaded one). Written under a temporary
  /// name and renamed, so `spill` is whole or absent. Throws StoreError.
  static void WriteSpill(const std::filesystem::path& spill, std::span<const FrameResult> results,
                         const Pipeline& pipeline, const std::optional<PeerMerge>& peer,
                         std::optional<BaseIndex> continues);
  /// Takes the spill `spill` (WriteSpill) into this database in one transaction: its base
  /// point, detected place and transition records and its peers are added, its memory, map
  /// and position replace ours. Only a spill that continues this database is taken: one whose
  /// writer reached our position or beyond and holds every place we hold, or, written by a
  /// tscd that never loaded a database, into an empty one; otherwise throws StoreError and
  /// changes nothing. The caller removes the spill after success.
  /// `robot` must own both.
  SpillReplay ReplaySpill(const std::filesystem::path& spill, uint32_t robot,
                          const PlaceMemoryOptions& options);

  /// One bounded step of retention (issue 23): while the pages in use exceed
  /// `options.budget_mb`, deletes the oldest records of the robot's history, at most
  /// `options.maintenance_pages` of them in one transaction: the detected places (and the
  /// transition regions before them) none of whose base points is kept, then the oldest base
  /// point records and the detected places left without base points by that; then hands at most
  /// that many free pages back to the file system (incremental vacuum, its own transaction) when
  /// the database reclaims space (reclaims_space()). Nothing else is ever deleted: learned places
  /// carry the member views recognition, merging and Load() use. Throws StoreError (the deletion
  /// rolled back).
  MaintenanceStep Maintain(const StoreOptions& options);
  /// True when freed pages can be handed back (auto_vacuum = INCREMENTAL): every database this
  /// code creates, and an older one EnableIncrementalVacuum() converted. A larger older
  /// database reuses its free pages, so it stops growing but does not shrink until converted
  /// offline (docs/reliability.md). Throws StoreError.
  bool reclaims_space() const;
  /// Converts a database created before incremental vacuum (issue 23) when it uses at most
  /// 64 MiB (a VACUUM, one transaction, well under a second); a larger one is left as it is.
  /// Returns reclaims_space(). Called by tscd at start, not by readers such as `tsc inspect`.
  /// Throws StoreError.
  bool EnableIncrementalVacuum();

  /// The robot id recorded in the database, if any. Throws StoreError.
  std::optional<uint32_t> robot() const;
  /// Writes a compacted copy of the database to `out` (which must not exist). Throws
  /// StoreError.
  void CopyTo(const std::filesystem::path& out) const;
  /// Replaces the learned places, the tree, its discriminants and the map by `memory` and
  /// `map` in one transaction (a merge result, core/merge); a previous place that was absorbed
  /// is replaced by the place that holds it. Throws StoreError (rolled back).
  /// `peer`, when given, is recorded in the peers table in the same transaction.
  void ReplaceKnowledge(const PlaceMemory& memory, const TopologicalMap& map,
                        const std::optional<PeerMerge>& peer = std::nullopt);
  /// Every detected place assigned to a learned place: the place it was recognised as or
  /// learned into (as recorded then) and its member base points, in detection order.
  /// Throws StoreError.
  std::vector<std::pair<PlaceId, std::vector<BaseIndex>>> LoadAssignments() const;
  /// The peers merged so far, by robot id. Throws StoreError.
  std::map<uint32_t, PeerMerge> LoadPeers() const;

  /// The place bodies of peer memories (store/peer_bodies.cc): what the exchange received, kept
  /// so that the next exchange with that peer fetches only the bodies it does not name. A
  /// cache: a body missing or damaged is fetched again, so each call is its own transaction.
  /// Digests of the bodies kept, by robot. Throws StoreError.
  std::map<uint32_t, std::vector<int64_t>> LoadPeerBodyDigests() const;
  /// f(digest, encoded body) for every body of `robot` kept. Throws StoreError.
  void ForEachPeerBody(uint32_t robot,
                       const std::function<void(int64_t, std::span<const unsigned char>)>& f) const;
  /// Keeps `bodies` (digest, encoded body) of `robot`, replacing one of the same digest. Throws
  /// StoreError (rolled back).
  void AddPeerBodies(uint32_t robot,
                     std::span<const std::pair<int64_t, std::vector<unsigned char>>> bodies);
  /// Drops the bodies of `robot` whose digest is not among `named`; returns the digests of
  /// those kept. Throws StoreError (rolled back).
  std::unordered_set<int64_t> KeepOnlyPeerBodies(uint32_t robot,
                                                 const std::unordered_set<int64_t>& named);

  const std::filesystem::path& path() const { return path_; }
  int schema_version() const;

 private:
  static Store Open(const std::filesystem::path& path, bool create);
  Store(std::filesystem::path path, sqlite3* db);
  std::filesystem::path path_;
  sqlite3* db_ = nullptr;
};

}  // namespace tsc
