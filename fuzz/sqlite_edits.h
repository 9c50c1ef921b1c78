#pragma once
// A fuzz input read as edits to a SQLite database, made through SQLite as a faulty disk,
// another program or an older tscd could leave the database (fuzz_store, fuzz_spill). The
// input is a list of at most kMaxEdits edits:
//   op (1 byte: op % 6), table, column, row (1 byte each, taken modulo what the database has)
//   op 0: the cell becomes an integer (8 bytes, little endian)
//   op 1: the cell becomes a real (8 bytes)
//   op 2: the cell becomes a blob (2-byte length, then as many bytes as the input still has)
//   op 3: bytes of the cell's blob overwritten (2-byte offset, 1-byte length, the bytes)
//   op 4: the row is deleted
//   op 5: the cell becomes NULL
// Edits SQLite refuses (a constraint it enforces) are skipped; CHECK constraints are not
// enforced, as a damaged file does not honour them either.

#include <sqlite3.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

namespace tsc::fuzz {

inline constexpr int kMaxEdits = 16;

struct SqlTable {
  std::string name;
  std::vector<std::string> columns;
};

namespace sqlite_edits_detail {

class EditInput {
 public:
  EditInput(const uint8_t* data, size_t size) : data_(data), size_(size) {}
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
inline bool RowId(sqlite3* db, const std::string& table, int r, int64_t* rowid) {
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

inline void Edit(sqlite3* db, const std::vector<SqlTable>& tables, EditInput& in) {
  const int op = in.Byte() % 6;
  const SqlTable& t = tables[in.Byte() % tables.size()];
  const std::string& column = t.columns[in.Byte() % t.columns.size()];
  int64_t rowid = 0;
  if (!RowId(db, t.name, in.Byte(), &rowid)) return;
  const std::string where = " WHERE rowid = " + std::to_string(rowid);
  if (op == 4) {
    sqlite3_exec(db, ("DELETE FROM \"" + t.name + "\"" + where).c_str(), nullptr, nullptr, nullptr);
    return;
  }
  sqlite3_stmt* s = nullptr;
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
  const std::string set = "UPDATE OR IGNORE \"" + t.name + "\" SET \"" + column + "\" = ?1" + where;
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

}  // namespace sqlite_edits_detail

/// The tables of the database `path` (by name, SQLite's own left out) and their columns.
inline std::vector<SqlTable> TablesOf(const std::filesystem::path& path) {
  std::vector<SqlTable> tables;
  sqlite3* db = nullptr;
  if (sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE, nullptr) != SQLITE_OK) {
    sqlite3_close(db);
    return tables;
  }
  sqlite3_stmt* s = nullptr;
  sqlite3_prepare_v2(db,
                     "SELECT name FROM sqlite_master WHERE type = 'table' AND name NOT LIKE "
                     "'sqlite_%' ORDER BY name",
                     -1, &s, nullptr);
  while (sqlite3_step(s) == SQLITE_ROW) {
    tables.push_back({reinterpret_cast<const char*>(sqlite3_column_text(s, 0)), {}});
  }
  sqlite3_finalize(s);
  for (SqlTable& t : tables) {
    sqlite3_prepare_v2(db, ("PRAGMA table_info(\"" + t.name + "\")").c_str(), -1, &s, nullptr);
    while (sqlite3_step(s) == SQLITE_ROW) {
      t.columns.emplace_back(reinterpret_cast<const char*>(sqlite3_column_text(s, 1)));
    }
    sqlite3_finalize(s);
  }
  sqlite3_close(db);
  return tables;
}

/// Applies the edits `data` describes to the database `path`, whose tables are `tables`.
inline void ApplyEdits(const std::filesystem::path& path, const std::vector<SqlTable>& tables,
                       const uint8_t* data, size_t size) {
  if (tables.empty()) return;
  sqlite3* db = nullptr;
  if (sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE, nullptr) != SQLITE_OK) {
    sqlite3_close(db);
    return;
  }
  sqlite3_exec(db, "PRAGMA ignore_check_constraints = 1", nullptr, nullptr, nullptr);
  sqlite_edits_detail::EditInput in(data, size);
  for (int edits = 0; !in.empty() && edits < kMaxEdits; ++edits) {
    sqlite_edits_detail::Edit(db, tables, in);
  }
  sqlite3_close(db);
}

}  // namespace tsc::fuzz
