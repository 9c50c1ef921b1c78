// tscd_footprint: what a learned memory of N places costs tscd in RAM and on disk (issue 23,
// deliver 3; DESIGN §8: RSS ≤ 200 MB at 10⁴ places). A whole-program measurement, not a
// Google Benchmark: a store holding N synthetic places (test/support/synthetic_places.h, the
// descriptor dimension of the default features, as many member views as a place keeps at
// most, 32 for each of two visits, unless --members says otherwise) is written, the real
// tscd binary is started on it (sim camera at 1 frame/s, LCM on memq://, so nothing leaves
// the process), and once it has loaded the memory, announced and built its first snapshot
// the report gives its resident set (VmRSS, and the peak VmHWM) and the database size, in
// total and per place, and the CPU tscd spent over the settling time (idle but for the sim
// camera's frame a second: announces, snapshots for peers). "Ready after" is the start-up time
// of a robot with that memory: tscd restores it on `--threads` threads (daemon.merge_threads,
// 0 = one per core, tscd's default).
//
// With --peer-places P the report goes on past the idle figures: a teammate (robot 2) appears
// serving P places of the same kind, half of them robot 1's, and once tscd logs that it merged
// them and has settled again its RSS is read a second time, with the peak the merge reached. A
// merge frees what it built; what the allocator keeps of that (GLIBC_TUNABLES set for this
// program reaches tscd) shows here. Then the teammate's version 2, one place changed, is
// merged too, and tscd's account of both merges (its "merged the memory" lines, with the time
// of each phase) is printed. The peer speaks the real exchange protocol over udpm://,
// so this mode runs in a private network namespace only (test/support/in_netns).
// With --peer-merged 1 the teammate has merged robot 1's memory before it serves its own (it
// holds robot 1's places among its sources), as in a team that has exchanged both ways: its
// version 2 is then the repeat exchange of a settled team, where without it every place of
// ours is new to the teammate and version 2 still recognises them.
//
//   build/bin/tscd_footprint [--places N] [--dim D] [--members M] [--settle-s S] [--out FILE]
//                            [--keep DIR | --reuse DIR] [--threads T]
//   test/support/in_netns build/bin/tscd_footprint --peer-places P [--peer-merged 1]
//                                                  [the options above]

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "bench/key_value_args.h"
#include "core/merge/merge.h"
#include "core/pipeline/pipeline.h"
#include "daemon/memory_snapshot.h"
#include "settings/daemon_options.h"
#include "store/store.h"
#include "test/support/child_process.h"
#include "test/support/serving_peer.h"
#include "test/support/synthetic_places.h"

namespace tsc {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

// A field of /proc/<pid>/status in MB ("VmRSS", "VmHWM"); -1 when the process is gone.
double StatusMb(pid_t pid, const std::string& field) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(field + ":", 0) != 0) continue;
    std::istringstream v(line.substr(field.size() + 1));
    double kb = 0;
    v >> kb;
    return kb / 1024.0;
  }
  return -1;
}

