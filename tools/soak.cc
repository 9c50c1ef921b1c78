#include "tools/soak.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <set>
#include <sstream>
#include <stdexcept>

#include "core/median.h"
#include "tools/events_json.h"

namespace tsc {
namespace fs = std::filesystem;

namespace {

// The fixed columns of soak.csv before the traffic columns, in SoakSample's order.
constexpr const char* kFixedColumns =
    "t_s,robot,life,pid,alive,life_s,rss_mb,cpu_percent,stats_age_s,frames,frames_dropped,"
    "places,edges,memory_version,snapshots_received,merges_completed,merges_changed,"
    "merges_failed,exchanges_given_up,messages_rejected,publish_failures,queue_frames,"
    "merge_inbox,"
    "pending_commits,peers,merged_peers,buffered_portions,db_mb,rooms";
constexpr size_t kFixedCount = 29;
constexpr size_t kTrafficColumns = 4;  // sent, received, sent_bytes, received_bytes

std::string Num(double v, int decimals) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(decimals) << v;
  return s.str();
}

std::vector<std::string> SplitCsv(const std::string& line) {
  std::vector<std::string> out;
  std::string cell;
  std::istringstream in(line);
  while (std::getline(in, cell, ',')) out.push_back(cell);
  if (!line.empty() && line.back() == ',') out.emplace_back();
  return out;
}

double ParseNumber(const std::string& cell, const fs::path& file, int line, const char* column) {
  try {
    size_t used = 0;
    const double v = std::stod(cell, &used);
    if (used == cell.size() && std::isfinite(v)) return v;
  } catch (const std::exception&) {
  }
  throw std::runtime_error(file.string() + ":" + std::to_string(line) + ": column " + column +
                           ": not a number: '" + cell + "'");
}

// Slope of y over t with one intercept per group (a fixed-effects least-squares fit): the
// common growth rate within groups, ignoring the level each group starts at. 0 without
// spread in t.
double WithinGroupSlope(const std::map<int, std::vector<std::pair<double, double>>>& groups) {
  double num = 0.0, den = 0.0;
  for (const auto& [group, points] : groups) {
    if (points.size() < 3) continue;
    double mt = 0.0, my = 0.0;
    for (const auto& [t, y] : points) {
      mt += t;
      my += y;
    }
    mt /= static_cast<double>(points.size());
    my /= static_cast<double>(points.size());
    for (const auto& [t, y] : points) {
      num += (t - mt) * (y - my);
      den += (t - mt) * (t - mt);
    }
  }
  return den > 0 ? num / den : 0.0;
}

// True when a robot other than `robot` published a new memory (another version, or a new
// process) between t0 and t1.
bool PeersChanged(const std::vector<SoakSample>& samples, int robot, double t0, double t1) {
  std::map<int, std::pair<int, int64_t>> first;  // robot → (life, memory version)
  for (const SoakSample& s : samples) {
    if (s.robot == robot || s.t_s < t0 || s.t_s > t1 || !s.alive || s.stats_age_s < 0) continue;
    const std::pair<int, int64_t> now{s.life, s.memory_version};
    auto [it, fresh] = first.try_emplace(s.robot, now);
    if (!fresh && it->second != now) return true;
  }
  return false;
}

}  // namespace

double PlacesPerRoom(const SoakSample& s) {
  return s.rooms > 0 ? static_cast<double>(s.places) / static_cast<double>(s.rooms) : 0.0;
}

std::string SoakCsvHeader() {
  std::string h = kFixedColumns;
  for (const char* f : kSoakFamilies) {
    const std::string p = f;
    h += "," + p + "_sent," + p + "_received," + p + "_sent_bytes," + p + "_received_bytes";
  }
  return h;
}

