#pragma once
// tscd: one robot's TSC pipeline and spatial memory as a service (DESIGN §6). Three threads:
//   - the event loop (Boost.Asio, the thread that calls Run): LCM, timers, signals, systemd;
//   - the camera thread: reads the camera and never blocks on the pipeline (FrameQueue);
//   - the pipeline worker: runs the TSC loop and commits every result to SQLite.
// The worker hands events to the loop, which alone talks to LCM.

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "core/pipeline/pipeline.h"
#include "daemon/frame_queue.h"
#include "daemon/join_gate.h"
#include "daemon/lcm_bus.h"
#include "daemon/memory_snapshot.h"
#include "daemon/peer_exchange.h"
#include "daemon/system_notifier.h"
#include "daemon/team_key.h"
#include "drivers/base/motor_base.h"
#include "drivers/camera/camera_source.h"
#include "settings/settings.h"
#include "store/store.h"

namespace boost::asio {
class io_context;
}

namespace tsc {

/// Where the settings came from, so SIGHUP can read them again.
struct SettingsSource {
  std::optional<std::filesystem::path> file;
  std::vector<std::string> overrides;
};

/// Counters published in announces and status lines.
struct DaemonCounters {
  std::atomic<int64_t> frames{0};             ///< base points processed
  std::atomic<int64_t> camera_errors{0};      ///< frames the camera could not deliver
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

/// The channel families tscd publishes on, for its traffic counters (TSC_STATS_<robot>).
enum class ChannelFamily { kAnnounce, kMemory, kRequest, kEvent, kStats };
inline constexpr int kChannelFamilies = 5;
/// "TSC_ANNOUNCE", "TSC_MEMORY", … (the channel without its robot suffix).
const char* ChannelFamilyName(ChannelFamily family);

/// Messages and bytes sent and received on one channel family.
struct ChannelTraffic {
  int64_t sent = 0;
  int64_t sent_bytes = 0;
  int64_t received = 0;  ///< authentic messages of other robots
  int64_t received_bytes = 0;
};

class Daemon {
 public:
  /// Opens the state directory and the store (loading the saved memory), LCM and the camera.
  /// A store that cannot be opened does not stop the daemon: it runs without persistence,
  /// keeps every result, and retries (see Status()). Throws std::runtime_error when LCM
  /// cannot start. `base`, when given, is the robot's motor channel: commands from
  /// JAGUAR_CMD_<robot>, odometry on JAGUAR_STATE_<robot>; the camera may read its pose.
  /// `team_key`, when given, signs every exchange message (announce, memory portion,
  /// request) and is required of every peer's; without it nothing is signed or checked.
  Daemon(Settings settings, SettingsSource source, std::unique_ptr<CameraSource> camera,
         std::unique_ptr<MotorBase> base = nullptr, std::optional<TeamKey> team_key = {});
  ~Daemon();
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  /// Runs until SIGTERM / SIGINT (or Stop()), then finishes the stream, commits and returns
  /// the exit code: 0, or 1 when results could not be stored before exit (spilled beside the
  /// database or in $RUNTIME_DIRECTORY for the next start, or lost; logged either way).
  int Run();
  /// Thread-safe request to stop, as SIGTERM.
  void Stop();

  const DaemonCounters& counters() const { return counters_; }

 private:
  // The views of one base point (a pan sweep's, whole); none: the camera ended.
  using BasePoint = FrameQueue<CameraFrame>::BasePoint;

  // Event loop side.
  void StartTimers();
  void WaitLcm();
  void OnAnnounceTimer();
  void OnStatusTimer();
  void OnWatchdogTimer();
  void OnMotorTimer();
  void OnMotorCommand(const std::string& channel, const uint8_t* data, size_t size);
  void OnSignal(int signal);
  void OnRequest(const std::string& channel, const uint8_t* data, size_t size);
  void OnPeerAnnounce(const std::string& channel, const uint8_t* data, size_t size);
  void OnPeerPortion(const std::string& channel, const uint8_t* data, size_t size);
  void OnExchangeTimer();
  void OnJoinTimer();
  void OnPeerSnapshot(PeerSnapshot snapshot);
  /// Decodes an exchange message and checks its signature; counts and logs what it drops.
  template <typename T>
  std::optional<T> Authentic(const std::string& channel, const uint8_t* data, size_t size,
                             const char* what);
  template <typename T>
  bool PublishSigned(ChannelFamily family, const std::string& channel, T msg);
  /// Publishes and counts the message in its family's traffic.
  template <typename T>
  bool PublishCounted(ChannelFamily family, const std::string& channel, const T& msg);
  void CountReceived(ChannelFamily family, size_t bytes);
  void PublishFailed(const std::string& channel);
  void PublishStats(int64_t utime);
  void PublishEvents(const std::vector<PlaceEvent>& events, int64_t utime);
  /// Rebuilds the snapshot when the memory changed since; true when it did.
  bool RefreshSnapshot();
  void PublishMemoryIfChanged();
  void PublishPortions(const std::vector<int32_t>& indices);
  void Reload();
  void Shutdown();
  std::string StatusLine() const;

