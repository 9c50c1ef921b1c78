// Fuzz target: a damaged database, loaded as tscd loads it at start. A real store (robot 1's
// learned places in tscd's default view basis, their tree and discriminants, the map, a merged
// peer and that peer's place bodies) is written once per process; each input is a list of
// edits to a fresh copy of it, made through SQLite as a faulty disk, another program or an
// older tscd could leave it:
//   op (1 byte: op % 6), table, column, row (1 byte each, taken modulo what the database has)
//   op 0: the cell becomes an integer (8 bytes, little endian)
//   op 1: the cell becomes a real (8 bytes)
//   op 2: the cell becomes a blob (2-byte length, then as many bytes as the input still has)
//   op 3: bytes of the cell's blob overwritten (2-byte offset, 1-byte length, the bytes)
//   op 4: the row is deleted
//   op 5: the cell becomes NULL
// Edits SQLite refuses (a constraint) are skipped. Then the database is opened and loaded as
// tscd's worker does (Load, the peers, the peer bodies, each decoded against its digest), the
// pipeline is built on what was loaded and its first snapshot taken, and `tsc inspect`'s
// assignments are read. What must hold: the store loads or throws StoreError; the pipeline is
// built or refuses the memory with std::invalid_argument; no crash, no unbounded allocation.

#include <sqlite3.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/memory/builtin_view_basis.h"
#include "core/pipeline/pipeline.h"
#include "daemon/memory_snapshot.h"
#include "fuzz/fuzz_target.h"
#include "store/store.h"
#include "test/support/random_memory.h"

namespace {

namespace fs = std::filesystem;

constexpr uint32_t kRobot = 1;

tsc::PipelineOptions Options() {
  tsc::PipelineOptions o;
  o.robot = kRobot;
  return o;
}

struct Table {
  std::string name;
  std::vector<std::string> columns;
};

// The database every input edits, written once, and its tables; removed when the process
// exits.
struct Seed {
  fs::path dir, db, work;
  std::vector<Table> tables;
  Seed() = default;
  Seed(const Seed&) = delete;
  Seed& operator=(const Seed&) = delete;
  ~Seed() {
    std::error_code ec;
    if (!dir.empty()) fs::remove_all(dir, ec);
  }
};

std::vector<Table> TablesOf(sqlite3* db) {
  std::vector<Table> tables;
  sqlite3_stmt* s = nullptr;
  sqlite3_prepare_v2(db,
                     "SELECT name FROM sqlite_master WHERE type = 'table' AND name NOT LIKE "
                     "'sqlite_%' ORDER BY name",
                     -1, &s, nullptr);
  while (sqlite3_step(s) == SQLITE_ROW) {
    tables.push_back({reinterpret_cast<const char*>(sqlite3_column_text(s, 0)), {}});
  }
  sqlite3_finalize(s);
  for (Table& t : tables) {
    sqlite3_prepare_v2(db, ("PRAGMA table_info(\"" + t.name + "\")").c_str(), -1, &s, nullptr);
    while (sqlite3_step(s) == SQLITE_ROW) {
      t.columns.emplace_back(reinterpret_cast<const char*>(sqlite3_column_text(s, 1)));
    }
    sqlite3_finalize(s);
  }
  return tables;
}

void Write(Seed& s) {
  s.dir = fs::temp_directory_path() / ("tscd-fuzz-store-" + tsc::fuzz::FixedWidthPid());
  fs::remove_all(s.dir);
  fs::create_directories(s.dir);
  s.db = s.dir / "seed.db";
  s.work = s.dir / "work.db";
  const int dim = tsc::BuiltinViewBasis()->input_dimension();
  const tsc::PipelineOptions options = Options();
  const auto ours = tsc::testing_support::MakeRandomMemory(kRobot, 6, dim, 1, 4, options.memory);
  const auto peer = tsc::testing_support::MakeRandomMemory(2, 3, dim, 2, 4, options.memory);
  const tsc::MemorySnapshot snap =
      tsc::BuildSnapshot(peer.memory, peer.map, tsc::SnapshotHeader{2, 7, 1, 0}, 60000);
  std::vector<std::pair<int64_t, std::vector<unsigned char>>> bodies;
  for (const tsc::memory_portion_v2_t& p : tsc::AllPortions(snap)) {
    for (const tsc::learned_place_v2_t& body : p.places) {
      const std::vector<uint8_t> bytes = tsc::EncodeBody(body);
      bodies.emplace_back(tsc::BodyDigest(body),
                          std::vector<unsigned char>(bytes.begin(), bytes.end()));
    }
  }
  {
    tsc::Store store = tsc::Store::Open(s.db);
    store.ReplaceKnowledge(ours.memory, ours.map, tsc::PeerMerge{2, 1, snap.digest, 1});
    store.AddPeerBodies(2, bodies);
  }
  sqlite3* db = nullptr;
  sqlite3_open_v2(s.db.c_str(), &db, SQLITE_OPEN_READWRITE, nullptr);
  s.tables = TablesOf(db);
  sqlite3_close(db);
}

const Seed& TheSeed() {
  static Seed seed;
  if (seed.tables.empty()) Write(seed);
  return seed;
}

class Input {
 public:
  Input(const uint8_t* data, size_t size) : data_(data), size_(size) {}
  bool empty() const { return at_ >= size_; }
  uint8_t Byte() { return at_ < size_ ? data_[at_++] : 0; }
  uint64_t Word(int bytes) {
    uint64_t v = 0;
    for (int i = 0; i < bytes; ++i) v |= uint64_t{Byte()} << (8 * i);
    return v;
  }
  std::vector<uint8_t> Bytes(size_t n) {
    n = std::min(n, size_ - std::min(at_, size_));
    std::vector<uint8_t> out(data_ + at_, data_ + at_ + n);
    at_ += n;
    return out;
  }

