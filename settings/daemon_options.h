#pragma once
// What tscd needs beyond the pipeline: where its memory lives, which camera and motor channel
// it drives (the drivers' own option structs), how it talks on LCM. Plain values; the
// configuration table (settings.h) names and checks them.

#include <string>

#include "core/range.h"
#include "drivers/camera/camera_options.h"
#include "drivers/motor/motor_options.h"
#include "store/store_options.h"

namespace tsc {

/// LCM bus and the memory exchange.
struct BusOptions {
  std::string url = "udpm://239.255.76.67:7667?ttl=0";  ///< host-local multicast
  double announce_period_s = 1.0;
  /// Least time between two broadcasts of a changed memory (requests are answered at once).
  double memory_period_s = 5.0;
  int portion_bytes = 60000;  ///< upper bound of one encoded memory portion (one datagram)
  static constexpr Range kPortionBytesRange{4096, 65000};  ///< below one UDP datagram
  std::string team_key_file;  ///< HMAC key shared by the team; empty = unsigned
  /// With an empty memory, how long to listen for peers before learning (a robot rejoining
  /// with a wiped store takes its old places back first; daemon/join_gate.h); 0 = at once.
  double join_wait_s = 2.0;
};

struct DaemonOptions {
  std::string state_dir = "/var/lib/tscd";  ///< holds memory.db
  /// Base points waiting for the pipeline, a pan sweep's views counting once (drop-oldest
  /// whole sweeps: daemon/frame_queue.h).
  int queue_frames = 8;
  /// Results kept in memory while the store cannot be written (full disk, read-only); beyond
  /// it the oldest results' base point records are dropped (learned places and edges never).
  int max_pending_results = 10000;
  /// Threads a merge of a peer's memory recognises on (the pipeline waits for the merge, so
  /// the robot's other cores shorten the pause); 0 = one per core. The merge is the same for
  /// any number.
  int merge_threads = 0;
  // Valid ranges (also the configuration's, daemon.*).
  static constexpr Range kQueueFramesRange{1, 1000};
  static constexpr Range kMaxPendingResultsRange{1, 10000000};
  static constexpr Range kMergeThreadsRange{0, 64};
  /// At stop, how long tscd keeps trying a failing store before it spills what it holds
  /// (seconds; below the unit's TimeoutStopSec).
  double stop_store_wait_s = 10.0;
  std::string log_level = "info";  ///< trace | debug | info | warn | error
  StoreOptions store;              ///< retention of memory.db (store.*)
  CameraOptions camera;
  SimOptions sim;
  BusOptions bus;
  MotorOptions motor;
  /// merge_threads with 0 resolved: the cores the machine reports (1 where unknown).
  int MergeThreads() const;
  /// Throws std::invalid_argument naming the bad field.
  void Validate() const;
};

}  // namespace tsc
