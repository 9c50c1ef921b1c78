#pragma once
// The store's SQLite connection, internal to tscd::store: prepared statements, transactions and
// typed, checked access to a row's cells. Every failure throws StoreError naming the database
// file (and, for a cell, its table, row and column), with the operating system's reason when
// the file system refused.

#include <sqlite3.h>

#include <cstdint>
#include <filesystem>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "core/memory/place_id.h"
#include "store/blob.h"
#include "store/store.h"

namespace tsc::store_internal {

/// The open connection and the file name every message carries.
struct Db {
  sqlite3* handle;
  const std::filesystem::path& path;
};

/// Throws StoreError "<path>: <what>".
[[noreturn]] void Fail(const Db& db, const std::string& what);
/// Throws StoreError with SQLite's message for the last failure and the system's reason.
[[noreturn]] void FailSqlite(const Db& db, const std::string& what);
/// Runs `sql` (statements without results).
void Exec(const Db& db, const char* sql);

/// A prepared statement, finalised on destruction.
class Statement {
 public:
  Statement(const Db& db, const char* sql) : db_(db) {
    if (sqlite3_prepare_v2(db.handle, sql, -1, &stmt_, nullptr) != SQLITE_OK) {
      FailSqlite(db, std::string("cannot prepare `") + sql + "`");
    }
  }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  ~Statement() { sqlite3_finalize(stmt_); }

  Statement& Int(int i, int64_t v) { return Check(sqlite3_bind_int64(stmt_, i, v)); }
  Statement& Real(int i, double v) { return Check(sqlite3_bind_double(stmt_, i, v)); }
  Statement& Null(int i) { return Check(sqlite3_bind_null(stmt_, i)); }
  Statement& Text(int i, const char* text) {
    return Check(sqlite3_bind_text(stmt_, i, text, -1, SQLITE_TRANSIENT));
  }
  Statement& Blob(int i, const Bytes& bytes) {
    static const unsigned char kEmpty = 0;  // a null pointer would bind NULL, not an empty blob
    return Check(sqlite3_bind_blob64(stmt_, i, bytes.empty() ? &kEmpty : bytes.data(), bytes.size(),
                                     SQLITE_TRANSIENT));
  }
  /// Binds robot at i and local at i + 1 (NULLs when absent).
  Statement& Place(int i, const std::optional<PlaceId>& id) {
    if (!id) return Null(i).Null(i + 1);
    return Int(i, id->robot).Int(i + 1, id->local);
  }

  /// True when a row is ready; false when the statement is done.
  bool Step() {
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    FailSqlite(db_, std::string("cannot run `") + sqlite3_sql(stmt_) + "`");
  }
  /// Runs a statement that returns no rows and makes it ready for new bindings.
  void Run() {
    while (Step()) {
    }
    Reset();
  }
  void Reset() {
    sqlite3_reset(stmt_);
    sqlite3_clear_bindings(stmt_);
  }
  sqlite3_stmt* get() const { return stmt_; }

 private:
  Statement& Check(int rc) {
    if (rc != SQLITE_OK)
      FailSqlite(db_, std::string("cannot bind to `") + sqlite3_sql(stmt_) + "`");
    return *this;
  }

  Db db_;
  sqlite3_stmt* stmt_ = nullptr;
};

/// BEGIN IMMEDIATE … COMMIT; rolls back unless Commit() succeeded (on exceptions too).
class Transaction {
 public:
  explicit Transaction(const Db& db) : db_(db) { Exec(db_, "BEGIN IMMEDIATE"); }
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  ~Transaction() {
    if (!committed_) sqlite3_exec(db_.handle, "ROLLBACK", nullptr, nullptr, nullptr);
  }
  void Commit() {
    Exec(db_, "COMMIT");
    committed_ = true;
  }

 private:
  Db db_;
  bool committed_ = false;
};

/// The current row of a query, with checked typed access: every failure names the table, the
/// row and the column.
class Row {
 public:
  Row(const Db& db, const Statement& stmt, std::string table, std::string row)
      : db_(db), stmt_(stmt.get()), table_(std::move(table)), row_(std::move(row)) {}

