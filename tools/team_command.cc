#include "tools/team_command.h"

#include <unistd.h>

#include <algorithm>
#include <boost/program_options.hpp>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "daemon/lcm_bus.h"
#include "drivers/camera/make_camera.h"
#include "drivers/camera/sim_camera.h"
#include "settings/settings.h"
#include "store/store.h"
#include "tools/command_line.h"
#include "tools/events_json.h"
#include "tools/inspect.h"
#include "tools/robot_processes.h"
#include "tools/scoring.h"
#include "tools/team_replay.h"
#include "tsc/announce_t.hpp"
#include "tsc/place_event_t.hpp"
#include "tsc/stats_t.hpp"

namespace tsc {
namespace {

// A duration for people, in whole seconds.
std::string Seconds(double seconds) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.0f s", seconds);
  return buf;
}

namespace fs = std::filesystem;
namespace po = boost::program_options;
using Clock = std::chrono::steady_clock;

constexpr const char* kNetnsEnv = "TSCD_TEAM_NETNS";
constexpr const char* kLcmUrl = "udpm://239.255.76.67:7667?ttl=0";

constexpr const char* kTeamHelp =
    R"(usage: tsc team --robots N --world SEED [--kind office|corridors|outdoor]
                [--seconds S] [--out DIR] [--fps F] [--config FILE] [--set KEY=VALUE]...
                [--netns new|current]
       tsc team --offline --robots N --world SEED [--order I,J,..] [--exchange-every B]
                [--kind ..] [--out DIR] [--config FILE] [--set KEY=VALUE]...

Runs a team simulation on this host: N tscd processes (robot ids 1..N) in one private network
namespace (`unshare -n`, multicast routed on lo only, so no packet leaves the namespace), each
driving its own route through the simulated world generated from SEED. Shows live progress
per robot, stops the robots cleanly after S seconds or, with --seconds 0, once every route
has ended and the memory exchange has settled (every robot has merged every other's last
memory), prints a summary per robot with merge correctness (DESIGN 7.1b) and whether the
final memories are consistent (know the same places), and writes DIR/summary.json,
DIR/robot-<id>/memory.db, tscd.log and memory.png. --netns current runs in the caller's namespace, which must itself be private
(tests do this to listen in); it is refused when that namespace has any interface but lo.

--offline is the deterministic evaluation: no process, no network. Each robot's route is
replayed in this process with the pipeline and settings its tscd would use; then, in rounds
until nothing changes, each robot in --order merges every other robot's memory in --order
(received as tscd receives it; MergeMemories, MergeMaps). The summary and DIR/summary.json
are the live run's (cpu, memory and seconds null), plus "mode", "order", "exchange_every" and
"settled". The same arguments give the same file. With --exchange-every B the robots also
exchange while they drive, as live robots do: each drives B base points, then each in --order
merges the others' memories as they stand and goes on with what it adopted; the rounds after
the routes follow. A live tscd broadcasts a changed memory every 5 s (lcm.memory_period_s):
about 50 base points of a 10 fps camera.

Both runs draw DIR/team_map.png: robot 1's final memory over the simulated floor plan, each
place at the mean position of its frames in the colour of the robot whose id it carries,
merged places ringed in the colours of the robots they absorbed, room labels from the ground
truth.

Options)";

struct RobotStats {
  int id = 0;
  pid_t pid = -1;
  fs::path dir;
  bool exited = false;
  int exit_status = 0;  // exit code, or 128 + signal
  // From its announces and events.
  int64_t frames = 0;
  int64_t dropped = 0;
  int32_t places = 0;
  int32_t edges = 0;
  int32_t detected = 0;
  int64_t recognitions = 0;
  int64_t learned = 0;
  int64_t merged = 0;  // "merged" events: peer places absorbed into ours
  std::string status;
  bool route_ended = false;
  int64_t memory_version = -1;                         // from its last announce
  std::chrono::steady_clock::time_point version_seen;  // when memory_version last changed
  // From its TSC_STATS: peer memories received and merged so far.
  int64_t snapshots_received = 0;
  int64_t merges_completed = 0;
  // Measured from /proc just before the stop.
  double cpu_percent = 0.0;  // of one core, averaged over the run
  double peak_rss_mb = 0.0;  // VmHWM
};