  // Camera thread.
  void CameraLoop();
  // Worker thread.
  void WorkerLoop();
  void Handle(BasePoint views);
  void CommitOrKeep(FrameResult result);
  void MergePeers();
  void MergePeer(const PeerSnapshot& snapshot);
  void PublishMerged(std::vector<std::pair<PlaceId, PlaceId>> absorbed, int64_t utime);
  /// Commits what is kept (results, a merge) when the store works; while it fails, at most
  /// once a second unless `now`.
  void RetryStore(bool now = false);
  /// Opens the store again (after it failed to open, or was closed after a file system
  /// failure); true when it is open.
  bool ReopenStore();
  /// One bounded retention step (Store::Maintain with store.*) once a second (five a second
  /// while it is behind), while the store works and holds every result.
  void MaintainStore();
  /// At stop, after the worker: waits up to daemon.stop_store_wait_s for the store, then
  /// spills; the exit code.
  int SaveBeforeExit();
  /// At start: takes earlier spills into the freshly opened `store`.
  void ReplaySpills(Store& store);

  Settings settings_;
  SettingsSource source_;
  std::unique_ptr<MotorBase> base_;  // before camera_: a simulated camera reads its pose
  std::unique_ptr<CameraSource> camera_;
  const uint32_t robot_;
  const int64_t boot_id_;
  const std::filesystem::path db_path_;

  std::unique_ptr<boost::asio::io_context> io_;
  struct Loop;  // Asio objects (signals, timers, LCM descriptor), kept out of this header
  std::unique_ptr<Loop> loop_;
  LcmBus bus_;
  SystemNotifier notifier_;

  // Owned by the worker once it runs; the mutex lets the loop take snapshots.
  mutable std::mutex pipeline_mutex_;
  std::unique_ptr<Pipeline> pipeline_;
  std::unique_ptr<JoinGate> join_;  ///< the camera waits here while a fresh robot listens
  std::optional<Store> store_;
  std::vector<FrameResult> pending_;        // results not yet committed (store missing or failing)
  std::optional<PeerMerge> unsaved_merge_;  // a merged memory the store has not taken yet
  bool replace_knowledge_ = false;          // results were dropped: write the whole memory
  // Base point the store's last commit reached; nullopt while it never opened.
  std::optional<int64_t> committed_next_base_;
  std::atomic<int64_t> pending_results_{0};  // pending_.size(), for the status line
  std::mutex inbox_mutex_;
  std::vector<PeerSnapshot> merge_inbox_;  // complete peer memories waiting for the worker
  std::string store_problem_;              // "" when the store works
  std::chrono::steady_clock::time_point next_store_retry_{};
  std::chrono::steady_clock::time_point next_maintenance_{};  // Maintain at most once a second
  int64_t base_points_thinned_ = 0;                           // by Maintain since the start

  FrameQueue<CameraFrame> queue_;
  std::atomic<bool> stopping_{false};
  int exit_code_ = 0;
  std::atomic<bool> camera_ended_{false};
  std::atomic<int64_t> worker_heartbeat_ms_{0};
  std::atomic<bool> degraded_store_{false};
  std::atomic<bool> degraded_camera_{false};
  DaemonCounters counters_;

  std::optional<TeamKey> team_key_;
  PeerExchange exchange_;                           // loop thread only
  std::shared_ptr<const MemorySnapshot> snapshot_;  // loop thread only
  std::chrono::steady_clock::time_point last_memory_broadcast_{};
  int64_t announces_sent_ = 0;
  std::array<ChannelTraffic, kChannelFamilies> traffic_{};  // loop thread only
  const std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();
  int64_t last_rejected_logged_ = 0;

  std::thread camera_thread_;
  std::thread worker_thread_;
};

}  // namespace tsc
