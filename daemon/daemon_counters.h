#pragma once
// The counters tscd's threads update and its announces, stats and status lines publish.

#include <atomic>
#include <cstdint>

namespace tsc {

/// Counters published in announces and status lines.
struct DaemonCounters {
  std::atomic<int64_t> frames{0};             ///< base points processed
  std::atomic<int64_t> camera_errors{0};      ///< frames the camera could not deliver
  std::atomic<int64_t> frames_standing{0};    ///< views skipped while the robot stood still
  std::atomic<int64_t> store_failures{0};     ///< commits that failed (kept and retried)
  std::atomic<int64_t> results_dropped{0};    ///< kept results beyond max_pending_results
  std::atomic<int64_t> messages_rejected{0};  ///< malformed messages on our channels
  std::atomic<int64_t> memory_version{0};     ///< bumped on every memory or map change
  std::atomic<int32_t> places{0};
  std::atomic<int32_t> edges{0};
  std::atomic<int32_t> detected_places{0};
  // Peer exchange and merging (chapter 4).
  std::atomic<int64_t> snapshots_received{0};  ///< complete, checked peer memories
  std::atomic<int64_t> merges_completed{0};    ///< merged, or found to bring nothing new
  std::atomic<int64_t> merges_changed{0};      ///< merges that changed our memory
  std::atomic<int64_t> merges_failed{0};       ///< merges that threw; the peer is fetched again
  std::atomic<int32_t> pending_commits{0};     ///< results not yet in the store
  std::atomic<int64_t> publish_failures{0};    ///< sends LCM refused (socket error, filter)
};

}  // namespace tsc
