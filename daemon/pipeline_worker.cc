#include "daemon/pipeline_worker.h"

#include <fcntl.h>
#include <malloc.h>
#include <spdlog/spdlog.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <optional>
#include <set>
#include <string_view>
#include <system_error>
#include <utility>

#include "core/memory/descriptor_space_mismatch.h"
#include "core/memory/unchanged_places.h"
#include "core/merge/merge.h"
#include "core/merge/merge_maps.h"
#include "daemon/log_throttle.h"
#include "drivers/dataset/base_point_spacing.h"
#include "drivers/dataset/lens_response.h"

namespace tsc {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

// A failing store (full disk, read-only or broken file system, one that would not open) is
// tried again this often, not on every frame: each attempt writes every kept result.
constexpr int kStoreRetrySeconds = 1;

// Exit code of a stop that left results out of the store (spilled or lost): runtime failure.
constexpr int kExitUnsaved = 1;

// Where a stopping tscd whose store fails writes what it holds (Store::WriteSpill), in order:
// beside the database, then the runtime folder systemd gives the unit (RuntimeDirectory=,
// kept across restarts), which survives a state directory that cannot be written.
std::vector<fs::path> SpillFolders(const fs::path& db_path) {
  std::vector<fs::path> out = {db_path.parent_path()};
  if (const char* runtime = std::getenv("RUNTIME_DIRECTORY"); runtime != nullptr && *runtime) {
    const std::string first = std::string(runtime).substr(0, std::string(runtime).find(':'));
    if (fs::path(first) != out.front()) out.emplace_back(first);
  }
  return out;
}

constexpr const char* kSpillPrefix = "memory.db.spill.";

// Absorptions a merge's log line names before it counts the rest.
constexpr size_t kLoggedAbsorptions = 20;

// Which place went into which, and at what cost, for the log: the first ones only (a merge of
// two large memories absorbs thousands, and a 10⁴-place peer made one log line of 260 KB). The
// place events published after the merge and the merged places' sources keep every one.
std::string AbsorptionsForTheLog(const std::vector<Absorption>& absorbed) {
  std::string out;
  for (size_t i = 0; i < std::min(absorbed.size(), kLoggedAbsorptions); ++i) {
    const Absorption& a = absorbed[i];
    out += fmt::format("{}{} into {} ({})", out.empty() ? "" : ", ", a.source.ToString(),
                       a.target.ToString(),
                       a.cost > 0.0 ? fmt::format("g {:.2f}", a.cost) : "joined by ids");
  }
  if (absorbed.size() > kLoggedAbsorptions) {
    out += fmt::format(" and {} more", absorbed.size() - kLoggedAbsorptions);
  }
  return out;
}

// The spills waiting in `folders`, oldest first (their names end in the writer's wall time).
std::vector<fs::path> FindSpills(const std::vector<fs::path>& folders) {
  std::vector<std::pair<std::string, fs::path>> found;
  for (const fs::path& folder : folders) {
    std::error_code ec;
    for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
      const std::string name = it->path().filename().string();
      if (!name.starts_with(kSpillPrefix)) continue;
      // memory.db.spill.<digits>: not a half-written one (.partial), nor SQLite's -wal, -shm.
      const std::string stamp = name.substr(std::string_view(kSpillPrefix).size());
      if (stamp.empty() || stamp.size() > 20 ||
          !std::all_of(stamp.begin(), stamp.end(), [](char c) { return c >= '0' && c <= '9'; })) {
        continue;
      }
      found.emplace_back(std::string(20 - stamp.size(), '0') + stamp, it->path());
    }
  }
  std::sort(found.begin(), found.end());
  std::vector<fs::path> out;
  for (auto& [key, path] : found) out.push_back(std::move(path));
  return out;
}

/// What the file system under `dir` says when a small file is written there, for a failing
/// store's log line: SQLite's own text ("disk I/O error") tells neither a full disk from a
/// read-only file system nor either from a failing device.
std::string FileSystemState(const fs::path& dir) {
  const fs::path probe = dir / ".tscd-write-probe";
  const auto describe = [&](int error) {
    return dir.string() + ": " + std::system_category().message(error);
  };
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) return describe(errno);
  const char byte = 0;
  const bool written = ::write(fd, &byte, 1) == 1 && ::fsync(fd) == 0;
  const int error = errno;
  ::close(fd);
  ::unlink(probe.c_str());
  if (!written) return describe(error);
  struct statvfs st {};
  if (::statvfs(dir.c_str(), &st) != 0) return describe(errno);
  return dir.string() + ": writable, " + std::to_string(st.f_bavail * st.f_frsize / 1024) +
         " KiB free";
}

}  // namespace

