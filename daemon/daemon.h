#pragma once
// tscd: one robot's TSC pipeline and spatial memory as a service (DESIGN §6). Three threads:
//   - the event loop (Boost.Asio, the thread that calls Run): LCM, timers, signals, systemd;
//   - the camera thread: reads the camera and never blocks on the pipeline (FrameQueue);
//   - the pipeline worker (PipelineWorker): runs the TSC loop, merges peer memories and
//     commits every result to SQLite.
// The worker hands events and memory snapshots to the loop, which alone talks to LCM and never
// waits for the worker.

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <unordered_set>
#include <vector>

#include "core/pipeline/pipeline.h"
#include "daemon/daemon_counters.h"
#include "daemon/frame_queue.h"
#include "daemon/join_gate.h"
#include "daemon/lcm_bus.h"
#include "daemon/memory_snapshot.h"
#include "daemon/peer_exchange.h"
#include "daemon/pipeline_worker.h"
#include "daemon/system_notifier.h"
#include "daemon/team_bus.h"
#include "daemon/team_key.h"
#include "drivers/base/motor_base.h"
#include "drivers/camera/camera_source.h"
#include "settings/settings.h"
#include "tsc/memory_request_t.hpp"

namespace boost::asio {
class io_context;
}

namespace tsc {

class MotorBridge;

/// Where the settings came from, so SIGHUP can read them again.
struct SettingsSource {
  std::optional<std::filesystem::path> file;
  std::vector<std::string> overrides;
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
  // Event loop side.
  void StartTimers();
  void WaitLcm();
  void OnAnnounceTimer();
  void OnStatusTimer();
  void OnWatchdogTimer();
  void OnSignal(int signal);
  void OnRequest(const std::string& channel, const uint8_t* data, size_t size);
  void OnPeerAnnounce(const std::string& channel, const uint8_t* data, size_t size);
  void OnPeerPortion(const std::string& channel, const uint8_t* data, size_t size);
  void OnExchangeTimer();
  void OnJoinTimer();
  void OnPeerSnapshot(SnapshotAssembler complete);
  void PublishStats(int64_t utime);
  void PublishEvents(const std::vector<PlaceEvent>& events, int64_t utime);
  /// Where snapshot_ stands against the memory: current, replaced by a newer one the worker
  /// handed over, or older with a fresh one asked of the worker (ServeSnapshot runs again once
  /// it is there).
  enum class Refresh { kCurrent, kReplaced, kAwaited };
  Refresh RefreshSnapshot();
  /// The snapshot of `version` the loop still holds (the current or the one before), or null.
  std::shared_ptr<const MemorySnapshot> HeldSnapshot(int64_t version) const;
  /// Serves what waits for a current snapshot (the memory broadcast, peers' requests) when the
  /// worker's snapshot is current; else asks the worker for one and returns.
  void ServeSnapshot();
  /// Broadcasts the memory when it changed since the last snapshot.
  void PublishMemoryIfChanged();
  void BroadcastMemory();
  /// Answers a request OnRequest could not serve from a held snapshot: the whole current
  /// snapshot when it asked for everything, else its structure (the peer then asks for bodies).
  void AnswerRequest(const memory_request_t& req);
  /// Publishes the portions `indices` of `snapshot` from `from` on, ~kBytesPerSlice per turn
  /// of the loop (the rest posted), so timers and LCM run in between; all at once when stopping.
  void PublishPortions(std::shared_ptr<const MemorySnapshot> snapshot, std::vector<int32_t> indices,
                       size_t from = 0);
  void PublishPortion(const memory_portion_v2_t& portion);
  void Reload();
  void Shutdown();
  std::string StatusLine() const;

  /// Publishes a "merged" event per absorbed place from `from` on, a slice per turn of the loop.
  void PublishMerged(std::vector<std::pair<PlaceId, PlaceId>> absorbed, int64_t utime,
                     size_t from = 0);

  // Camera thread.
  void CameraLoop();

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
  DaemonCounters counters_;             // before the parts that count: the worker, team_
  TeamBus team_;                        // loop thread only
  std::unique_ptr<MotorBridge> motor_;  // with a base only
  SystemNotifier notifier_;

  FrameQueue<CameraFrame> queue_;
  std::atomic<bool> stopping_{false};
  int exit_code_ = 0;
  std::atomic<bool> camera_ended_{false};
  std::atomic<bool> degraded_camera_{false};
  std::unique_ptr<PipelineWorker> worker_;  // after queue_ and counters_, which it uses
  std::unique_ptr<JoinGate> join_;          ///< the camera waits here while a fresh robot listens

  PeerExchange exchange_;                           // loop thread only
  std::shared_ptr<const MemorySnapshot> snapshot_;  // loop thread only; the worker's, shared
  // The snapshot snapshot_ replaced: a peer still assembling it gets its missing portions from
  // it, so an exchange completes while the memory keeps learning (loop thread only). Not after
  // a merge or consolidation replaced the memory: its bodies are withdrawn then, and the peer
  // moves on to the current structure (AnswerRequest).
  std::shared_ptr<const MemorySnapshot> previous_snapshot_;
  // Snapshots of this version or older no longer serve bodies (the worker withdrew them when
  // a merge or consolidation replaced the memory): not held, whatever snapshot_ still is.
  int64_t withdrawn_through_ = 0;  // loop thread only
  bool broadcast_wanted_ = false;  // loop thread only
  // The bodies the last broadcast carried or named: the next one sends only bodies beyond them.
  std::unordered_set<int64_t> broadcast_bodies_;    // loop thread only
  bool broadcast_once_ = false;                     // loop thread only: this life broadcast
  std::vector<memory_request_t> waiting_requests_;  // loop thread only: for a fresh snapshot
  // None until this life's first broadcast, which the first announce brings: the steady
  // clock counts from the host's boot, so a time point of zero put a robot started within
  // lcm.memory_period_s of boot out of the team until that much uptime.
  std::optional<std::chrono::steady_clock::time_point> last_memory_broadcast_;
  int64_t announces_sent_ = 0;
  const std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();
  int64_t last_rejected_logged_ = 0;

  std::thread camera_thread_;
};

}  // namespace tsc
