// tscd_loop_latency: how steadily tscd's event loop announces while its worker merges a large
// peer memory (issue 22: the loop must never wait for SQLite or a merge). A whole-program
// timing, not a Google Benchmark: one run is one merge.
//
// In one process: a Daemon (robot 1) whose store holds `--places` synthetic places, and a peer
// (robot 2) on the same LCM bus that announces `--places` places of its own (half of them
// seen by robot 1 as well) and serves them over the exchange protocol. Robot 1 fetches them,
// merges them on its worker (10⁴ + 10⁴ places by default), commits the merged memory and
// broadcasts it. The peer's side records when each of robot 1's announces arrives; the report
// gives the largest gap between two announces minus the announce period (the jitter) in three
// phases, bounded by tscd's "received the memory" and "merged the memory" log lines (timed by
// an in-process log sink): the transfer and the check of the peer's memory (joining its
// portions, their digest), the merge and its commit (on the worker), and the 10 s after (the
// new snapshot, the broadcast of the merged memory). The five largest gaps follow, with where they
// fall.
//
// Needs a private network namespace (udpm:// multicast stays inside it):
//   test/support/in_netns build/bin/tscd_loop_latency [--places N] [--dim D] [--out FILE]

#include <spdlog/sinks/base_sink.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "bench/key_value_args.h"
#include "core/pipeline/pipeline.h"
#include "daemon/daemon.h"
#include "daemon/memory_snapshot.h"
#include "store/store.h"
#include "test/support/serving_peer.h"
#include "test/support/synthetic_places.h"

namespace tsc {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr const char* kUrl = testing_support::kNamespaceBusUrl;
constexpr int kMembers = 12;
constexpr double kAnnouncePeriodS = 0.1;

// A camera that never delivers a frame: robot 1 only serves and merges its memory.
class IdleCamera : public CameraSource {
 public:
  std::optional<CameraFrame> Next() override {
    while (interrupted_.WaitUntil(Clock::now() + std::chrono::hours(1))) {
    }
    return std::nullopt;
  }
  const CameraIntrinsics& intrinsics() const override { return intrinsics_; }
  std::string name() const override { return "idle"; }

 private:
  CameraIntrinsics intrinsics_ = CameraIntrinsics::FromHorizontalFov(64, 48, 60);
};

// Records the instants of tscd's log lines that bound the merge.
class MergeLogSink : public spdlog::sinks::base_sink<std::mutex> {
 public:
  std::optional<Clock::time_point> received() const { return Get(received_); }
  std::optional<Clock::time_point> merged() const { return Get(merged_); }

 protected:
  void sink_it_(const spdlog::details::log_msg& msg) override {
    const std::string_view text(msg.payload.data(), msg.payload.size());
    const int64_t now = Clock::now().time_since_epoch().count();
    int64_t none = 0;
    if (text.starts_with("received the memory of robot 2")) {
      received_.compare_exchange_strong(none, now);
    } else if (text.starts_with("merged the memory of robot 2")) {
      merged_.compare_exchange_strong(none, now);
    }
  }
  void flush_() override {}

