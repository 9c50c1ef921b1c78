#include "store/schema.h"

#include <array>
#include <limits>
#include <string>

namespace tsc::store_internal {
namespace {

// Schema. kMigrations[v] takes a database from version v to v + 1; a step that has shipped is
// never edited, a change is a new step appended here.

constexpr std::array<const char*, 6> kMigrations = {
    // Version 1: the initial schema, after appendix D.2.
    R"sql(
CREATE TABLE meta(key TEXT PRIMARY KEY, value) WITHOUT ROWID;
CREATE TABLE base_points(
  idx INTEGER PRIMARY KEY,          -- BaseIndex k
  status INTEGER NOT NULL,          -- BaseStatus: 0 good, 1 uninformative, 2 incoherent
  descriptor BLOB NOT NULL,         -- float32 LE
  intensity_mean REAL NOT NULL,
  intensity_var REAL NOT NULL);
CREATE TABLE detected_places(
  idx INTEGER PRIMARY KEY,          -- DetectedPlaceIndex m
  mean BLOB NOT NULL,               -- float32 LE
  members BLOB NOT NULL,            -- int64 LE base point indices
  place_robot INTEGER,              -- β(D_m), once recognised or learned
  place_local INTEGER);
CREATE TABLE transition_regions(
  id INTEGER PRIMARY KEY AUTOINCREMENT,
  first INTEGER NOT NULL,           -- base points, inclusive
  last INTEGER NOT NULL,
  from_robot INTEGER, from_local INTEGER,
  to_robot INTEGER, to_local INTEGER,
  UNIQUE(first, last));
CREATE TABLE learned_places(
  position INTEGER PRIMARY KEY,     -- index in PlaceMemory::places()
  robot INTEGER NOT NULL,
  local INTEGER NOT NULL,
  mean BLOB NOT NULL,               -- float32 LE
  member_count INTEGER NOT NULL,
  samples BLOB NOT NULL,            -- int32 rows, int32 cols, float32 column-major
  detected BLOB NOT NULL,           -- int64 LE detected place indices
  members BLOB NOT NULL,            -- int64 LE base point indices
  UNIQUE(robot, local));
CREATE TABLE memory_nodes(
  idx INTEGER PRIMARY KEY,
  parent INTEGER NOT NULL,          -- -1 for the root
  place INTEGER NOT NULL,           -- place position for terminals, -1 for inner nodes
  height REAL NOT NULL,
  first_leaf INTEGER NOT NULL,
  end_leaf INTEGER NOT NULL,
  set_key INTEGER NOT NULL);        -- uint64 bit-cast to int64
CREATE TABLE discriminants(
  set_key INTEGER PRIMARY KEY,      -- uint64 bit-cast to int64
  dim INTEGER NOT NULL,
  n_sv INTEGER NOT NULL,
  rho REAL NOT NULL,
  gamma REAL NOT NULL,
  support BLOB NOT NULL,            -- float32 LE, dim x n_sv column-major
  coef BLOB NOT NULL);              -- float32 LE, n_sv
CREATE TABLE map_places(
  robot INTEGER NOT NULL,
  local INTEGER NOT NULL,
  PRIMARY KEY(robot, local)) WITHOUT ROWID;
CREATE TABLE map_edges(
  a_robot INTEGER NOT NULL, a_local INTEGER NOT NULL,  -- a < b
  b_robot INTEGER NOT NULL, b_local INTEGER NOT NULL,
  traversals INTEGER NOT NULL,
  transitions BLOB NOT NULL,        -- int64 LE (first, last) pairs
  PRIMARY KEY(a_robot, a_local, b_robot, b_local)) WITHOUT ROWID;
CREATE TABLE peers(                 -- teammates merged so far (written by the merge issue)
  robot INTEGER PRIMARY KEY,
  last_merged_version INTEGER NOT NULL,
  merged_at_utime INTEGER NOT NULL);
)sql",
    // Version 2: the ids of other robots' places a learned place absorbed by merging
    // (core/merge), uint32 LE (robot, local) pairs; empty for places never merged.
    R"sql(
ALTER TABLE learned_places ADD COLUMN sources BLOB NOT NULL DEFAULT x'';
)sql",
    // Version 3: the digest of the peer memory merged last (the exchange fetches a peer again
    // only when its digest changes).
    R"sql(
ALTER TABLE peers ADD COLUMN digest INTEGER NOT NULL DEFAULT 0;
)sql",
    // Version 4: learned_places.samples written as 16-bit views (EncodeSamples); rows of the
    // float32 layout are still read. No table changes: the version keeps an older tscd from
    // reading views it cannot decode.
    R"sql(
