#include "daemon/daemon.h"

#include <fcntl.h>
#include <spdlog/spdlog.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <algorithm>
#include <boost/asio/io_context.hpp>
#include <boost/asio/posix/stream_descriptor.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/signal_set.hpp>
#include <boost/asio/steady_timer.hpp>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <limits>
#include <random>
#include <set>
#include <string_view>
#include <system_error>

#include "core/merge/merge.h"
#include "core/merge/merge_maps.h"
#include "jaguar/motor_command_t.hpp"
#include "jaguar/motor_state_t.hpp"
#include "tsc/announce_t.hpp"
#include "tsc/memory_request_t.hpp"
#include "tsc/place_event_t.hpp"
#include "tsc/stats_t.hpp"

namespace tsc {
namespace fs = std::filesystem;
namespace asio = boost::asio;
using Clock = std::chrono::steady_clock;

namespace {

int64_t NowUtime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

int64_t SteadyMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now().time_since_epoch())
      .count();
}

int64_t RandomBootId() {
  std::random_device rd;
  const uint64_t hi = rd();
  const uint64_t lo = rd();
  return static_cast<int64_t>((hi << 32) | lo);
}

// Logs the first occurrences of a repeated problem, then one in every 100, so a flood of bad
// frames or messages cannot drown the journal but is never silent.
bool ShouldLog(int64_t occurrence) { return occurrence <= 10 || occurrence % 100 == 0; }

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

place_ref_t Ref(const PlaceId& id) {
  place_ref_t r;
  r.robot = static_cast<int32_t>(id.robot);
  r.local = static_cast<int32_t>(id.local);
  return r;
}

place_event_t ToMessage(const PlaceEvent& e, uint32_t robot, int64_t utime) {
  place_event_t m;
  m.utime = utime;
  m.robot = static_cast<int32_t>(robot);
  m.frame = e.frame;
  m.event = EventKindName(e.kind);
  m.detected_place = static_cast<int32_t>(e.detected_place);
  m.has_place = e.place.has_value();
  m.place = e.place ? Ref(*e.place) : place_ref_t{0, 0};
  m.has_from = e.from.has_value();
  m.from = e.from ? Ref(*e.from) : place_ref_t{0, 0};
  m.cost = e.cost;
  m.partial = e.partial;
  m.hybrid = e.hybrid;
  m.members = e.members;
  m.transition_first = e.transition.empty() ? -1 : e.transition.first;
  m.transition_last = e.transition.empty() ? -1 : e.transition.last;
  return m;
}