std::string SoakCsvRow(const SoakSample& s) {
  std::ostringstream o;
  o << Num(s.t_s, 3) << ',' << s.robot << ',' << s.life << ',' << s.pid << ',' << (s.alive ? 1 : 0)
    << ',' << Num(s.life_s, 3) << ',' << Num(s.rss_mb, 3) << ',' << Num(s.cpu_percent, 2) << ','
    << Num(s.stats_age_s, 3) << ',' << s.frames << ',' << s.frames_dropped << ',' << s.places << ','
    << s.edges << ',' << s.memory_version << ',' << s.snapshots_received << ','
    << s.merges_completed << ',' << s.merges_changed << ',' << s.merges_failed << ','
    << s.exchanges_given_up << ',' << s.messages_rejected << ',' << s.publish_failures << ','
    << s.queue_frames << ',' << s.merge_inbox << ',' << s.pending_commits << ',' << s.peers << ','
    << s.merged_peers << ',' << s.buffered_portions << ',' << Num(s.db_mb, 3) << ',' << s.rooms;
  for (const SoakTraffic& t : s.traffic) {
    o << ',' << t.sent << ',' << t.received << ',' << t.sent_bytes << ',' << t.received_bytes;
  }
  return o.str();
}

std::vector<SoakSample> ReadSoakCsv(const fs::path& file) {
  std::ifstream in(file);
  if (!in) throw std::runtime_error(file.string() + ": cannot open");
  std::string line;
  if (!std::getline(in, line) || line != SoakCsvHeader()) {
    throw std::runtime_error(file.string() + ":1: not a soak.csv header (tsc soak writes it)");
  }
  const size_t columns = kFixedCount + kTrafficColumns * kSoakFamilies.size();
  std::vector<std::string> names = SplitCsv(SoakCsvHeader());
  std::vector<SoakSample> out;
  for (int n = 2; std::getline(in, line); ++n) {
    if (line.empty()) continue;
    const std::vector<std::string> c = SplitCsv(line);
    if (c.size() != columns) {
      throw std::runtime_error(file.string() + ":" + std::to_string(n) + ": " +
                               std::to_string(c.size()) + " columns, expected " +
                               std::to_string(columns));
    }
    std::vector<double> v(columns);
    for (size_t i = 0; i < columns; ++i) v[i] = ParseNumber(c[i], file, n, names[i].c_str());
    auto i64 = [&](size_t i) { return static_cast<int64_t>(std::llround(v[i])); };
    SoakSample s;
    s.t_s = v[0];
    s.robot = static_cast<int>(i64(1));
    s.life = static_cast<int>(i64(2));
    s.pid = i64(3);
    s.alive = i64(4) != 0;
    s.life_s = v[5];
    s.rss_mb = v[6];
    s.cpu_percent = v[7];
    s.stats_age_s = v[8];
    int64_t* counts[] = {&s.frames,
                         &s.frames_dropped,
                         &s.places,
                         &s.edges,
                         &s.memory_version,
                         &s.snapshots_received,
                         &s.merges_completed,
                         &s.merges_changed,
                         &s.merges_failed,
                         &s.exchanges_given_up,
                         &s.messages_rejected,
                         &s.publish_failures,
                         &s.queue_frames,
                         &s.merge_inbox,
                         &s.pending_commits,
                         &s.peers,
                         &s.merged_peers,
                         &s.buffered_portions};
    for (size_t k = 0; k < std::size(counts); ++k) *counts[k] = i64(9 + k);
    s.db_mb = v[kFixedCount - 2];
    s.rooms = static_cast<int>(i64(kFixedCount - 1));
    for (size_t f = 0; f < kSoakFamilies.size(); ++f) {
      const size_t at = kFixedCount + kTrafficColumns * f;
      s.traffic[f] = {i64(at), i64(at + 2), i64(at + 1), i64(at + 3)};
    }
    out.push_back(s);
  }
  return out;
}

std::string RestartsCsvHeader() { return "t_s,robot,signal,exit_status,down_s"; }

std::string RestartsCsvRow(const SoakRestart& r) {
  return Num(r.t_s, 3) + "," + std::to_string(r.robot) + "," + r.signal + "," +
         std::to_string(r.exit_status) + "," + Num(r.down_s, 3);
}

