#include "tools/soak_command.h"

#include <unistd.h>

#include <boost/program_options.hpp>
#include <charconv>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <random>
#include <set>
#include <sstream>
#include <stdexcept>

#include "daemon/lcm_bus.h"
#include "drivers/camera/make_camera.h"
#include "drivers/camera/sim_camera.h"
#include "settings/settings.h"
#include "tools/command_line.h"
#include "tools/inspect.h"
#include "tools/robot_processes.h"
#include "tools/soak.h"
#include "tools/soak_plot.h"
#include "tsc/stats_t.hpp"

namespace tsc {
namespace {

namespace fs = std::filesystem;
namespace po = boost::program_options;
using Clock = std::chrono::steady_clock;

constexpr const char* kNetnsEnv = "TSCD_SOAK_NETNS";
constexpr const char* kLcmUrl = "udpm://239.255.76.67:7667?ttl=0";
constexpr const char* kLossTable = "tscd_soak";
constexpr double kStopGraceS = 30.0;  // SIGTERM → SIGKILL, as tsc team and systemd
constexpr double kDownS = 1.0;        // a stopped robot starts again this much later
// The accelerated day (issue 23): the frames a 10 fps camera takes in an hour, and the places
// per room a long-lived memory may end with.
constexpr double kFramesPerHour = 3600.0 * 10.0;
constexpr double kDayMaxPlacesPerRoom = 2.0;

constexpr const char* kSoakHelp =
    R"(usage: tsc soak [--robots N] [--world SEED] [--kind office|corridors|outdoor]
                [--minutes M | --seconds S] [--loss PERCENT] [--restart-every R]
                [--kill-fraction F] [--seed N] [--fps F] [--loop | --day [HOURS]] [--out DIR]
                [--set KEY=VALUE]... [--netns new|current] [--max-rss-slope MB_PER_MIN]
                [--max-late-growth F] [--max-places-per-room P]
       tsc soak --replot DIR [--robots N] [...check options]

A soak and load run: N tscd robots (ids 1..N) on the simulated world, each driving its route
once per process life (--loop: again and again, a restarted robot going on from where it
stood), in a private network namespace (only lo, multicast on lo: no packet leaves it) where nftables
drops PERCENT % of all UDP datagrams. Every R seconds a random robot is stopped (SIGTERM, or
SIGKILL with probability F) and started again from its state database. Every second it
records per robot the resident set and CPU (/proc) and the daemon's counters (TSC_STATS_<id>:
places, memory version, merges, messages per channel, queues) in DIR/soak.csv, the restarts in
DIR/restarts.csv, and at the end judges growth (RSS slope within each process life after the
warm-up, late versus middle RSS, queue bounds, merges after restarts, unexpected exits) into
DIR/soak.json and draws DIR/soak.png. Exit 0 when bounded, 1 when a check failed.
--replot judges and draws an existing DIR again without running anything.
--day is the accelerated day of issue 23: the routes driven again and again (closed, so a lap
ends where the next begins) for as many frames as a 10 fps camera takes in HOURS (24), at
--fps (e.g. --fps 200: 72 minutes for 24 hours); places per room (the rooms from the world's
ground truth) must end at or below --max-places-per-room (2 with --day). At the end every robot's store must
still hold every place it learned (its own ids, as places or as sources of the places that
absorbed them).

Options)";

enum class RobotState { kRunning, kStopping, kDown };

struct Robot {
  int id = 0;
  fs::path dir;
  pid_t pid = -1;
  int life = 0;
  RobotState state = RobotState::kDown;
  Clock::time_point started{};
  Clock::time_point state_since{};
  std::optional<size_t> restart;  // index into the restarts of the one in progress
  // CPU of the previous sample of this process.
  double last_cpu_s = 0.0;
  double last_sample_s = 0.0;
  // Stats of the current process.
  std::optional<stats_t> stats;
  Clock::time_point stats_at{};
  std::set<int64_t> dead_boots;  // boot ids of earlier processes: late stats are ignored
  // Route frames the robot's earlier lives drove (from their last stats): a looping robot
  // started again goes on from there, as a robot that stood still while its tscd was down.
  int64_t frames_driven = 0;
  int final_status = 0;
};