PipelineWorker::PipelineWorker(const Settings& settings, const CameraSource& camera,
                               SnapshotHeader header, DaemonCounters& counters,
                               FrameQueue<CameraFrame>& queue, PipelineWorkerHooks hooks)
    : settings_(settings),
      header_(header),
      db_path_(fs::path(settings_.daemon.state_dir) / "memory.db"),
      counters_(counters),
      queue_(queue),
      hooks_(std::move(hooks)) {
  PlaceMemory memory(header_.robot, settings_.pipeline.memory);
  TopologicalMap map;
  PipelineState state;
  try {
    std::error_code ec;
    fs::create_directories(settings_.daemon.state_dir, ec);
    if (ec) {
      throw StoreError("cannot create the state directory " + settings_.daemon.state_dir + ": " +
                       ec.message());
    }
    Store store = Store::Open(db_path_);
    ReplaySpills(store);
    // A store of 10⁵ places restores in seconds: on the cores a merge uses.
    const auto load_start = Clock::now();
    const int load_threads = settings_.daemon.MergeThreads();
    StoredState saved = store.Load(header_.robot, settings_.pipeline.memory, load_threads);
    const double load_s = std::chrono::duration<double>(Clock::now() - load_start).count();
    memory = std::move(saved.memory);
    map = std::move(saved.map);
    state = saved.pipeline;
    saved_peers_ = store.LoadPeers();
    kept_peer_bodies_ = store.LoadPeerBodyDigests();
    if (!store.EnableIncrementalVacuum() && settings_.daemon.store.budget_mb > 0) {
      spdlog::warn(
          "{} predates incremental vacuum and is too large to convert at start: base point "
          "records beyond store.budget_mb free pages that are reused, so the file stops "
          "growing but does not shrink; convert it with tscd stopped (docs/reliability.md)",
          db_path_.string());
    }
    store_ = std::move(store);
    committed_next_base_ = state.next_base;
    spdlog::info(
        "memory loaded from {} in {:.1f} s on {} thread(s): {} places, {} map edges, {} pairs "
        "of places with copy evidence, continuing at base point {}",
        db_path_.string(), load_s, load_threads, memory.places().size(), map.edges().size(),
        state.copies.size(), state.next_base);
  } catch (const DescriptorSpaceMismatch&) {
    // Learned under another configuration: no retry opens it, and a run beside it would learn
    // what cannot be joined with it. tscd stops with a configuration error; the store is kept.
    throw;
  } catch (const std::exception& e) {
    // Keep running (recognition and learning go on in memory) and keep every result for the
    // day the store opens; never touch a database we could not read.
    store_problem_ = e.what();
    degraded_store_ = true;
    next_store_retry_ = Clock::now() + std::chrono::seconds(kStoreRetrySeconds);
    spdlog::error(
        "memory is not persisted: {}; tscd keeps running, keeps its results and "
        "retries every {} s",
        store_problem_, kStoreRetrySeconds);
    for (const fs::path& spill : FindSpills(SpillFolders(db_path_))) {
      spdlog::error(
          "{} waits to be taken in, which needs the store: this run starts without it, and what "
          "it learns cannot be joined with it later; stop tscd and repair the store first",
          spill.string());
    }
  }
  counters_.places = static_cast<int32_t>(memory.places().size());
  counters_.edges = static_cast<int32_t>(map.edges().size());
  counters_.detected_places = static_cast<int32_t>(state.next_detected - 1);
  counters_.memory_version = 1;
  heartbeat_ms_ = SteadyMs();
  const std::optional<BasePointSpacing> declared = camera.spacing();
  const BasePointSpacing frames =
      ResolveSpacing(settings_.daemon.camera.spacing_m, declared ? &*declared : nullptr,
                     settings_.daemon.camera.fps / camera.paced_frames_per_base_point());
  const auto [stride, spacing] = BasePointsOf(frames);
  base_point_stride_ = stride;
  spacing_assumed_ = !(settings_.daemon.camera.spacing_m > 0.0) && !declared;
  lens_ = CameraLens::Of(camera.intrinsics(), camera.views_per_base_point());
  const PipelineOptions pipeline = AdaptedTo(spacing);
  if (const std::optional<std::string> note = LensNote(pipeline, lens_)) {
    spdlog::info("{}", *note);
  }
  if (const std::optional<std::string> caution = LensCaution(lens_)) {
    spdlog::warn("{}", *caution);
  }
  keyframes_check_ = AssumedKeyframesCheck(spacing, lens_);
  started_empty_ = memory.places().empty();
  try {
    pipeline_ = std::make_unique<Pipeline>(camera.intrinsics(), pipeline, std::move(memory),
                                           std::move(map), state);
    pipeline_->RequireMemoryOfTheseFeatures();
  } catch (const DescriptorSpaceMismatch& e) {
    throw DescriptorSpaceMismatch(db_path_.string() + ": " + e.what());
  }
  pipeline_->set_before_update(
      [this](int place) { bodies_.BeforeUpdate(pipeline_->memory(), place); });
  pipeline_->set_before_replace([this] { bodies_.BeforeReplace(); });
  BuildSnapshot();  // version 1, what the first announce names
}

PipelineOptions PipelineWorker::AdaptedTo(const BasePointSpacing& spacing) const {
  PipelineOptions pipeline = settings_.pipeline;
  AdaptToSpacing(pipeline, spacing);
  AdaptToLens(pipeline, lens_);
  spdlog::info("base points {:.3g} m apart ({}): places of {} base points or fewer are pruned",
               spacing.metres, spacing.basis, pipeline.detector.EffectiveTauP());
  if (const std::optional<std::string> note = SparseCameraNote(pipeline, spacing)) {
    spdlog::info("sparse camera: {}", *note);
  }
  if (const std::optional<std::string> caution = SpacingCaution(spacing)) {
    spdlog::warn("{}", *caution);
  }
  return pipeline;
}

void PipelineWorker::MeasuredSpacing(double metres) {
  std::lock_guard lock(spacing_mutex_);
  measured_spacing_m_ = metres;
}

void PipelineWorker::AdoptMeasuredSpacing() {
  std::optional<double> metres;
  {
    std::lock_guard lock(spacing_mutex_);
    metres = std::exchange(measured_spacing_m_, std::nullopt);
  }
  if (!metres) return;
  const PipelineOptions pipeline = AdaptedTo(BasePointSpacing{*metres, "by odometry"});
  pipeline_->Readapt(pipeline.detector, pipeline.memory.step_unit);
}

