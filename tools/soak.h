#pragma once
// The records of `tsc soak` and their analysis: one sample per robot per second (RSS, CPU and
// the daemon's counters from TSC_STATS_<robot>), the restarts the soak made, and the verdict
// "no unbounded growth" (docs/reliability.md, "Soak"). No processes or sockets here: the
// command (tools/soak_command.cc) measures, this file writes, reads and judges.

#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace tsc {

/// The channel families of stats_t, in its order, and their CSV column prefix.
inline constexpr std::array<const char*, 5> kSoakFamilies = {"announce", "memory", "request",
                                                             "event", "stats"};

/// Messages and bytes one robot process sent and received on one family (since it started).
struct SoakTraffic {
  int64_t sent = 0;
  int64_t sent_bytes = 0;
  int64_t received = 0;
  int64_t received_bytes = 0;
};

/// One row of soak.csv: one robot at one instant.
struct SoakSample {
  double t_s = 0.0;  ///< seconds since the soak started
  int robot = 0;
  int life = 0;  ///< 0 for the first process of this robot, +1 per restart
  int64_t pid = 0;
  bool alive = false;        ///< false while a restart has it down
  double life_s = 0.0;       ///< seconds since this process started
  double rss_mb = 0.0;       ///< VmRSS
  double cpu_percent = 0.0;  ///< of one core, since the previous sample of the same process
  double stats_age_s = -1;   ///< age of the last stats of this life (-1: none yet)
  // From the robot's last stats_t (counts since its process started).
  int64_t frames = 0;
  int64_t frames_dropped = 0;
  int64_t places = 0;
  int64_t edges = 0;
  int64_t memory_version = 0;
  int64_t snapshots_received = 0;
  int64_t merges_completed = 0;
  int64_t merges_changed = 0;
  int64_t merges_failed = 0;
  int64_t exchanges_given_up = 0;
  int64_t messages_rejected = 0;
  int64_t publish_failures = 0;
  int64_t queue_frames = 0;
  int64_t merge_inbox = 0;
  int64_t pending_commits = 0;
  int64_t peers = 0;
  int64_t merged_peers = 0;
  int64_t buffered_portions = 0;
  /// The robot's state database on disk (memory.db with its WAL), MB; sampled also while the
  /// process is down (the file stays).
  double db_mb = 0.0;
  /// Rooms the team's routes visit (the simulated world's ground truth; 0 when unknown): the
  /// places per room are places / rooms.
  int rooms = 0;
  std::array<SoakTraffic, kSoakFamilies.size()> traffic{};
};

/// One restart the soak made (restarts.csv), or a robot that exited on its own.
struct SoakRestart {
  double t_s = 0.0;  ///< when the signal was sent (or the exit seen)
  int robot = 0;
  std::string signal;   ///< "TERM", "KILL", or "none" for an unexpected exit
  int exit_status = 0;  ///< of the old process (128 + signal when killed)
  double down_s = 0.0;  ///< from the signal to the new process
};

/// Places in the robot's memory per room of the routes at `s`; 0 when the rooms are unknown.
double PlacesPerRoom(const SoakSample& s);

/// The header line of soak.csv.
std::string SoakCsvHeader();
std::string SoakCsvRow(const SoakSample& s);
/// Reads soak.csv. Throws std::runtime_error naming the file and line at fault.
std::vector<SoakSample> ReadSoakCsv(const std::filesystem::path& file);

std::string RestartsCsvHeader();
std::string RestartsCsvRow(const SoakRestart& r);
/// Reads restarts.csv. Throws std::runtime_error naming the file and line at fault.
std::vector<SoakRestart> ReadRestartsCsv(const std::filesystem::path& file);