double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

// The robot's state database on disk, MB: memory.db and its write-ahead log (0 before tscd
// creates it).
double DatabaseMb(const fs::path& state_dir) {
  double bytes = 0;
  for (const char* name : {"memory.db", "memory.db-wal"}) {
    std::error_code ec;
    const auto size = fs::file_size(state_dir / name, ec);
    if (!ec) bytes += static_cast<double>(size);
  }
  return bytes / (1 << 20);
}

SoakSample Sample(Robot& r, int rooms, double t, Clock::time_point now) {
  SoakSample s;
  s.t_s = t;
  s.robot = r.id;
  s.rooms = rooms;
  s.life = r.life;
  s.pid = r.pid;
  s.db_mb = DatabaseMb(r.dir);
  if (r.state == RobotState::kDown) return s;
  const ProcessSample p = SampleProcess(r.pid);
  s.alive = p.alive;
  if (!p.alive) return s;
  s.life_s = Seconds(now - r.started);
  s.rss_mb = p.rss_mb;
  const double dt = s.life_s - r.last_sample_s;
  if (dt > 0) s.cpu_percent = 100.0 * (p.cpu_s - r.last_cpu_s) / dt;
  r.last_cpu_s = p.cpu_s;
  r.last_sample_s = s.life_s;
  if (!r.stats) return s;
  const stats_t& m = *r.stats;
  s.stats_age_s = Seconds(now - r.stats_at);
  s.frames = m.frames;
  s.frames_dropped = m.frames_dropped;
  s.places = m.places;
  s.edges = m.edges;
  s.memory_version = m.memory_version;
  s.snapshots_received = m.snapshots_received;
  s.merges_completed = m.merges_completed;
  s.merges_changed = m.merges_changed;
  s.merges_failed = m.merges_failed;
  s.exchanges_given_up = m.exchanges_given_up;
  s.messages_rejected = m.messages_rejected;
  s.publish_failures = m.publish_failures;
  s.queue_frames = m.queue_frames;
  s.merge_inbox = m.merge_inbox;
  s.pending_commits = m.pending_commits;
  s.peers = m.peers;
  s.merged_peers = m.merged_peers;
  s.buffered_portions = m.buffered_portions;
  for (size_t i = 0; i < m.channel.size(); ++i) {
    for (size_t k = 0; k < kSoakFamilies.size(); ++k) {
      std::string family = m.channel[i].rfind("TSC_", 0) == 0 ? m.channel[i].substr(4) : "";
      for (char& c : family) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      if (family != kSoakFamilies[k]) continue;
      s.traffic[k] = {m.sent[i], m.sent_bytes[i], m.received[i], m.received_bytes[i]};
    }
  }
  return s;
}