PipelineWorker::~PipelineWorker() {
  // Normally joined at stop; this covers a start that failed after Start().
  queue_.Close();
  Join();
}

void PipelineWorker::Start(JoinGate& join) {
  join_ = &join;
  {
    std::lock_guard lock(body_mutex_);
    serving_bodies_ = true;
  }
  thread_ = std::thread([this] { Loop(); });
}

void PipelineWorker::Join() {
  if (thread_.joinable()) thread_.join();
}

void PipelineWorker::Enqueue(SnapshotAssembler complete) {
  {
    std::lock_guard lock(inbox_mutex_);
    merge_inbox_.push_back(std::move(complete));
  }
  // Merged now rather than after the next base point or the idle wait (up to 0.5 s).
  queue_.Wake();
}

size_t PipelineWorker::inbox_size() const {
  std::lock_guard lock(inbox_mutex_);
  return merge_inbox_.size();
}

std::shared_ptr<const MemorySnapshot> PipelineWorker::snapshot() const {
  std::lock_guard lock(snapshot_mutex_);
  return snapshot_;
}

void PipelineWorker::RequestSnapshot() {
  if (snapshot_wanted_.exchange(true)) return;  // asked already, not served yet
  queue_.Wake();
}

void PipelineWorker::RequestBodies(std::shared_ptr<const MemorySnapshot> snapshot,
                                   std::vector<int32_t> places, std::function<void(Bodies)> done) {
  {
    std::lock_guard lock(body_mutex_);
    if (serving_bodies_) {
      body_requests_.push_back({std::move(snapshot), std::move(places), std::move(done)});
      queue_.Wake();
      return;
    }
  }
  // No thread runs: the caller is the memory's owner now (the mutex orders it after the thread).
  done(ReadBodies(*snapshot, places));
}

void PipelineWorker::ServeBodies(bool last) {
  std::vector<BodyRequest> requests;
  {
    std::lock_guard lock(body_mutex_);
    requests.swap(body_requests_);
    if (last) serving_bodies_ = false;  // later requests are served by their caller
  }
  for (BodyRequest& r : requests) r.done(ReadBodies(*r.snapshot, r.places));
  if (!requests.empty()) freed_at_ = Clock::now();
}

PipelineWorker::Bodies PipelineWorker::ReadBodies(const MemorySnapshot& snapshot,
                                                  const std::vector<int32_t>& places) {
  Bodies bodies;
  if (!bodies_.Serves(snapshot)) return bodies;  // withdrawn by a merge or consolidation
  bodies.reserve(places.size());
  for (int32_t place : places) bodies.push_back(bodies_.Body(snapshot, place, pipeline_->memory()));
  return bodies;
}

void PipelineWorker::ServeSnapshot(bool stale) {
  const bool wanted = snapshot_wanted_.exchange(false);
  if (!wanted && !stale) return;
  if (snapshot()->version != counters_.memory_version) BuildSnapshot();
  if (wanted) hooks_.snapshot_ready();
}

// Worker thread (or the constructor): the memory and its version cannot change meanwhile, as
// only this thread changes them. Built outside the hand-over's mutex, which only swaps.
void PipelineWorker::BuildSnapshot() {
  SnapshotHeader header = header_;
  header.version = counters_.memory_version;
  header.utime = NowUtime();
  // The snapshot holds no body (a second copy of the memory): bodies_ serves them. The digests
  // of places unchanged since the last snapshot are taken over, not encoded and hashed again
  // (88 ms a snapshot at 10⁴ places otherwise).
  const std::shared_ptr<const MemorySnapshot> latest = snapshot();
  const std::optional<std::unordered_set<int>> changed =
      latest ? bodies_.ChangedSince(*latest) : std::nullopt;
  auto built = std::make_shared<const MemorySnapshot>(tsc::BuildSnapshotWithoutBodies(
      pipeline_->memory(), pipeline_->map(), header, settings_.daemon.bus.portion_bytes,
      changed ? latest.get() : nullptr, changed ? *changed : std::unordered_set<int>{}));
  bodies_.Track(built);
  std::lock_guard lock(snapshot_mutex_);
  snapshot_ = std::move(built);
}

void PipelineWorker::Loop() {
  for (;;) {
    heartbeat_ms_ = SteadyMs();
    std::optional<BasePoint> item = queue_.Pop(std::chrono::milliseconds(500));
    MergePeers();
    ServeSnapshot(false);
    ServeBodies();
    TrimAfterBursts();
    if (!item) {
      if (queue_.closed()) {
        ServeSnapshot(true);  // the memory as it ends, for the last broadcast at stop
        ServeBodies(true);
        return;
      }
      RetryStore();
      MaintainStore();
      continue;
    }
    try {
      AdoptMeasuredSpacing();
      Handle(std::move(*item));
    } catch (const std::exception& e) {
      // A frame the pipeline refuses (wrong size, say) is logged and skipped.
      const int64_t n = ++counters_.camera_errors;
      if (ShouldLog(n)) spdlog::error("pipeline: frame skipped: {}", e.what());
    }
    MaintainStore();
  }
}