  [[noreturn]] void Fail(const char* column, const std::string& what) const {
    store_internal::Fail(db_,
                         "table " + table_ + ", row " + row_ + ", column " + column + ": " + what);
  }

  bool IsNull(int col) const { return sqlite3_column_type(stmt_, col) == SQLITE_NULL; }

  int64_t Int(int col, const char* name, int64_t lo = std::numeric_limits<int64_t>::min(),
              int64_t hi = std::numeric_limits<int64_t>::max()) const {
    if (sqlite3_column_type(stmt_, col) != SQLITE_INTEGER) Fail(name, "not an integer");
    const int64_t v = sqlite3_column_int64(stmt_, col);
    if (v < lo || v > hi) {
      Fail(name,
           std::to_string(v) + " outside [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    }
    return v;
  }
  std::optional<int64_t> OptionalInt(int col, const char* name, int64_t lo, int64_t hi) const {
    if (IsNull(col)) return std::nullopt;
    return Int(col, name, lo, hi);
  }
  double Real(int col, const char* name) const {
    const int type = sqlite3_column_type(stmt_, col);
    if (type != SQLITE_FLOAT && type != SQLITE_INTEGER) Fail(name, "not a number");
    return sqlite3_column_double(stmt_, col);
  }
  PlaceId Place(int col, const char* name) const {
    std::optional<PlaceId> id = OptionalPlace(col, name);
    if (!id) Fail(name, "no place");
    return *id;
  }
  /// Robot at `col`, local at `col + 1`; both NULL → none.
  std::optional<PlaceId> OptionalPlace(int col, const char* name) const {
    constexpr int64_t kMax = std::numeric_limits<uint32_t>::max();
    if (IsNull(col) && IsNull(col + 1)) return std::nullopt;
    return PlaceId{static_cast<uint32_t>(Int(col, name, 0, kMax)),
                   static_cast<uint32_t>(Int(col + 1, name, 0, kMax))};
  }

  /// Runs `decode(BlobReader&)` over a BLOB column; decoding errors name the cell.
  template <typename F>
  auto Decode(int col, const char* name, F&& decode) const {
    if (sqlite3_column_type(stmt_, col) != SQLITE_BLOB) Fail(name, "not a blob");
    BlobReader reader = Reader(col);
    try {
      return decode(reader);
    } catch (const BlobError& e) {
      Fail(name, e.what());
    }
  }
  template <Arithmetic T>
  std::vector<T> Array(int col, const char* name) const {
    return Decode(col, name, [](BlobReader& r) { return r.TakeRest<T>(); });
  }
  /// Array's values, or nullopt where the cell holds none (not a blob, or a size that is no
  /// multiple of T): for a read that passes over a damaged cell instead of failing.
  template <Arithmetic T>
  std::optional<std::vector<T>> ArrayIfReadable(int col) const {
    if (sqlite3_column_type(stmt_, col) != SQLITE_BLOB) return std::nullopt;
    BlobReader reader = Reader(col);
    try {
      return reader.TakeRest<T>();
    } catch (const BlobError&) {
      return std::nullopt;
    }
  }

 private:
  BlobReader Reader(int col) const {
    const auto* data = static_cast<const unsigned char*>(sqlite3_column_blob(stmt_, col));
    const int size = sqlite3_column_bytes(stmt_, col);
    return BlobReader(std::span<const unsigned char>(data, data ? static_cast<size_t>(size) : 0));
  }

  Db db_;
  sqlite3_stmt* stmt_;
  std::string table_;
  std::string row_;
};

/// A row keyed by two places (columns 0-3: a_robot, a_local, b_robot, b_local), named by them
/// for the errors of its other columns.
struct PairRow {
  PlaceId a, b;
  Row row;
};
PairRow ReadPairRow(const Db& db, const Statement& s, const char* table);

/// The integer a pragma (or any one-value query) returns.
int64_t PragmaInt(const Db& db, const char* sql);

/// Pages in use (not on the free list) x page size.
int64_t BytesUsed(const Db& db);

}  // namespace tsc::store_internal