// CPU time (user + system) of the robot as a share of one core over `elapsed_s`, and its peak
// resident set in MB, from /proc.
void MeasureProcess(RobotStats& r, double elapsed_s) {
  const ProcessSample p = SampleProcess(r.pid);
  if (!p.alive) return;
  if (elapsed_s > 0) r.cpu_percent = 100.0 * p.cpu_s / elapsed_s;
  r.peak_rss_mb = p.peak_rss_mb;
}

void Reap(RobotStats& r, bool block) {
  if (r.exited || r.pid < 0) return;
  const ChildExit e = ReapChild(r.pid, block);
  if (e.exited) {
    r.exited = true;
    r.exit_status = e.status;
  }
}

void StopRobots(std::vector<RobotStats>& robots) {
  for (RobotStats& r : robots) {
    if (!r.exited) kill(r.pid, SIGTERM);
  }
  const auto deadline = Clock::now() + std::chrono::seconds(30);
  for (RobotStats& r : robots) {
    while (!r.exited && Clock::now() < deadline) {
      Reap(r, false);
      if (!r.exited) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    if (!r.exited) {
      std::cerr << "tsc: robot " << r.id << " did not stop within 30 s of SIGTERM; killing it\n";
      kill(r.pid, SIGKILL);
      Reap(r, true);
    }
  }
}

std::string ProgressLine(const std::vector<RobotStats>& robots, double elapsed) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(0) << elapsed << " s";
  for (const RobotStats& r : robots) {
    s << " | robot " << r.id << ": " << r.frames << " frames, " << r.places << " places, "
      << r.recognitions << " recognised, " << r.edges << " edges";
    if (r.exited) {
      s << " (exited " << r.exit_status << ")";
    } else if (r.route_ended) {
      s << " (route ended)";
    }
  }
  return s.str();
}

// DIR/team_map.png: the final memory of `whose` over the floor plan (tools/plots.h). A picture
// that cannot be drawn is reported, not fatal.
void WriteTeamMapOf(const std::vector<ReplayedRobot>& robots, const ReplayedRobot& whose,
                    const Settings& settings, long long world, const std::string& kind,
                    const fs::path& out) {
  try {
    const WorldPlan plan = WorldPlanOf(settings);
    std::ostringstream title, subtitle;
    title << "team map: robot " << whose.id << "'s memory after merging, " << kind << " world "
          << world;
    subtitle << whose.memory.places().size() << " places, " << whose.map.edges().size()
             << " edges, " << robots.size() << " robots";
    WriteTeamMap(TeamMapOf(whose.memory, whose.map, robots, title.str(), subtitle.str()), &plan,
                 out / "team_map.png");
    std::cout << "team map: " << (out / "team_map.png").string() << "\n";
  } catch (const std::exception& e) {
    std::cerr << "tsc: no team map: " << e.what() << "\n";
  }
}

// One robot's row of summary.json and of the printed table; both modes write the same fields
// (the offline replay has no process: no exit status, CPU, RSS, store or log).
struct RobotRow {
  uint32_t robot = 0;
  int exit_status = 0;
  int64_t frames = 0, frames_dropped = 0, detected_places = 0, places = 0, recognitions = 0,
          edges = 0;
  // Merging (chapter 4): places the robot learned itself, places it took from peers, and
  // peers' places absorbed into one of its places.
  int64_t own = 0, from_peers = 0, absorbed = 0;
  int64_t merged_events = 0;
  double cpu_percent = std::nan(""), peak_rss_mb = std::nan("");
  std::optional<fs::path> dir;  ///< the robot's state directory (memory.db, tscd.log)

