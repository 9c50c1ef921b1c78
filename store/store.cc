#include "store/store.h"

#include <fcntl.h>
#include <sqlite3.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <limits>
#include <span>
#include <string_view>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

#include "core/memory/descriptor_space_mismatch.h"
#include "store/blob.h"
#include "store/layouts.h"
#include "store/schema.h"
#include "store/sqlite_db.h"

namespace tsc {
namespace {

using namespace store_internal;  // the store's blobs, their layouts, connection and schema

constexpr int kBusyTimeoutMs = 5000;

// An older database without incremental vacuum is converted (EnableIncrementalVacuum) when its
// pages in use are at most this many bytes (a VACUUM rewrites the file: well under a second here);
// a larger one keeps auto_vacuum NONE and reuses its free pages (StoreOptions,
// docs/reliability.md).
constexpr int64_t kConvertMaxBytes = int64_t{64} << 20;
// A base point record beyond its descriptor: the row header, idx, status, two doubles and the
// cell pointer (Store::Maintain's estimate of what deleting one record frees).
constexpr int64_t kBaseRecordOverheadBytes = 40;
// PRAGMA auto_vacuum values.
constexpr int64_t kAutoVacuumNone = 0;
constexpr int64_t kAutoVacuumIncremental = 2;

// Keys of the meta table.
constexpr const char* kMetaRobot = "robot";
constexpr const char* kMetaNextBase = "next_base";
constexpr const char* kMetaNextDetected = "next_detected";
constexpr const char* kMetaPreviousRobot = "previous_place_robot";
constexpr const char* kMetaPreviousLocal = "previous_place_local";
constexpr const char* kMetaNextLocal = "next_local_id";
constexpr const char* kMetaSlink = "slink";  // EncodeSlink
// In a spill only (Store::WriteSpill): the next_base of the database it continues; NULL when
// the process that wrote it never loaded that database.
constexpr const char* kMetaSpillContinues = "spill_continues_base";

int64_t ToSqlKey(uint64_t key) { return std::bit_cast<int64_t>(key); }
uint64_t FromSqlKey(int64_t key) { return std::bit_cast<uint64_t>(key); }

// ---------------------------------------------------------------------------------------
// Meta table.

void SetMeta(const Db& db, const char* key, const std::optional<int64_t>& value) {
  Statement s(db, "INSERT OR REPLACE INTO meta(key, value) VALUES(?1, ?2)");
  s.Text(1, key);
  if (value) {
    s.Int(2, *value);
  } else {
    s.Null(2);
  }
  s.Run();
}

void SetMetaBlob(const Db& db, const char* key, const Bytes& value) {
  Statement s(db, "INSERT OR REPLACE INTO meta(key, value) VALUES(?1, ?2)");
  s.Text(1, key).Blob(2, value).Run();
}

/// Runs `read(Row&)` on the meta row `key`; nullopt when there is none or its value is NULL.
template <typename F>
auto ReadMeta(const Db& db, const char* key, F&& parse)
    -> std::optional<decltype(parse(std::declval<const Row&>()))> {
  Statement s(db, "SELECT value FROM meta WHERE key = ?1");
  s.Text(1, key);
  if (!s.Step()) return std::nullopt;
  const Row row(db, s, "meta", std::string("key=") + key);
  if (row.IsNull(0)) return std::nullopt;
  return parse(row);
}

std::optional<int64_t> MetaInt(const Db& db, const char* key, int64_t lo, int64_t hi) {
  return ReadMeta(db, key, [&](const Row& r) { return r.Int(0, "value", lo, hi); });
}

/// Records `robot` in a new database; throws if the database belongs to another robot.
void CheckRobot(const Db& db, uint32_t robot) {
  const std::optional<int64_t> stored =
      MetaInt(db, kMetaRobot, 0, std::numeric_limits<uint32_t>::max());
  if (!stored) {
    SetMeta(db, kMetaRobot, robot);
  } else if (*stored != robot) {
    Fail(db, "database belongs to robot " + std::to_string(*stored) + ", not to robot " +
                 std::to_string(robot));
  }
}

// ---------------------------------------------------------------------------------------
// Commit helpers.

void InsertBasePoint(const Db& db, const BasePointRecord& base) {
  Statement(db,
            "INSERT OR REPLACE INTO base_points(idx, status, descriptor, intensity_mean, "
            "intensity_var) VALUES(?1, ?2, ?3, ?4, ?5)")
      .Int(1, base.index)
      .Int(2, static_cast<int64_t>(base.status))
      .Blob(3, EncodeFloats(base.descriptor))
      .Real(4, base.intensity.mean)
      .Real(5, base.intensity.variance)
      .Run();
}

/// Non-partial recognised / learned event of detected place `m`, if any.
const PlaceEvent* Assignment(const FrameResult& result, DetectedPlaceIndex m) {
  for (const PlaceEvent& e : result.events) {
    if ((e.kind == EventKind::kRecognized || e.kind == EventKind::kLearned) && !e.partial &&
        e.detected_place == m && e.place) {
      return &e;
    }
  }
  return nullptr;
}

void InsertDetectedPlaces(const Db& db, const FrameResult& result) {
  Statement s(db,
              "INSERT OR REPLACE INTO detected_places(idx, mean, members, place_robot, "
              "place_local) VALUES(?1, ?2, ?3, ?4, ?5)");
  for (const DetectedPlace& d : result.closed_places) {
    const PlaceEvent* assigned = Assignment(result, d.index);
    s.Int(1, d.index)
        .Blob(2, d.descriptors.cols() > 0 ? EncodeFloats(d.Mean()) : Bytes{})
        .Blob(3, EncodeArray(std::span<const int64_t>(d.members)))
        .Place(4, assigned ? assigned->place : std::nullopt)
        .Run();
  }
  // Assignments of places closed by earlier results (the pipeline assigns a place when it
  // closes it, but the event alone is enough to fill the column).
  Statement update(db,
                   "UPDATE detected_places SET place_robot = ?1, place_local = ?2 WHERE idx = ?3");
  for (const PlaceEvent& e : result.events) {
    const bool closed_now =
        std::any_of(result.closed_places.begin(), result.closed_places.end(),
                    [&](const DetectedPlace& d) { return d.index == e.detected_place; });
    if (!closed_now && Assignment(result, e.detected_place) == &e) {
      update.Place(1, e.place).Int(3, e.detected_place).Run();
    }
  }
}

/// The transition region before a closed place runs from the robot's whereabouts (β(D_{m−1}),
/// or a known place recognised on the way) to β(D_m): the mapped event gives both; without
/// one the place was recognised as its predecessor (no edge).
void InsertTransitions(const Db& db, const FrameResult& result) {
  Statement s(db,
              "INSERT OR REPLACE INTO transition_regions(first, last, from_robot, from_local, "
              "to_robot, to_local) VALUES(?1, ?2, ?3, ?4, ?5, ?6)");
  for (const TransitionRegion& r : result.transitions) {
    std::optional<PlaceId> from, to;
    for (const DetectedPlace& d : result.closed_places) {
      if (d.members.empty() || d.members.front() != r.last + 1) continue;
      if (const PlaceEvent* assigned = Assignment(result, d.index)) to = assigned->place;
      from = to;
      for (const PlaceEvent& e : result.events) {
        if (e.kind == EventKind::kMapped && e.detected_place == d.index) from = e.from;
      }
    }
    s.Int(1, r.first).Int(2, r.last).Place(3, from).Place(5, to).Run();
  }
}

void UpsertLearnedPlaces(const Db& db, const PlaceMemory& memory, const std::vector<int>& changed) {
  Statement s(db,
              "INSERT INTO learned_places(position, robot, local, mean, member_count, samples, "
              "detected, members, sources) VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9) "
              "ON CONFLICT(position) DO UPDATE SET robot = excluded.robot, "
              "local = excluded.local, mean = excluded.mean, "
              "member_count = excluded.member_count, samples = excluded.samples, "
              "detected = excluded.detected, members = excluded.members, "
              "sources = excluded.sources");
  for (int position : changed) {
    if (position < 0 || position >= static_cast<int>(memory.places().size())) {
      Fail(db, "changed place " + std::to_string(position) + " is not one of the " +
                   std::to_string(memory.places().size()) + " learned places");
    }
    const LearnedPlace& p = memory.places()[static_cast<size_t>(position)];
    s.Int(1, position)
        .Int(2, p.id.robot)
        .Int(3, p.id.local)
        .Blob(4, EncodeFloats(p.mean))
        .Int(5, p.member_count)
        .Blob(6, EncodeSamples(p.samples))
        .Blob(7, EncodeArray(std::span<const int64_t>(p.detected)))
        .Blob(8, EncodeArray(std::span<const int64_t>(p.members)))
        .Blob(9, EncodeSources(p.sources))
        .Run();
  }
}

/// Rewrites the tree and the SLINK state; stores the discriminants of new node sets and of the
/// nodes on the paths of changed places (Update() retrains those in place), and deletes those
/// no node uses any more.
void WriteTree(const Db& db, const PlaceMemory& memory, const std::vector<int>& changed) {
  const std::vector<MemoryNode>& nodes = memory.nodes();
  Exec(db, "DELETE FROM memory_nodes");
  Statement insert_node(db,
                        "INSERT INTO memory_nodes(idx, parent, place, height, first_leaf, "
                        "end_leaf, set_key) VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7)");
  for (size_t i = 0; i < nodes.size(); ++i) {
    const MemoryNode& n = nodes[i];
    insert_node.Int(1, static_cast<int64_t>(i))
        .Int(2, n.parent)
        .Int(3, n.place)
        .Real(4, n.height)
        .Int(5, n.first_leaf)
        .Int(6, n.end_leaf)
        .Int(7, ToSqlKey(n.set_key))
        .Run();
  }

  std::unordered_set<uint64_t> stored;
  {
    Statement s(db, "SELECT set_key FROM discriminants");
    while (s.Step()) {
      stored.insert(FromSqlKey(Row(db, s, "discriminants", "?").Int(0, "set_key")));
    }
  }
  std::unordered_set<uint64_t> refresh;
  for (int place : changed) {
    for (int n = place; n >= 0 && n < static_cast<int>(nodes.size()); n = nodes[n].parent) {
      refresh.insert(nodes[n].set_key);
    }
  }
  Statement insert_disc(db,
                        "INSERT OR REPLACE INTO discriminants(set_key, dim, n_sv, rho, gamma, "
                        "support, coef) VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7)");
  std::unordered_set<uint64_t> wanted;
  for (size_t i = 0; i < nodes.size(); ++i) {
    const OneClassDiscriminant& d = memory.discriminants()[i];
    const uint64_t key = nodes[i].set_key;
    if (!d.trained() || !wanted.insert(key).second) continue;  // the root's is never trained
    if (stored.contains(key) && !refresh.contains(key)) continue;
    const Eigen::MatrixXf& support = d.support();
    insert_disc.Int(1, ToSqlKey(key))
        .Int(2, support.rows())
        .Int(3, support.cols())
        .Real(4, d.rho())
        .Real(5, d.gamma())
        .Blob(6, EncodeFloats(support))
        .Blob(7, EncodeFloats(d.coef()))
        .Run();
  }
  Statement erase(db, "DELETE FROM discriminants WHERE set_key = ?1");
  for (uint64_t key : stored) {
    if (!wanted.contains(key)) erase.Int(1, ToSqlKey(key)).Run();
  }
  SetMetaBlob(db, kMetaSlink, EncodeSlink(memory.slink()));
  SetMeta(db, kMetaNextLocal, memory.next_local_id());
}

void WriteMap(const Db& db, const FrameResult& result, const TopologicalMap& map) {
  Statement place(db, "INSERT OR IGNORE INTO map_places(robot, local) VALUES(?1, ?2)");
  Statement edge(db,
                 "INSERT OR REPLACE INTO map_edges(a_robot, a_local, b_robot, b_local, "
                 "traversals, transitions) VALUES(?1, ?2, ?3, ?4, ?5, ?6)");
  for (const PlaceEvent& e : result.events) {
    const bool assigned =
        (e.kind == EventKind::kRecognized || e.kind == EventKind::kLearned) && !e.partial;
    if (!assigned && e.kind != EventKind::kMapped) continue;
    for (const std::optional<PlaceId>& id : {e.place, e.from}) {
      if (id && map.places().contains(*id)) place.Place(1, id).Run();
    }
    if (e.kind != EventKind::kMapped) continue;
    if (!e.place || !e.from) Fail(db, "mapped event without both places");
    const MapEdge* found = map.Find(*e.from, *e.place);
    if (!found) {
      Fail(db, "mapped event " + e.from->ToString() + " - " + e.place->ToString() +
                   " has no edge in the map");
    }
    edge.Place(1, found->a)
        .Place(3, found->b)
        .Int(5, found->traversals)
        .Blob(6, EncodeTransitions(found->transitions))
        .Run();
  }
}

/// The pipeline position, and with `copies` its copy evidence (written only when it changed:
/// it rarely does, and a commit is made for every base point).
void WritePipelineState(const Db& db, const PipelineState& state, bool copies) {
  if (copies) {
    Exec(db, "DELETE FROM copy_evidence");
    Statement insert(db,
                     "INSERT INTO copy_evidence(a_robot, a_local, b_robot, b_local, count, last) "
                     "VALUES (?1, ?2, ?3, ?4, ?5, ?6)");
    for (const CopyWitness& w : state.copies) {
      insert.Place(1, w.a).Place(3, w.b).Int(5, w.count).Int(6, w.last).Run();
    }
  }
  SetMeta(db, kMetaNextBase, state.next_base);
  SetMeta(db, kMetaNextDetected, state.next_detected);
  SetMeta(
      db, kMetaPreviousRobot,
      state.previous_place ? std::optional<int64_t>(state.previous_place->robot) : std::nullopt);
  SetMeta(
      db, kMetaPreviousLocal,
      state.previous_place ? std::optional<int64_t>(state.previous_place->local) : std::nullopt);
}

// The learned places of `memory`, all of them or, given `unchanged` (one flag per place), those
// not held already at their position: rows past the memory's end and at changed positions go,
// changed places are written (no row of an unchanged position holds a changed place's id,
// since ids are unique in the memory).
// Returns the positions written.
std::vector<int> WriteLearnedPlaces(const Db& db, const PlaceMemory& memory,
                                    const std::vector<char>* unchanged) {
  const int n = static_cast<int>(memory.places().size());
  std::vector<int> write;
  if (unchanged == nullptr || unchanged->size() != memory.places().size()) {
    Exec(db, "DELETE FROM learned_places");
    write.resize(static_cast<size_t>(n));
    for (int i = 0; i < n; ++i) write[static_cast<size_t>(i)] = i;
  } else {
    Statement(db, "DELETE FROM learned_places WHERE position >= ?1").Int(1, n).Run();
    Statement drop(db, "DELETE FROM learned_places WHERE position = ?1");
    for (int i = 0; i < n; ++i) {
      if ((*unchanged)[static_cast<size_t>(i)] != 0) continue;
      drop.Int(1, i).Run();
      write.push_back(i);
    }
  }
  UpsertLearnedPlaces(db, memory, write);
  return write;
}

/// Replaces the learned places, the tree, its discriminants and the map by `memory` and `map`
/// (inside the caller's transaction); records `peer` when given. The pipeline's previous place
/// may have been absorbed: it continues from the place that holds it. `unchanged`: as
/// WriteLearnedPlaces.
void WritePeer(const Db& db, const PeerMerge& peer) {
  Statement(db,
            "INSERT OR REPLACE INTO peers(robot, last_merged_version, merged_at_utime, digest) "
            "VALUES(?1, ?2, ?3, ?4)")
      .Int(1, peer.robot)
      .Int(2, peer.version)
      .Int(3, peer.utime)
      .Int(4, peer.digest)
      .Run();
}

void WriteKnowledge(const Db& db, const PlaceMemory& memory, const TopologicalMap& map,
                    const std::optional<PeerMerge>& peer,
                    const std::vector<char>* unchanged = nullptr) {
  if (peer) WritePeer(db, *peer);
  // The discriminants of the nodes above the places written are refreshed with the tree.
  WriteTree(db, memory, WriteLearnedPlaces(db, memory, unchanged));
  Exec(db, "DELETE FROM map_edges; DELETE FROM map_places;");
  Statement place(db, "INSERT INTO map_places(robot, local) VALUES(?1, ?2)");
  for (const PlaceId& p : map.places()) place.Place(1, p).Run();
  Statement edge(db,
                 "INSERT INTO map_edges(a_robot, a_local, b_robot, b_local, traversals, "
                 "transitions) VALUES(?1, ?2, ?3, ?4, ?5, ?6)");
  for (const auto& [key, e] : map.edges()) {
    edge.Place(1, e.a)
        .Place(3, e.b)
        .Int(5, e.traversals)
        .Blob(6, EncodeTransitions(e.transitions))
        .Run();
  }
  // The pipeline's previous place may have been absorbed: continue from its holder.
  const std::optional<int64_t> robot =
      MetaInt(db, kMetaPreviousRobot, 0, std::numeric_limits<uint32_t>::max());
  const std::optional<int64_t> local =
      MetaInt(db, kMetaPreviousLocal, 0, std::numeric_limits<uint32_t>::max());
  if (robot && local) {
    const PlaceId previous{static_cast<uint32_t>(*robot), static_cast<uint32_t>(*local)};
    for (const LearnedPlace& p : memory.places()) {
      if (std::binary_search(p.sources.begin(), p.sources.end(), previous)) {
        SetMeta(db, kMetaPreviousRobot, p.id.robot);
        SetMeta(db, kMetaPreviousLocal, p.id.local);
      }
    }
  }
}

// ---------------------------------------------------------------------------------------
// Load helpers.

std::vector<LearnedPlace> ReadLearnedPlaces(const Db& db) {
  std::vector<LearnedPlace> places;
  Statement s(db,
              "SELECT position, robot, local, mean, member_count, samples, detected, members, "
              "sources FROM learned_places ORDER BY position");
  while (s.Step()) {
    const int64_t position = Row(db, s, "learned_places", "?").Int(0, "position");
    const Row row(db, s, "learned_places", "position=" + std::to_string(position));
    if (position != static_cast<int64_t>(places.size())) {
      row.Fail("position",
               "expected " + std::to_string(places.size()) + " (positions must be 0, 1, 2, ...)");
    }
    LearnedPlace p;
    p.id = row.Place(1, "robot/local");
    p.mean = row.Decode(3, "mean", [](BlobReader& r) { return DecodeVector(r); });
    if (p.mean.size() == 0) row.Fail("mean", "empty");
    if (!places.empty() && p.mean.size() != places.front().mean.size()) {
      row.Fail("mean", "dimension " + std::to_string(p.mean.size()) + " differs from " +
                           std::to_string(places.front().mean.size()) + " of position 0");
    }
    p.member_count = row.Int(4, "member_count", 1);
    p.samples = row.Decode(5, "samples", DecodeSamples);
    // Their dimension is the view basis' (or the mean's, before views were kept in a basis):
    // Load checks it against the configured basis (PlaceMemory::Restore).
    if (p.samples.rows() == 0 || p.samples.cols() == 0) {
      row.Fail("samples", std::to_string(p.samples.rows()) + " x " +
                              std::to_string(p.samples.cols()) + " samples");
    }
    p.detected = row.Array<int64_t>(6, "detected");
    p.members = row.Array<int64_t>(7, "members");
    p.sources = row.Decode(8, "sources", DecodeSources);
    places.push_back(std::move(p));
  }
  return places;
}

Slink ReadSlink(const Db& db, size_t expected) {
  std::optional<Slink> slink = ReadMeta(db, kMetaSlink, [&](const Row& row) {
    return row.Decode(0, "value", [&](BlobReader& r) { return DecodeSlink(r, expected); });
  });
  if (slink) return std::move(*slink);
  if (expected != 0) {
    Fail(db, "table meta has no row key=" + std::string(kMetaSlink) + " for " +
                 std::to_string(expected) + " learned places");
  }
  return Slink();
}

std::unordered_map<uint64_t, OneClassDiscriminant> ReadDiscriminants(const Db& db) {
  std::unordered_map<uint64_t, OneClassDiscriminant> saved;
  Statement s(db, "SELECT set_key, dim, n_sv, rho, gamma, support, coef FROM discriminants");
  constexpr int64_t kMaxSize = std::numeric_limits<int32_t>::max();
  while (s.Step()) {
    const int64_t key = Row(db, s, "discriminants", "?").Int(0, "set_key");
    const Row row(db, s, "discriminants", "set_key=" + std::to_string(key));
    const auto dim = static_cast<int32_t>(row.Int(1, "dim", 0, kMaxSize));
    const auto n_sv = static_cast<int32_t>(row.Int(2, "n_sv", 0, kMaxSize));
    const double rho = row.Real(3, "rho"), gamma = row.Real(4, "gamma");
    Eigen::MatrixXf support =
        row.Decode(5, "support", [&](BlobReader& r) { return DecodeMatrix(r, dim, n_sv); });
    Eigen::VectorXf coef =
        row.Decode(6, "coef", [&](BlobReader& r) { return DecodeVector(r, n_sv); });
    try {
      saved.emplace(FromSqlKey(key),
                    OneClassDiscriminant(std::move(support), std::move(coef), rho, gamma));
    } catch (const std::invalid_argument& e) {
      row.Fail("support", e.what());
    }
  }
  return saved;
}

TopologicalMap ReadMap(const Db& db) {
  TopologicalMap map;
  {
    Statement s(db, "SELECT robot, local FROM map_places ORDER BY robot, local");
    while (s.Step()) map.AddPlace(Row(db, s, "map_places", "?").Place(0, "robot/local"));
  }
  Statement s(db,
              "SELECT a_robot, a_local, b_robot, b_local, traversals, transitions FROM "
              "map_edges ORDER BY a_robot, a_local, b_robot, b_local");
  while (s.Step()) {
    const auto [a, b, row] = ReadPairRow(db, s, "map_edges");
    MapEdge edge;
    edge.a = a;
    edge.b = b;
    edge.traversals = row.Int(4, "traversals", 0);
    edge.transitions = row.Decode(5, "transitions", DecodeTransitions);
    try {
      map.RestoreEdge(std::move(edge));
    } catch (const std::invalid_argument& e) {
      row.Fail("a_robot", e.what());
    }
  }
  return map;
}

/// Retention of the history: the detected places (and the transition regions before them)
/// none of whose base points is kept any more, oldest first, at most `count` of each. They
/// are the robot's history, as the base points are, and nothing reads them back but the
/// assignments of an evaluation: kept forever they grew ~56 MB a day at 10 fps (the mean and
/// members of ~10⁴ places, session 50's accelerated day) and squeezed every base point out of
/// a 64 MiB budget within the day, then grew past it. With no base point left, all may go.
int64_t ThinDetectedPlaces(const Db& db, int64_t count) {
  const int64_t horizon =
      PragmaInt(db, "SELECT COALESCE(MIN(idx), 9223372036854775807) FROM base_points");
  // The places that go are a prefix in index order: the oldest up to the first newer one.
  int64_t gone = 0, last = 0;
  {
    Statement s(db, "SELECT idx, members FROM detected_places ORDER BY idx LIMIT ?1");
    s.Int(1, count);
    while (s.Step()) {
      const Row row(db, s, "detected_places", "?");
      // Members that cannot be read (a damaged disk, a spill taken in) leave history nothing
      // can use: it goes in its turn, where failing here stopped retention for good.
      const std::optional<std::vector<int64_t>> members = row.ArrayIfReadable<int64_t>(1);
      // The first place with a base point kept ends the prefix: later places are newer.
      if (members && !members->empty() && members->back() >= horizon) break;
      last = row.Int(0, "idx");
      ++gone;
    }
  }
  if (gone > 0) Statement(db, "DELETE FROM detected_places WHERE idx <= ?1").Int(1, last).Run();
  // A region whose end is no number (damaged as above) compared above every integer and
  // stayed for good: it goes in its turn too.
  Statement(db,
            "DELETE FROM transition_regions WHERE id IN (SELECT id FROM transition_regions "
            "WHERE last < ?1 OR typeof(last) NOT IN ('integer', 'real') ORDER BY id LIMIT ?2)")
      .Int(1, horizon)
      .Int(2, count)
      .Run();
  return gone;
}

/// MAX(column) of `table`, or nullopt for an empty table.
std::optional<int64_t> MaxIndex(const Db& db, const char* table) {
  Statement s(db, (std::string("SELECT MAX(idx) FROM ") + table).c_str());
  if (!s.Step()) return std::nullopt;
  return Row(db, s, table, "max")
      .OptionalInt(0, "idx", std::numeric_limits<int64_t>::min(),
                   std::numeric_limits<int64_t>::max());
}

PipelineState ReadPipelineState(const Db& db) {
  constexpr int64_t kMax = std::numeric_limits<int64_t>::max();
  constexpr int64_t kMaxId = std::numeric_limits<uint32_t>::max();
  PipelineState state;
  state.next_base = MetaInt(db, kMetaNextBase, 0, kMax).value_or(0);
  state.next_detected = MetaInt(db, kMetaNextDetected, 1, kMax).value_or(1);
  const std::optional<int64_t> robot = MetaInt(db, kMetaPreviousRobot, 0, kMaxId);
  const std::optional<int64_t> local = MetaInt(db, kMetaPreviousLocal, 0, kMaxId);
  if (robot.has_value() != local.has_value()) {
    Fail(db, "table meta: previous place has only one of robot and local");
  }
  if (robot) {
    state.previous_place = PlaceId{static_cast<uint32_t>(*robot), static_cast<uint32_t>(*local)};
  }
  {
    // Bounded whatever the file holds: the pipeline keeps at most kMaxPairs pairs.
    Statement c(db,
                "SELECT a_robot, a_local, b_robot, b_local, count, last FROM copy_evidence "
                "ORDER BY a_robot, a_local, b_robot, b_local LIMIT ?1");
    c.Int(1, static_cast<int64_t>(CopyEvidence::kMaxPairs));
    while (c.Step()) {
      const auto [a, b, row] = ReadPairRow(db, c, "copy_evidence");
      CopyWitness w;
      w.a = a;
      w.b = b;
      if (!(w.a < w.b)) row.Fail("b_robot", "the pair is not in order");
      w.count = static_cast<int>(row.Int(4, "count", 1, std::numeric_limits<int>::max()));
      w.last = row.Int(5, "last", 0, kMax);
      state.copies.push_back(w);
    }
  }
  // Both tables are written in the same transaction as the position, so it must be past them.
  if (const auto k = MaxIndex(db, "base_points"); k && *k >= state.next_base) {
    Fail(db, "table meta: next_base " + std::to_string(state.next_base) +
                 " is not past base point " + std::to_string(*k));
  }
  if (const auto m = MaxIndex(db, "detected_places"); m && *m >= state.next_detected) {
    Fail(db, "table meta: next_detected " + std::to_string(state.next_detected) +
                 " is not past detected place " + std::to_string(*m));
  }
  return state;
}

}  // namespace

// ---------------------------------------------------------------------------------------

Store::Store(std::filesystem::path path, sqlite3* db) : path_(std::move(path)), db_(db) {}

Store::Store(Store&& other) noexcept
    : path_(std::move(other.path_)), db_(std::exchange(other.db_, nullptr)) {}

Store& Store::operator=(Store&& other) noexcept {
  if (this != &other) {
    sqlite3_close_v2(db_);
    path_ = std::move(other.path_);
    db_ = std::exchange(other.db_, nullptr);
  }
  return *this;
}

Store::~Store() { sqlite3_close_v2(db_); }

Store Store::OpenExisting(const std::filesystem::path& path) { return Open(path, false); }

Store Store::Open(const std::filesystem::path& path) { return Open(path, true); }

Store Store::Open(const std::filesystem::path& path, bool create) {
  std::error_code ec;
  if (!create && !std::filesystem::exists(path, ec)) {
    throw StoreError(path.string() +
                         ": not there (its file system not mounted again?); no new database is "
                         "made in its place",
                     true);
  }
  sqlite3* handle = nullptr;
  const int rc = sqlite3_open_v2(
      path.c_str(), &handle, SQLITE_OPEN_READWRITE | (create ? SQLITE_OPEN_CREATE : 0), nullptr);
  Store store(path, handle);  // owns the handle from here, even when opening failed
  const Db db{handle, store.path_};
  if (rc != SQLITE_OK) FailSqlite(db, "cannot open the database");
  // SQLite falls back to reading when the file cannot be opened for writing (a read-only file
  // system): such a store would fail at its first commit, so it is refused now.
  if (sqlite3_db_readonly(handle, "main") == 1) {
    throw StoreError(path.string() +
                         ": opened read-only: the file or its file system cannot be "
                         "written",
                     true);
  }
  sqlite3_extended_result_codes(handle, 1);
  if (sqlite3_busy_timeout(handle, kBusyTimeoutMs) != SQLITE_OK) {
    FailSqlite(db, "cannot set the busy timeout");
  }
  // Freed pages go back to the file system in bounded steps (Maintain). SQLite applies this
  // to a database that has no table yet; an older one keeps auto_vacuum NONE until
  // EnableIncrementalVacuum() converts it (Open() itself never rewrites a file).
  Exec(db, "PRAGMA auto_vacuum=INCREMENTAL");
  {
    Statement wal(db, "PRAGMA journal_mode=WAL");
    const bool row = wal.Step();
    const auto* mode = row ? sqlite3_column_text(wal.get(), 0) : nullptr;
    if (mode == nullptr || std::string_view(reinterpret_cast<const char*>(mode)) != "wal") {
      Fail(db, "cannot switch to WAL journal mode");
    }
  }
  Exec(db, "PRAGMA synchronous=NORMAL; PRAGMA foreign_keys=ON;");
  Migrate(db);
  return store;
}

int Store::schema_version() const {
  const Db db{db_, path_};
  return static_cast<int>(ReadSchemaVersion(db));
}

StoredState Store::Load(uint32_t robot, const PlaceMemoryOptions& options, int threads) {
  options.Validate();  // a configuration error, not a store error: std::invalid_argument
  const Db db{db_, path_};
  try {
    Transaction tx(db);
    CheckRobot(db, robot);
    std::vector<LearnedPlace> places = ReadLearnedPlaces(db);
    Slink slink = ReadSlink(db, places.size());
    const uint32_t next_local = static_cast<uint32_t>(
        MetaInt(db, kMetaNextLocal, 1, std::numeric_limits<uint32_t>::max()).value_or(1));
    const auto saved = ReadDiscriminants(db);
    std::optional<PlaceMemory> memory;
    try {
      memory = PlaceMemory::Restore(robot, options, std::move(places), std::move(slink), next_local,
                                    saved, {}, threads);
    } catch (const DescriptorSpaceMismatch& e) {
      // The configuration's fault, not the store's: nothing to repair or retry.
      throw DescriptorSpaceMismatch(path_.string() + ": " + e.what());
    } catch (const std::invalid_argument& e) {
      Fail(db, std::string("tables learned_places/discriminants, meta slink: ") + e.what());
    }
    TopologicalMap map = ReadMap(db);
    const PipelineState state = ReadPipelineState(db);
    tx.Commit();
    return StoredState{std::move(*memory), std::move(map), state};
  } catch (const StoreError&) {
    throw;
  } catch (const DescriptorSpaceMismatch&) {
    throw;
  } catch (const std::exception& e) {
    Fail(db, std::string("cannot load: ") + e.what());
  }
}

MaintenanceStep Store::Maintain(const StoreOptions& options) {
  options.Validate();  // a configuration error, not a store error: std::invalid_argument
  const Db db{db_, path_};
  MaintenanceStep step;
  const int64_t budget = options.budget_mb * (int64_t{1} << 20);
  const int64_t pages = options.maintenance_pages;
  bool records_left = false;
  if (budget > 0 && BytesUsed(db) > budget) {
    Transaction tx(db);
    // Oldest first: the history older than every base point kept goes before any of them (a
    // store written before session 50 holds a day of it per 56 MB).
    step.detected_places_deleted = ThinDetectedPlaces(db, pages);
    const int64_t excess = BytesUsed(db) - budget;
    // What deleting one record frees: its share of a page, from the newest one's size (all
    // descriptors have one dimension; a 2.8 KB record fills a 4 KiB page alone).
    const int64_t page_size = PragmaInt(db, "PRAGMA page_size");
    const int64_t record =
        PragmaInt(db,
                  "SELECT COALESCE(MAX(length(descriptor)), 0) FROM base_points WHERE idx = "
                  "(SELECT MAX(idx) FROM base_points)") +
        kBaseRecordOverheadBytes;
    const int64_t per_page = std::max<int64_t>(1, page_size / record);
    const int64_t freed = page_size / per_page;
    const int64_t count =
        std::clamp((excess + freed - 1) / freed, int64_t{0}, pages - step.detected_places_deleted);
    if (count > 0) {
      Statement(db,
                "DELETE FROM base_points WHERE idx IN "
                "(SELECT idx FROM base_points ORDER BY idx LIMIT ?1)")
          .Int(1, count)
          .Run();
      step.base_points_deleted = sqlite3_changes(db_);
      step.detected_places_deleted += ThinDetectedPlaces(db, count);
    }
    records_left = PragmaInt(db,
                             "SELECT EXISTS(SELECT 1 FROM base_points) OR "
                             "EXISTS(SELECT 1 FROM detected_places)") != 0;
    tx.Commit();
  }
  const bool reclaims = reclaims_space();
  if (reclaims) {
    const int64_t free_before = PragmaInt(db, "PRAGMA freelist_count");
    if (free_before > 0) {
      // Its own transaction; the file shrinks when the WAL is checkpointed (at once if no
      // reader holds an older snapshot, else at a later checkpoint).
      Exec(db, ("PRAGMA incremental_vacuum(" + std::to_string(pages) + ")").c_str());
      step.pages_released = free_before - PragmaInt(db, "PRAGMA freelist_count");
      Exec(db, "PRAGMA wal_checkpoint(PASSIVE)");
    }
  }
  step.bytes_used = BytesUsed(db);
  step.more = (budget > 0 && step.bytes_used > budget && records_left) ||
              (reclaims && PragmaInt(db, "PRAGMA freelist_count") > 0);
  return step;
}

bool Store::EnableIncrementalVacuum() {
  const Db db{db_, path_};
  if (PragmaInt(db, "PRAGMA auto_vacuum") == kAutoVacuumNone && BytesUsed(db) <= kConvertMaxBytes) {
    // The pragma applies at a VACUUM (one transaction: a crash leaves the old file whole).
    Exec(db, "PRAGMA auto_vacuum=INCREMENTAL; VACUUM;");
  }
  return reclaims_space();
}

bool Store::reclaims_space() const {
  const Db db{db_, path_};
  return PragmaInt(db, "PRAGMA auto_vacuum") == kAutoVacuumIncremental;
}

std::optional<uint32_t> Store::robot() const {
  const Db db{db_, path_};
  const std::optional<int64_t> id =
      MetaInt(db, kMetaRobot, 0, std::numeric_limits<uint32_t>::max());
  if (!id) return std::nullopt;
  return static_cast<uint32_t>(*id);
}

void Store::CopyTo(const std::filesystem::path& out) const {
  const Db db{db_, path_};
  Statement(db, "VACUUM INTO ?1").Text(1, out.c_str()).Run();
}

std::vector<std::pair<PlaceId, std::vector<BaseIndex>>> Store::LoadAssignments() const {
  const Db db{db_, path_};
  std::vector<std::pair<PlaceId, std::vector<BaseIndex>>> out;
  Statement s(db,
              "SELECT idx, place_robot, place_local, members FROM detected_places "
              "WHERE place_robot IS NOT NULL ORDER BY idx");
  while (s.Step()) {
    const Row row(db, s, "detected_places", "?");
    constexpr int64_t kMaxId = std::numeric_limits<uint32_t>::max();
    const PlaceId id{static_cast<uint32_t>(row.Int(1, "place_robot", 0, kMaxId)),
                     static_cast<uint32_t>(row.Int(2, "place_local", 0, kMaxId))};
    std::vector<BaseIndex> members;
    for (int64_t b : row.Array<int64_t>(3, "members")) members.push_back(static_cast<BaseIndex>(b));
    out.emplace_back(id, std::move(members));
  }
  return out;
}

std::map<uint32_t, PeerMerge> Store::LoadPeers() const {
  const Db db{db_, path_};
  std::map<uint32_t, PeerMerge> peers;
  Statement s(db, "SELECT robot, last_merged_version, digest, merged_at_utime FROM peers");
  while (s.Step()) {
    const Row row(db, s, "peers", "?");
    PeerMerge p;
    p.robot = static_cast<uint32_t>(row.Int(0, "robot", 1, std::numeric_limits<uint32_t>::max()));
    p.version = row.Int(1, "last_merged_version");
    p.digest = row.Int(2, "digest");
    p.utime = row.Int(3, "merged_at_utime");
    peers[p.robot] = p;
  }
  return peers;
}

void Store::ReplaceKnowledge(const PlaceMemory& memory, const TopologicalMap& map,
                             const std::optional<PeerMerge>& peer) {
  const Db db{db_, path_};
  try {
    Transaction tx(db);
    CheckRobot(db, memory.robot());
    WriteKnowledge(db, memory, map, peer);
    tx.Commit();
  } catch (const StoreError&) {
    throw;
  } catch (const std::exception& e) {
    Fail(db, std::string("cannot replace the knowledge: ") + e.what());
  }
}

void Store::Commit(const FrameResult& result, const Pipeline& pipeline) {
  CommitPending(std::span<const FrameResult>(&result, 1), pipeline, false, std::nullopt);
}

void Store::CommitPending(std::span<const FrameResult> results, const Pipeline& pipeline,
                          bool replace_knowledge, const std::optional<PeerMerge>& peer,
                          const std::vector<char>* unchanged) {
  const Db db{db_, path_};
  try {
    Transaction tx(db);
    const PlaceMemory& memory = pipeline.memory();
    CheckRobot(db, memory.robot());
    std::vector<int> changed;
    bool tree_changed = false;
    for (const FrameResult& result : results) {
      if (result.has_base) InsertBasePoint(db, result.base);
      InsertDetectedPlaces(db, result);
      InsertTransitions(db, result);
      changed.insert(changed.end(), result.changed_places.begin(), result.changed_places.end());
      tree_changed |= result.memory_changed || !result.changed_places.empty();
      replace_knowledge |= result.memory_replaced;
    }
    const bool copies_changed = std::any_of(results.begin(), results.end(),
                                            [](const FrameResult& r) { return r.copies_changed; });
    const bool copies = copies_changed || replace_knowledge || peer;
    WritePipelineState(db, copies ? pipeline.state() : pipeline.position(), copies);
    if (replace_knowledge || peer) {
      // Positions and map edges of older results may not exist any more (a merge renumbers
      // places and collapses edges): the whole current knowledge replaces the stored one.
      WriteKnowledge(db, memory, pipeline.map(), peer, unchanged);
    } else {
      std::sort(changed.begin(), changed.end());
      changed.erase(std::unique(changed.begin(), changed.end()), changed.end());
      if (!changed.empty()) UpsertLearnedPlaces(db, memory, changed);
      if (tree_changed) WriteTree(db, memory, changed);
      for (const FrameResult& result : results) WriteMap(db, result, pipeline.map());
    }
    tx.Commit();
  } catch (const StoreError&) {
    throw;
  } catch (const std::exception& e) {
    Fail(db, std::string("cannot commit: ") + e.what());
  }
}

void Store::WriteSpill(const std::filesystem::path& spill, std::span<const FrameResult> results,
                       const Pipeline& pipeline, const std::optional<PeerMerge>& peer,
                       std::optional<BaseIndex> continues) {
  std::filesystem::path partial = spill;
  partial += ".partial";
  std::error_code ec;
  const auto remove_partial = [&] {  // with the companions a crash may have left
    for (const char* suffix : {"", "-wal", "-shm", "-journal"}) {
      std::filesystem::remove(partial.string() + suffix, ec);
    }
  };
  remove_partial();
  try {
    Store store = Open(partial, true);
    const Db db{store.db_, store.path_};
    // The whole memory and map with the records of `results`, and what it continues from.
    store.CommitPending(results, pipeline, true, peer);
    SetMeta(db, kMetaSpillContinues, continues);
    Exec(db, "PRAGMA wal_checkpoint(TRUNCATE)");
  } catch (...) {  // closed; nothing half written stays behind (on a full disk least of all)
    remove_partial();
    throw;
  }  // closed: the WAL is folded into the file and removed
  if (std::filesystem::rename(partial, spill, ec); ec) {
    throw StoreError(spill.string() + ": cannot put the spill in place: " + ec.message(), true);
  }
  // The rename is durable only once its folder is synced.
  const std::filesystem::path dir = spill.has_parent_path() ? spill.parent_path() : ".";
  if (const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC); fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
}

SpillReplay Store::ReplaySpill(const std::filesystem::path& spill, uint32_t robot,
                               const PlaceMemoryOptions& options) {
  const Db db{db_, path_};
  Store from = OpenExisting(spill);
  std::optional<int64_t> continues;
  {
    const Db sdb{from.db_, from.path_};
    continues = MetaInt(sdb, kMetaSpillContinues, 0, std::numeric_limits<int64_t>::max());
  }
  const StoredState saved = from.Load(robot, options);  // throws for another robot's
  // Read as Load reads them, not copied row by row: a damaged one refuses the spill rather
  // than the next start's store (fuzz_spill).
  const std::map<uint32_t, PeerMerge> peers = from.LoadPeers();
  const StoredState ours = Load(robot, options);
  // A continuation of exactly this database, or of none when its writer never loaded one.
  if (!continues) {
    if (!ours.memory.empty() || ours.pipeline.next_base > 0) {
      Fail(db, spill.string() +
                   " was written by a tscd that never loaded this database, which holds a "
                   "memory: the two cannot be joined; the spill is left untouched");
    }
  } else {
    if (ours.pipeline.next_base > *continues) {
      Fail(db, spill.string() + " continues base point " + std::to_string(*continues) +
                   " but the database is at " + std::to_string(ours.pipeline.next_base) +
                   " already; the spill is left untouched");
    }
    std::unordered_set<uint64_t> held;
    const auto key = [](const PlaceId& id) { return (uint64_t{id.robot} << 32) | id.local; };
    for (const LearnedPlace& p : saved.memory.places()) {
      held.insert(key(p.id));
      for (const PlaceId& s : p.sources) held.insert(key(s));
    }
    for (const LearnedPlace& p : ours.memory.places()) {
      if (!held.contains(key(p.id))) {
        Fail(db, spill.string() + " lacks place " + p.id.ToString() +
                     " of the database; the spill is left untouched");
      }
    }
  }
  SpillReplay out;
  out.next_base = saved.pipeline.next_base;
  out.places = saved.memory.places().size();
  out.edges = saved.map.edges().size();
  Statement(db, "ATTACH DATABASE ?1 AS spill").Text(1, spill.c_str()).Run();
  try {
    Transaction tx(db);
    Exec(db,
         "INSERT OR IGNORE INTO main.base_points SELECT * FROM spill.base_points;"
         "INSERT OR IGNORE INTO main.detected_places SELECT * FROM spill.detected_places;"
         "INSERT OR IGNORE INTO main.transition_regions(first, last, from_robot, from_local, "
         "to_robot, to_local) SELECT first, last, from_robot, from_local, to_robot, to_local "
         "FROM spill.transition_regions ORDER BY id;");
    for (const auto& [peer_robot, peer] : peers) WritePeer(db, peer);
    {
      Statement count(db, "SELECT COUNT(*) FROM spill.base_points");
      if (count.Step()) out.base_points = sqlite3_column_int64(count.get(), 0);
    }
    WriteKnowledge(db, saved.memory, saved.map, std::nullopt);
    WritePipelineState(db, saved.pipeline, true);
    tx.Commit();
  } catch (...) {
    sqlite3_exec(db_, "DETACH DATABASE spill", nullptr, nullptr, nullptr);
    throw;
  }
  Exec(db, "DETACH DATABASE spill");
  return out;
}

}  // namespace tsc