void PipelineWorker::MaintainStore() {
  // Only over a store that holds every result: retention keeps what the stored places need,
  // and a memory not yet written in full (AllCommitted) may need records it would thin.
  if (!store_ || degraded_store_ || !AllCommitted() || Clock::now() < next_maintenance_) {
    return;
  }
  next_maintenance_ = Clock::now() + std::chrono::seconds(1);
  try {
    const MaintenanceStep step = store_->Maintain(settings_.daemon.store);
    // Behind (a database opened over its budget, frames faster than a step a second frees):
    // five steps a second, each bounded (~40 ms for 1024 pages here), until it has caught up.
    if (step.more) next_maintenance_ = Clock::now() + std::chrono::milliseconds(200);
    if (step.base_points_deleted > 0 && base_points_thinned_ == 0) {
      spdlog::info(
          "store {} reached store.budget_mb = {}: the oldest base point records are deleted "
          "from now on (learned places, map and peers are kept)",
          db_path_.string(), settings_.daemon.store.budget_mb);
    }
    base_points_thinned_ += step.base_points_deleted;
    if (step.base_points_deleted > 0 || step.pages_released > 0) {
      spdlog::debug(
          "store maintenance: {} base point records deleted ({} in all), {} pages "
          "released, {:.1f} MiB in use",
          step.base_points_deleted, base_points_thinned_, step.pages_released,
          static_cast<double>(step.bytes_used) / (1 << 20));
    }
  } catch (const std::exception& e) {
    // Not a lost commit (the step rolled back): the next commit shows whether the store works.
    spdlog::warn("store maintenance failed, tried again in {} s: {}", kStoreRetrySeconds, e.what());
    next_maintenance_ = Clock::now() + std::chrono::seconds(kStoreRetrySeconds);
  }
}

void PipelineWorker::Handle(BasePoint views) {
  FrameResult result;
  const int64_t utime = views.empty() ? NowUtime() : views.back().utime;
  if (views.empty()) {
    result = pipeline_->Finish();
  } else {
    // The queue hands over whole sweeps only (FrameQueue), so the first view is the sweep's.
    std::vector<Observation> observations;
    observations.reserve(views.size());
    for (CameraFrame& v : views) observations.push_back(std::move(v.observation));
    result = pipeline_->Process(observations);
    ++counters_.frames;
    if (const std::optional<std::string> caution = keyframes_check_.Add(result.base.descriptor)) {
      spdlog::warn("camera: {}", *caution);
    }
  }
  const PipelineState state = pipeline_->position();
  counters_.places = static_cast<int32_t>(pipeline_->memory().places().size());
  counters_.edges = static_cast<int32_t>(pipeline_->map().edges().size());
  counters_.detected_places = static_cast<int32_t>(state.next_detected - 1);
  bool map_changed = false;
  for (const PlaceEvent& e : result.events) map_changed |= e.kind == EventKind::kMapped;
  const bool changed = result.memory_changed || !result.changed_places.empty() || map_changed;
  std::vector<PlaceEvent> events = result.events;
  CommitOrKeep(std::move(result));
  if (changed) ++counters_.memory_version;
  if (!events.empty()) {
    hooks_.events(std::move(events), utime);
  }
}

void PipelineWorker::MergePeers() {
  std::vector<SnapshotAssembler> inbox;
  {
    std::lock_guard lock(inbox_mutex_);
    inbox.swap(merge_inbox_);
  }
  if (inbox.empty()) return;
  MergeInbox(std::move(inbox));
  freed_at_ = Clock::now();
}

void PipelineWorker::TrimAfterBursts() {
  // A merge frees about as much as the memory weighs (the peer's memory, the one replaced, the
  // peer's bodies), and sending a memory a body per place; glibc keeps what they freed resident
  // (~260 MB after a 10⁴-place merge, issue 23). Handed back once such a burst has been over a
  // second, the broadcast that follows a merge included: a few ms, seldom.
  if (!freed_at_ || Clock::now() - *freed_at_ < std::chrono::seconds(1)) return;
  freed_at_.reset();
  malloc_trim(0);
}

void PipelineWorker::MergeInbox(std::vector<SnapshotAssembler> inbox) {
  for (SnapshotAssembler& complete : inbox) {
    // The check the loop leaves to us: joining the portions and their digest over all of them.
    std::string reason;
    const int32_t robot = complete.robot();
    // The kept bodies are loaded only where their names do not do (MergePeer loads them when
    // the merge needs them).
    const auto names = kept_names_.find(robot);
    std::optional<PeerSnapshot> checked = complete.Take(
        &reason, [&](const KnownDigests& digests) { return LoadPeerBodies(robot, digests); },
        names == kept_names_.end() ? nullptr : &names->second);
    if (!checked) {
      const int64_t n = ++counters_.messages_rejected;
      if (ShouldLog(n)) {
        spdlog::warn(
            "TSC_MEMORY_{}: dropped the memory of robot {} ({}); it is fetched again whole", robot,
            robot, reason);
      }
      hooks_.merge_failed(robot);  // fetched again
      continue;
    }
    const int64_t version = checked->version;
    spdlog::info("received the memory of robot {} (version {}, {} places, {} map edges{})", robot,
                 version, checked->places.size(), checked->edges.size(),
                 checked->unloaded > 0
                     ? fmt::format("; {} kept bodies known by name", checked->unloaded)
                     : "");
    ++counters_.snapshots_received;
    // Kept before the merge, which can then let the bodies go once it has the peer's places.
    KeepPeerBodies(*checked);
    try {
      MergePeer(std::move(*checked));
      ++counters_.merges_completed;
    } catch (const std::exception& e) {
      ++counters_.messages_rejected;
      ++counters_.merges_failed;
      spdlog::error("merging the memory of robot {} (version {}) failed: {}", robot, version,
                    e.what());
      hooks_.merge_failed(robot);
    }
  }
}