  void CountOrigins(const PlaceMemory& memory) {
    for (const LearnedPlace& p : memory.places()) {
      (p.id.robot == robot ? own : from_peers) += 1;
      absorbed += static_cast<int64_t>(p.sources.size());
    }
  }
  std::string Json() const {
    std::ostringstream json;
    json << "{\"robot\":" << robot << ",\"exit_status\":" << exit_status << ",\"frames\":" << frames
         << ",\"frames_dropped\":" << frames_dropped << ",\"detected_places\":" << detected_places
         << ",\"places\":" << places << ",\"recognitions\":" << recognitions
         << ",\"edges\":" << edges << ",\"own_places\":" << own
         << ",\"places_from_peers\":" << from_peers << ",\"peer_places_absorbed\":" << absorbed
         << ",\"merged_events\":" << merged_events << ",\"cpu_percent\":" << JsonNumber(cpu_percent)
         << ",\"peak_rss_mb\":" << JsonNumber(peak_rss_mb)
         << ",\"db\":" << (dir ? JsonString((*dir / "memory.db").string()) : "null")
         << ",\"log\":" << (dir ? JsonString((*dir / "tscd.log").string()) : "null") << "}";
    return json.str();
  }
  /// One line of the printed table; a live run adds the process columns (exit, dropped, CPU,
  /// RSS) under LiveHeader().
  void Print(std::ostream& o, bool live) const {
    o << std::setw(5) << robot;
    if (live) o << std::setw(6) << exit_status;
    o << std::setw(8) << frames;
    if (live) o << std::setw(9) << frames_dropped;
    o << std::setw(10) << detected_places << std::setw(8) << places << std::setw(12) << recognitions
      << std::setw(7) << edges << std::setw(5) << own << std::setw(11) << from_peers
      << std::setw(10) << absorbed;
    if (live) {
      o << std::fixed << std::setprecision(1) << std::setw(6) << cpu_percent << std::setw(8)
        << peak_rss_mb << std::defaultfloat;
    }
    o << "\n";
  }
  static const char* Header(bool live) {
    return live
               ? "\nrobot  exit  frames  dropped  detected  places  recognised  edges  own  "
                 "merged-in  absorbed  cpu%  rss MB\n"
               : "\nrobot  frames  detected  places  recognised  edges  own  merged-in  absorbed\n";
  }
};

// What `tsc team` was asked for, checked: the robots' settings as their tscd will read them.
struct TeamRequest {
  int robots = 0;
  long long world = 0;
  std::string kind;
  double seconds = 0.0;  ///< 0: until the routes ended and the exchange settled
  double settle = 0.0;   ///< with seconds 0: the longest wait for settling
  double fps = 0.0;
  std::string netns;  ///< new|current
  fs::path out;
  std::optional<std::vector<uint32_t>> offline_order;  ///< set: --offline, in this order
  int64_t exchange_every = 0;  ///< --offline: base points between exchanges while driving; 0 none
  std::vector<std::string> common;  ///< tscd arguments every robot gets
  std::vector<Settings> settings;   ///< robot i + 1's
};

// "2,1,3": a permutation of 1..n (UsageError otherwise).
std::vector<uint32_t> ParseOrder(const std::string& text, int n) {
  std::vector<uint32_t> order;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    size_t used = 0;
    int id = 0;
    try {
      id = std::stoi(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != item.size() || id < 1 || id > n) {
      throw UsageError("--order: '" + item + "' is not a robot id in 1.." + std::to_string(n));
    }
    order.push_back(static_cast<uint32_t>(id));
  }
  std::vector<uint32_t> sorted = order, all;
  std::sort(sorted.begin(), sorted.end());
  for (int i = 1; i <= n; ++i) all.push_back(static_cast<uint32_t>(i));
  if (sorted != all) {
    throw UsageError("--order must name each robot 1.." + std::to_string(n) + " once");
  }
  return order;
}

