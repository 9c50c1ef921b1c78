#pragma once
// The store's schema (internal to tscd::store): the steps that take a database from one
// version to the next, and Migrate, which applies those it lacks.

#include <cstdint>

#include "store/sqlite_db.h"

namespace tsc::store_internal {

/// Brings the database to Store::kSchemaVersion in one transaction; refuses (StoreError) a
/// database of a newer version than this program knows.
void Migrate(const Db& db);

/// The database's schema version (0 for a new one).
int64_t ReadSchemaVersion(const Db& db);

}  // namespace tsc::store_internal