PlaceBodies PipelineWorker::LoadPeerBodies(int32_t robot, const KnownDigests& digests) {
  PlaceBodies bodies;
  if (!store_ || degraded_store_) return bodies;
  try {
    std::unordered_set<int64_t> sound;  // every kept body of `robot` but the damaged ones
    size_t damaged = 0;
    store_->ForEachPeerBody(
        static_cast<uint32_t>(robot), [&](int64_t digest, std::span<const unsigned char> bytes) {
          if (!digests.contains(digest)) {
            sound.insert(digest);
            return;
          }
          // Damaged on disk: left out, so the memory is fetched again whole.
          if (auto body = DecodeBody(bytes, digest)) {
            sound.insert(digest);
            bodies.emplace(digest, std::make_shared<const learned_place_v2_t>(std::move(*body)));
          } else {
            ++damaged;
          }
        });
    // Dropped, so that the whole memory fetched next keeps them afresh (KeepPeerBodies adds only
    // bodies the store lacks): kept, a damaged body failed every later exchange that read it.
    if (damaged > 0) {
      spdlog::warn("{} kept bodies of robot {}'s places were damaged in the store; dropped",
                   damaged, robot);
      store_->KeepOnlyPeerBodies(static_cast<uint32_t>(robot), sound);
    }
  } catch (const StoreError& e) {
    spdlog::warn("the kept bodies of robot {}'s places cannot be read: {}", robot, e.what());
  }
  return bodies;
}

void PipelineWorker::KeepPeerBodies(const PeerSnapshot& snapshot) {
  const int32_t robot = snapshot.robot;
  // Named again below once the store holds every body.
  const auto earlier = kept_names_.extract(robot);
  if (!store_ || degraded_store_) {
    hooks_.bodies_not_kept(robot);
    return;
  }
  try {
    std::unordered_set<int64_t> named;
    for (const place_entry_t& e : snapshot.entries) named.insert(e.body_digest);
    // What the peer's earlier memory left that this one still names; the rest is added.
    std::unordered_set<int64_t> have =
        store_->KeepOnlyPeerBodies(static_cast<uint32_t>(robot), named);
    // In batches, so a memory of 10⁵ places is not encoded at once beside itself.
    constexpr size_t kBatch = 256;
    std::vector<std::pair<int64_t, std::vector<unsigned char>>> batch;
    for (size_t i = 0; i < snapshot.entries.size(); ++i) {
      const int64_t digest = snapshot.entries[i].body_digest;
      if (!have.insert(digest).second) continue;
      if (!snapshot.places[i]) {  // named only, and gone from the store since
        throw StoreError("a kept place body is missing from the store");
      }
      batch.emplace_back(digest, EncodeBody(*snapshot.places[i]));
      if (batch.size() == kBatch) {
        store_->AddPeerBodies(static_cast<uint32_t>(robot), batch);
        batch.clear();
      }
    }
    if (!batch.empty()) store_->AddPeerBodies(static_cast<uint32_t>(robot), batch);
    kept_names_.emplace(robot, NamesOfBodies(snapshot, earlier ? &earlier.mapped() : nullptr));
  } catch (const StoreError& e) {
    spdlog::warn(
        "the bodies of robot {}'s places were not kept ({}): its next exchange fetches them "
        "again",
        robot, e.what());
    hooks_.bodies_not_kept(robot);
  }
}

std::optional<PlaceMemory> PipelineWorker::PeerMemoryToMerge(PeerSnapshot snapshot,
                                                             bool stored_as_ours) {
  const int32_t robot = snapshot.robot;
  // Most exchanges of a settled team bring nothing new. Where the ids alone say the merge
  // leaves ours as it is, the peer's memory is not built to learn so (0.65 s of 0.69 s at 10⁴
  // places); ours then stands, which needs the store to hold it as it is.
  if (stored_as_ours) {
    const auto kept = kept_names_.find(robot);
    const std::optional<std::vector<LearnedPlace>> names = PlaceNamesOf(
        snapshot, pipeline_->memory(), kept == kept_names_.end() ? nullptr : &kept->second);
    if (names && MergeLeavesOurs(pipeline_->memory(), static_cast<uint32_t>(robot), *names)) {
      return std::nullopt;
    }
  }
  std::string reason;
  if (!LoadKeptBodies(
          snapshot, [&](const KnownDigests& d) { return LoadPeerBodies(robot, d); }, &reason)) {
    throw std::runtime_error(reason + " (it is fetched again whole)");
  }
  // The bodies go as the places are built: the peer's memory is not held twice (164 MB more at
  // the peak of a 10⁴-place merge; the bodies are in the store, KeepPeerBodies).
  PlaceMemory peer = ToPlaceMemory(std::move(snapshot), pipeline_->memory().options(),
                                   settings_.daemon.MergeThreads());
  // The bodies decoded and let go while the places were built go back to the system before
  // the merge allocates: glibc keeps them in holes between the built places, which the
  // merge's larger blocks and other threads do not reuse. A 10⁴-place merge peaked at 720 MB
  // RSS without, 559 MB with, for 0.26 s of trimming (tscd_footprint --peer-places 10000).
  malloc_trim(0);
  return peer;
}