SoakCheckOptions CheckOptions(const po::variables_map& vm) {
  SoakCheckOptions o;
  o.max_rss_slope_mb_per_min = vm["max-rss-slope"].as<double>();
  o.max_late_growth = vm["max-late-growth"].as<double>();
  if (vm.count("max-places-per-room")) {
    o.max_places_per_room = vm["max-places-per-room"].as<double>();
  } else if (vm.count("day")) {
    o.max_places_per_room = kDayMaxPlacesPerRoom;
  }
  try {
    o.Validate();
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  return o;
}

int Report(const SoakVerdict& v, int team_size, const std::vector<SoakSample>& samples,
           const std::vector<SoakRestart>& restarts, const fs::path& out) {
  WriteTextFile(out / "soak.json", SoakVerdictJson(v));
  WriteSoakPlot(samples, restarts, team_size, out / "soak.png");
  std::cout << SoakVerdictText(v) << "csv: " << (out / "soak.csv").string()
            << "\nrestarts: " << (out / "restarts.csv").string()
            << "\nverdict: " << (out / "soak.json").string()
            << "\nplot: " << (out / "soak.png").string() << "\n";
  return v.ok ? kExitOk : kExitFailure;
}

int Replot(const po::variables_map& vm) {
  const fs::path dir = vm["replot"].as<std::string>();
  const std::vector<SoakSample> samples = ReadSoakCsv(dir / "soak.csv");
  const std::vector<SoakRestart> restarts = ReadRestartsCsv(dir / "restarts.csv");
  int team = 0;
  for (const SoakSample& s : samples) team = std::max(team, s.robot);
  if (!vm["robots"].defaulted()) team = vm["robots"].as<int>();
  SoakCheckOptions check = CheckOptions(vm);
  check.expected_restarts = 0;
  return Report(AnalyseSoak(samples, restarts, team, check), team, samples, restarts, dir);
}

// Drops `percent` % of every UDP datagram sent in this namespace (nftables output hook), as
// team_test does: one send is lost for every receiver at once. Which ones is a seeded hash of
// the datagram's first 16 payload bytes (LCM's magic and per-sender sequence number, then the
// channel or fragment header), not nftables' `numgen random`: the same traffic loses the same
// datagrams for the same seed, so a run can be replayed.
void AddLossRule(int percent, unsigned seed) {
  const std::string table = kLossTable;
  const std::vector<std::vector<std::string>> steps = {
      {"nft", "add", "table", "inet", table},
      {"nft", "add", "chain", "inet", table, "out", "{ type filter hook output priority 0; }"},
      {"nft", "add", "rule", "inet", table, "out", "meta", "l4proto", "udp", "jhash", "@th,64,128",
       "mod", "100", "seed", std::to_string(seed), "<", std::to_string(percent), "drop"}};
  for (const auto& step : steps) {
    if (RunProgram(step) != 0) {
      throw std::runtime_error(
          "nft cannot add the packet loss rule in the private namespace "
          "(is nftables installed and may this user change it?)");
    }
  }
}

// `v` as its shortest decimal form (0.15, not Boost's 0.14999999999999999).
std::string Shortest(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

po::options_description SoakOptions() {
  po::options_description desc(kSoakHelp);
  desc.add_options()("help,h", "show this help")(
      "robots", po::value<int>()->default_value(5)->value_name("N"), "robots, 2..16")(
      "world", po::value<long long>()->default_value(7)->value_name("SEED"), "seed of the world")(
      "kind", po::value<std::string>()->default_value("office"), "office|corridors|outdoor")(
      "minutes", po::value<double>()->default_value(10.0, "10")->value_name("M"),
      "length of the soak")("seconds", po::value<double>()->value_name("S"),
                            "length in seconds (instead of --minutes)")(
      "loss", po::value<int>()->default_value(10)->value_name("PERCENT"),
      "UDP datagrams dropped, 0..90")(
      "restart-every", po::value<double>()->default_value(60.0, "60")->value_name("R"),
      "seconds between restarts of a random robot (0: none)")(
      "kill-fraction", po::value<double>()->default_value(0.3, "0.3")->value_name("F"),
      "share of restarts by SIGKILL instead of SIGTERM")(
      "seed", po::value<unsigned>()->default_value(1),
      "seed of the restart schedule and of the packet loss")(
      "fps", po::value<double>()->default_value(10.0, "10"), "camera frames per second per robot")(
      "loop", "drive the routes again and again (load) instead of once per process life")(
      "day", po::value<double>()->implicit_value(24.0, "24")->value_name("HOURS"),
      "an accelerated day: --loop for the frames a 10 fps camera takes in HOURS, at --fps (sets "
      "the length); places per room judged")(
      "max-places-per-room", po::value<double>()->value_name("P"),
      "bound on a robot's places per room at the end (0: not judged; 2 with --day)")(
      "out", po::value<std::string>()->default_value("soak-out")->value_name("DIR"),
      "output folder (soak.csv, restarts.csv, soak.json, soak.png, robot-<id>/)")(
      "set", po::value<std::vector<std::string>>()->composing()->value_name("KEY=VALUE"),
      "override a tscd key for every robot (repeatable)")(
      "netns", po::value<std::string>()->default_value("new"), "new|current")(
      "max-rss-slope",
      po::value<double>()->default_value(SoakCheckOptions{}.max_rss_slope_mb_per_min,
                                         Shortest(SoakCheckOptions{}.max_rss_slope_mb_per_min)),
      "bound on the RSS slope within a process life after the warm-up, MB/min")(
      "max-late-growth",
      po::value<double>()->default_value(SoakCheckOptions{}.max_late_growth,
                                         Shortest(SoakCheckOptions{}.max_late_growth)),
      "bound on (RSS median of the last sixth) / (median of the middle third) - 1")(
      "replot", po::value<std::string>()->value_name("DIR"),
      "judge and draw DIR/soak.csv again; runs nothing");
  return desc;
}

// What a soak run was asked for, checked.
struct SoakRequest {
  int robots = 0;
  double duration_s = 0.0;
  int loss = 0;          ///< % of UDP datagrams dropped
  double every_s = 0.0;  ///< between restarts, 0: none
  double kill_fraction = 0.0;
  unsigned seed = 0;  ///< of the restart schedule and the loss
  std::string netns;  ///< new|current
  fs::path out;
  bool loop = false;                   ///< routes driven again and again (--loop, --day)
  double day_hours = 0.0;              ///< the accelerated day (--day): a 10 fps camera's hours
  std::vector<std::string> overrides;  ///< every robot's tscd keys (its route comes on top)
  SoakCheckOptions check;
};

SoakRequest ToSoakRequest(const po::variables_map& vm) {
  SoakRequest req;
  req.robots = vm["robots"].as<int>();
  if (req.robots < 2 || req.robots > 16) throw UsageError("--robots must be in 2..16");
  const bool day = vm.count("day") > 0;
  req.loop = day || vm.count("loop") > 0;
  const double fps_asked = vm["fps"].as<double>();
  if (day) {
    if (vm.count("loop")) throw UsageError("--day drives the routes again and again: no --loop");
    if (vm.count("seconds") || !vm["minutes"].defaulted()) {
      throw UsageError(
          "--day sets the length (a day's frames at --fps): no --minutes or --seconds");
    }
    if (!(fps_asked > 0)) throw UsageError("--day needs --fps above 0");
    req.day_hours = vm["day"].as<double>();
    if (!(req.day_hours > 0 && req.day_hours <= 24 * 365)) {
      throw UsageError("--day HOURS must be above 0 (and at most a year)");
    }
    req.duration_s = req.day_hours * kFramesPerHour / fps_asked;
  } else {
    req.duration_s =
        vm.count("seconds") ? vm["seconds"].as<double>() : 60.0 * vm["minutes"].as<double>();
  }
  if (!(req.duration_s >= 10)) throw UsageError("the soak must last at least 10 seconds");
  req.loss = vm["loss"].as<int>();
  if (req.loss < 0 || req.loss > 90) throw UsageError("--loss must be in 0..90");
  req.every_s = vm["restart-every"].as<double>();
  if (req.every_s < 0 || (req.every_s > 0 && req.every_s < 5)) {
    throw UsageError("--restart-every is 0 or ≥ 5 s");
  }
  req.kill_fraction = vm["kill-fraction"].as<double>();
  if (!(req.kill_fraction >= 0 && req.kill_fraction <= 1)) {
    throw UsageError("--kill-fraction is in [0, 1]");
  }
  req.netns = vm["netns"].as<std::string>();
  if (req.netns != "new" && req.netns != "current") throw UsageError("--netns is new or current");
  req.check = CheckOptions(vm);
  req.seed = vm["seed"].as<unsigned>();
  req.out = vm["out"].as<std::string>();
  // The soak's own keys first, so --set can change them.
  std::ostringstream fps;
  fps << vm["fps"].as<double>();
  req.overrides = {"camera.source=sim",
                   std::string("camera.loop=") + (req.loop ? "true" : "false"),
                   "lcm.url=" + std::string(kLcmUrl),
                   "sim.world_seed=" + std::to_string(vm["world"].as<long long>()),
                   "sim.world=" + vm["kind"].as<std::string>(),
                   "sim.team_size=" + std::to_string(req.robots),
                   "sim.width=160",
                   "sim.height=120",
                   "camera.fps=" + fps.str()};
  if (vm.count("set")) {
    for (const std::string& kv : vm["set"].as<std::vector<std::string>>()) {
      req.overrides.push_back(kv);
    }
  }
  return req;
}

// The soak's robots through their process lives: started, watched, stopped on schedule and
// started again; what happened to them is kept in restarts().
class SoakTeam {
 public:
  SoakTeam(const SoakRequest& req, fs::path tscd) : req_(req), tscd_(std::move(tscd)) {
    robots_.resize(static_cast<size_t>(req.robots));
    for (int i = 0; i < req.robots; ++i) {
      Robot& r = robots_[static_cast<size_t>(i)];
      r.id = i + 1;
      r.dir = req.out / ("robot-" + std::to_string(r.id));
      fs::remove_all(r.dir);  // a soak starts from empty memories
      fs::create_directories(r.dir);
    }
  }

  std::vector<Robot>& robots() { return robots_; }
  const std::vector<SoakRestart>& restarts() const { return restarts_; }

  /// Keeps the stats of each robot's current process (late ones of earlier lives are ignored).
  void Listen(LcmBus& bus) {
    bus.Subscribe("TSC_STATS_.*", [this](const std::string&, const uint8_t* data, size_t size) {
      const auto m = LcmBus::Decode<stats_t>(data, size);
      if (!m || m->robot < 1 || static_cast<size_t>(m->robot) > robots_.size()) return;
      Robot& r = robots_[static_cast<size_t>(m->robot - 1)];
      if (r.state == RobotState::kDown || r.dead_boots.count(m->boot_id)) return;
      if (r.stats && r.stats->boot_id != m->boot_id) r.dead_boots.insert(r.stats->boot_id);
      r.stats = *m;
      r.stats_at = Clock::now();
    });
  }

  void Spawn(Robot& r) {
    std::vector<std::string> argv = {"tscd", "--robot", std::to_string(r.id), "--state-dir",
                                     r.dir.string()};
    for (const std::string& kv : req_.overrides) {
      argv.push_back("--set");
      argv.push_back(kv);
    }
    argv.push_back("--set");
    argv.push_back("sim.route=" + std::to_string(r.id - 1));
    if (req_.loop && r.frames_driven > 0) {
      argv.push_back("--set");
      argv.push_back("sim.start_frame=" + std::to_string(r.frames_driven));
    }
    r.pid = SpawnProcess(tscd_, argv, r.dir / "tscd.log");
    r.state = RobotState::kRunning;
    r.started = r.state_since = Clock::now();
    r.last_cpu_s = r.last_sample_s = 0.0;
    if (r.stats) r.dead_boots.insert(r.stats->boot_id);
    r.stats.reset();
  }

  /// At `t` s into the run: starts again robots that have been down long enough (not after
  /// the end), notes exits (an unasked one is a restart of its own) and kills a robot that
  /// ignores SIGTERM.
  void Supervise(double t, Clock::time_point now) {
    for (Robot& r : robots_) {
      if (r.state == RobotState::kDown) {
        if (Seconds(now - r.state_since) >= kDownS && t < req_.duration_s) {
          Spawn(r);
          ++r.life;
          if (r.restart) restarts_[*r.restart].down_s = t - restarts_[*r.restart].t_s;
          r.restart.reset();
        }
        continue;
      }
      const ChildExit e = ReapChild(r.pid, false);
      if (e.exited) {
        if (r.state == RobotState::kRunning) {  // nobody asked it to stop
          std::cerr << "tsc: robot " << r.id << " exited on its own (status " << e.status << ") at "
                    << t << " s; starting it again\n";
          restarts_.push_back({t, r.id, "none", e.status, 0.0});
          r.restart = restarts_.size() - 1;
        } else if (r.restart) {
          restarts_[*r.restart].exit_status = e.status;
        }
        r.state = RobotState::kDown;
        r.state_since = now;
        if (r.stats) r.frames_driven += r.stats->frames;
        continue;
      }
      if (r.state == RobotState::kStopping && Seconds(now - r.state_since) > kStopGraceS) {
        std::cerr << "tsc: robot " << r.id << " did not stop within " << kStopGraceS
                  << " s of SIGTERM; killing it\n";
        kill(r.pid, SIGKILL);
      }
    }
  }

  /// Stops a random running robot (SIGKILL with the request's probability, else SIGTERM).
  void RestartOne(double t, Clock::time_point now, std::mt19937& rng) {
    std::vector<Robot*> running;
    for (Robot& r : robots_) {
      if (r.state == RobotState::kRunning) running.push_back(&r);
    }
    if (running.empty()) return;
    Robot& r = *running[std::uniform_int_distribution<size_t>(0, running.size() - 1)(rng)];
    const bool kill9 = std::bernoulli_distribution(req_.kill_fraction)(rng);
    kill(r.pid, kill9 ? SIGKILL : SIGTERM);
    r.state = RobotState::kStopping;
    r.state_since = now;
    restarts_.push_back({t, r.id, kill9 ? "KILL" : "TERM", 0, 0.0});
    r.restart = restarts_.size() - 1;
    std::cout << "  " << static_cast<int>(t) << " s: restarting robot " << r.id << " (SIG"
              << (kill9 ? "KILL" : "TERM") << ")" << std::endl;
  }

  /// Stops everyone at the end (a robot still down is not started again); the problems seen.
  std::vector<std::string> StopAll() {
    std::vector<std::string> problems;
    for (Robot& r : robots_) {
      if (r.state != RobotState::kDown) kill(r.pid, SIGTERM);
    }
    for (Robot& r : robots_) {
      if (r.state == RobotState::kDown) continue;
      const ChildExit e = WaitForExit(r.pid, kStopGraceS);
      if (r.state == RobotState::kRunning && e.status != 0) {
        problems.push_back("robot " + std::to_string(r.id) + " exited with status " +
                           std::to_string(e.status) + " after the final SIGTERM");
      }
    }
    return problems;
  }

 private:
  const SoakRequest& req_;
  fs::path tscd_;
  std::vector<Robot> robots_;
  std::vector<SoakRestart> restarts_;
};

// soak.csv, written as the run goes (a killed soak keeps what it sampled), and the samples.
class SoakSamples {
 public:
  SoakSamples(const fs::path& path, int rooms) : csv_(path), rooms_(rooms) {
    if (!csv_) throw std::runtime_error(path.string() + ": cannot write");
    csv_ << SoakCsvHeader() << "\n";
  }
  /// One sample of every robot at `t` s; every 30 s a line of figures.
  void Take(std::vector<Robot>& robots, double t, Clock::time_point now) {
    for (Robot& r : robots) {
      samples_.push_back(Sample(r, rooms_, t, now));
      csv_ << SoakCsvRow(samples_.back()) << "\n";
    }
    csv_.flush();
    if (static_cast<int>(t) % 30 != 0) return;
    std::ostringstream line;
    line << "  " << static_cast<int>(t) << " s:";
    for (size_t i = samples_.size() - robots.size(); i < samples_.size(); ++i) {
      const SoakSample& s = samples_[i];
      line << " r" << s.robot << " " << static_cast<int>(s.rss_mb) << " MB " << s.places
           << " places " << s.merges_completed << " merges;";
    }
    std::cout << line.str() << std::endl;
  }
  const std::vector<SoakSample>& samples() const { return samples_; }
  void Close() { csv_.close(); }

 private:
  std::ofstream csv_;
  int rooms_;
  std::vector<SoakSample> samples_;
};

// Settings of robot `route`'s tscd, as the soak starts it.
Settings RobotSettings(const SoakRequest& req, int route) {
  std::vector<std::string> o = req.overrides;
  o.push_back("sim.route=" + std::to_string(route));
  return LoadSettings(std::nullopt, o);
}

// Rooms the team's routes pass through, from the simulated world's ground truth: the places
// per room are counted against them. Every robot's settings name the same world and team.
int TeamRooms(const SoakRequest& req) {
  const Settings settings = RobotSettings(req, 0);
  const SimCameraOptions camera =
      ToSimCameraOptions(settings.daemon.camera, settings.daemon.sim, false);
  std::set<std::string> labels;
  for (const auto& route : sim::MakeScenario(SceneOf(camera)).routes) {
    for (const sim::RouteFrame& f : route) {
      if (!f.label.empty()) labels.insert(f.label);
    }
  }
  return static_cast<int>(labels.size());
}

// Every place a robot learned is still in its store at the end: a robot numbers its places
// 1, 2, ... (DESIGN §3.6), so each of its ids below its next local id must be a place of its
// memory or a source of the place that absorbed it; and every map edge joins two places of
// the memory. The problems found, one per robot.
std::vector<std::string> LostPlaces(const SoakRequest& req, const std::vector<Robot>& robots) {
  std::vector<std::string> problems;
  for (const Robot& r : robots) {
    const std::string name = "robot " + std::to_string(r.id);
    try {
      const Settings settings = RobotSettings(req, r.id - 1);
      const InspectedStore stored =
          InspectStore(r.dir / "memory.db", settings.pipeline.memory, static_cast<uint32_t>(r.id));
      std::set<PlaceId> places, held;  // the places; they and their sources
      for (const LearnedPlace& p : stored.memory.places()) {
        places.insert(p.id);
        held.insert(p.id);
        held.insert(p.sources.begin(), p.sources.end());
      }
      std::vector<uint32_t> lost;
      for (uint32_t local = 1; local < stored.memory.next_local_id(); ++local) {
        if (!held.count(PlaceId{static_cast<uint32_t>(r.id), local})) lost.push_back(local);
      }
      if (!lost.empty()) {
        std::string ids;
        for (size_t i = 0; i < lost.size() && i < 10; ++i) {
          ids += (i ? ", " : "") + std::to_string(r.id) + ":" + std::to_string(lost[i]);
        }
        problems.push_back(name + ": " + std::to_string(lost.size()) + " of its " +
                           std::to_string(stored.memory.next_local_id() - 1) +
                           " learned places are in no place of its store (" + ids +
                           (lost.size() > 10 ? ", ..." : "") + ")");
      }
      int64_t dangling = 0;
      for (const auto& [ends, e] : stored.map.edges()) {
        if (!places.count(e.a) || !places.count(e.b)) ++dangling;
      }
      if (dangling > 0) {
        problems.push_back(name + ": " + std::to_string(dangling) +
                           " map edges end in no place of its memory");
      }
      std::cout << "  " << name << ": " << stored.memory.places().size() << " places hold its "
                << stored.memory.next_local_id() - 1 << " learned ids, "
                << stored.map.edges().size() << " map edges" << std::endl;
    } catch (const std::exception& e) {
      problems.push_back(name + ": its store cannot be read at the end: " + e.what());
    }
  }
  return problems;
}

void WriteRestartsCsv(const std::vector<SoakRestart>& restarts, const fs::path& path) {
  std::ofstream csv(path);
  csv << RestartsCsvHeader() << "\n";
  for (const SoakRestart& r : restarts) csv << RestartsCsvRow(r) << "\n";
  csv.close();
  if (!csv) throw std::runtime_error(path.string() + ": cannot write");
}

int RunSoak(const SoakRequest& req, const std::vector<std::string>& args) {
  if (const auto failed = EnterPrivateNetwork("soak", args, req.netns, kNetnsEnv)) return *failed;
  fs::create_directories(req.out);
  const fs::path tscd = TscdBesideThisTsc();
  for (int i = 0; i < req.robots; ++i) {  // a bad key is one message here, not N robot logs
    (void)RobotSettings(req, i);
  }
  if (req.loss > 0) AddLossRule(req.loss, req.seed);
  struct RemoveLoss {
    bool added;
    ~RemoveLoss() {
      if (added) RunProgram({"nft", "delete", "table", "inet", kLossTable});
    }
  } remove_loss{req.loss > 0 && req.netns == "current"};

  SoakTeam team(req, tscd);
  LcmBus bus(kLcmUrl);
  team.Listen(bus);
  SoakSamples samples(req.out / "soak.csv", TeamRooms(req));
  std::mt19937 rng(req.seed);

  for (Robot& r : team.robots()) team.Spawn(r);
  if (req.day_hours > 0) {
    std::cout << "tsc soak --day: " << req.day_hours * kFramesPerHour << " frames per robot ("
              << req.day_hours << " h of a 10 fps camera) in " << req.duration_s << " s"
              << std::endl;
  }
  std::cout << "tsc soak: " << req.robots << " robots, " << req.duration_s << " s, " << req.loss
            << " % UDP loss, a restart every " << req.every_s << " s (seed " << req.seed
            << ": loss and restarts); output in " << req.out.string() << std::endl;
  const auto start = Clock::now();
  auto next_sample = start + std::chrono::seconds(1);
  double next_restart = req.every_s > 0 ? req.every_s : req.duration_s + 1;
  for (;;) {
    bus.HandleTimeout(50);
    const auto now = Clock::now();
    const double t = Seconds(now - start);
    team.Supervise(t, now);
    if (t >= next_restart && t < req.duration_s - req.every_s / 2) {
      next_restart += req.every_s;
      team.RestartOne(t, now, rng);
    }
    if (now >= next_sample) {
      next_sample += std::chrono::seconds(1);
      samples.Take(team.robots(), t, now);
    }
    if (t >= req.duration_s) break;
  }
  std::vector<std::string> final_problems = team.StopAll();
  for (std::string& p : LostPlaces(req, team.robots())) final_problems.push_back(std::move(p));
  samples.Close();
  WriteRestartsCsv(team.restarts(), req.out / "restarts.csv");

  // Restarts scheduled in the run's window, so a short run checks what it asked for.
  SoakCheckOptions check = req.check;
  check.expected_restarts =
      req.every_s > 0
          ? static_cast<int>(std::ceil((req.duration_s - req.every_s / 2) / req.every_s)) - 1
          : 0;
  check.expected_restarts = std::max(0, check.expected_restarts);
  SoakVerdict v = AnalyseSoak(samples.samples(), team.restarts(), req.robots, check);
  for (const std::string& p : final_problems) {
    v.ok = false;
    v.problems.push_back(p);
  }
  return Report(v, req.robots, samples.samples(), team.restarts(), req.out);
}

int Soak(const std::vector<std::string>& args) {
  const po::options_description desc = SoakOptions();
  const po::variables_map vm = ParseCommandLine(args, desc);
  if (vm.count("help")) {
    std::cout << desc << "\n";
    return kExitOk;
  }
  if (vm.count("replot")) return Replot(vm);
  return RunSoak(ToSoakRequest(vm), args);
}

}  // namespace

int RunSoakCommand(const std::vector<std::string>& args) {
  return RunReportingErrors("soak", [&] { return Soak(args); });
}

}  // namespace tsc