std::vector<SoakRestart> ReadRestartsCsv(const fs::path& file) {
  std::ifstream in(file);
  if (!in) throw std::runtime_error(file.string() + ": cannot open");
  std::string line;
  if (!std::getline(in, line) || line != RestartsCsvHeader()) {
    throw std::runtime_error(file.string() + ":1: not a restarts.csv header");
  }
  std::vector<SoakRestart> out;
  for (int n = 2; std::getline(in, line); ++n) {
    if (line.empty()) continue;
    const std::vector<std::string> c = SplitCsv(line);
    if (c.size() != 5) {
      throw std::runtime_error(file.string() + ":" + std::to_string(n) + ": expected 5 columns");
    }
    SoakRestart r;
    r.t_s = ParseNumber(c[0], file, n, "t_s");
    r.robot = static_cast<int>(ParseNumber(c[1], file, n, "robot"));
    r.signal = c[2];
    if (r.signal != "TERM" && r.signal != "KILL" && r.signal != "none") {
      throw std::runtime_error(file.string() + ":" + std::to_string(n) +
                               ": column signal: expected TERM, KILL or none, not '" + c[2] + "'");
    }
    r.exit_status = static_cast<int>(ParseNumber(c[3], file, n, "exit_status"));
    r.down_s = ParseNumber(c[4], file, n, "down_s");
    out.push_back(r);
  }
  return out;
}

void SoakCheckOptions::Validate() const {
  auto fail = [](const std::string& what) { throw std::invalid_argument(what); };
  if (!(warmup_fraction >= 0 && warmup_fraction < 1)) fail("warm-up fraction must be in [0, 1)");
  if (!(life_warmup_s >= 0)) fail("process warm-up must not be negative");
  if (!(max_rss_slope_mb_per_min > 0)) fail("RSS slope bound must be positive");
  if (!(max_late_growth > 0)) fail("late RSS growth bound must be positive");
  if (expected_restarts < 0) fail("expected restarts must not be negative");
  if (!(min_sampled_fraction >= 0 && min_sampled_fraction <= 1)) {
    fail("sampled fraction must be in [0, 1]");
  }
  if (max_pending_commits < 0) fail("pending commits bound must not be negative");
  if (!(max_places_per_room >= 0)) fail("places per room bound must not be negative");
}

