#pragma once
// tscd's pipeline worker (DESIGN §6): the thread that owns the TSC pipeline and the store. It
// takes base points from the camera's queue and peer memories from its merge inbox, commits
// every result and merge to SQLite (keeping them, retrying, reopening the store while it
// fails, spilling them at stop), and hands the event loop what it publishes: place events,
// merges, and immutable snapshots of the memory for peers. Nothing here blocks the loop: the
// loop reaches the worker only through the inbox, the snapshot hand-over and atomics.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "core/pipeline/pipeline.h"
#include "daemon/daemon_counters.h"
#include "daemon/frame_queue.h"
#include "daemon/join_gate.h"
#include "daemon/memory_snapshot.h"
#include "daemon/peer_exchange.h"
#include "daemon/snapshot_assembler.h"
#include "daemon/system_notifier.h"
#include "drivers/camera/camera_source.h"
#include "drivers/dataset/assumed_keyframes_check.h"
#include "drivers/dataset/camera_lens.h"
#include "settings/settings.h"
#include "store/store.h"

namespace tsc {

/// What the worker reports; each is called on the worker thread and must only hand the work
/// over (post it to the event loop).
struct PipelineWorkerHooks {
  /// Place events of one base point (or of the end of the stream) taken at `utime` (µs).
  std::function<void(std::vector<PlaceEvent> events, int64_t utime)> events;
  /// A peer memory was merged: which place (source) went into which (target).
  std::function<void(std::vector<std::pair<PlaceId, PlaceId>> absorbed)> merged;
  /// Merging `robot`'s memory failed: fetch it again.
  std::function<void(int32_t robot)> merge_failed;
  /// The bodies of `robot`'s memory just merged could not be kept (the store failed): the next
  /// exchange with it fetches them.
  std::function<void(int32_t robot)> bodies_not_kept;
  /// A snapshot asked for by RequestSnapshot() is ready in snapshot().
  std::function<void()> snapshot_ready;
};

class PipelineWorker {
 public:
  using BasePoint = FrameQueue<CameraFrame>::BasePoint;

  /// Opens the store under settings.daemon.state_dir (taking in earlier spills, loading the
  /// saved memory) and builds the pipeline for `camera`'s intrinsics and spacing, then the
  /// first snapshot (version 1) of the memory. A store that cannot be opened is logged and
  /// retried later (status()). `header` names the robot and its boot in every snapshot.
  PipelineWorker(const Settings& settings, const CameraSource& camera, SnapshotHeader header,
                 DaemonCounters& counters, FrameQueue<CameraFrame>& queue,
                 PipelineWorkerHooks hooks);
  ~PipelineWorker();
  PipelineWorker(const PipelineWorker&) = delete;
  PipelineWorker& operator=(const PipelineWorker&) = delete;

  /// The peers the loaded store had merged (robot → version and digest); empty after the first
  /// call.
  std::map<uint32_t, PeerMerge> TakeSavedPeers() { return std::exchange(saved_peers_, {}); }
  /// The digests of the peer bodies the store keeps, by robot (the exchange need not fetch
  /// them again), once.
  std::map<uint32_t, std::vector<int64_t>> TakeKeptPeerBodies() {
    return std::exchange(kept_peer_bodies_, {});
  }
  /// Whether the memory was empty at start (a robot that may be rejoining its team).
  bool started_empty() const { return started_empty_; }
  /// Every how many of the camera's base points the pipeline takes one (StrideFor: 1 but for
  /// a camera denser than the calibrated spacing); the camera thread drops the others.
  int base_point_stride() const { return base_point_stride_; }
  /// Whether that stride rests on a speed assumed for the camera's frame rate (neither
  /// camera.spacing_m nor the source says how far apart its frames are): the robot's odometry
  /// may measure it instead.
  bool spacing_assumed() const { return spacing_assumed_; }
  /// Thread-safe: the robot's odometry says its base points lie `metres` apart (the camera
  /// thread's BasePointPicker); before its next base point the pipeline counts τ_p and τ_w,
  /// and scales its step unit, at that spacing (AdaptToSpacing), as for a declared one.
  void MeasuredSpacing(double metres);

  /// Starts the thread; it learns only once `join` is open (the camera waits there) and opens
  /// it after merging a peer memory. It runs until the queue is closed and drained.
  void Start(JoinGate& join);
  /// Waits for the thread to end (after the queue was closed).
  void Join();

