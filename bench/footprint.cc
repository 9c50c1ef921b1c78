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
//   build/bin/tscd_footprint [--places N] [--dim D] [--members M] [--settle-s S] [--out FILE]
//                            [--keep DIR | --reuse DIR] [--threads T]

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
#include "core/pipeline/pipeline.h"
#include "store/store.h"
#include "test/support/child_process.h"
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

uint64_t FileBytes(const fs::path& p) {
  std::error_code ec;
  const auto n = fs::file_size(p, ec);
  return ec ? 0 : n;
}

int Main(int argc, char** argv) {
  const auto args = KeyValueArgs(
      argc, argv, {"places", "dim", "members", "settle-s", "out", "keep", "reuse", "threads"},
      "[--places N] [--dim D] [--members M] [--settle-s S] [--out FILE] "
      "[--keep DIR | --reuse DIR] [--threads T]");
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
  if (places < 1 || dim < 1 || members < 1 || threads < 0) {
    std::fprintf(stderr, "%s: places, dim and members must be positive, threads not negative\n",
                 argv[0]);
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
  if (!reuse) {
    const testing_support::SyntheticPlaces world(1, dim, 64, 0.02f, 1);
    Store store = Store::Open(dir / "memory.db");
    // The memory as tscd keeps it with its default options: member views in the builtin basis
    // when the dimension is the default features' (core/memory/builtin_view_basis.h).
    PipelineOptions options;
    if (dim != options.memory.view_basis->input_dimension()) options.memory.view_basis = nullptr;
    // From 10⁵ places the SLINK tree over the means' coordinates in the basis, as the
    // benchmarks' fixtures (every γ in 1200 dimensions would take the writer hours).
    const bool large = places >= testing_support::kLargeMemory && options.memory.view_basis;
    const Pipeline pipeline(CameraIntrinsics::FromHorizontalFov(160, 120, 60), options,
                            large ? testing_support::LargeSyntheticMemory(
                                        1, world, 0, places, members, options.memory, visits)
                                  : testing_support::SyntheticMemory(1, world, 0, places, members,
                                                                     options.memory, visits),
                            TopologicalMap{}, PipelineState{});
    store.CommitPending({}, pipeline, true, std::nullopt);
  }
  const uint64_t db_bytes = FileBytes(dir / "memory.db") + FileBytes(dir / "memory.db-wal");
  if (!reuse) {
    std::printf("a store of %d places (dim %d, %d member views) written in %.1f s\n", places, dim,
                members, Seconds(Clock::now() - t_build));
  }

  const fs::path log = dir / "tscd.log";
  fs::remove(log);  // an earlier run's, when reused: "ready" is looked for in this one's
  testing_support::ChildProcess tscd(
      {std::string(TSCD_BIN_DIR) + "/tscd", "--robot", "1", "--state-dir", dir.string(), "--set",
       "camera.source=sim", "--set", "camera.fps=1", "--set", "lcm.url=memq://", "--set",
       "daemon.merge_threads=" + std::to_string(threads)},
      log);
  // Loaded, announcing and serving: "ready" is logged after the memory is loaded; the first
  // announce asks the worker for a snapshot, which the settling time leaves room for.
  const auto t_start = Clock::now();
  while (tscd.running() && tscd.Log().find("ready:") == std::string::npos &&
         Clock::now() - t_start < std::chrono::minutes(10)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
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
  tscd.Signal(SIGTERM);
  const std::optional<int> status = tscd.Wait(std::chrono::seconds(60));
  if (rss < 0 || !status || *status != 0) {
    std::fprintf(stderr, "tscd did not run through (exit %d); its log:\n%s\n",
                 status ? *status : -1, tscd.Log().c_str());
    if (!keep) fs::remove_all(dir);
    return 1;
  }
  if (!keep) fs::remove_all(dir);

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
  if (!out.empty()) std::ofstream(out, std::ios::app) << report;
  return 0;
}

}  // namespace
}  // namespace tsc

int main(int argc, char** argv) { return tsc::Main(argc, argv); }