// The request, or nullopt when --help was answered. Every robot's settings are loaded here once,
// so a bad key is one message, not N robot logs (ConfigError → exit 78).
std::optional<TeamRequest> ParseTeam(const std::vector<std::string>& args) {
  po::options_description desc(kTeamHelp);
  desc.add_options()("help,h", "show this help")(
      "robots", po::value<int>()->required()->value_name("N"), "robots in the team, 1..16")(
      "world", po::value<long long>()->required()->value_name("SEED"), "seed of the world")(
      "kind", po::value<std::string>()->default_value("office"), "office|corridors|outdoor")(
      "seconds", po::value<double>()->default_value(0.0, "0")->value_name("S"),
      "stop after S seconds (0: when every route has ended and the team has settled)")(
      "settle", po::value<double>()->default_value(60.0, "60")->value_name("S"),
      "with --seconds 0: after the routes end, wait up to S seconds until no memory has "
      "changed and no exchange was in progress for two broadcast periods (every robot has "
      "merged every other's last memory)")(
      "out", po::value<std::string>()->default_value("team-out")->value_name("DIR"),
      "output folder (robot state, logs, summary.json)")(
      "fps", po::value<double>()->default_value(10.0, "10"), "camera frames per second per robot")(
      "config", po::value<std::string>()->value_name("FILE"), "tscd configuration for all")(
      "set", po::value<std::vector<std::string>>()->composing()->value_name("KEY=VALUE"),
      "override a key for every robot (repeatable)")(
      "netns", po::value<std::string>()->default_value("new"), "new|current")(
      "offline",
      "deterministic evaluation: replay every route in this process, then merge "
      "(no robot processes, no network; DIR/summary.json as the live run writes it)")(
      "order", po::value<std::string>()->value_name("I,J,..."),
      "with --offline: the order in which the robots merge each other's memories (a "
      "permutation of 1..N; default 1,2,..,N)")(
      "exchange-every", po::value<long long>()->value_name("B"),
      "with --offline: the robots also exchange while they drive, every B base points (as "
      "live robots do; default: only after the routes)");
  const po::variables_map vm = ParseCommandLine(args, desc);
  if (vm.count("help")) {
    std::cout << desc << "\n";
    return std::nullopt;
  }
  TeamRequest req;
  req.robots = vm["robots"].as<int>();
  if (req.robots < 1 || req.robots > 16) throw UsageError("--robots must be in 1..16");
  req.seconds = vm["seconds"].as<double>();
  if (req.seconds < 0) throw UsageError("--seconds must not be negative");
  req.settle = vm["settle"].as<double>();
  if (req.settle < 0) throw UsageError("--settle must not be negative");
  req.netns = vm["netns"].as<std::string>();
  if (req.netns != "new" && req.netns != "current") throw UsageError("--netns is new or current");
  if (vm.count("order") && !vm.count("offline")) throw UsageError("--order needs --offline");
  if (vm.count("exchange-every")) {
    if (!vm.count("offline")) throw UsageError("--exchange-every needs --offline");
    req.exchange_every = vm["exchange-every"].as<long long>();
    if (req.exchange_every < 1) throw UsageError("--exchange-every must be at least 1");
  }
  req.world = vm["world"].as<long long>();
  req.kind = vm["kind"].as<std::string>();
  req.fps = vm["fps"].as<double>();
  req.out = vm["out"].as<std::string>();

  if (vm.count("config")) req.common = {"--config", vm["config"].as<std::string>()};
  std::vector<std::string> overrides;
  auto set = [&](const std::string& kv) {
    req.common.push_back("--set");
    req.common.push_back(kv);
    overrides.push_back(kv);
  };
  set("camera.source=sim");
  set("lcm.url=" + std::string(kLcmUrl));
  set("sim.world_seed=" + std::to_string(req.world));
  set("sim.world=" + req.kind);
  set("sim.team_size=" + std::to_string(req.robots));
  {
    std::ostringstream fps;
    fps << req.fps;
    set("camera.fps=" + fps.str());
  }
  if (vm.count("set")) {
    for (const std::string& kv : vm["set"].as<std::vector<std::string>>()) set(kv);
  }
  std::optional<fs::path> file;
  if (vm.count("config")) file = vm["config"].as<std::string>();
  for (int i = 0; i < req.robots; ++i) {
    std::vector<std::string> own = overrides;
    own.push_back("sim.route=" + std::to_string(i));
    req.settings.push_back(LoadSettings(file, own));
  }
  if (vm.count("offline")) {
    std::vector<uint32_t> order;
    for (int i = 1; i <= req.robots; ++i) order.push_back(static_cast<uint32_t>(i));
    if (vm.count("order")) order = ParseOrder(vm["order"].as<std::string>(), req.robots);
    req.offline_order = std::move(order);
  }
  return req;
}

// The verdict, the team map and OUT/summary.json (the rows, the verdict, then `tail`: the
// fields of the mode), shared by both modes.
void WriteTeamSummary(const TeamRequest& req, const std::vector<RobotRow>& rows,
                      const TeamVerdict& verdict, const std::vector<ReplayedRobot>& robots,
                      const std::string& tail, bool frames_dropped) {
  PrintTeamVerdict(std::cout, verdict);
  if (frames_dropped) {
    std::cout << "  (frames were dropped: place labels from the route may be shifted)\n";
  }
  WriteTeamMapOf(robots, robots.front(), req.settings.front(), req.world, req.kind, req.out);
  std::ostringstream json;
  json << "{\"robots\":[";
  for (size_t i = 0; i < rows.size(); ++i) json << (i ? "," : "") << rows[i].Json();
  json << "]" << TeamVerdictJson(verdict) << tail << "}\n";
  WriteTextFile(req.out / "summary.json", json.str());
  std::cout << "summary: " << (req.out / "summary.json").string() << "\n";
}