 private:
  static std::optional<Clock::time_point> Get(const std::atomic<int64_t>& at) {
    const int64_t v = at;
    if (v == 0) return std::nullopt;
    return Clock::time_point(Clock::duration(v));
  }
  std::atomic<int64_t> received_{0}, merged_{0};
};

using Announce = testing_support::ServingPeer::HeardAnnounce;

double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

// Largest gap between consecutive announces that ends in (from, to], minus the period (ms): a
// stall counts in the phase where it ends (the announce it held back).
double JitterMs(const std::vector<Announce>& a, Clock::time_point from, Clock::time_point to) {
  double worst = 0.0;
  for (size_t i = 1; i < a.size(); ++i) {
    if (a[i].at <= from || a[i].at > to) continue;
    worst = std::max(worst, Seconds(a[i].at - a[i - 1].at) - kAnnouncePeriodS);
  }
  return worst * 1000.0;
}

int Main(int argc, char** argv) {
  const auto args =
      KeyValueArgs(argc, argv, {"places", "dim", "out"}, "[--places N] [--dim D] [--out FILE]");
  if (!args) return 2;
  const int places = static_cast<int>(NumberArg(*args, "places", 10000));
  const int dim = static_cast<int>(NumberArg(*args, "dim", 1200));
  const std::string out = args->count("out") ? args->at("out") : "";
  const char* netns = std::getenv("TSCD_IN_NETNS");
  if (netns == nullptr) {
    std::fprintf(stderr, "run me in a private network namespace: test/support/in_netns %s\n",
                 argv[0]);
    return 2;
  }
  const fs::path dir =
      fs::temp_directory_path() / ("tscd_loop_latency." + std::to_string(getpid()));
  fs::create_directories(dir);

  // Robot 1's memory in its store; robot 2's as a snapshot (half of its places are robot 1's).
  const auto t_build = Clock::now();
  const testing_support::SyntheticPlaces world(1, dim, 64, 0.02f, 1);
  PlaceMemory ours = testing_support::SyntheticMemory(1, world, 0, places, kMembers);
  const PlaceMemory theirs =
      testing_support::SyntheticMemory(2, world, places / 2, places, kMembers);
  {
    Store store = Store::Open(dir / "memory.db");
    IdleCamera camera;
    const Pipeline pipeline(camera.intrinsics(), PipelineOptions{}, std::move(ours),
                            TopologicalMap{}, PipelineState{});
    store.CommitPending({}, pipeline, true, std::nullopt);
  }
  const TopologicalMap no_map;
  // Robot 2: serves its memory to robot 1 (announcing from StartAnnouncing on) and records
  // robot 1's announces.
  testing_support::ServingPeer peer(
      2, BuildSnapshot(theirs, no_map, SnapshotHeader{2, 4242, 1, 1}, BusOptions{}.portion_bytes),
      kUrl, /*announcing=*/false);
  std::printf("memories of %d places (dim %d) built and stored in %.1f s\n", places, dim,
              Seconds(Clock::now() - t_build));

  auto sink = std::make_shared<MergeLogSink>();
  spdlog::default_logger()->sinks().push_back(sink);
  Settings settings = LoadSettings(
      std::nullopt, {"robot.id=1", "camera.source=sim", "daemon.state_dir=" + dir.string(),
                     std::string("lcm.url=") + kUrl,
                     "lcm.announce_period_s=" + std::to_string(kAnnouncePeriodS)});
  std::optional<Daemon> daemon;
  daemon.emplace(std::move(settings), SettingsSource{}, std::make_unique<IdleCamera>());
  std::thread loop([&] { daemon->Run(); });
  // Robot 1 announces for a second, then robot 2 appears; the run ends 10 s after the merge.
  std::this_thread::sleep_for(std::chrono::seconds(1));
  const auto t_peer = Clock::now();
  peer.StartAnnouncing();
  while (!sink->merged() && Clock::now() - t_peer < std::chrono::minutes(10)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  std::this_thread::sleep_for(std::chrono::seconds(10));
  const auto t_end = Clock::now();
  daemon->Stop();
  loop.join();
  daemon.reset();
  fs::remove_all(dir);

  const std::vector<Announce> a = peer.announces();
  if (!sink->received() || !sink->merged()) {
    std::fprintf(stderr, "no merge within 10 min\n");
    return 1;
  }
  int64_t version_before = 0, version_after = 0;
  for (const Announce& x : a) {
    if (x.at < *sink->received()) version_before = x.memory_version;
    version_after = x.memory_version;
  }
  char report[1024];
  std::snprintf(report, sizeof report,
                "places %d + %d (dim %d), announce period %.0f ms, %zu announces\n"
                "transfer %.2f s, merge and commit %.2f s (received -> merged log lines)\n"
                "memory version %lld -> %lld\n"
                "announce jitter (largest gap - period): while the memory arrives and is "
                "assembled %.1f ms, during the merge and its commit %.1f ms, in the 10 s after "
                "(snapshot, broadcast) %.1f ms\n",
                places, places, dim, kAnnouncePeriodS * 1000, a.size(),
                Seconds(*sink->received() - t_peer), Seconds(*sink->merged() - *sink->received()),
                static_cast<long long>(version_before), static_cast<long long>(version_after),
                JitterMs(a, t_peer, *sink->received() + std::chrono::milliseconds(500)),
                JitterMs(a, *sink->received() + std::chrono::milliseconds(500), *sink->merged()),
                JitterMs(a, *sink->merged(), t_end));
  std::fputs(report, stdout);
  // The largest gaps, for a look at where they fall.
  std::vector<std::pair<double, double>> gaps;  // (gap ms, its end in s after "received")
  for (size_t i = 1; i < a.size(); ++i) {
    gaps.emplace_back(Seconds(a[i].at - a[i - 1].at) * 1000.0,
                      Seconds(a[i].at - *sink->received()));
  }
  std::sort(gaps.rbegin(), gaps.rend());
  for (size_t i = 0; i < std::min<size_t>(5, gaps.size()); ++i) {
    std::printf("  gap %.0f ms ending %.2f s after the memory was received\n", gaps[i].first,
                gaps[i].second);
  }
  if (!out.empty()) std::ofstream(out, std::ios::app) << report;
  return 0;
}

}  // namespace
}  // namespace tsc

int main(int argc, char** argv) { return tsc::Main(argc, argv); }