// Merges one peer memory into ours (chapter 4) on the worker, then stores the whole merged
// memory and the peer's version in one transaction.
void PipelineWorker::MergePeer(PeerSnapshot snapshot) {
  const auto start = Clock::now();
  RetryStore(true);  // results from before the merge go in first
  // Then the database holds our memory as it is, unless the store is failing.
  const bool stored_as_ours = store_ && AllCommitted() && !degraded_store_;
  // The peer's places are measured in our units (our camera's spacing and lens): one g_N.
  const TopologicalMap peer_map = ToTopologicalMap(snapshot);
  const int32_t robot = snapshot.robot;
  const int64_t version = snapshot.version, digest = snapshot.digest;
  std::optional<PlaceMemory> peer = PeerMemoryToMerge(std::move(snapshot), stored_as_ours);
  const bool left_by_ids = !peer;
  const auto built = Clock::now();
  std::vector<std::pair<PlaceId, PlaceId>> absorbed;
  std::string absorptions;  // for the log (AbsorptionsForTheLog)
  size_t places_before = 0, places_after = 0;
  MergeCase merge_case = MergeCase::kNothingNew;
  size_t added = 0;
  bool peer_into_ours = true;
  bool changed = false;
  bool given_up = false;  // our memory was handed over to the merge, not copied
  {
    places_before = pipeline_->memory().places().size();
    // Our memory is given up to the merge rather than copied (0.1-0.4 s of a 10⁴-place merge
    // on fresh pages) only where the store holds it as it is: a merge that fails after that
    // point has lost it, and it is loaded back from there. What a store row needs rewriting is
    // then told by fingerprints taken now (UnchangedPositions).
    std::vector<PlaceFingerprint> fingerprints;
    if (stored_as_ours) fingerprints = FingerprintsOf(pipeline_->memory().places());
    const auto give_up_ours = [this, &given_up] {
      bodies_.BeforeReplace();  // the snapshots built so far read the memory given up
      given_up = true;
      return pipeline_->GiveUpMemory();
    };
    bool adopted = false;
    try {  // until the pipeline holds a memory again (LoadMemoryBack)
      MemoryMerge merged = left_by_ids ? OursLeftAsItIs(pipeline_->memory())
                           : stored_as_ours
                               ? MergeMemories(pipeline_->memory(), std::move(*peer),
                                               settings_.daemon.MergeThreads(), give_up_ours)
                               : MergeMemories(pipeline_->memory(), std::move(*peer),
                                               settings_.daemon.MergeThreads());
      // Where ours was the base and the merge changed nothing, it left ours where it is.
      const bool ours_stands = stored_as_ours && !given_up && merged.peer_into_ours;
      const PlaceMemory& merged_memory = ours_stands ? pipeline_->memory() : merged.memory;
      merge_case = merged.merge_case;
      peer_into_ours = merged.peer_into_ours;
      added = merged.added.size();
      absorbed.reserve(merged.absorbed.size());
      for (const Absorption& a : merged.absorbed) absorbed.emplace_back(a.source, a.target);
      absorptions = AbsorptionsForTheLog(merged.absorbed);
      TopologicalMap map = MergeMaps(pipeline_->map(), peer_map, merged_memory);
      changed = MergeChangesAnything(merged, map, pipeline_->map());
      if (changed) {        // always where ours was given up (the merge changed it)
        if (ours_stands) {  // only the map changed: ours goes back in with it
          merged.memory = pipeline_->GiveUpMemory();
          given_up = true;
        }
        std::vector<char> unchanged;
        if (stored_as_ours) {
          // Fingerprints hold for a merge into ours; ours as the smaller memory was only read.
          unchanged =
              merged.peer_into_ours
                  ? UnchangedPositions(fingerprints, merged.memory.places())
                  : UnchangedPositions(pipeline_->memory().places(), merged.memory.places());
        }
        bodies_.BeforeReplace();
        pipeline_->AdoptMerged(std::move(merged.memory), std::move(map));
        // Only once the memory they describe is the pipeline's.
        if (stored_as_ours) stored_unchanged_ = std::move(unchanged);
      } else if (stored_as_ours) {
        // The store holds our memory as it stands; only the peer's version is new. Rewriting
        // every place for it took 1.5 s at 10⁴ places on every exchange of a settled team.
        stored_unchanged_ = std::vector<char>(pipeline_->memory().places().size(), 1);
      }
      adopted = true;
    } catch (const std::exception& e) {
      if (given_up && !adopted) LoadMemoryBack(e.what());
      throw;
    }
    places_after = pipeline_->memory().places().size();
    counters_.places = static_cast<int32_t>(places_after);
    counters_.edges = static_cast<int32_t>(pipeline_->map().edges().size());
  }
  const auto merged_at = Clock::now();
  unsaved_merge_ = PeerMerge{static_cast<uint32_t>(robot), version, digest, NowUtime()};
  RetryStore(true);
  if (changed) {
    ++counters_.memory_version;
    ++counters_.merges_changed;
  }
  const auto ms = [](Clock::time_point from, Clock::time_point to) {
    return std::chrono::duration<double, std::milli>(to - from).count();
  };
  const auto end = Clock::now();
  spdlog::log(changed ? spdlog::level::info : spdlog::level::debug,
              "merged the memory of robot {} (version {}, {}): case {}, {} places absorbed, {} "
              "added; {} -> {} places in {:.0f} ms (its places {} {:.0f}, merged {:.0f}{}, "
              "stored {:.0f})",
              robot, version, peer_into_ours ? "into ours" : "ours into the larger peer memory",
              ToString(merge_case), absorbed.size(), added, places_before, places_after,
              ms(start, end), left_by_ids ? "known by their ids" : "built", ms(start, built),
              ms(built, merged_at), given_up ? " with ours handed over" : "", ms(merged_at, end));
  if (changed && !absorptions.empty()) spdlog::info("  absorbed: {}", absorptions);
  if (!join_->open()) {
    join_->PeerMerged();
    const uint32_t next = pipeline_->memory().next_local_id();
    spdlog::info(
        "learning starts: the team's memory is merged; new places are numbered from "
        "{}:{}",
        header_.robot, next);
  }
  hooks_.merged(std::move(absorbed));
}

