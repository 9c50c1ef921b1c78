#include "daemon/daemon.h"

#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <boost/asio/dispatch.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/posix/stream_descriptor.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/signal_set.hpp>
#include <boost/asio/steady_timer.hpp>
#include <csignal>
#include <random>
#include <utility>

#include "daemon/log_throttle.h"
#include "daemon/motor_bridge.h"
#include "drivers/dataset/base_point_picker.h"
#include "tsc/announce_t.hpp"
#include "tsc/memory_request_t.hpp"
#include "tsc/place_event_t.hpp"
#include "tsc/stats_t.hpp"

namespace tsc {
namespace fs = std::filesystem;
namespace asio = boost::asio;
using Clock = std::chrono::steady_clock;

namespace {

// Memory portion bytes published per turn of the event loop (a few ms): a memory of 10⁴
// places is ~1.5 GB of place bodies, which must not hold announces and timers back for long.
constexpr int64_t kBytesPerSlice = 2 << 20;
// Place bodies asked of the worker at a time (~1.4 MB with 12 member views, ~2.7 MB with 32).
constexpr size_t kBodiesPerSlice = 128;
// "merged" place events published per turn of the loop.
constexpr size_t kEventsPerSlice = 256;

int64_t RandomBootId() {
  std::random_device rd;
  const uint64_t hi = rd();
  const uint64_t lo = rd();
  return static_cast<int64_t>((hi << 32) | lo);
}

place_ref_t Ref(const PlaceId& id) {
  place_ref_t r{};
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
  m.has_place = e.place.has_value() ? 1 : 0;
  m.place = e.place ? Ref(*e.place) : place_ref_t{0, 0};
  m.has_from = e.from.has_value() ? 1 : 0;
  m.from = e.from ? Ref(*e.from) : place_ref_t{0, 0};
  m.cost = e.cost;
  m.partial = e.partial ? 1 : 0;
  m.hybrid = e.hybrid ? 1 : 0;
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
  // Why: g_N and its terms (3.8), and D's agreement with N¹; a learned place names the last
  // cost tried (none when the memory was empty).
  const auto terms = [&] {
    return fmt::format(" (distance {:.3g}, ratio {:.3g}, vote {:.3g}, agreement {:.3g})",
                       e.terms.distance, e.terms.ratio, e.terms.vote, e.terms.agreement);
  };
  if (e.kind == EventKind::kRecognized) {
    s += ", cost " + std::to_string(e.cost) + terms() + (e.partial ? " (partial)" : "") +
         (e.hybrid ? " (hybrid)" : "") + (e.neighbour ? " (map neighbour)" : "");
    if (!e.folded.empty()) {
      s += "; its copies";
      for (const PlaceId& f : e.folded) s += " " + f.ToString();
      s += " folded into it (consolidation)";
    }
  }
  if (e.kind == EventKind::kLearned && e.terms.best >= 0) {
    s += ", last cost tried " + std::to_string(e.cost) + terms();
  }
  if (e.kind == EventKind::kAmbiguous) {
    s += ", cost " + std::to_string(e.cost) + terms() +
         (e.near_miss ? ": nearly recognised, half of it in a place held already"
                      : ": its points name other places") +
         "; neither recognised nor learned";
  }
  if (e.members > 0) s += ", " + std::to_string(e.members) + " base points";
  return s;
}

}  // namespace

struct Daemon::Loop {
  explicit Loop(asio::io_context& io)
      : signals(io, SIGTERM, SIGINT, SIGHUP),
        lcm(io),
        announce(io),
        status(io),
        watchdog(io),
        exchange(io),
        join(io) {}
  asio::signal_set signals;
  asio::posix::stream_descriptor lcm;
  asio::steady_timer announce;
  asio::steady_timer status;
  asio::steady_timer watchdog;
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
      team_(bus_, std::move(team_key), counters_),
      queue_(static_cast<size_t>(settings_.daemon.queue_frames)),
      exchange_(static_cast<int32_t>(robot_),
                PeerExchangeOptions{.view_basis =
                                        ViewBasisId(settings_.pipeline.memory.view_basis.get())}) {
  if (!team_.signs()) {
    spdlog::warn(
        "no team key (lcm.team_key_file): exchange messages are neither signed nor "
        "checked");
  }
  if (base_) motor_ = std::make_unique<MotorBridge>(*base_, robot_, team_, *io_, counters_);
  spdlog::info("tscd robot {} starting (camera {}, LCM {}, state {})", robot_, camera_->name(),
               bus_.url(), db_path_.string());
  worker_ = std::make_unique<PipelineWorker>(
      settings_, *camera_, SnapshotHeader{static_cast<int32_t>(robot_), boot_id_, 0, 0}, counters_,
      queue_,
      PipelineWorkerHooks{
          .events =
              [this](std::vector<PlaceEvent> events, int64_t utime) {
                asio::post(*io_, [this, events = std::move(events), utime] {
                  PublishEvents(events, utime);
                });
              },
          .merged =
              [this](std::vector<std::pair<PlaceId, PlaceId>> absorbed) {
                asio::post(*io_, [this, absorbed = std::move(absorbed)]() mutable {
                  PublishMerged(std::move(absorbed), NowUtime());
                });
              },
          .merge_failed =
              [this](int32_t robot) {
                asio::post(*io_, [this, robot] { exchange_.Forget(robot); });
              },
          .bodies_not_kept =
              [this](int32_t robot) {
                asio::post(*io_, [this, robot] { exchange_.Know(robot, {}); });
              },
          .snapshot_ready = [this] { asio::post(*io_, [this] { ServeSnapshot(); }); },
      });
  for (const auto& [robot, peer] : worker_->TakeSavedPeers()) {
    exchange_.MarkMerged(static_cast<int32_t>(robot), {peer.version, peer.digest});
  }
  for (const auto& [robot, digests] : worker_->TakeKeptPeerBodies()) {
    exchange_.Know(static_cast<int32_t>(robot), {digests.begin(), digests.end()});
  }
  const bool fresh = worker_->started_empty() && settings_.daemon.bus.join_wait_s > 0.0;
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
  worker_->Join();
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
  if (motor_) motor_->Subscribe();
  loop_->lcm.assign(::dup(bus_.fd()));
  WaitLcm();
  loop_->signals.async_wait([this](const boost::system::error_code& ec, int sig) {
    if (!ec) OnSignal(sig);
  });
  worker_->Start(*join_);
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
  if (motor_) motor_->Start();
  OnExchangeTimer();
}

void Daemon::OnExchangeTimer() {
  if (stopping_) return;
  for (const memory_request_t& r : exchange_.Tick(PeerExchange::Clock::now())) {
    spdlog::debug("asking robot {} for {} portions of version {}", r.robot,
                  r.missing.empty() ? std::string("all") : std::to_string(r.missing.size()),
                  r.version);
    team_.PublishSigned(ChannelFamily::kRequest, "TSC_REQUEST_" + std::to_string(r.robot), r);
  }
  loop_->exchange.expires_after(std::chrono::milliseconds(100));
  loop_->exchange.async_wait([this](const boost::system::error_code& ec) {
    if (!ec) OnExchangeTimer();
  });
}

void Daemon::OnPeerPortion(const std::string& channel, const uint8_t* data, size_t size) {
  if (channel == "TSC_MEMORY_" + std::to_string(robot_)) return;  // our own, looped back
  auto portion = team_.Authentic<memory_portion_v2_t>(channel, data, size, "memory portion");
  if (!portion) return;
  team_.CountReceived(ChannelFamily::kMemory, size);
  const int64_t rejected_before = exchange_.rejected_portions();
  std::optional<SnapshotAssembler> complete =
      exchange_.OnPortion(*portion, PeerExchange::Clock::now());
  if (exchange_.rejected_portions() > rejected_before) {
    const int64_t n = ++counters_.messages_rejected;
    if (ShouldLog(n)) {
      spdlog::warn("{}: dropped a memory portion: {}", channel, exchange_.last_rejection());
    }
  }
  if (complete) OnPeerSnapshot(std::move(*complete));
}

void Daemon::OnPeerSnapshot(SnapshotAssembler complete) {
  // Not fetched again while its content stays the same; forgotten again if its check (on the
  // worker: the digest over ~250 MB at 10⁴ places would hold the loop up for a second) or the
  // merge fails.
  exchange_.MarkMerged(complete.robot(), {complete.version(), complete.digest()});
  worker_->Enqueue(std::move(complete));
}

void Daemon::PublishMerged(std::vector<std::pair<PlaceId, PlaceId>> absorbed, int64_t utime,
                           size_t from) {
  const std::string channel = "TSC_EVENT_" + std::to_string(robot_);
  // A merge of 10⁴ places absorbs thousands: a slice per turn of the loop, as for portions.
  const size_t end =
      stopping_ ? absorbed.size() : std::min(absorbed.size(), from + kEventsPerSlice);
  for (size_t k = from; k < end; ++k) {
    const auto& [source, target] = absorbed[k];
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
    if (!team_.PublishCounted(ChannelFamily::kEvent, channel, m)) {
      team_.PublishFailed(channel);
    }
  }
  if (end == absorbed.size()) return;
  asio::post(*io_, [this, absorbed = std::move(absorbed), utime, end]() mutable {
    PublishMerged(std::move(absorbed), utime, end);
  });
}

void Daemon::WaitLcm() {
  loop_->lcm.async_wait(asio::posix::stream_descriptor::wait_read,
                        [this](const boost::system::error_code& ec) {
                          // Cancelled at shutdown, or ready before the cancel (its handler
                          // still runs, with success): waiting again would keep the loop up.
                          if (ec || stopping_) return;
                          if (!bus_.HandleReady()) spdlog::warn("LCM: receive error");
                          WaitLcm();
                        });
}

void Daemon::OnAnnounceTimer() {
  if (stopping_) return;
  const auto memory_period = std::chrono::duration<double>(settings_.daemon.bus.memory_period_s);
  if (!last_memory_broadcast_ || Clock::now() - *last_memory_broadcast_ >= memory_period) {
    PublishMemoryIfChanged();
  }
  announce_t a;
  a.utime = NowUtime();
  a.protocol = announce_t::PROTOCOL;
  a.robot = static_cast<int32_t>(robot_);
  a.boot_id = boot_id_;
  a.sequence = ++announces_sent_;
  // Both branches lvalues: `snapshot_ ? *snapshot_ : MemorySnapshot{}` copied the whole
  // snapshot (110 MB at 10⁴ places) at every announce.
  static const MemorySnapshot kNoSnapshot{};
  DescribeInAnnounce(snapshot_ ? *snapshot_ : kNoSnapshot, a);
  a.view_basis = ViewBasisId(settings_.pipeline.memory.view_basis.get());
  a.places = counters_.places;
  a.edges = counters_.edges;
  a.detected_places = counters_.detected_places;
  a.frames = counters_.frames;
  a.frames_dropped = queue_.dropped();
  a.messages_rejected = counters_.messages_rejected;
  a.queue_fill = static_cast<float>(queue_.fill());
  a.status = StatusLine();
  a.hmac_size = 0;
  if (!team_.PublishSigned(ChannelFamily::kAnnounce, "TSC_ANNOUNCE", a)) {
    team_.PublishFailed("TSC_ANNOUNCE");
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
  s.merge_inbox = static_cast<int32_t>(worker_->inbox_size());
  s.pending_commits = counters_.pending_commits;
  s.peers = static_cast<int32_t>(exchange_.peers());
  s.merged_peers = static_cast<int32_t>(exchange_.merged_peers());
  s.buffered_portions = static_cast<int32_t>(exchange_.buffered_portions());
  team_.PublishStats("TSC_STATS_" + std::to_string(robot_), std::move(s));
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
  if (stopping_) return;  // a wait that completed before Shutdown's cancel
  // Pet the watchdog only while the worker is alive: a hung pipeline gets the daemon restarted.
  const int64_t silent_ms = SteadyMs() - worker_->heartbeat_ms();
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
  if (stopping_) return;  // a signal that arrived as the stop began: nothing to wait for again
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
  if (motor_) motor_->StopMotors();
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
  worker_->Join();
  exit_code_ = worker_->SaveBeforeExit(notifier_);
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
  if (motor_) motor_->Cancel();
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
  const auto req = team_.Authentic<memory_request_t>(channel, data, size, "memory request");
  if (!req) return;
  if (req->robot != static_cast<int32_t>(robot_)) {
    const int64_t n = ++counters_.messages_rejected;
    if (ShouldLog(n)) spdlog::warn("{}: dropped a request for robot {}", channel, req->robot);
    return;
  }
  team_.CountReceived(ChannelFamily::kRequest, size);
  // Portions still missing of a snapshot the loop holds go out at once from it, even when the
  // memory has changed since: asking for a fresh snapshot instead would restart a peer's
  // assembly at every change, and under loss a memory that keeps changing never arrives whole.
  if (!req->missing.empty()) {
    if (const auto held = HeldSnapshot(req->version)) {
      std::vector<int32_t> indices;
      for (int32_t i : req->missing) {
        if (i >= 0 && i < held->count()) indices.push_back(i);
      }
      if (!indices.empty()) {
        spdlog::debug("robot {} asked for {} missing portions of version {}", req->requester,
                      indices.size(), req->version);
        PublishPortions(held, std::move(indices));
        return;
      }
    }
  }
  waiting_requests_.push_back(*req);
  ServeSnapshot();
}

std::shared_ptr<const MemorySnapshot> Daemon::HeldSnapshot(int64_t version) const {
  if (version <= withdrawn_through_) return nullptr;
  for (const auto& held : {snapshot_, previous_snapshot_}) {
    if (held && held->version == version) return held;
  }
  return nullptr;
}

void Daemon::AnswerRequest(const memory_request_t& req) {
  // OnRequest serves missing portions of the snapshots the loop holds; what reaches here asked
  // for everything (the whole current snapshot), or for portions of a version the loop no
  // longer holds: the current structure, from which the peer sees which bodies it still lacks.
  if (req.missing.empty()) {
    spdlog::debug("robot {} asked for version {}; sending all {} portions of version {}",
                  req.requester, req.version, snapshot_->count(), snapshot_->version);
    PublishPortions(snapshot_, PortionsBelow(snapshot_->count()));
    return;
  }
  spdlog::debug(
      "robot {} asked for portions of version {}; sending the {} structure portions "
      "of version {}",
      req.requester, req.version, snapshot_->structure_portions, snapshot_->version);
  PublishPortions(snapshot_, PortionsBelow(snapshot_->structure_portions));
}

void Daemon::OnPeerAnnounce(const std::string& channel, const uint8_t* data, size_t size) {
  const auto a = team_.Authentic<announce_t>(channel, data, size, "announce");
  if (!a || a->robot == static_cast<int32_t>(robot_)) return;
  team_.CountReceived(ChannelFamily::kAnnounce, size);
  if (a->places > 0) join_->PeerHeard(JoinGate::Clock::now());  // it may hold our places
  const int64_t other_basis = exchange_.other_basis();
  if (!exchange_.OnAnnounce(*a, PeerExchange::Clock::now())) {
    const int64_t n = ++counters_.messages_rejected;
    if (ShouldLog(n)) {
      spdlog::warn("{}: dropped a replayed announce of robot {} (sequence {})", channel, a->robot,
                   a->sequence);
    }
  } else if (exchange_.other_basis() > other_basis && ShouldLog(exchange_.other_basis())) {
    spdlog::warn("{}: {}", channel, exchange_.last_rejection());
  }
}

void Daemon::PublishEvents(const std::vector<PlaceEvent>& events, int64_t utime) {
  const std::string channel = "TSC_EVENT_" + std::to_string(robot_);
  for (const PlaceEvent& e : events) {
    const auto level = e.kind == EventKind::kPruned ? spdlog::level::debug : spdlog::level::info;
    spdlog::log(level, "{}", Describe(e));
    if (!team_.PublishCounted(ChannelFamily::kEvent, channel, ToMessage(e, robot_, utime))) {
      team_.PublishFailed(channel);
    }
  }
}

Daemon::Refresh Daemon::RefreshSnapshot() {
  if (snapshot_ && snapshot_->version == counters_.memory_version) return Refresh::kCurrent;
  // The worker's newest, when it is newer than ours: built since we last asked (or the first).
  std::shared_ptr<const MemorySnapshot> latest = worker_->snapshot();
  if (!snapshot_ || latest->version > snapshot_->version) {
    previous_snapshot_ = std::exchange(snapshot_, std::move(latest));
    return Refresh::kReplaced;
  }
  worker_->RequestSnapshot();
  return Refresh::kAwaited;
}

void Daemon::ServeSnapshot() {
  if (!broadcast_wanted_ && waiting_requests_.empty()) return;
  const Refresh refresh = RefreshSnapshot();
  if (refresh == Refresh::kAwaited) return;  // served again once the worker hands it over
  const bool rebuilt = refresh == Refresh::kReplaced;
  if (std::exchange(broadcast_wanted_, false) && rebuilt) BroadcastMemory();
  for (const memory_request_t& req : std::exchange(waiting_requests_, {})) AnswerRequest(req);
}

void Daemon::PublishMemoryIfChanged() {
  broadcast_wanted_ = true;
  ServeSnapshot();
}

void Daemon::BroadcastMemory() {
  last_memory_broadcast_ = Clock::now();
  // The structure and the bodies that changed: a peer that holds the others fills them in, one
  // that does not asks for them (issue 23: one place changed in 10⁴ is not 10⁴ bodies again).
  // A life's first broadcast names the bodies without sending them: peers that merged this
  // memory before its restart hold them, and one that holds nothing asks for the whole memory
  // anyway (a robot of 10⁵ places sent 2 GB at every start that no peer had asked for).
  std::vector<int32_t> changed = std::exchange(broadcast_once_, true)
                                     ? PortionsBeyond(*snapshot_, broadcast_bodies_)
                                     : PortionsBelow(snapshot_->structure_portions);
  broadcast_bodies_ = {snapshot_->body_digests.begin(), snapshot_->body_digests.end()};
  PublishPortions(snapshot_, std::move(changed));
}

void Daemon::PublishPortions(std::shared_ptr<const MemorySnapshot> snapshot,
                             std::vector<int32_t> indices, size_t from) {
  // Stopping, the loop has nothing else to do: everything at once, before "stopped".
  size_t end = from;
  std::vector<int32_t> places;  // a run of body portions: the worker reads them
  for (int64_t bytes = 0; end < indices.size() && (stopping_ || bytes < kBytesPerSlice); ++end) {
    const int32_t index = indices[end];
    if (index >= snapshot->structure_portions) {
      if (!stopping_ && places.size() == kBodiesPerSlice) break;
      places.push_back(index - snapshot->structure_portions);
      continue;
    }
    if (!places.empty()) break;  // in order: the bodies asked for go first
    memory_portion_v2_t unused;  // structure portions are not copied
    const memory_portion_v2_t& portion = snapshot->Portion(index, unused);
    bytes += portion.getEncodedSize();
    PublishPortion(portion);
  }
  if (places.empty()) {
    if (end == indices.size()) return;
    asio::post(*io_,
               [this, snapshot = std::move(snapshot), indices = std::move(indices), end]() mutable {
                 PublishPortions(std::move(snapshot), std::move(indices), end);
               });
    return;
  }
  // The snapshot holds no body: they are the memory's, which the worker owns. It reads them
  // between base points and hands them back (at once when it has ended, as when stopping).
  auto publish = [this, snapshot, indices = std::move(indices),
                  end](PipelineWorker::Bodies bodies) mutable {
    if (bodies.empty()) {
      // The memory was replaced whole since (a merge or consolidation): this snapshot and the
      // older ones are no longer held, so the peer's next request is answered with the current
      // structure (AnswerRequest) and it moves on, keeping the bodies it has. Held, they
      // starved the peers of a robot that merges often (docs/decisions.md, "Memory exchange").
      spdlog::debug("memory snapshot {}: its bodies were withdrawn when the memory was replaced",
                    snapshot->version);
      withdrawn_through_ = std::max(withdrawn_through_, snapshot->version);
      return;
    }
    memory_portion_v2_t scratch;
    for (size_t k = 0, first = end - bodies.size(); k < bodies.size(); ++k) {
      if (!bodies[k]) {  // the place changed under the snapshot: peers would refuse it
        spdlog::error("memory snapshot {}: place body {} no longer matches its digest; not sent",
                      snapshot->version, indices[first + k] - snapshot->structure_portions);
        continue;
      }
      PublishPortion(snapshot->Portion(indices[first + k], scratch, bodies[k].get()));
    }
    if (end < indices.size()) PublishPortions(std::move(snapshot), std::move(indices), end);
  };
  worker_->RequestBodies(
      std::move(snapshot), std::move(places),
      [this, publish = std::move(publish)](PipelineWorker::Bodies bodies) mutable {
        asio::dispatch(*io_, [publish = std::move(publish), bodies = std::move(bodies)]() mutable {
          publish(std::move(bodies));
        });
      });
}

void Daemon::PublishPortion(const memory_portion_v2_t& portion) {
  const std::string channel = "TSC_MEMORY_" + std::to_string(robot_);
  if (!team_.PublishSigned(ChannelFamily::kMemory, channel, portion)) {
    team_.PublishFailed(channel);
  }
}

std::string Daemon::StatusLine() const {
  const int64_t standing = counters_.frames_standing.load();
  std::string s = "frames " + std::to_string(counters_.frames.load()) + " (dropped " +
                  std::to_string(queue_.dropped()) +
                  (standing > 0 ? ", " + std::to_string(standing) + " standing still" : "") +
                  "), places " + std::to_string(counters_.places.load()) + ", edges " +
                  std::to_string(counters_.edges.load()) + ", detected " +
                  std::to_string(counters_.detected_places.load());
  if (worker_->store_degraded()) {
    s += "; degraded: memory not persisted (" + std::to_string(worker_->pending_results()) +
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
  // Base points about the calibrated spacing apart (BasePointPicker): every stride-th of a
  // camera denser than that, none while the robot stands still, and the stride set by the
  // robot's measured speed when its odometry is known. Dropped here, before they take queue
  // room. The odometry is the motor base's, for a camera that moves with it (one mounted on
  // the robot, or a simulated camera the base drives) and whose spacing was only assumed.
  BasePointPicker taken(worker_->base_point_stride());
  const bool live = base_ != nullptr && worker_->spacing_assumed() && !replay;
  if (live) {
    spdlog::info(
        "camera: the spacing above is assumed from camera.fps; the robot's odometry measures "
        "it once the robot drives");
  }
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
      ViewMotion motion{frame->pose, std::nullopt, frame->utime};
      if (live && (frame->pose || camera_->rides_the_base())) {
        const Odometry o = base_->state();
        if (o.link_ok) {
          motion.speed_mps = o.linear_mps;
          if (!motion.pose) motion.pose = PlanarPose{o.x, o.y, o.heading};
        }
      }
      const int stride = taken.stride();
      const std::optional<double> spacing = taken.base_point_spacing_m();
      const bool take = taken.Take(ends, motion);
      if (taken.stride() != stride) {
        spdlog::info("camera: frames {:.3g} m apart by odometry: one base point in {}",
                     taken.measured_spacing_m().value_or(0.0), taken.stride());
      }
      if (taken.base_point_spacing_m() != spacing) {
        worker_->MeasuredSpacing(*taken.base_point_spacing_m());
      }
      if (!take) {
        if (taken.standing()) ++counters_.frames_standing;
        continue;
      }
      queue_.Push(std::move(*frame), ends, replay);
    } catch (const CameraError& e) {
      if (stopping_) return;  // a read cut short by the stop
      const int64_t n = ++counters_.camera_errors;
      if (ShouldLog(n)) spdlog::warn("camera: {} ({} camera errors so far)", e.what(), n);
      if (e.recoverable()) {
        // A source that fails at once again and again must not spin a core.
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        continue;
      }
      spdlog::error("camera {} failed for good: {}; tscd keeps serving its memory", camera_->name(),
                    e.what());
      degraded_camera_ = true;
      return;
    } catch (const std::exception& e) {
      spdlog::error("camera {}: unexpected failure: {}", camera_->name(), e.what());
      degraded_camera_ = true;
      return;
    }
  }
}

}  // namespace tsc