// `tsc team --offline`: every route replayed in this process, the memories exchanged in
// the request's order until nothing changes (tools/team_replay.h), scored and written as the
// live run writes summary.json (process figures null), plus "mode", "order" and "settled".
int TeamOffline(const TeamRequest& req) {
  const std::vector<uint32_t>& order = *req.offline_order;
  fs::create_directories(req.out);
  std::cout << "tsc team --offline: " << req.robots << " robots in world " << req.world << " ("
            << req.kind << "), merge order";
  for (uint32_t id : order) std::cout << " " << id;
  std::cout << ", output in " << req.out.string() << "\n";
  const int portion_bytes = req.settings.front().daemon.bus.portion_bytes;
  std::vector<ReplayedRobot> robots;
  if (req.exchange_every > 0) {
    std::cout << "exchanging every " << req.exchange_every << " base points while driving\n";
    robots = ReplayTeam(req.settings, order, req.exchange_every, portion_bytes);
  } else {
    for (size_t i = 0; i < req.settings.size(); ++i) {
      robots.push_back(ReplayRoute(req.settings[i], static_cast<uint32_t>(i + 1)));
    }
  }
  for (const ReplayedRobot& r : robots) {
    std::cout << "robot " << r.id << ": route replayed, " << r.frames << " base points, "
              << r.memory.places().size() << " places, " << r.recognitions << " recognised\n";
  }
  const bool settled = ExchangeMemories(robots, order, portion_bytes);
  std::cout << "memory exchange " << (settled ? "settled" : "did NOT settle (20 rounds)") << "\n";

  std::vector<TeamMemoryForScoring> scoring;
  std::vector<RobotRow> rows;
  std::cout << RobotRow::Header(false);
  for (const ReplayedRobot& r : robots) {
    scoring.push_back(ForMergeScoring(r, r.memory));
    RobotRow& row = rows.emplace_back();
    row.robot = r.id;
    row.frames = r.frames;
    row.detected_places = r.detected_places;
    row.places = static_cast<int64_t>(r.memory.places().size());
    row.recognitions = r.recognitions;
    row.edges = static_cast<int64_t>(r.map.edges().size());
    row.merged_events = r.absorbed;
    row.CountOrigins(r.memory);
    row.Print(std::cout, false);
  }
  std::ostringstream tail;
  tail << ",\"seconds\":null,\"fps\":" << JsonNumber(req.fps)
       << ",\"mode\":\"offline\",\"order\":[";
  for (size_t i = 0; i < order.size(); ++i) tail << (i ? "," : "") << order[i];
  tail << "],\"exchange_every\":" << req.exchange_every
       << ",\"settled\":" << (settled ? "true" : "false");
  WriteTeamSummary(req, rows, JudgeTeam(scoring), robots, tail.str(), false);
  return settled ? kExitOk : kExitFailure;
}

// Keeps each robot's figures from its announces, stats and events (robot i + 1 is robots[i]).
void ListenToTeam(LcmBus& bus, std::vector<RobotStats>& robots) {
  auto of = [&robots](int32_t robot) -> RobotStats* {
    return robot >= 1 && static_cast<size_t>(robot) <= robots.size()
               ? &robots[static_cast<size_t>(robot - 1)]
               : nullptr;
  };
  bus.Subscribe("TSC_ANNOUNCE", [of](const std::string&, const uint8_t* data, size_t size) {
    const auto a = LcmBus::Decode<announce_t>(data, size);
    RobotStats* r = a ? of(a->robot) : nullptr;
    if (r == nullptr) return;
    r->frames = a->frames;
    r->dropped = a->frames_dropped;
    r->places = a->places;
    r->edges = a->edges;
    r->detected = a->detected_places;
    r->status = a->status;
    r->route_ended = a->status.find("camera ended") != std::string::npos;
    if (a->memory_version != r->memory_version) {
      r->memory_version = a->memory_version;
      r->version_seen = Clock::now();
    }
  });
  // An exchange in progress (portions held, a memory waiting for its merge, or one received or
  // merged since the last stats) counts as a change for settling: under packet loss a fetch
  // can take longer than the quiet time, and stopping then leaves a peer's last places out.
  bus.Subscribe("TSC_STATS_.*", [of](const std::string&, const uint8_t* data, size_t size) {
    const auto s = LcmBus::Decode<stats_t>(data, size);
    RobotStats* r = s ? of(s->robot) : nullptr;
    if (r == nullptr) return;
    if (s->buffered_portions > 0 || s->merge_inbox > 0 ||
        s->snapshots_received != r->snapshots_received ||
        s->merges_completed != r->merges_completed) {
      r->version_seen = Clock::now();
    }
    r->snapshots_received = s->snapshots_received;
    r->merges_completed = s->merges_completed;
  });
  bus.Subscribe("TSC_EVENT_.*", [of](const std::string&, const uint8_t* data, size_t size) {
    const auto e = LcmBus::Decode<place_event_t>(data, size);
    RobotStats* r = e ? of(e->robot) : nullptr;
    if (r == nullptr) return;
    if (e->event == "recognized" && !e->partial) ++r->recognitions;
    if (e->event == "learned") ++r->learned;
    if (e->event == "merged") ++r->merged;
  });
}