void PipelineWorker::LoadMemoryBack(const std::string& why) {
  spdlog::error("a merge failed after our memory was handed to it ({}); loading it back from {}",
                why, db_path_.string());
  try {
    // With the options the memory had (a readapted step unit), not the configured ones.
    StoredState saved =
        store_->Load(header_.robot, pipeline_->memory().options(), settings_.daemon.MergeThreads());
    pipeline_->AdoptMerged(std::move(saved.memory), TopologicalMap(pipeline_->map()));
    // A new version: the snapshots built before the merge no longer serve bodies (it withdrew
    // them), so peers are to move on to a snapshot of the memory loaded back.
    ++counters_.memory_version;
    spdlog::info("memory loaded back: {} places", pipeline_->memory().places().size());
  } catch (const std::exception& e) {
    // Going on without it would learn places under ids already given; everything is in the
    // store, which the next start loads.
    spdlog::critical("cannot load our memory back from {}: {}; aborting so that tscd restarts",
                     db_path_.string(), e.what());
    spdlog::shutdown();
    std::abort();
  }
}

void PipelineWorker::CommitOrKeep(FrameResult result) {
  pending_.push_back(std::move(result));
  const size_t limit = static_cast<size_t>(settings_.daemon.max_pending_results);
  if (pending_.size() > limit) {
    // The learned memory and map stay whole in the pipeline and are written in full by the
    // next commit; what is given up is the raw record (base point descriptors, detected
    // places, transition regions) of the oldest results.
    const size_t drop = pending_.size() - limit;
    const int64_t first = pending_.front().has_base ? pending_.front().base.index : -1;
    const int64_t last = pending_[drop - 1].has_base ? pending_[drop - 1].base.index : first;
    pending_.erase(pending_.begin(), pending_.begin() + static_cast<std::ptrdiff_t>(drop));
    replace_knowledge_ = true;
    const int64_t n = counters_.results_dropped += static_cast<int64_t>(drop);
    if (ShouldLog(n)) {
      spdlog::error(
          "store unavailable and {} results kept (daemon.max_pending_results): the records of "
          "base points {}..{} are dropped ({} so far); learned places and map edges are kept "
          "and written in full once the store works",
          limit, first, last, n);
    }
  }
  pending_results_ = static_cast<int64_t>(pending_.size());
  counters_.pending_commits = static_cast<int32_t>(pending_.size());
  RetryStore();
}

void PipelineWorker::RetryStore(bool now) {
  if (AllCommitted()) return;
  // Taken once, and only from the store the merge saw: a reopened one may have lost commits.
  std::optional<std::vector<char>> unchanged = std::exchange(stored_unchanged_, {});
  if (!store_) unchanged.reset();
  // While the store fails, a retry per frame would rewrite every kept result each time.
  if (!now && degraded_store_ && Clock::now() < next_store_retry_) return;
  if (!store_ && !ReopenStore()) return;
  try {
    // One transaction for everything kept: the database goes from its last committed state
    // straight to the current one, whatever instant the process dies at.
    store_->CommitPending(pending_, *pipeline_, replace_knowledge_, unsaved_merge_,
                          unchanged ? &*unchanged : nullptr);
    if (degraded_store_) {
      spdlog::info("store {} writable again: {} kept results committed{}", db_path_.string(),
                   pending_.size(), unsaved_merge_ ? " with the merged memory" : "");
    }
    committed_next_base_ = pipeline_->position().next_base;
    pending_.clear();
    pending_results_ = 0;
    counters_.pending_commits = 0;
    unsaved_merge_.reset();
    replace_knowledge_ = false;
    degraded_store_ = false;
    store_problem_.clear();
  } catch (const std::exception& e) {
    const int64_t n = ++counters_.store_failures;
    const auto* store_error = dynamic_cast<const StoreError*>(&e);
    const bool file_system = store_error != nullptr && store_error->file_system();
    if (ShouldLog(n) || e.what() != store_problem_) {
      spdlog::error(
          "commit failed, {} results kept (recognition goes on from memory), retrying every "
          "{} s: {} [{}]",
          pending_.size(), kStoreRetrySeconds, e.what(), FileSystemState(db_path_.parent_path()));
    }
    if (file_system) {
      // A file system that failed under SQLite (I/O error, remounted read-only) may come back
      // only once repaired and mounted again, which our open files would prevent.
      spdlog::error("closing {} until its file system works again", db_path_.string());
      store_.reset();
    }
    store_problem_ = e.what();
    degraded_store_ = true;
    next_store_retry_ = Clock::now() + std::chrono::seconds(kStoreRetrySeconds);
  }
}