SELECT 1;
)sql",
    // Version 5: the revisits seen so far that showed two places holding one room
    // (core/pipeline/copy_evidence.h), so that a restart between laps does not forget them.
    R"sql(
CREATE TABLE copy_evidence(
  a_robot INTEGER NOT NULL, a_local INTEGER NOT NULL,
  b_robot INTEGER NOT NULL, b_local INTEGER NOT NULL,
  count INTEGER NOT NULL,           -- revisits that showed the pair
  last INTEGER NOT NULL,            -- detected place index of the latest
  PRIMARY KEY(a_robot, a_local, b_robot, b_local)) WITHOUT ROWID;
)sql",
    // Version 6: the place bodies of the peer memories merged last (issue 23), so the next
    // exchange with a peer, after a restart too, fetches only what changed; tscd kept them in
    // memory before, a second copy of each peer's memory.
    R"sql(
CREATE TABLE peer_bodies(
  robot INTEGER NOT NULL,
  digest INTEGER NOT NULL,          -- BodyDigest: SHA-256 prefix of `body`
  body BLOB NOT NULL,               -- learned_place_v2_t, LCM encoding without fingerprint
  PRIMARY KEY(robot, digest));
)sql",
};
static_assert(static_cast<int>(kMigrations.size()) == Store::kSchemaVersion);

}  // namespace

int64_t ReadSchemaVersion(const Db& db) {
  Statement s(db, "SELECT MAX(version) FROM schema_version");
  if (!s.Step()) return 0;
  const Row row(db, s, "schema_version", "max");
  return row.IsNull(0) ? 0 : row.Int(0, "version", 0, std::numeric_limits<int32_t>::max());
}

void Migrate(const Db& db) {
  Transaction tx(db);
  Exec(db, "CREATE TABLE IF NOT EXISTS schema_version(version INTEGER NOT NULL)");
  const int64_t version = ReadSchemaVersion(db);
  if (version > Store::kSchemaVersion) {
    Fail(db, "database schema version " + std::to_string(version) + " is newer than the version " +
                 std::to_string(Store::kSchemaVersion) +
                 " this program knows; refusing to open it");
  }
  if (version == 0) {
    // This code records the version with the first tables it creates: tables without one
    // are another program's, or a tscd database whose version row was lost. Migrating from 0
    // would stop at the first table that exists, with SQLite's "already exists".
    Statement tables(db,
                     "SELECT group_concat(name, ', ') FROM sqlite_master WHERE type = 'table' "
                     "AND name <> 'schema_version' AND name NOT LIKE 'sqlite\\_%' ESCAPE '\\'");
    if (tables.Step() && sqlite3_column_type(tables.get(), 0) != SQLITE_NULL) {
      Fail(db, std::string("no schema version is recorded (table schema_version), yet it holds "
                           "tables (") +
                   reinterpret_cast<const char*>(sqlite3_column_text(tables.get(), 0)) +
                   "): not a tscd database, or one whose version was lost; refusing to change "
                   "it");
    }
  }
  if (version < Store::kSchemaVersion) {
    for (int64_t v = version; v < Store::kSchemaVersion; ++v) {
      Exec(db, kMigrations[static_cast<size_t>(v)]);
    }
    Exec(db, "DELETE FROM schema_version");
    Statement(db, "INSERT INTO schema_version(version) VALUES(?1)")
        .Int(1, Store::kSchemaVersion)
        .Run();
  }
  tx.Commit();
}

}  // namespace tsc::store_internal