namespace {

void AddProblem(SoakVerdict& v, const std::string& p) {
  v.ok = false;
  v.problems.push_back(p);
}

// Counts the restarts; an exit nobody asked for, a SIGTERM answered by a failure or fewer
// restarts than scheduled are problems.
void JudgeRestarts(const std::vector<SoakRestart>& restarts, const SoakCheckOptions& options,
                   SoakVerdict& v) {
  for (const SoakRestart& r : restarts) {
    if (r.signal == "none") {
      ++v.unexpected_exits;
      AddProblem(v, "robot " + std::to_string(r.robot) + " exited on its own at " + Num(r.t_s, 1) +
                        " s (status " + std::to_string(r.exit_status) + ")");
      continue;
    }
    ++v.restarts;
    if (r.signal == "KILL") ++v.kills;
    if (r.signal == "TERM" && r.exit_status != 0) {
      AddProblem(v, "robot " + std::to_string(r.robot) + " exited with status " +
                        std::to_string(r.exit_status) + " after SIGTERM at " + Num(r.t_s, 1) +
                        " s");
    }
  }
  if (v.restarts < options.expected_restarts) {
    AddProblem(v, std::to_string(v.restarts) + " restarts, expected at least " +
                      std::to_string(options.expected_restarts));
  }
}

// One robot's samples while alive, life by life (a life is one process).
struct RobotSeries {
  std::map<int, const SoakSample*> last_of_life;
  std::map<int, std::pair<double, double>> life_span;  // first, last t while alive
  std::map<int, int64_t> life_merges;
  // After the run's and the process' warm-up: (t, RSS), (t, places), (places, RSS) per life.
  std::map<int, std::vector<std::pair<double, double>>> rss_by_life, places_by_life, rss_by_places;
  std::vector<double> middle, late;  // RSS in the middle third and the last sixth of the run
  std::vector<std::pair<double, double>> db;  // (t, database MB) after the run's warm-up
};

// The series of one robot's samples over a run of `d` seconds, and the figures read along.
RobotSeries Collect(const std::vector<const SoakSample*>& rows, double d,
                    const SoakCheckOptions& options, SoakRobotFigures& f) {
  const double warm_end = options.warmup_fraction * d;
  RobotSeries series;
  double cpu_sum = 0.0;
  int cpu_n = 0;
  bool first_after_warmup = true;
  for (const SoakSample* s : rows) {
    if (s->t_s >= warm_end && s->db_mb > 0) {  // the file, whether the process is up or not
      if (series.db.empty()) f.db_first_mb = s->db_mb;
      f.db_last_mb = s->db_mb;
      series.db.emplace_back(s->t_s, s->db_mb);
    }
    if (!s->alive) continue;
    series.last_of_life[s->life] = s;
    auto [span, fresh] = series.life_span.try_emplace(s->life, s->t_s, s->t_s);
    if (!fresh) span->second.second = s->t_s;
    series.life_merges[s->life] = std::max(series.life_merges[s->life], s->merges_completed);
    cpu_sum += s->cpu_percent;
    ++cpu_n;
    if (s->life_s >= 10.0) {
      ++f.expected;
      if (s->stats_age_s >= 0 && s->stats_age_s <= 5.0) ++f.samples;
    }
    if (s->t_s < warm_end) continue;
    f.max_queue_frames = std::max(f.max_queue_frames, s->queue_frames);
    f.max_merge_inbox = std::max(f.max_merge_inbox, s->merge_inbox);
    f.max_pending_commits = std::max(f.max_pending_commits, s->pending_commits);
    f.max_peers = std::max(f.max_peers, s->peers);
    f.max_merged_peers = std::max(f.max_merged_peers, s->merged_peers);
    f.max_buffered_portions = std::max(f.max_buffered_portions, s->buffered_portions);
    if (s->life_s < options.life_warmup_s) continue;
    if (first_after_warmup) {
      f.rss_first_mb = s->rss_mb;
      f.places_first = s->places;
      first_after_warmup = false;
    }
    f.rss_last_mb = s->rss_mb;
    f.places_last = s->places;
    f.places_per_room_last = PlacesPerRoom(*s);
    f.rss_max_mb = std::max(f.rss_max_mb, s->rss_mb);
    f.places_max = std::max(f.places_max, s->places);
    series.rss_by_life[s->life].emplace_back(s->t_s, s->rss_mb);
    series.places_by_life[s->life].emplace_back(s->t_s, static_cast<double>(s->places));
    series.rss_by_places[s->life].emplace_back(static_cast<double>(s->places), s->rss_mb);
    if (s->t_s >= d / 3 && s->t_s <= 2 * d / 3) series.middle.push_back(s->rss_mb);
    if (s->t_s >= d * 5 / 6) series.late.push_back(s->rss_mb);
  }
  f.lives = static_cast<int>(series.life_span.size());
  f.cpu_percent_mean = cpu_n > 0 ? cpu_sum / cpu_n : 0.0;
  f.rss_slope_mb_per_min = 60.0 * WithinGroupSlope(series.rss_by_life);
  f.places_slope_per_min = 60.0 * WithinGroupSlope(series.places_by_life);
  f.rss_mb_per_place = WithinGroupSlope(series.rss_by_places);
  f.db_slope_mb_per_min = 60.0 * WithinGroupSlope({{0, series.db}});
  f.rss_middle_median_mb = Median(series.middle);
  f.rss_late_median_mb = Median(series.late);
  return series;
}

// Merges, frames and traffic: each life's last counters, summed, traffic per second of the run.
void AddTotals(const RobotSeries& series, double d, SoakRobotFigures& f) {
  double sent_bytes = 0, received_bytes = 0;
  for (const auto& [life, s] : series.last_of_life) {
    f.merges += s->merges_completed;
    f.merges_changed += s->merges_changed;
    f.merges_failed += s->merges_failed;
    f.frames += s->frames;
    for (size_t k = 0; k < kSoakFamilies.size(); ++k) {
      f.sent_per_s[k] += static_cast<double>(s->traffic[k].sent);
      f.received_per_s[k] += static_cast<double>(s->traffic[k].received);
      sent_bytes += static_cast<double>(s->traffic[k].sent_bytes);
      received_bytes += static_cast<double>(s->traffic[k].received_bytes);
    }
  }
  if (d > 0) {
    for (size_t k = 0; k < kSoakFamilies.size(); ++k) {
      f.sent_per_s[k] /= d;
      f.received_per_s[k] /= d;
    }
    f.sent_kb_per_s = sent_bytes / 1024.0 / d;
    f.received_kb_per_s = received_bytes / 1024.0 / d;
  }
}

// A life that began with a restart and lasted long enough to fetch a peer's memory must have
// merged one, unless no peer had anything new for it: a robot fetches a memory only when its
// digest differs from the one it merged last (kept in its store).
void JudgeLivesAfterRestart(const std::vector<SoakSample>& samples, int robot,
                            const RobotSeries& series, const SoakCheckOptions& options,
                            SoakVerdict& v) {
  for (const auto& [life, span] : series.life_span) {
    if (life == 0 || span.second - span.first < 2 * options.life_warmup_s) continue;
    ++v.lives_after_restart;
    if (series.life_merges.at(life) > 0) {
      ++v.lives_after_restart_merged;
    } else if (!PeersChanged(samples, robot, span.first + options.life_warmup_s, span.second)) {
      ++v.lives_after_restart_idle;
    } else {
      AddProblem(v, "robot " + std::to_string(robot) + ": no merge completed in its life " +
                        std::to_string(life) + " (" + Num(span.first, 0) + "–" +
                        Num(span.second, 0) + " s) after a restart");
    }
  }
}

// The bounds: counters seen, RSS slope and late growth, results waiting, peers.
void JudgeBounds(const SoakRobotFigures& f, const RobotSeries& series,
                 const SoakCheckOptions& options, int team_size, SoakVerdict& v) {
  const std::string name = "robot " + std::to_string(f.robot);
  if (f.expected == 0 || f.samples < options.min_sampled_fraction * f.expected) {
    AddProblem(v, name + ": counters in " + std::to_string(f.samples) + " of " +
                      std::to_string(f.expected) + " samples while up");
  }
  if (series.rss_by_life.empty()) {
    AddProblem(v, name + ": no sample after the warm-up");
  } else if (f.rss_slope_mb_per_min > options.max_rss_slope_mb_per_min) {
    AddProblem(v, name + ": RSS grows " + Num(f.rss_slope_mb_per_min, 2) +
                      " MB/min after the warm-up (bound " +
                      Num(options.max_rss_slope_mb_per_min, 2) + ")");
  }
  if (!series.middle.empty() && !series.late.empty() &&
      f.rss_late_median_mb > (1 + options.max_late_growth) * f.rss_middle_median_mb) {
    AddProblem(v, name + ": RSS median of the last sixth " + Num(f.rss_late_median_mb, 1) +
                      " MB is more than " + Num(100 * options.max_late_growth, 0) +
                      " % above the middle third's " + Num(f.rss_middle_median_mb, 1) + " MB");
  }
  if (options.max_places_per_room > 0 && f.places_per_room_last > options.max_places_per_room) {
    AddProblem(v, name + ": " + Num(f.places_per_room_last, 2) +
                      " places per room at its last sample (bound " +
                      Num(options.max_places_per_room, 2) + ")");
  }
  if (f.max_pending_commits > options.max_pending_commits) {
    AddProblem(
        v, name + ": " + std::to_string(f.max_pending_commits) + " results waiting for the store");
  }
  const int64_t others = team_size - 1;
  if (f.max_peers > others || f.max_merged_peers > others || f.max_merge_inbox > others) {
    AddProblem(v, name + ": more peers or waiting memories than robots in the team (peers " +
                      std::to_string(f.max_peers) + ", merged " +
                      std::to_string(f.max_merged_peers) + ", inbox " +
                      std::to_string(f.max_merge_inbox) + ")");
  }
}

}  // namespace