std::string Describe(const PlaceEvent& e) {
  std::string s = std::string(EventKindName(e.kind)) + " at base point " + std::to_string(e.frame) +
                  ": detected place " + std::to_string(e.detected_place);
  if (e.place) s += ", place " + e.place->ToString();
  if (e.from) s += ", from " + e.from->ToString();
  if (e.kind == EventKind::kRecognized) {
    s += ", cost " + std::to_string(e.cost) + (e.partial ? " (partial)" : "") +
         (e.hybrid ? " (hybrid)" : "");
  }
  if (e.members > 0) s += ", " + std::to_string(e.members) + " base points";
  return s;
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

const char* ChannelFamilyName(ChannelFamily family) {
  switch (family) {
    case ChannelFamily::kAnnounce:
      return "TSC_ANNOUNCE";
    case ChannelFamily::kMemory:
      return "TSC_MEMORY";
    case ChannelFamily::kRequest:
      return "TSC_REQUEST";
    case ChannelFamily::kEvent:
      return "TSC_EVENT";
    case ChannelFamily::kStats:
      return "TSC_STATS";
  }
  return "?";
}

struct Daemon::Loop {
  explicit Loop(asio::io_context& io)
      : signals(io, SIGTERM, SIGINT, SIGHUP),
        lcm(io),
        announce(io),
        status(io),
        watchdog(io),
        motor(io),
        exchange(io),
        join(io) {}
  asio::signal_set signals;
  asio::posix::stream_descriptor lcm;
  asio::steady_timer announce;
  asio::steady_timer status;
  asio::steady_timer watchdog;
  asio::steady_timer motor;
  asio::steady_timer exchange;
  asio::steady_timer join;
};

Daemon::Daemon(Settings settings, SettingsSource source, std::unique_ptr<CameraSource> camera,
               std::unique_ptr<MotorBase> base, std::optional<TeamKey> team_key)
    : settings_(std::move(settings)),
      source_(std::move(source)),
      base_(std::move(base)),
      camera_(std::move(camera)),
      robot_(settings_.pipeline.robot),
      boot_id_(RandomBootId()),
      db_path_(fs::path(settings_.daemon.state_dir) / "memory.db"),
      io_(std::make_unique<asio::io_context>()),
      loop_(std::make_unique<Loop>(*io_)),
      bus_(settings_.daemon.bus.url),
      queue_(static_cast<size_t>(settings_.daemon.queue_frames)),
      team_key_(std::move(team_key)),
      exchange_(static_cast<int32_t>(robot_), PeerExchangeOptions{}) {
  if (!team_key_) {
    spdlog::warn(
        "no team key (lcm.team_key_file): exchange messages are neither signed nor "
        "checked");
  }
  spdlog::info("tscd robot {} starting (camera {}, LCM {}, state {})", robot_, camera_->name(),
               bus_.url(), db_path_.string());
  PlaceMemory memory(robot_, settings_.pipeline.memory);
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
    StoredState saved = store.Load(robot_, settings_.pipeline.memory);
    memory = std::move(saved.memory);
    map = std::move(saved.map);
    state = saved.pipeline;
    for (const auto& [robot, peer] : store.LoadPeers()) {
      exchange_.MarkMerged(static_cast<int32_t>(robot), {peer.version, peer.digest});
    }
    if (!store.EnableIncrementalVacuum() && settings_.daemon.store.budget_mb > 0) {
      spdlog::warn(
          "{} predates incremental vacuum and is too large to convert at start: base point "
          "records beyond store.budget_mb free pages that are reused, so the file stops "
          "growing but does not shrink; convert it with tscd stopped (docs/reliability.md)",
          db_path_.string());
    }
    store_ = std::move(store);
    committed_next_base_ = state.next_base;
    spdlog::info("memory loaded from {}: {} places, {} map edges, continuing at base point {}",
                 db_path_.string(), memory.places().size(), map.edges().size(), state.next_base);
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
  worker_heartbeat_ms_ = SteadyMs();
  PipelineOptions pipeline = settings_.pipeline;
  const std::optional<BasePointSpacing> declared = camera_->spacing();
  const BasePointSpacing spacing =
      ResolveSpacing(settings_.daemon.camera.spacing_m, declared ? &*declared : nullptr,
                     settings_.daemon.camera.fps);
  pipeline.detector.spacing_m = spacing.metres;
  spdlog::info("base points {:.3g} m apart ({}): places of {} base points or fewer are pruned",
               spacing.metres, spacing.basis, pipeline.detector.EffectiveTauP());
  const bool fresh = memory.places().empty() && settings_.daemon.bus.join_wait_s > 0.0;
  pipeline_ = std::make_unique<Pipeline>(camera_->intrinsics(), pipeline, std::move(memory),
                                         std::move(map), state);
  const auto wait = std::chrono::duration_cast<JoinGate::Clock::duration>(
      std::chrono::duration<double>(settings_.daemon.bus.join_wait_s));
  // A peer heard whose memory does not complete holds learning at most ten join waits.
  join_ = std::make_unique<JoinGate>(fresh, wait, 10 * wait, JoinGate::Clock::now());
}

Daemon::~Daemon() {
  stopping_ = true;  // normally Run() has stopped everything; this covers a failed start
  camera_->Interrupt();
  queue_.Close();
  if (camera_thread_.joinable()) camera_thread_.join();
  if (worker_thread_.joinable()) worker_thread_.join();
}

void Daemon::Stop() {
  asio::post(*io_, [this] { Shutdown(); });
}

int Daemon::Run() {
  const std::string me = std::to_string(robot_);
  bus_.Subscribe("TSC_REQUEST_" + me,
                 [this](const std::string& c, const uint8_t* d, size_t n) { OnRequest(c, d, n); });
  bus_.Subscribe("TSC_ANNOUNCE", [this](const std::string& c, const uint8_t* d, size_t n) {
    OnPeerAnnounce(c, d, n);
  });
  bus_.Subscribe("TSC_MEMORY_.*", [this](const std::string& c, const uint8_t* d, size_t n) {
    OnPeerPortion(c, d, n);
  });
  if (base_) {
    bus_.Subscribe("JAGUAR_CMD_" + me, [this](const std::string& c, const uint8_t* d, size_t n) {
      OnMotorCommand(c, d, n);
    });
  }
  loop_->lcm.assign(::dup(bus_.fd()));
  WaitLcm();
  loop_->signals.async_wait([this](const boost::system::error_code& ec, int sig) {
    if (!ec) OnSignal(sig);
  });
  worker_thread_ = std::thread([this] { WorkerLoop(); });
  camera_thread_ = std::thread([this] { CameraLoop(); });
  StartTimers();
  OnAnnounceTimer();
  notifier_.Ready(StatusLine());
  spdlog::info("ready: {}", StatusLine());
  io_->run();
  return exit_code_;
}

// ---------------------------------------------------------------------------------------------
// Event loop

void Daemon::OnJoinTimer() {
  const std::string why = join_->Tick(JoinGate::Clock::now());
  if (!why.empty()) {
    spdlog::info("learning starts: {} in {} s", why, settings_.daemon.bus.join_wait_s);
    return;
  }
  if (join_->open()) return;
  loop_->join.expires_after(std::chrono::milliseconds(100));
  loop_->join.async_wait([this](const boost::system::error_code& ec) {
    if (!ec) OnJoinTimer();
  });
}

void Daemon::StartTimers() {
  if (!join_->open()) {
    spdlog::info(
        "the memory is empty: listening for peers for {} s before learning (lcm.join_wait_s), "
        "so that a robot rejoining its team takes its places back first",
        settings_.daemon.bus.join_wait_s);
    OnJoinTimer();
  }
  OnStatusTimer();
  if (notifier_.watchdog_interval()) OnWatchdogTimer();
  if (base_) OnMotorTimer();
  OnExchangeTimer();
}

template <typename T>
std::optional<T> Daemon::Authentic(const std::string& channel, const uint8_t* data, size_t size,
                                   const char* what) {
  std::optional<T> msg = LcmBus::Decode<T>(data, size);
  const char* problem = nullptr;
  if (!msg) {
    problem = "a malformed";
  } else if (team_key_ &&
             !VerifyMessage(*team_key_, *msg, [](const T& m) { return LcmBus::Encode(m); })) {
    problem = msg->hmac_size == 0 ? "an unsigned" : "a forged";
  }
  if (problem == nullptr) return msg;
  const int64_t n = ++counters_.messages_rejected;
  if (ShouldLog(n)) spdlog::warn("{}: dropped {} {} ({} bytes)", channel, problem, what, size);
  return std::nullopt;
}

template <typename T>
bool Daemon::PublishSigned(ChannelFamily family, const std::string& channel, T msg) {
  if (team_key_) {
    SignMessage(*team_key_, msg, [](const T& m) { return LcmBus::Encode(m); });
  }
  return PublishCounted(family, channel, msg);
}

template <typename T>
bool Daemon::PublishCounted(ChannelFamily family, const std::string& channel, const T& msg) {
  const std::vector<uint8_t> bytes = LcmBus::Encode(msg);
  if (!bus_.PublishRaw(channel, bytes)) return false;
  ChannelTraffic& t = traffic_[static_cast<size_t>(family)];
  ++t.sent;
  t.sent_bytes += static_cast<int64_t>(bytes.size());
  return true;
}

void Daemon::PublishFailed(const std::string& channel) {
  // A packet filter that drops datagrams makes every such send fail (EPERM): log the first
  // and then one in a hundred, so a lossy network cannot fill the journal.
  const int64_t n = ++counters_.publish_failures;
  if (ShouldLog(n)) spdlog::warn("LCM: cannot publish on {} ({} failed sends so far)", channel, n);
}

void Daemon::CountReceived(ChannelFamily family, size_t bytes) {
  ChannelTraffic& t = traffic_[static_cast<size_t>(family)];
  ++t.received;
  t.received_bytes += static_cast<int64_t>(bytes);
}

void Daemon::OnExchangeTimer() {
  if (stopping_) return;
  for (const memory_request_t& r : exchange_.Tick(PeerExchange::Clock::now())) {
    spdlog::debug("asking robot {} for {} portions of version {}", r.robot,
                  r.missing.empty() ? std::string("all") : std::to_string(r.missing.size()),
                  r.version);
    PublishSigned(ChannelFamily::kRequest, "TSC_REQUEST_" + std::to_string(r.robot), r);
  }
  loop_->exchange.expires_after(std::chrono::milliseconds(100));
  loop_->exchange.async_wait([this](const boost::system::error_code& ec) {
    if (!ec) OnExchangeTimer();
  });
}

void Daemon::OnPeerPortion(const std::string& channel, const uint8_t* data, size_t size) {
  if (channel == "TSC_MEMORY_" + std::to_string(robot_)) return;  // our own, looped back
  auto portion = Authentic<memory_portion_t>(channel, data, size, "memory portion");
  if (!portion) return;
  CountReceived(ChannelFamily::kMemory, size);
  const int64_t rejected_before = exchange_.rejected_portions();
  std::optional<PeerSnapshot> snap = exchange_.OnPortion(*portion, PeerExchange::Clock::now());
  if (exchange_.rejected_portions() > rejected_before) {
    const int64_t n = ++counters_.messages_rejected;
    if (ShouldLog(n)) {
      spdlog::warn("{}: dropped a memory portion: {}", channel, exchange_.last_rejection());
    }
  }
  if (snap) OnPeerSnapshot(std::move(*snap));
}

void Daemon::OnPeerSnapshot(PeerSnapshot snapshot) {
  spdlog::info("received the memory of robot {} (version {}, {} places, {} map edges)",
               snapshot.robot, snapshot.version, snapshot.places.size(), snapshot.edges.size());
  // Not fetched again while its content stays the same; forgotten again if the merge fails.
  exchange_.MarkMerged(snapshot.robot, {snapshot.version, snapshot.digest});
  ++counters_.snapshots_received;
  std::lock_guard lock(inbox_mutex_);
  merge_inbox_.push_back(std::move(snapshot));
}

void Daemon::PublishMerged(std::vector<std::pair<PlaceId, PlaceId>> absorbed, int64_t utime) {
  const std::string channel = "TSC_EVENT_" + std::to_string(robot_);
  for (const auto& [source, target] : absorbed) {
    place_event_t m{};
    m.utime = utime;
    m.robot = static_cast<int32_t>(robot_);
    m.frame = -1;
    m.event = "merged";
    m.detected_place = 0;
    m.has_place = true;
    m.place = Ref(target);
    m.has_from = true;
    m.from = Ref(source);
    m.transition_first = m.transition_last = -1;
    if (!PublishCounted(ChannelFamily::kEvent, channel, m)) {
      PublishFailed(channel);
    }
  }
}

void Daemon::OnMotorTimer() {
  const Odometry odo = base_->state();
  jaguar::motor_state_t m{};
  m.utime = NowUtime();
  m.x = odo.x;
  m.y = odo.y;
  m.heading = odo.heading;
  m.linear_mps = odo.linear_mps;
  m.angular_radps = odo.angular_radps;
  m.left_ticks = odo.left_ticks;  // 0 on a simulated base: no encoders
  m.right_ticks = odo.right_ticks;
  m.battery_volts = odo.battery_volts;
  m.temperatures_c = odo.temperatures_c;
  m.num_temperatures = static_cast<int16_t>(m.temperatures_c.size());
  m.link_ok = odo.link_ok;
  m.stopped = odo.stopped;
  m.fault = odo.fault;
  const std::string channel = "JAGUAR_STATE_" + std::to_string(robot_);
  if (!bus_.Publish(channel, m)) PublishFailed(channel);
  loop_->motor.expires_after(std::chrono::milliseconds(100));
  loop_->motor.async_wait([this](const boost::system::error_code& ec) {
    if (!ec) OnMotorTimer();
  });
}

void Daemon::OnMotorCommand(const std::string& channel, const uint8_t* data, size_t size) {
  if (stopping_) return;  // shutting down: the motors stay stopped
  const auto c = LcmBus::Decode<jaguar::motor_command_t>(data, size);
  if (!c) {
    const int64_t n = ++counters_.messages_rejected;
    if (ShouldLog(n))
      spdlog::warn("{}: dropped a malformed motor command ({} bytes)", channel, size);
    return;
  }
  base_->Command(MotorCommand{c->linear_mps, c->angular_radps, c->estop != 0, c->flipper_front,
                              c->flipper_rear});
}

void Daemon::WaitLcm() {
  loop_->lcm.async_wait(asio::posix::stream_descriptor::wait_read,
                        [this](const boost::system::error_code& ec) {
                          if (ec) return;  // cancelled at shutdown
                          if (!bus_.HandleReady()) spdlog::warn("LCM: receive error");
                          WaitLcm();
                        });
}

void Daemon::OnAnnounceTimer() {
  if (stopping_) return;
  const auto memory_period = std::chrono::duration<double>(settings_.daemon.bus.memory_period_s);
  if (Clock::now() - last_memory_broadcast_ >= memory_period) PublishMemoryIfChanged();
  announce_t a;
  a.utime = NowUtime();
  a.protocol = announce_t::PROTOCOL;
  a.robot = static_cast<int32_t>(robot_);
  a.boot_id = boot_id_;
  a.sequence = ++announces_sent_;
  a.memory_version = snapshot_ ? snapshot_->version : 0;
  a.memory_digest = snapshot_ ? snapshot_->digest : 0;
  a.portions = snapshot_ ? static_cast<int32_t>(snapshot_->portions.size()) : 0;
  a.places = counters_.places;
  a.edges = counters_.edges;
  a.detected_places = counters_.detected_places;
  a.frames = counters_.frames;
  a.frames_dropped = queue_.dropped();
  a.messages_rejected = counters_.messages_rejected;
  a.queue_fill = static_cast<float>(queue_.fill());
  a.status = StatusLine();
  a.hmac_size = 0;
  if (!PublishSigned(ChannelFamily::kAnnounce, "TSC_ANNOUNCE", a)) {
    PublishFailed("TSC_ANNOUNCE");
  }
  PublishStats(a.utime);
  const auto period = std::chrono::duration<double>(settings_.daemon.bus.announce_period_s);
  loop_->announce.expires_after(std::chrono::duration_cast<Clock::duration>(period));
  loop_->announce.async_wait([this](const boost::system::error_code& ec) {
    if (!ec) OnAnnounceTimer();
  });
}

void Daemon::PublishStats(int64_t utime) {
  stats_t s{};
  s.utime = utime;
  s.robot = static_cast<int32_t>(robot_);
  s.boot_id = boot_id_;
  s.uptime_s = std::chrono::duration<double>(Clock::now() - started_).count();
  s.frames = counters_.frames;
  s.frames_dropped = queue_.dropped();
  s.places = counters_.places;
  s.edges = counters_.edges;
  s.memory_version = snapshot_ ? snapshot_->version : 0;
  s.snapshots_received = counters_.snapshots_received;
  s.merges_completed = counters_.merges_completed;
  s.merges_changed = counters_.merges_changed;
  s.merges_failed = counters_.merges_failed;
  s.exchanges_given_up = exchange_.given_up();
  s.messages_rejected = counters_.messages_rejected;
  s.publish_failures = counters_.publish_failures;
  s.queue_frames = static_cast<int32_t>(queue_.size());
  {
    std::lock_guard lock(inbox_mutex_);
    s.merge_inbox = static_cast<int32_t>(merge_inbox_.size());
  }
  s.pending_commits = counters_.pending_commits;
  s.peers = static_cast<int32_t>(exchange_.peers());
  s.merged_peers = static_cast<int32_t>(exchange_.merged_peers());
  s.buffered_portions = static_cast<int32_t>(exchange_.buffered_portions());
  // The stats message counts itself: it is sent right after.
  ChannelTraffic& own = traffic_[static_cast<size_t>(ChannelFamily::kStats)];
  ++own.sent;
  for (int f = 0; f < kChannelFamilies; ++f) {
    const ChannelTraffic& t = traffic_[static_cast<size_t>(f)];
    s.channel.push_back(ChannelFamilyName(static_cast<ChannelFamily>(f)));
    s.sent.push_back(t.sent);
    s.sent_bytes.push_back(t.sent_bytes);
    s.received.push_back(t.received);
    s.received_bytes.push_back(t.received_bytes);
  }
  s.num_channels = static_cast<int16_t>(kChannelFamilies);
  const std::vector<uint8_t> bytes = LcmBus::Encode(s);
  const std::string channel = "TSC_STATS_" + std::to_string(robot_);
  if (bus_.PublishRaw(channel, bytes)) {
    own.sent_bytes += static_cast<int64_t>(bytes.size());
  } else {
    --own.sent;
    PublishFailed(channel);
  }
}

void Daemon::OnStatusTimer() {
  if (stopping_) return;
  const std::string line = StatusLine();
  notifier_.Status(line);
  spdlog::info("{}", line);
  const int64_t rejected = counters_.messages_rejected;
  if (rejected > last_rejected_logged_) {
    spdlog::warn("{} malformed LCM messages dropped so far", rejected);
    last_rejected_logged_ = rejected;
  }
  loop_->status.expires_after(std::chrono::seconds(10));
  loop_->status.async_wait([this](const boost::system::error_code& ec) {
    if (!ec) OnStatusTimer();
  });
}

void Daemon::OnWatchdogTimer() {
  // Pet the watchdog only while the worker is alive: a hung pipeline gets the daemon restarted.
  const int64_t silent_ms = SteadyMs() - worker_heartbeat_ms_;
  if (silent_ms < 30000) {
    notifier_.Watchdog();
  } else {
    spdlog::error("pipeline worker silent for {} ms; not petting the systemd watchdog", silent_ms);
  }
  loop_->watchdog.expires_after(*notifier_.watchdog_interval());
  loop_->watchdog.async_wait([this](const boost::system::error_code& ec) {
    if (!ec) OnWatchdogTimer();
  });
}

void Daemon::OnSignal(int signal) {
  if (signal == SIGHUP) {
    Reload();
    loop_->signals.async_wait([this](const boost::system::error_code& ec, int sig) {
      if (!ec) OnSignal(sig);
    });
    return;
  }
  spdlog::info("signal {}: stopping", signal == SIGTERM ? "SIGTERM" : "SIGINT");
  Shutdown();
}

void Daemon::Shutdown() {
  if (stopping_.exchange(true)) return;
  // The motors first: the rest of the shutdown (final commit) may take a while, and commands
  // are ignored from now on.
  if (base_) base_->Stop();
  notifier_.Stopping();
  // Camera first (no new frames; its waits for the next frame, a reconnect or a stream read
  // are cut short, so stopping never waits for the camera's rate), then the worker drains the
  // queue, finishes the stream and commits; the loop stays alive meanwhile so it could still
  // publish.
  camera_->Interrupt();
  join_->Open();  // a camera still waiting to start ends at once
  if (camera_thread_.joinable()) camera_thread_.join();
  queue_.PushEnd();  // end of stream: close the open place and commit
  queue_.Close();
  if (worker_thread_.joinable()) worker_thread_.join();
  exit_code_ = SaveBeforeExit();
  // The loop runs what is still queued (the worker's last events), then this, then returns.
  asio::post(*io_, [this] {
    PublishMemoryIfChanged();
    spdlog::info("stopped: {}", StatusLine());
  });
  boost::system::error_code ignored;
  loop_->signals.cancel(ignored);
  loop_->lcm.cancel(ignored);
  loop_->announce.cancel();
  loop_->status.cancel();
  loop_->watchdog.cancel();
  loop_->motor.cancel();
  loop_->exchange.cancel();
  loop_->join.cancel();
  if (base_) base_->Stop();  // again, in case a command slipped in; the destructor stops too
}

void Daemon::Reload() {
  notifier_.Reloading();
  try {
    const Settings fresh = LoadSettings(source_.file, source_.overrides);
    std::vector<std::string> later;
    for (const ConfigKey& k : ConfigTable()) {
      if (k.get(fresh) == k.get(settings_)) continue;
      if (k.key == "daemon.log_level") {
        spdlog::set_level(spdlog::level::from_str(fresh.daemon.log_level));
      } else if (k.key == "lcm.announce_period_s" || k.key == "lcm.memory_period_s") {
        // Read by the next timer tick; nothing else to do.
      } else {
        later.push_back(k.key);
        continue;
      }
      k.set(settings_, k.get(fresh));
      spdlog::info("reload: {} = {}", k.key, k.get(fresh));
    }
    for (const std::string& key : later) {
      spdlog::warn("reload: {} changed; it takes effect when tscd restarts", key);
    }
  } catch (const std::exception& e) {
    spdlog::error("reload refused, the running configuration stays: {}", e.what());
  }
  notifier_.Ready(StatusLine());
}

void Daemon::OnRequest(const std::string& channel, const uint8_t* data, size_t size) {
  const auto req = Authentic<memory_request_t>(channel, data, size, "memory request");
  if (!req) return;
  if (req->robot != static_cast<int32_t>(robot_)) {
    const int64_t n = ++counters_.messages_rejected;
    if (ShouldLog(n)) spdlog::warn("{}: dropped a request for robot {}", channel, req->robot);
    return;
  }
  CountReceived(ChannelFamily::kRequest, size);
  const bool rebuilt = RefreshSnapshot();
  std::vector<int32_t> indices;
  if (!rebuilt && req->version == snapshot_->version) {
    for (int32_t i : req->missing) {
      if (i >= 0 && i < static_cast<int32_t>(snapshot_->portions.size())) indices.push_back(i);
    }
  }
  // An older version or an empty list: the whole current snapshot.
  if (indices.empty()) {
    for (int32_t i = 0; i < static_cast<int32_t>(snapshot_->portions.size()); ++i) {
      indices.push_back(i);
    }
  }
  spdlog::debug("robot {} asked for {} portions of version {}", req->requester, indices.size(),
                req->version);
  PublishPortions(indices);
}

void Daemon::OnPeerAnnounce(const std::string& channel, const uint8_t* data, size_t size) {
  const auto a = Authentic<announce_t>(channel, data, size, "announce");
  if (!a || a->robot == static_cast<int32_t>(robot_)) return;
  CountReceived(ChannelFamily::kAnnounce, size);
  if (a->places > 0) join_->PeerHeard(JoinGate::Clock::now());  // it may hold our places
  if (!exchange_.OnAnnounce(*a, PeerExchange::Clock::now())) {
    const int64_t n = ++counters_.messages_rejected;
    if (ShouldLog(n)) {
      spdlog::warn("{}: dropped a replayed announce of robot {} (sequence {})", channel, a->robot,
                   a->sequence);
    }
  }
}

void Daemon::PublishEvents(const std::vector<PlaceEvent>& events, int64_t utime) {
  const std::string channel = "TSC_EVENT_" + std::to_string(robot_);
  for (const PlaceEvent& e : events) {
    const auto level = e.kind == EventKind::kPruned ? spdlog::level::debug : spdlog::level::info;
    spdlog::log(level, "{}", Describe(e));
    if (!PublishCounted(ChannelFamily::kEvent, channel, ToMessage(e, robot_, utime))) {
      PublishFailed(channel);
    }
  }
}

bool Daemon::RefreshSnapshot() {
  const int64_t version = counters_.memory_version;
  if (snapshot_ && snapshot_->version == version) return false;
  SnapshotHeader header{static_cast<int32_t>(robot_), boot_id_, version, NowUtime()};
  std::lock_guard lock(pipeline_mutex_);
  snapshot_ = std::make_shared<const MemorySnapshot>(BuildSnapshot(
      pipeline_->memory(), pipeline_->map(), header, settings_.daemon.bus.portion_bytes));
  return true;
}

void Daemon::PublishMemoryIfChanged() {
  if (!RefreshSnapshot()) return;
  last_memory_broadcast_ = Clock::now();
  std::vector<int32_t> all(snapshot_->portions.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int32_t>(i);
  PublishPortions(all);
}

void Daemon::PublishPortions(const std::vector<int32_t>& indices) {
  const std::string channel = "TSC_MEMORY_" + std::to_string(robot_);
  for (int32_t i : indices) {
    if (!PublishSigned(ChannelFamily::kMemory, channel,
                       snapshot_->portions[static_cast<size_t>(i)])) {
      PublishFailed(channel);
    }
  }
}

std::string Daemon::StatusLine() const {
  std::string s = "frames " + std::to_string(counters_.frames.load()) + " (dropped " +
                  std::to_string(queue_.dropped()) + "), places " +
                  std::to_string(counters_.places.load()) + ", edges " +
                  std::to_string(counters_.edges.load()) + ", detected " +
                  std::to_string(counters_.detected_places.load());
  if (degraded_store_) {
    s += "; degraded: memory not persisted (" + std::to_string(pending_results_.load()) +
         " results kept)";
  }
  if (degraded_camera_) s += "; degraded: camera failed";
  if (camera_ended_) s += "; camera ended";
  return s;
}

// ---------------------------------------------------------------------------------------------
// Camera thread

void Daemon::CameraLoop() {
  join_->Wait();
  const bool replay = camera_->replays_every_frame();  // fixed for the source's life
  while (!stopping_) {
    try {
      std::optional<CameraFrame> frame = camera_->Next();
      if (stopping_) return;  // interrupted, or a frame after the stop: not taken
      if (!frame) {
        spdlog::info("camera {} ended; tscd keeps serving its memory", camera_->name());
        camera_ended_ = true;
        queue_.PushEnd();
        return;
      }
      const bool ends = frame->ends_base_point;
      queue_.Push(std::move(*frame), ends, replay);
    } catch (const CameraError& e) {
      if (stopping_) return;  // a read cut short by the stop
      const int64_t n = ++counters_.camera_errors;
      if (ShouldLog(n)) spdlog::warn("camera: {} ({} camera errors so far)", e.what(), n);
      if (e.recoverable()) {
        // A source that fails at once again and again must not spin a core.
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        continue;
      } else {
        spdlog::error("camera {} failed for good: {}; tscd keeps serving its memory",
                      camera_->name(), e.what());
        degraded_camera_ = true;
        return;
      }
    } catch (const std::exception& e) {
      spdlog::error("camera {}: unexpected failure: {}", camera_->name(), e.what());
      degraded_camera_ = true;
      return;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Worker thread

void Daemon::WorkerLoop() {
  for (;;) {
    worker_heartbeat_ms_ = SteadyMs();
    std::optional<BasePoint> item = queue_.Pop(std::chrono::milliseconds(500));
    MergePeers();
    if (!item) {
      if (queue_.closed()) return;
      RetryStore();
      MaintainStore();
      continue;
    }
    try {
      Handle(std::move(*item));
    } catch (const std::exception& e) {
      // A frame the pipeline refuses (wrong size, say) is logged and skipped.
      const int64_t n = ++counters_.camera_errors;
      if (ShouldLog(n)) spdlog::error("pipeline: frame skipped: {}", e.what());
    }
    MaintainStore();
  }
}

void Daemon::MaintainStore() {
  if (!store_ || degraded_store_ || !pending_.empty() || unsaved_merge_ ||
      Clock::now() < next_maintenance_) {
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

void Daemon::Handle(BasePoint views) {
  FrameResult result;
  const int64_t utime = views.empty() ? NowUtime() : views.back().utime;
  {
    std::lock_guard lock(pipeline_mutex_);
    if (views.empty()) {
      result = pipeline_->Finish();
    } else {
      // The queue hands over whole sweeps only (FrameQueue), so the first view is the sweep's.
      std::vector<Observation> observations;
      observations.reserve(views.size());
      for (CameraFrame& v : views) observations.push_back(std::move(v.observation));
      result = pipeline_->Process(observations);
      ++counters_.frames;
    }
    const PipelineState state = pipeline_->state();
    counters_.places = static_cast<int32_t>(pipeline_->memory().places().size());
    counters_.edges = static_cast<int32_t>(pipeline_->map().edges().size());
    counters_.detected_places = static_cast<int32_t>(state.next_detected - 1);
  }
  bool map_changed = false;
  for (const PlaceEvent& e : result.events) map_changed |= e.kind == EventKind::kMapped;
  const bool changed = result.memory_changed || !result.changed_places.empty() || map_changed;
  std::vector<PlaceEvent> events = result.events;
  CommitOrKeep(std::move(result));
  if (changed) ++counters_.memory_version;
  if (!events.empty()) {
    asio::post(*io_, [this, events = std::move(events), utime] { PublishEvents(events, utime); });
  }
}

void Daemon::MergePeers() {
  std::vector<PeerSnapshot> inbox;
  {
    std::lock_guard lock(inbox_mutex_);
    inbox.swap(merge_inbox_);
  }
  for (const PeerSnapshot& s : inbox) {
    try {
      MergePeer(s);
      ++counters_.merges_completed;
    } catch (const std::exception& e) {
      ++counters_.messages_rejected;
      ++counters_.merges_failed;
      spdlog::error("merging the memory of robot {} (version {}) failed: {}", s.robot, s.version,
                    e.what());
      asio::post(*io_, [this, robot = s.robot] { exchange_.Forget(robot); });
    }
  }
}

// Merges one peer memory into ours (chapter 4) on the worker, then stores the whole merged
// memory and the peer's version in one transaction.
void Daemon::MergePeer(const PeerSnapshot& snapshot) {
  const auto start = Clock::now();
  RetryStore(true);  // results from before the merge go in first
  PlaceMemory peer = ToPlaceMemory(snapshot, settings_.pipeline.memory);
  const TopologicalMap peer_map = ToTopologicalMap(snapshot);
  std::vector<std::pair<PlaceId, PlaceId>> absorbed;
  std::string absorptions;  // for the log: which place went into which, and at what cost
  size_t places_before = 0, places_after = 0;
  MergeCase merge_case = MergeCase::kNothingNew;
  size_t added = 0;
  bool peer_into_ours = true;
  bool changed = false;
  {
    std::lock_guard lock(pipeline_mutex_);
    places_before = pipeline_->memory().places().size();
    MemoryMerge merged = MergeMemories(pipeline_->memory(), peer);
    merge_case = merged.merge_case;
    peer_into_ours = merged.peer_into_ours;
    added = merged.added.size();
    for (const Absorption& a : merged.absorbed) {
      absorbed.emplace_back(a.source, a.target);
      absorptions += fmt::format("{}{} into {} ({})", absorptions.empty() ? "" : ", ",
                                 a.source.ToString(), a.target.ToString(),
                                 a.cost > 0.0 ? fmt::format("g {:.2f}", a.cost) : "joined by ids");
    }
    TopologicalMap map = MergeMaps(pipeline_->map(), peer_map, merged.memory);
    changed = MergeChangesAnything(merged, map, pipeline_->map());
    if (changed) pipeline_->AdoptMerged(std::move(merged.memory), std::move(map));
    places_after = pipeline_->memory().places().size();
    counters_.places = static_cast<int32_t>(places_after);
    counters_.edges = static_cast<int32_t>(pipeline_->map().edges().size());
  }
  unsaved_merge_ = PeerMerge{static_cast<uint32_t>(snapshot.robot), snapshot.version,
                             snapshot.digest, NowUtime()};
  RetryStore(true);
  if (changed) {
    ++counters_.memory_version;
    ++counters_.merges_changed;
  }
  const double ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  spdlog::log(changed ? spdlog::level::info : spdlog::level::debug,
              "merged the memory of robot {} (version {}, {}): case {}, {} places absorbed, {} "
              "added; {} -> {} places in {:.0f} ms",
              snapshot.robot, snapshot.version,
              peer_into_ours ? "into ours" : "ours into the larger peer memory",
              ToString(merge_case), absorbed.size(), added, places_before, places_after, ms);
  if (changed && !absorptions.empty()) spdlog::info("  absorbed: {}", absorptions);
  if (!join_->open()) {
    join_->PeerMerged();
    uint32_t next = 0;
    {
      std::lock_guard lock(pipeline_mutex_);
      next = pipeline_->memory().next_local_id();
    }
    spdlog::info(
        "learning starts: the team's memory is merged; new places are numbered from "
        "{}:{}",
        robot_, next);
  }
  asio::post(*io_, [this, absorbed = std::move(absorbed)]() mutable {
    PublishMerged(std::move(absorbed), NowUtime());
  });
}

void Daemon::CommitOrKeep(FrameResult result) {
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

void Daemon::RetryStore(bool now) {
  if (pending_.empty() && !unsaved_merge_ && !replace_knowledge_) return;
  // While the store fails, a retry per frame would rewrite every kept result each time.
  if (!now && degraded_store_ && Clock::now() < next_store_retry_) return;
  if (!store_ && !ReopenStore()) return;
  try {
    // One transaction for everything kept: the database goes from its last committed state
    // straight to the current one, whatever instant the process dies at.
    std::lock_guard lock(pipeline_mutex_);
    store_->CommitPending(pending_, *pipeline_, replace_knowledge_, unsaved_merge_);
    if (degraded_store_) {
      spdlog::info("store {} writable again: {} kept results committed{}", db_path_.string(),
                   pending_.size(), unsaved_merge_ ? " with the merged memory" : "");
    }
    committed_next_base_ = pipeline_->state().next_base;
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

bool Daemon::ReopenStore() {
  if (Clock::now() < next_store_retry_) return false;
  next_store_retry_ = Clock::now() + std::chrono::seconds(kStoreRetrySeconds);
  try {
    // Ours, closed after a failure, must still be there: a missing file is a file system not
    // mounted again yet, and a new database would end up under the mount.
    Store store = committed_next_base_ ? Store::OpenExisting(db_path_) : Store::Open(db_path_);
    const StoredState saved = store.Load(robot_, settings_.pipeline.memory);
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
        std::lock_guard lock(pipeline_mutex_);
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
int Daemon::SaveBeforeExit() {
  const auto unsaved = [&] { return !pending_.empty() || unsaved_merge_ || replace_knowledge_; };
  if (!unsaved()) return 0;
  const double wait_s = settings_.daemon.stop_store_wait_s;
  spdlog::warn("stopping with {} results not in the store {} ({}); trying it for up to {} s",
               pending_.size(), db_path_.string(), store_problem_, wait_s);
  const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                           std::chrono::duration<double>(wait_s));
  notifier_.Status(fmt::format("stopping: {} results not in the store; trying it for {} s",
                               pending_.size(), wait_s));
  for (;;) {
    notifier_.Watchdog();  // alive meanwhile, should systemd still watch
    next_store_retry_ = {};
    RetryStore(true);
    if (!unsaved()) {
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
      std::lock_guard lock(pipeline_mutex_);
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
void Daemon::ReplaySpills(Store& store) {
  for (const fs::path& spill : FindSpills(SpillFolders(db_path_))) {
    try {
      const SpillReplay r = store.ReplaySpill(spill, robot_, settings_.pipeline.memory);
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