bool PipelineWorker::ReopenStore() {
  if (Clock::now() < next_store_retry_) return false;
  next_store_retry_ = Clock::now() + std::chrono::seconds(kStoreRetrySeconds);
  try {
    // Ours, closed after a failure, must still be there: a missing file is a file system not
    // mounted again yet, and a new database would end up under the mount.
    Store store = committed_next_base_ ? Store::OpenExisting(db_path_) : Store::Open(db_path_);
    const StoredState saved =
        store.Load(header_.robot, settings_.pipeline.memory, settings_.daemon.MergeThreads());
    if (!committed_next_base_) {
      // The store failed at start, so our memory does not hold what a database there holds.
      if (!saved.memory.empty() || saved.pipeline.next_base > 0) {
        throw StoreError(db_path_.string() +
                         " now holds a memory this process did not load; leaving it untouched");
      }
    } else {
      // Ours, closed after a failure: take it back only if it holds nothing we do not (it
      // may have lost its last commits with the file system), then write the whole memory.
      std::set<PlaceId> ours;
      {
        for (const LearnedPlace& p : pipeline_->memory().places()) {
          ours.insert(p.id);
          ours.insert(p.sources.begin(), p.sources.end());
        }
      }
      for (const LearnedPlace& p : saved.memory.places()) {
        if (!ours.contains(p.id)) {
          throw StoreError(db_path_.string() + " now holds place " + p.id.ToString() +
                           " this process never had; leaving it untouched");
        }
      }
      if (saved.pipeline.next_base > *committed_next_base_) {
        throw StoreError(db_path_.string() + " is ahead of this process (base point " +
                         std::to_string(saved.pipeline.next_base) + "); leaving it untouched");
      }
      if (saved.pipeline.next_base < *committed_next_base_) {
        spdlog::error(
            "store {} lost its commits after base point {} with its file system: the records "
            "of base points {}..{} are gone; the memory is written in full",
            db_path_.string(), saved.pipeline.next_base, saved.pipeline.next_base,
            *committed_next_base_ - 1);
      }
      replace_knowledge_ = true;
    }
    store_ = std::move(store);
    spdlog::info("store {} opened; writing {} kept results", db_path_.string(), pending_.size());
    return true;
  } catch (const std::exception& e) {
    if (e.what() != store_problem_) spdlog::error("store still unavailable: {}", e.what());
    store_problem_ = e.what();
    return false;
  }
}

// Stopping with results the store has not taken (it fails, or never opened): wait a bounded
// time for it, then spill what tscd holds to a file the next start takes in, and say loudly
// what is not in the store. Worker stopped: called on the loop thread with everything ours.
int PipelineWorker::SaveBeforeExit(SystemNotifier& notifier) {
  if (AllCommitted()) return 0;
  const double wait_s = settings_.daemon.stop_store_wait_s;
  spdlog::warn("stopping with {} results not in the store {} ({}); trying it for up to {} s",
               pending_.size(), db_path_.string(), store_problem_, wait_s);
  const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                           std::chrono::duration<double>(wait_s));
  notifier.Status(fmt::format("stopping: {} results not in the store; trying it for {} s",
                              pending_.size(), wait_s));
  for (;;) {
    notifier.Watchdog();  // alive meanwhile, should systemd still watch
    next_store_retry_ = {};
    RetryStore(true);
    if (AllCommitted()) {
      spdlog::info("store {} took every kept result before stopping", db_path_.string());
      return 0;
    }
    const auto now = Clock::now();
    if (now >= deadline) break;
    std::this_thread::sleep_for(
        std::min<Clock::duration>(deadline - now, std::chrono::milliseconds(250)));
  }
  int64_t first = -1, last = -1;
  for (const FrameResult& r : pending_) {
    if (!r.has_base) continue;
    if (first < 0) first = r.base.index;
    last = r.base.index;
  }
  const std::string what =
      fmt::format("{} results{} and the memory of {} places and {} map edges{}", pending_.size(),
                  first >= 0 ? fmt::format(" (base points {}..{})", first, last) : std::string(),
                  counters_.places.load(), counters_.edges.load(),
                  unsaved_merge_ ? " with a merged peer memory" : "");
  const std::string name = kSpillPrefix + std::to_string(NowUtime());
  for (const fs::path& folder : SpillFolders(db_path_)) {
    const fs::path spill = folder / name;
    try {
      Store::WriteSpill(spill, pending_, *pipeline_, unsaved_merge_, committed_next_base_);
      spdlog::error(
          "NOT SAVED in {} ({}): {} written to {} instead; the next start takes it in once the "
          "store opens. Exiting with code {}.",
          db_path_.string(), store_problem_, what, spill.string(), kExitUnsaved);
      return kExitUnsaved;
    } catch (const std::exception& e) {
      spdlog::error("cannot spill to {}: {} [{}]", spill.string(), e.what(),
                    FileSystemState(folder));
    }
  }
  spdlog::critical(
      "LOST: {} could not be written to {} ({}) nor spilled; they are gone. Exiting with code "
      "{}.",
      what, db_path_.string(), store_problem_, kExitUnsaved);
  return kExitUnsaved;
}

// Takes in what earlier runs spilled at stop (SaveBeforeExit), oldest first, before the memory
// is loaded; a spill that does not continue this database is left where it is and logged.
void PipelineWorker::ReplaySpills(Store& store) {
  for (const fs::path& spill : FindSpills(SpillFolders(db_path_))) {
    try {
      const SpillReplay r = store.ReplaySpill(spill, header_.robot, settings_.pipeline.memory);
      std::error_code ec;
      fs::remove(spill, ec);
      if (ec) {
        spdlog::error("spill {} taken in but not removed: {}; remove it by hand", spill.string(),
                      ec.message());
      }
      spdlog::warn(
          "took in {} spilled at the last stop: {} base point records; {} places, {} map edges, "
          "continuing at base point {}",
          spill.string(), r.base_points, r.places, r.edges, r.next_base);
    } catch (const std::exception& e) {
      spdlog::error("spill {} not taken in: {}", spill.string(), e.what());
    }
  }
}

}  // namespace tsc