  /// Thread-safe: hands a peer memory, all its portions received, to the worker, which checks
  /// it (SnapshotAssembler::Take: its digest over every portion) and merges it; one that fails
  /// the check is counted in messages_rejected and reported to hooks.merge_failed.
  void Enqueue(SnapshotAssembler complete);
  /// Thread-safe: peer memories waiting to be merged.
  size_t inbox_size() const;

  /// Thread-safe: the newest snapshot the worker built; never null. Its version is the
  /// memory version it shows (DaemonCounters::memory_version then).
  std::shared_ptr<const MemorySnapshot> snapshot() const;
  /// Thread-safe: asks for a snapshot of the memory as it is; the worker builds it between
  /// base points and merges (at once when the latest is current) and calls
  /// hooks.snapshot_ready. Cheap; requests made before it builds are served together.
  void RequestSnapshot();

  using Bodies = std::vector<std::shared_ptr<const learned_place_v2_t>>;
  /// Thread-safe: asks for the bodies of places `places` of `snapshot` (one this worker built,
  /// which holds none) as it named them; the worker, which owns the memory they are read from,
  /// reads them between base points and merges and calls `done` on its thread with them in
  /// order, or with none when the memory was replaced since `snapshot` was built (its bodies
  /// are withdrawn: SnapshotBodies::BeforeReplace). Before Start() and once the thread has
  /// ended, at once on the calling thread.
  void RequestBodies(std::shared_ptr<const MemorySnapshot> snapshot, std::vector<int32_t> places,
                     std::function<void(Bodies)> done);

  /// Thread-safe: true while the store fails or is missing (results are kept meanwhile).
  bool store_degraded() const { return degraded_store_; }
  /// Thread-safe: results not yet in the store.
  int64_t pending_results() const { return pending_results_; }
  /// Thread-safe: monotonic ms of the worker's last sign of life.
  int64_t heartbeat_ms() const { return heartbeat_ms_; }

  /// After Join(), on the calling thread: waits up to daemon.stop_store_wait_s for the store
  /// (telling `notifier`), then spills what it has not taken; the exit code.
  int SaveBeforeExit(SystemNotifier& notifier);

 private:
  void Loop();
  // settings_.pipeline for base points `spacing` apart (AdaptToSpacing), saying so in the log,
  // and for the camera's lens (AdaptToLens).
  PipelineOptions AdaptedTo(const BasePointSpacing& spacing) const;
  // Readapts the pipeline to the spacing MeasuredSpacing gave, if one waits.
  void AdoptMeasuredSpacing();
  void Handle(BasePoint views);
  void CommitOrKeep(FrameResult result);
  void MergePeers();
  void MergeInbox(std::vector<SnapshotAssembler> inbox);
  /// Returns the heap freed by merges and bodies served to the system, once they are over.
  void TrimAfterBursts();
  void MergePeer(PeerSnapshot snapshot);
  /// The peer's memory built for the merge, its kept bodies loaded; nullopt where the ids alone
  /// say the merge leaves ours as it is (only where `stored_as_ours`: ours then stands). Throws
  /// where a kept body cannot be loaded.
  std::optional<PlaceMemory> PeerMemoryToMerge(PeerSnapshot snapshot, bool stored_as_ours);
  // After a merge that failed holding our memory (MergePeer): the store's copy of it becomes the
  // pipeline's again.
  void LoadMemoryBack(const std::string& why);
  /// The bodies of `robot` the store keeps among `digests` (SnapshotAssembler::Take's loader).
  PlaceBodies LoadPeerBodies(int32_t robot, const KnownDigests& digests);
  /// Keeps the bodies of `snapshot`, about to be merged, in the store for the next exchange,
  /// and their names in kept_names_.
  void KeepPeerBodies(const PeerSnapshot& snapshot);
  /// Builds and hands over a snapshot when one was asked for (or `stale`: when the memory
  /// changed since the latest).
  void ServeSnapshot(bool stale);
  void BuildSnapshot();
  /// Answers the bodies asked for (RequestBodies); `last`: the thread takes no more requests.
  void ServeBodies(bool last = false);
  Bodies ReadBodies(const MemorySnapshot& snapshot, const std::vector<int32_t>& places);
  /// Commits what is kept (results, a merge) when the store works; while it fails, at most
  /// once a second unless `now`.
  void RetryStore(bool now = false);
  /// Whether everything learned and merged is in the store's last commit (none kept back).
  bool AllCommitted() const { return pending_.empty() && !unsaved_merge_ && !replace_knowledge_; }
  /// Opens the store again (after it failed to open, or was closed after a file system
  /// failure); true when it is open.
  bool ReopenStore();
  /// One bounded retention step (Store::Maintain with store.*) once a second (five a second
  /// while it is behind), while the store works and holds every result.
  void MaintainStore();
  /// At start: takes earlier spills into the freshly opened `store`.
  void ReplaySpills(Store& store);

