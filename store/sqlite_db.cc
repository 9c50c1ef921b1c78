#include "store/sqlite_db.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <string_view>
#include <system_error>

namespace tsc::store_internal {
namespace {

/// Why this process cannot write the database `path` (an errno: EACCES, EROFS, ENOTDIR,
/// ENOENT for a missing folder), or 0 when it could: the file when it exists, then the folder,
/// where SQLite makes the file, its -wal and its -shm.
int CannotWriteReason(const std::filesystem::path& path) {
  if (::faccessat(AT_FDCWD, path.c_str(), F_OK, AT_EACCESS) == 0) {
    if (::faccessat(AT_FDCWD, path.c_str(), R_OK | W_OK, AT_EACCESS) != 0) return errno;
  } else if (errno != ENOENT) {
    return errno;
  }
  const std::filesystem::path dir = path.has_parent_path() ? path.parent_path() : ".";
  return ::faccessat(AT_FDCWD, dir.c_str(), W_OK | X_OK, AT_EACCESS) == 0 ? 0 : errno;
}

/// The last failure came from the file system under SQLite (not a full disk: that passes).
bool FileSystemFailure(const Db& db) {
  if (db.handle == nullptr) return false;
  const int primary = sqlite3_errcode(db.handle) & 0xff;
  return primary == SQLITE_IOERR || primary == SQLITE_READONLY || primary == SQLITE_CANTOPEN;
}

/// " (No space left on device)" when the last failure came from the file system: SQLite's own
/// text says "disk I/O error" or "database or disk is full", the operating system's says which.
std::string OsError(const Db& db) {
  const int primary = sqlite3_errcode(db.handle) & 0xff;
  const bool io = primary == SQLITE_IOERR || primary == SQLITE_FULL || primary == SQLITE_CANTOPEN ||
                  primary == SQLITE_READONLY;
  int os_errno = sqlite3_system_errno(db.handle);
  if (primary == SQLITE_CANTOPEN || primary == SQLITE_READONLY) {
    // SQLite falls back to opening read-only after a refused read-write open, so the errno it
    // keeps is that of the fallback (ENOENT for a file not made yet), or none, not why it
    // could not write: ask the system about the file and the folder it makes its files in.
    if (const int why = CannotWriteReason(db.path); why != 0) os_errno = why;
  }
  if (!io || os_errno == 0) return "";
  return " (" + std::system_category().message(os_errno) + ")";
}

/// What a person can do about a file SQLite cannot read as a database, which the store never
/// rewrites: "" for every other failure.
std::string Remedy(const Db& db) {
  switch (sqlite3_errcode(db.handle) & 0xff) {
    case SQLITE_NOTADB:
      return "; the file is not a SQLite database and is left as it is: move it away to start a "
             "new memory, or put back a copy";
    case SQLITE_CORRUPT:
      return "; the database is damaged and is left as it is: put back a copy, or try "
             "`sqlite3 FILE .recover`";
    default:
      return "";
  }
}

}  // namespace

[[noreturn]] void Fail(const Db& db, const std::string& what) {
  throw StoreError(db.path.string() + ": " + what);
}

[[noreturn]] void FailSqlite(const Db& db, const std::string& what) {
  if (db.handle == nullptr) Fail(db, what + ": out of memory");
  throw StoreError(
      db.path.string() + ": " + what + ": " + sqlite3_errmsg(db.handle) + OsError(db) + Remedy(db),
      FileSystemFailure(db));
}

void Exec(const Db& db, const char* sql) {
  char* message = nullptr;
  if (sqlite3_exec(db.handle, sql, nullptr, nullptr, &message) != SQLITE_OK) {
    const std::string text =
        (message ? message : sqlite3_errmsg(db.handle)) + OsError(db) + Remedy(db);
    sqlite3_free(message);
    const std::string_view head(sql);
    throw StoreError(
        db.path.string() + ": cannot execute `" + std::string(head.substr(0, 60)) + "`: " + text,
        FileSystemFailure(db));
  }
}

PairRow ReadPairRow(const Db& db, const Statement& s, const char* table) {
  const Row key(db, s, table, "?");
  const PlaceId a = key.Place(0, "a_robot/a_local"), b = key.Place(2, "b_robot/b_local");
  return PairRow{a, b, Row(db, s, table, a.ToString() + "-" + b.ToString())};
}

int64_t PragmaInt(const Db& db, const char* sql) {
  Statement s(db, sql);
  if (!s.Step()) Fail(db, std::string("`") + sql + "` returned nothing");
  return sqlite3_column_int64(s.get(), 0);
}

int64_t BytesUsed(const Db& db) {
  return (PragmaInt(db, "PRAGMA page_count") - PragmaInt(db, "PRAGMA freelist_count")) *
         PragmaInt(db, "PRAGMA page_size");
}

}  // namespace tsc::store_internal