/// What "bounded" means; the defaults are justified in docs/reliability.md ("Soak").
struct SoakCheckOptions {
  double warmup_fraction = 1.0 / 3.0;  ///< of the run, excluded from the growth figures
  double life_warmup_s = 20.0;         ///< of each process: loading and first merges
  double max_rss_slope_mb_per_min = 1.0;
  double max_late_growth = 0.15;      ///< late RSS median over middle median, minus 1
  int expected_restarts = 0;          ///< at least this many restarts must have happened
  double min_sampled_fraction = 0.9;  ///< of the robot's expected samples, while up
  int64_t max_pending_commits = 16;
  /// Bound on a robot's places per room at the end of the run (issue 23: ≤ 2 after a day of
  /// laps); 0: reported, not judged.
  double max_places_per_room = 0.0;
  /// Throws std::invalid_argument naming the option out of range.
  void Validate() const;
};

/// The figures of one robot over the run.
struct SoakRobotFigures {
  int robot = 0;
  int samples = 0;   ///< rows with the process alive
  int expected = 0;  ///< rows the robot should have had while up
  int lives = 0;
  double rss_first_mb = 0.0;          ///< first sample after the warm-up
  double rss_last_mb = 0.0;           ///< last sample
  double rss_max_mb = 0.0;            ///< after the warm-up
  double rss_middle_median_mb = 0.0;  ///< middle third of the run
  double rss_late_median_mb = 0.0;  ///< last sixth of the run (at least the last minute when long)
  /// Least-squares slope of RSS over time within each process life (one intercept per life),
  /// after the warm-ups, MB per minute: growth of a process, not the jump of a restart.
  double rss_slope_mb_per_min = 0.0;
  double cpu_percent_mean = 0.0;  ///< over the rows with the process alive
  int64_t places_first = 0, places_last = 0, places_max = 0;
  double places_slope_per_min = 0.0;  ///< as the RSS slope
  /// Places in the robot's memory per room the team visits, at its last sample (0 when the
  /// rooms are unknown).
  double places_per_room_last = 0.0;
  /// Slope of RSS over the place count within each life after the warm-ups, MB per place:
  /// what a learned place costs when the place count grows.
  double rss_mb_per_place = 0.0;
  /// The database after the run's warm-up (first and last sample, MB) and its least-squares
  /// slope over time across every life (the file outlives the processes), MB per minute.
  double db_first_mb = 0.0, db_last_mb = 0.0, db_slope_mb_per_min = 0.0;
  int64_t merges = 0;  ///< completed over all lives
  int64_t merges_changed = 0;
  int64_t merges_failed = 0;
  int64_t frames = 0;  ///< over all lives
  /// Max over the rows after the warm-up.
  int64_t max_queue_frames = 0, max_merge_inbox = 0, max_pending_commits = 0, max_peers = 0,
          max_merged_peers = 0, max_buffered_portions = 0;
  /// Messages per second sent and received, whole run, per family (kSoakFamilies).
  std::array<double, kSoakFamilies.size()> sent_per_s{}, received_per_s{};
  double sent_kb_per_s = 0.0, received_kb_per_s = 0.0;  ///< all families
};

struct SoakVerdict {
  bool ok = true;
  std::vector<std::string> problems;  ///< each names the robot and the figure
  std::vector<SoakRobotFigures> robots;
  double duration_s = 0.0;
  int restarts = 0;
  int kills = 0;  ///< restarts by SIGKILL
  int unexpected_exits = 0;
  int lives_after_restart = 0;         ///< lives that began with a restart and lasted
  int lives_after_restart_merged = 0;  ///< … and completed a merge
  int lives_after_restart_idle = 0;    ///< … and had no new peer memory to merge
};

/// Judges a soak from its records. `team_size` robots 1..team_size are expected; a robot with
/// no row is a problem.
SoakVerdict AnalyseSoak(const std::vector<SoakSample>& samples,
                        const std::vector<SoakRestart>& restarts, int team_size,
                        const SoakCheckOptions& options);

/// The verdict and figures as JSON (soak.json).
std::string SoakVerdictJson(const SoakVerdict& v);
/// A table per robot and the problems, for a person.
std::string SoakVerdictText(const SoakVerdict& v);

}  // namespace tsc