// Shows progress until the robots are to stop: all exited, --seconds reached, or (--seconds 0)
// every route ended and the memory exchange settled. Returns the seconds the team ran.
double WatchTeam(LcmBus& bus, std::vector<RobotStats>& robots, const TeamRequest& req) {
  const bool tty = isatty(STDOUT_FILENO) != 0;
  const char* clear = tty ? "\r\033[K" : "";
  const auto start = Clock::now();
  auto last_print = start;
  std::optional<Clock::time_point> settling;  // when every route had ended
  const auto quiet = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(2 * req.settings.front().daemon.bus.memory_period_s + 2.0));
  const auto settle_for =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(req.settle));
  for (;;) {
    bus.HandleTimeout(100);
    const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
    bool all_exited = true, all_ended = true;
    for (RobotStats& r : robots) {
      Reap(r, false);
      all_exited &= r.exited;
      all_ended &= r.route_ended || r.exited;
    }
    if (Clock::now() - last_print >= std::chrono::seconds(tty ? 1 : 5)) {
      last_print = Clock::now();
      std::cout << clear << ProgressLine(robots, elapsed) << (tty ? "" : "\n") << std::flush;
    }
    if (all_exited || (req.seconds > 0 && elapsed >= req.seconds)) break;
    if (req.seconds > 0 || !all_ended) continue;
    // Settling: a changed memory is broadcast within one memory period and merged on arrival,
    // which changes the receiver's version in turn; two quiet periods (and the merge) with no
    // exchange in progress mean every robot has merged every other's last memory.
    if (!settling) {
      settling = Clock::now();
      std::cout << clear << "tsc team: every route ended after " << Seconds(elapsed)
                << "; waiting for the memory exchange to settle (no change for "
                << Seconds(std::chrono::duration<double>(quiet).count()) << ", at most "
                << Seconds(req.settle) << ")\n";
    }
    auto last_change = *settling;
    for (const RobotStats& r : robots) last_change = std::max(last_change, r.version_seen);
    if (Clock::now() - last_change >= quiet) {
      std::cout << clear << "tsc team: memories settled "
                << Seconds(std::chrono::duration<double>(Clock::now() - *settling).count())
                << " after the routes ended; stopping the robots\n";
      break;
    }
    if (Clock::now() - *settling >= settle_for) {
      std::cout << (tty ? "\n" : "") << "tsc team: memories still changing " << req.settle
                << " s after the routes ended; stopping anyway\n";
      break;
    }
  }
  // Let the last announces and events arrive.
  for (int i = 0; i < 5; ++i) bus.HandleTimeout(50);
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Robot `r`'s row from its store (the truth: it survives the process), with `route` given the
// store's assignments, memory and map for scoring. False when the store cannot be read.
bool ReadRobotStore(const RobotStats& r, ReplayedRobot& route, RobotRow& row,
                    TeamMemoryForScoring& scoring) {
  try {
    const InspectedStore s =
        InspectStore(r.dir / "memory.db", PipelineOptions{}.memory, static_cast<uint32_t>(r.id));
    row.frames = s.summary.base_points;
    row.places = static_cast<int64_t>(s.summary.learned_places.size());
    row.edges = s.summary.map_edges;
    row.detected_places = s.summary.detected_places;
    row.CountOrigins(s.memory);
    // The route's labels by base point: frame k of the route is base point k as long as no
    // frame was dropped (and the robot did not restart).
    route.assignments = Store::Open(r.dir / "memory.db").LoadAssignments();
    route.memory = s.memory;
    route.map = s.map;
    scoring = ForMergeScoring(route, s.memory);
    try {
      RenderPng(ToDot(s.memory, s.map), r.dir / "memory.png");
    } catch (const std::exception& e) {
      std::cerr << "tsc: robot " << r.id << ": no picture: " << e.what() << "\n";
    }
    return true;
  } catch (const std::exception& e) {
    std::cerr << "tsc: robot " << r.id << ": cannot read its memory: " << e.what() << "\n";
    return false;
  }
}