SoakVerdict AnalyseSoak(const std::vector<SoakSample>& samples,
                        const std::vector<SoakRestart>& restarts, int team_size,
                        const SoakCheckOptions& options) {
  options.Validate();
  SoakVerdict v;
  for (const SoakSample& s : samples) v.duration_s = std::max(v.duration_s, s.t_s);
  JudgeRestarts(restarts, options, v);
  std::map<int, std::vector<const SoakSample*>> by_robot;
  for (const SoakSample& s : samples) by_robot[s.robot].push_back(&s);
  for (int robot = 1; robot <= team_size; ++robot) {
    SoakRobotFigures f;
    f.robot = robot;
    const auto it = by_robot.find(robot);
    if (it == by_robot.end()) {
      AddProblem(v, "robot " + std::to_string(robot) + ": no sample");
      v.robots.push_back(f);
      continue;
    }
    const RobotSeries series = Collect(it->second, v.duration_s, options, f);
    AddTotals(series, v.duration_s, f);
    JudgeLivesAfterRestart(samples, robot, series, options, v);
    JudgeBounds(f, series, options, team_size, v);
    v.robots.push_back(f);
  }
  return v;
}

std::string SoakVerdictJson(const SoakVerdict& v) {
  std::ostringstream j;
  j << "{\"ok\":" << (v.ok ? "true" : "false") << ",\"duration_s\":" << JsonNumber(v.duration_s)
    << ",\"restarts\":" << v.restarts << ",\"kills\":" << v.kills
    << ",\"unexpected_exits\":" << v.unexpected_exits
    << ",\"lives_after_restart\":" << v.lives_after_restart
    << ",\"lives_after_restart_merged\":" << v.lives_after_restart_merged
    << ",\"lives_after_restart_idle\":" << v.lives_after_restart_idle << ",\"problems\":[";
  for (size_t i = 0; i < v.problems.size(); ++i) {
    j << (i ? "," : "") << JsonString(v.problems[i]);
  }
  j << "],\"robots\":[";
  for (size_t i = 0; i < v.robots.size(); ++i) {
    const SoakRobotFigures& f = v.robots[i];
    j << (i ? "," : "") << "{\"robot\":" << f.robot << ",\"samples\":" << f.samples
      << ",\"expected_samples\":" << f.expected << ",\"lives\":" << f.lives
      << ",\"rss_first_mb\":" << JsonNumber(f.rss_first_mb)
      << ",\"rss_last_mb\":" << JsonNumber(f.rss_last_mb)
      << ",\"rss_max_mb\":" << JsonNumber(f.rss_max_mb)
      << ",\"rss_middle_median_mb\":" << JsonNumber(f.rss_middle_median_mb)
      << ",\"rss_late_median_mb\":" << JsonNumber(f.rss_late_median_mb)
      << ",\"rss_slope_mb_per_min\":" << JsonNumber(f.rss_slope_mb_per_min)
      << ",\"cpu_percent_mean\":" << JsonNumber(f.cpu_percent_mean)
      << ",\"places_first\":" << f.places_first << ",\"places_last\":" << f.places_last
      << ",\"places_max\":" << f.places_max
      << ",\"places_slope_per_min\":" << JsonNumber(f.places_slope_per_min)
      << ",\"places_per_room_last\":" << JsonNumber(f.places_per_room_last)
      << ",\"rss_mb_per_place\":" << JsonNumber(f.rss_mb_per_place)
      << ",\"db_first_mb\":" << JsonNumber(f.db_first_mb)
      << ",\"db_last_mb\":" << JsonNumber(f.db_last_mb)
      << ",\"db_slope_mb_per_min\":" << JsonNumber(f.db_slope_mb_per_min)
      << ",\"frames\":" << f.frames << ",\"merges\":" << f.merges
      << ",\"merges_changed\":" << f.merges_changed << ",\"merges_failed\":" << f.merges_failed
      << ",\"max_queue_frames\":" << f.max_queue_frames
      << ",\"max_merge_inbox\":" << f.max_merge_inbox
      << ",\"max_pending_commits\":" << f.max_pending_commits << ",\"max_peers\":" << f.max_peers
      << ",\"max_merged_peers\":" << f.max_merged_peers
      << ",\"max_buffered_portions\":" << f.max_buffered_portions << ",\"sent_per_s\":{";
    for (size_t k = 0; k < kSoakFamilies.size(); ++k) {
      j << (k ? "," : "") << JsonString(kSoakFamilies[k]) << ":" << JsonNumber(f.sent_per_s[k]);
    }
    j << "},\"received_per_s\":{";
    for (size_t k = 0; k < kSoakFamilies.size(); ++k) {
      j << (k ? "," : "") << JsonString(kSoakFamilies[k]) << ":" << JsonNumber(f.received_per_s[k]);
    }
    j << "},\"sent_kb_per_s\":" << JsonNumber(f.sent_kb_per_s)
      << ",\"received_kb_per_s\":" << JsonNumber(f.received_kb_per_s) << "}";
  }
  j << "]}\n";
  return j.str();
}