  const Settings settings_;
  const SnapshotHeader header_;
  const std::filesystem::path db_path_;
  DaemonCounters& counters_;
  FrameQueue<CameraFrame>& queue_;
  const PipelineWorkerHooks hooks_;
  JoinGate* join_ = nullptr;

  // The worker thread's alone once it runs (before: the constructor's, after: SaveBeforeExit's).
  std::unique_ptr<Pipeline> pipeline_;
  std::optional<Store> store_;
  std::vector<FrameResult> pending_;        // results not yet committed (store missing or failing)
  std::optional<PeerMerge> unsaved_merge_;  // a merged memory the store has not taken yet
  // With unsaved_merge_, when the store held exactly the memory the merge replaced: which
  // places of the merged memory it holds already (UnchangedPositions), so that the commit
  // writes only the others. Dropped after the first attempt: a retry writes everything.
  std::optional<std::vector<char>> stored_unchanged_;
  bool replace_knowledge_ = false;  // results were dropped: write the whole memory
  // Base point the store's last commit reached; nullopt while it never opened.
  std::optional<int64_t> committed_next_base_;
  std::string store_problem_;  // "" when the store works
  std::chrono::steady_clock::time_point next_store_retry_{};
  std::chrono::steady_clock::time_point next_maintenance_{};  // Maintain at most once a second
  int64_t base_points_thinned_ = 0;                           // by Maintain since the start
  std::map<uint32_t, PeerMerge> saved_peers_;
  std::map<uint32_t, std::vector<int64_t>> kept_peer_bodies_;
  // The names of the bodies KeepPeerBodies kept of each peer this run, so that Take need not
  // load them to decide an exchange that changes nothing (empty after a start: the first
  // exchange loads them).
  std::map<int32_t, KeptPlaceNames> kept_names_;
  // The last merge or bodies served, not trimmed since (TrimAfterBursts).
  std::optional<std::chrono::steady_clock::time_point> freed_at_;
  bool started_empty_ = false;
  int base_point_stride_ = 1;
  bool spacing_assumed_ = true;
  CameraLens lens_;  // which the thresholds follow (AdaptToLens)
  AssumedKeyframesCheck keyframes_check_{BasePointSpacing{}, CameraLens()};  // the worker thread's
  std::mutex spacing_mutex_;
  std::optional<double> measured_spacing_m_;  // under spacing_mutex_: not yet adopted

  std::atomic<int64_t> pending_results_{0};  // pending_.size(), for the status line
  std::atomic<bool> degraded_store_{false};
  std::atomic<int64_t> heartbeat_ms_{0};
  std::atomic<bool> snapshot_wanted_{false};

  mutable std::mutex inbox_mutex_;
  std::vector<SnapshotAssembler> merge_inbox_;  // complete peer memories waiting for the worker

  // The hand-over: the worker replaces the pointer, readers copy it; held for nothing else.
  mutable std::mutex snapshot_mutex_;
  std::shared_ptr<const MemorySnapshot> snapshot_;

  // What the snapshots name of the memory, read from it or kept from before a change
  // (the worker thread's, as the memory is).
  SnapshotBodies bodies_;
  struct BodyRequest {
    std::shared_ptr<const MemorySnapshot> snapshot;
    std::vector<int32_t> places;
    std::function<void(Bodies)> done;
  };
  std::mutex body_mutex_;
  std::vector<BodyRequest> body_requests_;  // under body_mutex_
  bool serving_bodies_ = false;             // under body_mutex_: the thread takes requests

  std::thread thread_;
};

}  // namespace tsc