// The live run: N tscd processes in a private network, watched until they are to stop, then
// scored from their stores.
int TeamLive(const TeamRequest& req, const std::vector<std::string>& args) {
  if (const auto failed = EnterPrivateNetwork("team", args, req.netns, kNetnsEnv)) return *failed;
  fs::create_directories(req.out);
  const fs::path tscd = TscdBesideThisTsc();
  LcmBus bus(kLcmUrl);
  std::vector<RobotStats> robots(static_cast<size_t>(req.robots));
  for (int i = 0; i < req.robots; ++i) {
    RobotStats& r = robots[static_cast<size_t>(i)];
    r.id = i + 1;
    r.dir = req.out / ("robot-" + std::to_string(r.id));
    fs::create_directories(r.dir);
  }
  ListenToTeam(bus, robots);
  for (RobotStats& r : robots) {
    std::vector<std::string> argv = {"tscd", "--robot", std::to_string(r.id), "--state-dir",
                                     r.dir.string()};
    argv.insert(argv.end(), req.common.begin(), req.common.end());
    argv.push_back("--set");
    argv.push_back("sim.route=" + std::to_string(r.id - 1));
    r.pid = SpawnProcess(tscd, argv, r.dir / "tscd.log");
  }
  std::cout << "tsc team: " << req.robots << " robots in world " << req.world << " (" << req.kind
            << "), output in " << req.out.string() << "\n";
  const double run_s = WatchTeam(bus, robots, req);
  for (RobotStats& r : robots) {
    if (!r.exited) MeasureProcess(r, run_s);
  }
  StopRobots(robots);
  if (isatty(STDOUT_FILENO) != 0) std::cout << "\n";

  bool ok = true, any_dropped = false;
  std::vector<TeamMemoryForScoring> scoring(robots.size());
  std::vector<ReplayedRobot> routes = RoutesOf(req.settings);  // labels and positions
  std::vector<RobotRow> rows;
  std::cout << RobotRow::Header(true);
  for (size_t i = 0; i < robots.size(); ++i) {
    const RobotStats& r = robots[i];
    RobotRow& row = rows.emplace_back();
    row.robot = static_cast<uint32_t>(r.id);
    row.exit_status = r.exit_status;
    row.frames_dropped = r.dropped;
    row.recognitions = r.recognitions;
    row.merged_events = r.merged;
    row.cpu_percent = r.cpu_percent;
    row.peak_rss_mb = r.peak_rss_mb;
    row.dir = r.dir;
    ok &= r.exit_status == 0;
    if (ReadRobotStore(r, routes[i], row, scoring[i])) {
      any_dropped |= r.dropped > 0;
    } else {
      ok = false;
    }
    row.Print(std::cout, true);
  }
  std::ostringstream tail;
  tail << ",\"seconds\":" << JsonNumber(run_s) << ",\"fps\":" << JsonNumber(req.fps);
  WriteTeamSummary(req, rows, JudgeTeam(scoring), routes, tail.str(), any_dropped);
  if (!ok) std::cerr << "tsc: some robots failed; see their tscd.log\n";
  return ok ? kExitOk : kExitFailure;
}

int Team(const std::vector<std::string>& args) {
  const std::optional<TeamRequest> req = ParseTeam(args);
  if (!req) return kExitOk;
  return req->offline_order ? TeamOffline(*req) : TeamLive(*req, args);
}

}  // namespace

int RunTeamCommand(const std::vector<std::string>& args) {
  return RunReportingErrors("team", [&] { return Team(args); });
}

}  // namespace tsc