std::string SoakVerdictText(const SoakVerdict& v) {
  std::ostringstream o;
  o << "soak: " << Num(v.duration_s, 0) << " s, " << v.restarts << " restarts (" << v.kills
    << " by SIGKILL), " << v.unexpected_exits << " unexpected exits; "
    << v.lives_after_restart_merged << " of " << v.lives_after_restart
    << " restarted lives completed a merge (" << v.lives_after_restart_idle
    << " more had no new peer memory to merge)\n";
  o << "robot lives samples  rss first  last   max  slope MB/min  cpu%  places first last  "
       "per room  merges  msg/s sent recv  KB/s sent recv  db MB last slope/min\n";
  for (const SoakRobotFigures& f : v.robots) {
    double sent = 0, received = 0;
    for (size_t k = 0; k < kSoakFamilies.size(); ++k) {
      sent += f.sent_per_s[k];
      received += f.received_per_s[k];
    }
    o << std::setw(5) << f.robot << std::setw(6) << f.lives << std::setw(5) << f.samples << "/"
      << std::setw(3) << f.expected << std::setw(11) << Num(f.rss_first_mb, 1) << std::setw(6)
      << Num(f.rss_last_mb, 1) << std::setw(6) << Num(f.rss_max_mb, 1) << std::setw(14)
      << Num(f.rss_slope_mb_per_min, 3) << std::setw(6) << Num(f.cpu_percent_mean, 1)
      << std::setw(13) << f.places_first << std::setw(5) << f.places_last << std::setw(10)
      << (f.places_per_room_last > 0 ? Num(f.places_per_room_last, 2) : "-") << std::setw(8)
      << f.merges << std::setw(15) << Num(sent, 1) << std::setw(5) << Num(received, 1)
      << std::setw(11) << Num(f.sent_kb_per_s, 1) << std::setw(5) << Num(f.received_kb_per_s, 1)
      << std::setw(13) << Num(f.db_last_mb, 1) << std::setw(10) << Num(f.db_slope_mb_per_min, 3)
      << "\n";
  }
  o << (v.ok ? "verdict: bounded (no unbounded growth found)\n" : "verdict: FAILED\n");
  for (const std::string& p : v.problems) o << "  - " << p << "\n";
  return o.str();
}

}  // namespace tsc
