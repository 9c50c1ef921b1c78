#pragma once
// What the store keeps of the raw record, and how much maintenance work one step may do
// (issue 23). Header only: the configuration (settings/) fills it without linking SQLite.

#include <cstdint>

#include "core/range.h"

namespace tsc {

/// Retention of the store (Store::Maintain). Learned places (with their member views, the
/// descriptors recognition and merging use), the tree, its discriminants, the map and the
/// peers' versions are kept forever; only the history is thinned: base point records (the
/// raw stream, one ~2.8 KB descriptor per base point, ~5 GB a day at 10 fps), and with them
/// the detected places and transition regions none of whose base points is kept.
struct StoreOptions {
  /// Size the database may use (MiB) before the oldest base point records are deleted; 0 =
  /// unlimited (everything is kept, as before issue 23). A size, not an age, because what a
  /// robot runs out of is disk (an age limit would not bound it for a faster camera): the
  /// default keeps about a day of base points at 10 fps (~4 KiB each: ~29 h). When the kept
  /// knowledge alone is larger, every base point record goes and nothing else does.
  int64_t budget_mb = 4096;
  /// Pages (4 KiB each) one maintenance step deletes and hands back to the file system at
  /// most: bounds how long the pipeline waits for a step (tscd runs one a second, five a
  /// second while behind; 1024 pages took 25-40 ms on the development machine).
  int maintenance_pages = 1024;
  static constexpr Range kBudgetMbRange{0, 1e9};
  static constexpr Range kMaintenancePagesRange{1, 1e6};

  /// Throws std::invalid_argument naming the bad field.
  void Validate() const {
    kBudgetMbRange.Check("store.budget_mb", static_cast<double>(budget_mb));
    kMaintenancePagesRange.Check("store.maintenance_pages", maintenance_pages);
  }
};

}  // namespace tsc