 private:
  const uint8_t* data_;
  size_t size_, at_ = 0;
};

// The rowid of row `r` (modulo the rows) of `table`; false when it has none.
bool RowId(sqlite3* db, const std::string& table, int r, int64_t* rowid) {
  sqlite3_stmt* s = nullptr;
  const std::string count = "SELECT COUNT(*) FROM \"" + table + "\"";
  if (sqlite3_prepare_v2(db, count.c_str(), -1, &s, nullptr) != SQLITE_OK) return false;
  const int64_t rows = sqlite3_step(s) == SQLITE_ROW ? sqlite3_column_int64(s, 0) : 0;
  sqlite3_finalize(s);
  if (rows == 0) return false;
  const std::string pick = "SELECT rowid FROM \"" + table + "\" ORDER BY rowid LIMIT 1 OFFSET " +
                           std::to_string(r % rows);
  if (sqlite3_prepare_v2(db, pick.c_str(), -1, &s, nullptr) != SQLITE_OK) return false;
  const bool found = sqlite3_step(s) == SQLITE_ROW;
  if (found) *rowid = sqlite3_column_int64(s, 0);
  sqlite3_finalize(s);
  return found;
}

void Edit(sqlite3* db, const Seed& seed, Input& in) {
  const int op = in.Byte() % 6;
  const Table& t = seed.tables[in.Byte() % seed.tables.size()];
  const std::string& column = t.columns[in.Byte() % t.columns.size()];
  int64_t rowid = 0;
  if (!RowId(db, t.name, in.Byte(), &rowid)) return;
  const std::string where = " WHERE rowid = " + std::to_string(rowid);
  const std::string set = "UPDATE OR IGNORE \"" + t.name + "\" SET \"" + column + "\" = ?1" + where;
  sqlite3_stmt* s = nullptr;
  if (op == 4) {
    sqlite3_exec(db, ("DELETE FROM \"" + t.name + "\"" + where).c_str(), nullptr, nullptr, nullptr);
    return;
  }
  std::vector<uint8_t> blob;
  if (op == 3) {  // the cell's own bytes, partly overwritten
    const std::string get = "SELECT \"" + column + "\" FROM \"" + t.name + "\"" + where;
    if (sqlite3_prepare_v2(db, get.c_str(), -1, &s, nullptr) != SQLITE_OK) return;
    if (sqlite3_step(s) == SQLITE_ROW) {
      const auto* p = static_cast<const uint8_t*>(sqlite3_column_blob(s, 0));
      blob.assign(p, p + sqlite3_column_bytes(s, 0));
    }
    sqlite3_finalize(s);
    const size_t offset = in.Word(2);
    const std::vector<uint8_t> bytes = in.Bytes(in.Byte());
    if (blob.empty()) return;
    for (size_t i = 0; i < bytes.size(); ++i) blob[(offset + i) % blob.size()] = bytes[i];
  } else if (op == 2) {
    blob = in.Bytes(in.Word(2));
  }
  if (sqlite3_prepare_v2(db, set.c_str(), -1, &s, nullptr) != SQLITE_OK) return;
  switch (op) {
    case 0:
      sqlite3_bind_int64(s, 1, static_cast<int64_t>(in.Word(8)));
      break;
    case 1: {
      const uint64_t bits = in.Word(8);
      double v = 0;
      std::memcpy(&v, &bits, sizeof v);
      sqlite3_bind_double(s, 1, v);
      break;
    }
    case 2:
    case 3:
      sqlite3_bind_blob(s, 1, blob.data(), static_cast<int>(blob.size()), SQLITE_TRANSIENT);
      break;
    default:
      sqlite3_bind_null(s, 1);
  }
  sqlite3_step(s);  // a constraint SQLite enforces refuses the edit: skipped
  sqlite3_finalize(s);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const Seed& seed = TheSeed();
  fs::copy_file(seed.db, seed.work, fs::copy_options::overwrite_existing);
  {
    sqlite3* db = nullptr;
    if (sqlite3_open_v2(seed.work.c_str(), &db, SQLITE_OPEN_READWRITE, nullptr) != SQLITE_OK) {
      sqlite3_close(db);
      return 0;
    }
    sqlite3_exec(db, "PRAGMA ignore_check_constraints = 1", nullptr, nullptr, nullptr);
    Input in(data, size);
    for (int edits = 0; !in.empty() && edits < 16; ++edits) Edit(db, seed, in);
    sqlite3_close(db);
  }
  std::optional<tsc::StoredState> loaded;
  try {
    tsc::Store store = tsc::Store::OpenExisting(seed.work);
    loaded.emplace(store.Load(kRobot, Options().memory));
    (void)store.LoadPeers();
    for (const auto& [robot, digests] : store.LoadPeerBodyDigests()) {
      store.ForEachPeerBody(robot, [](int64_t digest, std::span<const unsigned char> bytes) {
        (void)tsc::DecodeBody(bytes, digest);
      });
    }
    (void)store.LoadAssignments();
  } catch (const tsc::StoreError&) {
    return 0;  // the documented way to fail: tscd says so and runs without its store
  }
  try {
    const tsc::Pipeline pipeline(tsc::CameraIntrinsics::FromHorizontalFov(64, 48, 60), Options(),
                                 std::move(loaded->memory), std::move(loaded->map),
                                 loaded->pipeline);
    (void)tsc::BuildSnapshot(pipeline.memory(), pipeline.map(),
                             tsc::SnapshotHeader{kRobot, 1, 1, 0}, 60000);
  } catch (const std::invalid_argument&) {
    // a memory the pipeline cannot take: refused with its reason
  }
  return 0;
}