// utime + stime of a process in seconds (/proc/<pid>/stat fields 14 and 15); -1 when gone.
double CpuSeconds(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string stat((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // The command name (field 2) may hold spaces: fields are counted after its closing ')'.
  const size_t close = stat.rfind(')');
  if (close == std::string::npos) return -1;
  std::istringstream fields(stat.substr(close + 1));
  std::string field;
  double ticks = 0;
  for (int i = 3; i <= 15 && fields >> field; ++i) {
    if (i >= 14) ticks += std::stod(field);
  }
  return ticks / static_cast<double>(sysconf(_SC_CLK_TCK));
}

// Waits until tscd's log holds `line`, tscd exits or `limit` passes; true when it holds it.
bool AwaitLogLine(testing_support::ChildProcess& tscd, const std::string& line,
                  Clock::duration limit) {
  const auto start = Clock::now();
  while (tscd.running() && tscd.Log().find(line) == std::string::npos &&
         Clock::now() - start < limit) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return tscd.Log().find(line) != std::string::npos;
}

uint64_t FileBytes(const fs::path& p) {
  std::error_code ec;
  const auto n = fs::file_size(p, ec);
  return ec ? 0 : n;
}

int Main(int argc, char** argv) {
  const auto args =
      KeyValueArgs(argc, argv,
                   {"places", "dim", "members", "settle-s", "out", "keep", "reuse", "threads",
                    "peer-places", "peer-merged"},
                   "[--places N] [--dim D] [--members M] [--settle-s S] [--out FILE] "
                   "[--keep DIR | --reuse DIR] [--threads T] [--peer-places P [--peer-merged 1]]");
  if (!args) return 2;
  const int places = static_cast<int>(NumberArg(*args, "places", 10000));
  const int dim = static_cast<int>(NumberArg(*args, "dim", 1200));
  // A place of a long-lived memory holds the cap: memory.max_samples_per_place views for each
  // of memory.sample_visits visits.
  const PlaceMemoryOptions defaults;
  const int members = static_cast<int>(
      NumberArg(*args, "members", defaults.max_samples_per_place * defaults.sample_visits));
  // Seen as often as its views need: a place keeps max_samples_per_place views a visit.
  const int visits =
      std::max(1, (members + defaults.max_samples_per_place - 1) / defaults.max_samples_per_place);
  const double settle_s = NumberArg(*args, "settle-s", 15);
  const int threads = static_cast<int>(NumberArg(*args, "threads", 0));
  const std::string out = args->count("out") ? args->at("out") : "";
  const int peer_places = static_cast<int>(NumberArg(*args, "peer-places", 0));
  const bool peer_merged = NumberArg(*args, "peer-merged", 0) != 0;
  if (places < 1 || dim < 1 || members < 1 || threads < 0 || peer_places < 0) {
    std::fprintf(stderr,
                 "%s: places, dim and members must be positive, threads and peer-places not "
                 "negative\n",
                 argv[0]);
    return 2;
  }
  if (peer_places > 0 && std::getenv("TSCD_IN_NETNS") == nullptr) {
    std::fprintf(stderr,
                 "%s: --peer-places needs a private network namespace: "
                 "test/support/in_netns %s ...\n",
                 argv[0], argv[0]);
    return 2;
  }
  // --keep: the state directory is written there and left for inspection (tsc inspect, a heap
  // profiler on tscd); else a temporary one is removed at the end. --reuse: the store an
  // earlier --keep left there is measured again as it is (writing 10⁵ places takes minutes);
  // --places and --members must then say what it holds, as tscd's log line below does.
  const bool reuse = args->count("reuse") > 0;
  if (reuse && args->count("keep")) {
    std::fprintf(stderr, "%s: --keep and --reuse exclude each other\n", argv[0]);
    return 2;
  }
  const bool keep = reuse || args->count("keep") > 0;
  const fs::path dir =
      reuse  ? fs::path(args->at("reuse"))
      : keep ? fs::path(args->at("keep"))
             : fs::temp_directory_path() / ("tscd_footprint." + std::to_string(getpid()));
  if (fs::exists(dir / "memory.db") != reuse) {
    std::fprintf(stderr, reuse ? "%s: %s holds no store\n" : "%s: %s already holds a store\n",
                 argv[0], dir.c_str());
    return 2;
  }
  fs::create_directories(dir);

  const auto t_build = Clock::now();
  const testing_support::SyntheticPlaces world(1, dim, 64, 0.02f, 1);
  // The memory as tscd keeps it with its default options: member views in the builtin basis
  // when the dimension is the default features' (core/memory/builtin_view_basis.h).
  PipelineOptions options;
  if (dim != options.memory.view_basis->input_dimension()) options.memory.view_basis = nullptr;
  // From 10⁵ places the SLINK tree over the means' coordinates in the basis, as the
  // benchmarks' fixtures (every γ in 1200 dimensions would take the writer hours).
  const auto synthetic = [&](uint32_t robot, int first, int n) {
    return n >= testing_support::kLargeMemory && options.memory.view_basis
               ? testing_support::LargeSyntheticMemory(robot, world, first, n, members,
                                                       options.memory, visits)
               : testing_support::SyntheticMemory(robot, world, first, n, members, options.memory,
                                                  visits);
  };
  if (!reuse) {
    Store store = Store::Open(dir / "memory.db");
    const Pipeline pipeline(CameraIntrinsics::FromHorizontalFov(160, 120, 60), options,
                            synthetic(1, 0, places), TopologicalMap{}, PipelineState{});
    store.CommitPending({}, pipeline, true, std::nullopt);
  }
  const uint64_t db_bytes = FileBytes(dir / "memory.db") + FileBytes(dir / "memory.db-wal");
  // A merge commits to the store tscd runs on: a reused store is merged in a copy, so it stays
  // the memory it was written as (and robot 2's version, once merged, is not skipped next time).
  const bool on_copy = reuse && peer_places > 0;
  const fs::path run_dir =
      on_copy ? fs::temp_directory_path() / ("tscd_footprint." + std::to_string(getpid())) : dir;
  if (on_copy) {
    fs::create_directories(run_dir);
    for (const char* f : {"memory.db", "memory.db-wal"}) {
      if (fs::exists(dir / f)) fs::copy_file(dir / f, run_dir / f);
    }
  }
  if (!reuse) {
    std::printf("a store of %d places (dim %d, %d member views) written in %.1f s\n", places, dim,
                members, Seconds(Clock::now() - t_build));
  }

  // Robot 2, silent until tscd has been measured idle: its places start half-way through
  // robot 1's, so where P = N half of each memory is the other's.
  // Then its version 2, which changes one place: what a merge costs in a team that has merged
  // before (one body fetched, one place changed).
  std::optional<testing_support::ServingPeer> peer;
  std::optional<MemorySnapshot> peer_v2;
  if (peer_places > 0) {
    const auto t_peer = Clock::now();
    PlaceMemory v1 = synthetic(2, places / 2, peer_places);
    if (peer_merged) {
      // Robot 1's memory as its store holds it (the same synthetic places), merged into the
      // teammate's as the teammate's tscd would have.
      v1 =
          MergeMemories(std::move(v1), synthetic(1, 0, places), std::thread::hardware_concurrency())
              .memory;
    }
    std::vector<LearnedPlace> changed = v1.places();
    changed.front().member_count += 1;
    changed.front().mean *= 1.001f;
    const PlaceMemory v2 = PlaceMemory::Restore(2, v1.options(), std::move(changed), v1.slink(),
                                                v1.next_local_id(), {});
    peer_v2 = BuildSnapshot(v2, TopologicalMap{}, SnapshotHeader{2, 4242, 2, 2},
                            BusOptions{}.portion_bytes);
    peer.emplace(2,
                 BuildSnapshot(v1, TopologicalMap{}, SnapshotHeader{2, 4242, 1, 1},
                               BusOptions{}.portion_bytes),
                 testing_support::kNamespaceBusUrl, /*announcing=*/false);
    std::printf("a peer of %d places built in %.1f s\n", peer_places,
                Seconds(Clock::now() - t_peer));
  }

  const fs::path log = run_dir / "tscd.log";
  fs::remove(log);  // an earlier run's, when reused: "ready" is looked for in this one's
  testing_support::ChildProcess tscd(
      {std::string(TSCD_BIN_DIR) + "/tscd", "--robot", "1", "--state-dir", run_dir.string(),
       "--set", "camera.source=sim", "--set", "camera.fps=1", "--set",
       std::string("lcm.url=") + (peer ? testing_support::kNamespaceBusUrl : "memq://"), "--set",
       "daemon.merge_threads=" + std::to_string(threads), "--set",
       // A settled team's repeat exchange changes nothing, which tscd logs at debug level.
       std::string("daemon.log_level=") + (peer_merged ? "debug" : "info")},
      log);
  // Loaded, announcing and serving: "ready" is logged after the memory is loaded; the first
  // announce asks the worker for a snapshot, which the settling time leaves room for.
  const auto t_start = Clock::now();
  AwaitLogLine(tscd, "ready:", std::chrono::minutes(10));
  const double ready_s = Seconds(Clock::now() - t_start);
  // What tscd says it loaded, and in what time (the rest of "ready" is the process starting).
  const std::string started = tscd.Log();
  const size_t loaded = started.find("memory loaded from");
  if (loaded != std::string::npos) {
    std::printf("tscd: %s\n", started.substr(loaded, started.find('\n', loaded) - loaded).c_str());
  }
  // What tscd spends while idle with this memory (announces, snapshots for peers).
  const double cpu_before = CpuSeconds(tscd.pid());
  std::this_thread::sleep_for(std::chrono::duration<double>(settle_s));
  const double cpu_s = CpuSeconds(tscd.pid()) - cpu_before;
  const double rss = StatusMb(tscd.pid(), "VmRSS"), hwm = StatusMb(tscd.pid(), "VmHWM");
  // With a peer: its memory arrives, is merged and committed; then tscd settles again.
  std::string merged_report;
  bool merged = true;
  if (peer) {
    const auto t_peer = Clock::now();
    peer->StartAnnouncing();
    merged = AwaitLogLine(tscd, "merged the memory of robot 2", std::chrono::minutes(10));
    const double merged_s = Seconds(Clock::now() - t_peer);
    std::this_thread::sleep_for(std::chrono::duration<double>(settle_s));
    char line[384];
    std::snprintf(line, sizeof line,
                  "peer of %d places (half of them robot 1's%s) merged %.1f s after it "
                  "appeared; %.0f s later: RSS %.1f MB, peak %.1f MB\n",
                  peer_places, peer_merged ? ", and robot 1's memory merged before" : "", merged_s,
                  settle_s, StatusMb(tscd.pid(), "VmRSS"), StatusMb(tscd.pid(), "VmHWM"));
    merged_report = line;
    // tscd's own account: the merge's case, places and time (building the peer's memory,
    // merging and storing the result; not the transfer).
    const auto report_merge = [&](const std::string& logged) {
      const std::string after = tscd.Log();
      const size_t at = after.find(logged);
      if (at != std::string::npos) {
        merged_report += "tscd: " + after.substr(at, after.find('\n', at) - at) + "\n";
      }
    };
    report_merge("merged the memory of robot 2 (version 1");
    // Version 2, one place changed, merged into the memory that holds version 1.
    peer.reset();
    peer.emplace(2, std::move(*peer_v2), testing_support::kNamespaceBusUrl, /*announcing=*/true);
    merged = AwaitLogLine(tscd, "merged the memory of robot 2 (version 2", std::chrono::minutes(5));
    // The exchange of version 2 as tscd logged it, with its times: its requests, the memory
    // received and checked (where kept bodies are loaded or known by name), the merge.
    const std::string after = tscd.Log();
    std::istringstream lines(after);
    for (std::string l; std::getline(lines, l);) {
      if (l.find("of version 2") != std::string::npos ||
          l.find("robot 2 (version 2") != std::string::npos) {
        merged_report += "tscd log: " + l + "\n";
      }
    }
  }
  tscd.Signal(SIGTERM);
  const std::optional<int> status = tscd.Wait(std::chrono::seconds(60));
  if (rss < 0 || !merged || !status || *status != 0) {
    std::fprintf(stderr, "tscd did not run through (exit %d%s); its log:\n%s\n",
                 status ? *status : -1, merged ? "" : ", no merge of the peer logged",
                 tscd.Log().c_str());
    if (!keep) fs::remove_all(dir);
    if (on_copy) fs::remove_all(run_dir);
    return 1;
  }
  if (peer) {
    // The merged memory, the peer's version and its place bodies (kept for its next exchange).
    const uint64_t bytes = FileBytes(run_dir / "memory.db") + FileBytes(run_dir / "memory.db-wal");
    char line[160];
    std::snprintf(line, sizeof line, "database after the merge %.1f MB\n",
                  static_cast<double>(bytes) / (1 << 20));
    merged_report += line;
  }
  if (!keep) fs::remove_all(dir);
  if (on_copy) fs::remove_all(run_dir);

  char report[768];
  std::snprintf(report, sizeof report,
                "places %d (dim %d, %d member views): tscd ready after %.1f s (%d restore threads, "
                "0 = one per core); after %.0f s "
                "more: RSS %.1f MB (%.1f KB per place), peak %.1f MB (%.1f KB per place); "
                "database %.1f MB (%.1f KB per place); CPU over those %.0f s %.2f s (%.1f %% of "
                "a core)\n",
                places, dim, members, ready_s, threads, settle_s, rss, 1024.0 * rss / places, hwm,
                1024.0 * hwm / places, static_cast<double>(db_bytes) / (1 << 20),
                static_cast<double>(db_bytes) / 1024.0 / places, settle_s, cpu_s,
                100.0 * cpu_s / settle_s);
  std::fputs(report, stdout);
  std::fputs(merged_report.c_str(), stdout);
  if (!out.empty()) std::ofstream(out, std::ios::app) << report << merged_report;
  return 0;
}

}  // namespace
}  // namespace tsc

int main(int argc, char** argv) { return tsc::Main(argc, argv); }
