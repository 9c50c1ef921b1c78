// DESIGN §5 under kill -9: tscd as a real process on real udpm:// LCM inside the test's private
// network namespace, with real SQLite files, killed at random instants while it learns and
// while it receives, merges and commits a teammate's memory. After each kill the database is
// copied as the crash left it (the last committed state) and compared structurally
// (test/support/memory_compare.h) with what the daemon announced, with what a restarted tscd
// holds, and, for merges, with the memory before and after the merge.
//
// TSCD_KILL_INSTANTS (default 100) sets the instants of both tests together: 3/5 during
// learning, 2/5 during a merge. TSCD_KILL_INSTANTS=1000 is the long opt-in run.

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <set>
#include <string>
#include <thread>

#include "daemon/memory_snapshot.h"
#include "store/store.h"
#include "test/daemon/bus_listener.h"
#include "test/daemon/fast_sim_robot.h"
#include "test/support/child_process.h"
#include "test/support/memory_compare.h"
#include "test/support/random_memory.h"
#include "test/support/serving_peer.h"
#include "test/support/temp_dir.h"

namespace tsc {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;
using std::chrono::seconds;
using testing_support::BusListener;
using testing_support::ChildProcess;
using testing_support::CopyCrashImage;
using testing_support::DescribeDifferences;
using testing_support::FastSimRobot;
using testing_support::Knowledge;
using testing_support::LoadKnowledge;

const std::string kTscd = std::string(TSCD_BIN_DIR) + "/tscd";

int EnvInt(const char* name, int fallback) {
  const char* v = std::getenv(name);
  return v != nullptr && std::atoi(v) > 0 ? std::atoi(v) : fallback;
}

int TotalInstants() { return EnvInt("TSCD_KILL_INSTANTS", 100); }
// Sanitizer builds run tscd several times slower (scripts/test --sanitize).
int Slowdown() { return EnvInt("TSCD_TEST_SLOWDOWN", 1); }

// A robot that only serves and merges memories: its camera is a folder of one frame, read
// once (one base point cannot make a place, so its own memory does not change).
std::vector<std::string> IdleRobot(int robot, const fs::path& state, const fs::path& frames) {
  return {kTscd,
          "--robot",
          std::to_string(robot),
          "--state-dir",
          state.string(),
          "--set",
          "camera.source=folder",
          "--set",
          "camera.path=" + frames.string(),
          "--set",
          "camera.loop=false",
          "--set",
          "lcm.announce_period_s=0.2"};
}

size_t Announces(BusListener& bus, int robot) {
  size_t n = 0;
  bus.Inspect([&](const BusListener& b) {
    if (!b.announces.count("TSC_ANNOUNCE")) return;
    for (const announce_t& a : b.announces.at("TSC_ANNOUNCE")) n += a.robot == robot ? 1 : 0;
  });
  return n;
}

/// Waits for an announce of `robot` after the first `before` ones: the daemon has opened its
/// store, loaded its memory and started.
bool WaitNewAnnounce(BusListener& bus, int robot, size_t before, seconds timeout) {
  return bus.WaitFor(
      [&](const BusListener& b) {
        if (!b.announces.count("TSC_ANNOUNCE")) return false;
        size_t n = 0;
        for (const announce_t& a : b.announces.at("TSC_ANNOUNCE")) n += a.robot == robot ? 1 : 0;
        return n > before;
      },
      timeout);
}

/// MIN(idx) and COUNT(*) of the base point records in `db` (a crash image nothing writes).
std::pair<int64_t, int64_t> BasePointRecords(const fs::path& db) {
  sqlite3* handle = nullptr;
  std::pair<int64_t, int64_t> out{-1, -1};
  if (sqlite3_open_v2(db.c_str(), &handle, SQLITE_OPEN_READONLY, nullptr) == SQLITE_OK) {
    sqlite3_stmt* stmt = nullptr;
    if (sqlite3_prepare_v2(handle, "SELECT MIN(idx), COUNT(*) FROM base_points", -1, &stmt,
                           nullptr) == SQLITE_OK &&
        sqlite3_step(stmt) == SQLITE_ROW) {
      out = {sqlite3_column_int64(stmt, 0), sqlite3_column_int64(stmt, 1)};
    }
    sqlite3_finalize(stmt);
  }
  sqlite3_close(handle);
  return out;
}

bool WaitLog(ChildProcess& p, const std::string& text, milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  while (Clock::now() < deadline) {
    if (p.Log().find(text) != std::string::npos) return true;
    if (!p.running()) return p.Log().find(text) != std::string::npos;
    std::this_thread::sleep_for(milliseconds(5));
  }
  return p.Log().find(text) != std::string::npos;
}

using Key = std::pair<int, int>;  // (robot, local)

class CrashTest : public ::testing::Test {
 protected:
  void SetUp() override {
    // One frame of a real dataset for the idle robots' folder camera.
    fs::create_directories(frames_);
    const fs::path source = fs::path(TSCD_DATA_DIR) / "rtabmap-loop";
    for (const auto& e : fs::directory_iterator(source)) {
      if (e.path().extension() == ".jpg") {
        fs::copy_file(e.path(), frames_ / "0.jpg");
        break;
      }
    }
    ASSERT_TRUE(fs::exists(frames_ / "0.jpg")) << source;
  }

  /// Restarts tscd on `state` as an idle robot, lets it load and stop cleanly, and returns
  /// what its store then holds.
  Knowledge RestartAndStop(int robot, const fs::path& state, BusListener& bus) {
    const size_t before = Announces(bus, robot);
    fs::remove(dir_ / "restart.log");
    ChildProcess dut(IdleRobot(robot, state, frames_), dir_ / "restart.log");
    EXPECT_TRUE(WaitNewAnnounce(bus, robot, before, seconds(60))) << dut.Log();
    EXPECT_TRUE(WaitLog(dut, "ended", seconds(20))) << dut.Log();
    dut.Signal(SIGTERM);
    EXPECT_EQ(dut.Wait(seconds(30)), 0) << dut.Log();
    return LoadKnowledge(state / "memory.db", static_cast<uint32_t>(robot));
  }

  testing_support::TempDir temp_{"crash_test"};
  fs::path dir_ = temp_.path();
  fs::path frames_ = dir_ / "frames";
};

// kill -9 at random instants of learning (sim camera). After each: every place and map edge
// tscd announced (it publishes only after its commit) is in the crash image; every fourth
// instant (and the last) tscd restarts on the crash image, and the memory it holds equals the
// crash image structurally (the other instants restart learning from it, which the next
// instants check). The store's budget is 1 MiB, so once the database outgrows it the kills
// also meet retention steps (deleting base point records, incremental vacuum) under way.
TEST_F(CrashTest, KillNineWhileLearningLosesNothingAndRestartsFromTheLastCommit) {
  TSCD_REQUIRE_PRIVATE_NETNS();
  BusListener bus("TSC_ANNOUNCE|TSC_EVENT_.*");
  const int instants = TotalInstants() * 3 / 5;
  constexpr unsigned kSeed = 20261123;  // of the kill instants, printed to replay a failure
  std::printf("kill instants: %d, seed %u\n", instants, kSeed);
  std::mt19937 rng(kSeed);
  std::uniform_int_distribution<int> delay_ms(100 * Slowdown(), 900 * Slowdown());
  const fs::path state = dir_ / "state";
  const fs::path crash = dir_ / "crash.db";
  std::set<Key> announced_places;
  std::set<std::pair<Key, Key>> announced_edges;
  size_t events_seen = 0;
  size_t places_first = 0, places_last = 0, restarts = 0;
  int64_t base_points_last = 0;
  const auto start = Clock::now();
  for (int instant = 0; instant < instants; ++instant) {
    {
      const size_t before = Announces(bus, 1);
      ChildProcess dut(FastSimRobot(state, {"--set", "store.budget_mb=1", "--set",
                                            "store.maintenance_pages=256"}),
                       dir_ / "tscd.log");
      ASSERT_TRUE(WaitNewAnnounce(bus, 1, before, seconds(60))) << dut.Log();
      std::this_thread::sleep_for(milliseconds(delay_ms(rng)));
      dut.Signal(SIGKILL);
      ASSERT_EQ(dut.Wait(seconds(10)), 128 + SIGKILL);
    }
    std::this_thread::sleep_for(milliseconds(100));  // the last datagrams in flight
    bus.Inspect([&](const BusListener& b) {
      if (!b.events.count("TSC_EVENT_1")) return;
      const auto& ev = b.events.at("TSC_EVENT_1");
      for (; events_seen < ev.size(); ++events_seen) {
        const place_event_t& e = ev[events_seen];
        if (e.event == "learned") announced_places.insert({e.place.robot, e.place.local});
        if (e.event == "mapped" && e.has_from) {
          const Key a{e.from.robot, e.from.local}, c{e.place.robot, e.place.local};
          if (a != c) announced_edges.insert({std::min(a, c), std::max(a, c)});
        }
      }
    });
    ASSERT_TRUE(fs::exists(state / "memory.db")) << "instant " << instant;
    CopyCrashImage(state / "memory.db", crash);
    const Knowledge committed = LoadKnowledge(crash, 1);
    std::set<Key> stored;
    for (const LearnedPlace& p : committed.state.memory.places()) {
      stored.insert({static_cast<int>(p.id.robot), static_cast<int>(p.id.local)});
    }
    for (const Key& p : announced_places) {
      EXPECT_TRUE(stored.count(p))
          << "instant " << instant << ": announced place " << p.first << ":" << p.second << " lost";
    }
    for (const auto& [a, c] : announced_edges) {
      EXPECT_NE(committed.state.map.Find(
                    PlaceId{static_cast<uint32_t>(a.first), static_cast<uint32_t>(a.second)},
                    PlaceId{static_cast<uint32_t>(c.first), static_cast<uint32_t>(c.second)}),
                nullptr)
          << "instant " << instant << ": announced edge lost";
    }
    if (instant % 4 == 0 || instant == instants - 1) {
      const Knowledge restarted = RestartAndStop(1, state, bus);
      EXPECT_EQ(DescribeDifferences(committed, restarted), "")
          << "instant " << instant << ": the restarted memory is not the committed one";
      ++restarts;
    }
    if (instant == 0) places_first = stored.size();
    places_last = stored.size();
    base_points_last = committed.state.pipeline.next_base;
  }
  const double s = std::chrono::duration<double>(Clock::now() - start).count();
  const auto [first_kept, kept] = BasePointRecords(crash);
  std::printf(
      "[ figures  ] learning: %d kill -9 instants, %zu restarts compared, %zu places announced, "
      "%zu edges announced, 0 lost; %zu -> %zu places, %lld base points (records of %lld kept "
      "from %lld on, store.budget_mb = 1, crash image %ju bytes); %.1f s\n",
      instants, restarts, announced_places.size(), announced_edges.size(), places_first,
      places_last, static_cast<long long>(base_points_last), static_cast<long long>(kept),
      static_cast<long long>(first_kept), fs::file_size(crash), s);
  // Retention deleted records while the kills went on: the oldest (first_kept > 0), or all of
  // them once the learned places alone outgrew the budget (under ASan, 25 places of 32 member
  // views filled 1.27 MB: no record was left, and first_kept was 0).
  EXPECT_LT(kept, base_points_last);
  EXPECT_TRUE(kept == 0 || first_kept > 0) << "records kept from " << first_kept;
  EXPECT_GT(places_last, places_first);    // learning went on across the restarts
  EXPECT_GE(announced_places.size(), 3u);  // the test saw learning, so the check had teeth
}

// A teammate's memory of `count` places in the descriptor space of `ours`: each place's member
// descriptors are one of our places' mean scaled feature by feature at random, so the two
// memories overlap and the merge has hyper-terminals to match.
testing_support::RandomMemory PeerMemory(const PlaceMemory& ours, uint32_t robot, int count,
                                         unsigned seed) {
  // Our options: the views in our basis, as a teammate's are.
  testing_support::RandomMemory out{PlaceMemory(robot, ours.options()), TopologicalMap{}};
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> scale(0.5f, 1.5f);
  const auto& places = ours.places();
  const Eigen::Index dims = places.front().mean.size();
  constexpr int kMembers = 3;
  for (int k = 0; k < count; ++k) {
    const Eigen::VectorXf& base = places[static_cast<size_t>(k) % places.size()].mean;
    DetectedPlace d;
    d.index = k + 1;
    d.descriptors.resize(dims, kMembers);
    for (int j = 0; j < kMembers; ++j) {
      d.members.push_back(static_cast<BaseIndex>(k * 10 + j));
      for (Eigen::Index i = 0; i < dims; ++i) d.descriptors(i, j) = base(i) * scale(rng);
    }
    out.memory.Learn(d);
    const PlaceId id = out.memory.places().back().id;
    out.map.AddPlace(id);
    if (k > 0) {
      out.map.RecordTransition(out.memory.places()[static_cast<size_t>(k - 1)].id, id, {});
    }
  }
  return out;
}

// kill -9 at random instants while tscd receives a teammate's memory over the real exchange
// (a second tscd serving a stored memory of a few hundred places), merges it and commits the
// merged memory. Each instant starts from the same pre-merge database; after the kill the crash
// image must be exactly the pre-merge memory (peer not recorded) or exactly the post-merge one
// of an uninterrupted reference run (peer recorded), and tscd restarted on it must complete the
// merge once more or, when it was committed, not fetch the peer again, ending with the
// post-merge memory. The steps are the fixture's; each asserts what the next relies on.
class CrashDuringMergeTest : public CrashTest {
 protected:
  // Our memory before the merge: learned by a real tscd from its simulated camera.
  void LearnOurMemory() {
    ChildProcess dut(FastSimRobot(pre_dir_), dir_ / "learn.log");
    ASSERT_TRUE(bus_->WaitFor(
        [](const BusListener& b) {
          if (!b.announces.count("TSC_ANNOUNCE")) return false;
          for (const announce_t& a : b.announces.at("TSC_ANNOUNCE")) {
            if (a.robot == 1 && a.places >= 4) return true;
          }
          return false;
        },
        seconds(120)))
        << dut.Log();
    dut.Signal(SIGTERM);
    ASSERT_EQ(dut.Wait(seconds(30)), 0) << dut.Log();
    pre_ = LoadKnowledge(pre_dir_ / "memory.db", 1);
    ASSERT_GE(pre_->state.memory.places().size(), 4u);
  }

  void CopyPreMergeStore(const fs::path& to) const {
    fs::remove_all(to);
    fs::create_directories(to);
    fs::copy_file(pre_dir_ / "memory.db", to / "memory.db");
  }

  // The merge uninterrupted, timed from robot 1's first announce: the memory every recorded
  // peer must leave, and the times the kill instants are drawn over.
  void RunReferenceMerge() {
    const fs::path ref_dir = dir_ / "reference";
    CopyPreMergeStore(ref_dir);
    {
      const size_t before = Announces(*bus_, 1);
      ChildProcess dut(IdleRobot(1, ref_dir, frames_), dir_ / "reference.log");
      ASSERT_TRUE(WaitNewAnnounce(*bus_, 1, before, seconds(60))) << dut.Log();
      const auto t0 = Clock::now();
      ASSERT_TRUE(WaitLog(dut, "received the memory of robot 2", seconds(60))) << dut.Log();
      received_s_ = std::chrono::duration<double>(Clock::now() - t0).count();
      ASSERT_TRUE(WaitLog(dut, "merged the memory of robot 2", seconds(60))) << dut.Log();
      merged_s_ = std::chrono::duration<double>(Clock::now() - t0).count();
      dut.Signal(SIGTERM);
      ASSERT_EQ(dut.Wait(seconds(30)), 0) << dut.Log();
    }
    post_ = LoadKnowledge(ref_dir / "memory.db", 1);
    ASSERT_TRUE(post_->peers.count(2));
    ASSERT_NE(DescribeDifferences(*pre_, *post_), "") << "the merge changed nothing: no teeth";
  }

  // Starts tscd on the pre-merge store, kills it `delay` after its first announce (or after
  // its reception log line, when `from_reception`) and returns its log.
  void KillDuringMerge(milliseconds delay, bool from_reception, std::string* log) {
    CopyPreMergeStore(state_);
    const size_t before = Announces(*bus_, 1);
    fs::remove(dir_ / "instant.log");
    ChildProcess dut(IdleRobot(1, state_, frames_), dir_ / "instant.log");
    ASSERT_TRUE(WaitNewAnnounce(*bus_, 1, before, seconds(60))) << dut.Log();
    if (from_reception) {
      ASSERT_TRUE(WaitLog(dut, "received the memory of robot 2", seconds(60))) << dut.Log();
    }
    std::this_thread::sleep_for(delay);
    dut.Signal(SIGKILL);
    ASSERT_EQ(dut.Wait(seconds(10)), 128 + SIGKILL);
    *log = dut.Log();
  }

  // The crash image is the pre- or the post-merge memory; returns the phase the kill met and
  // whether the peer is recorded.
  std::string JudgeCrashImage(int instant, const std::string& log, bool* recorded) {
    const fs::path crash = dir_ / "crash.db";
    CopyCrashImage(state_ / "memory.db", crash);
    const Knowledge committed = LoadKnowledge(crash, 1);
    *recorded = committed.peers.count(2) > 0;
    const bool received = log.find("received the memory of robot 2") != std::string::npos;
    const bool logged = log.find("merged the memory of robot 2") != std::string::npos;
    const std::string phase = !received   ? "receiving"
                              : logged    ? "after the merge"
                              : *recorded ? "committed, not yet logged"
                                          : "merging or committing";
    if (*recorded) {
      EXPECT_EQ(DescribeDifferences(committed, *post_), "")
          << "instant " << instant << " (" << phase << "): peer recorded but not the merged memory";
    } else {
      EXPECT_EQ(DescribeDifferences(committed, *pre_), "")
          << "instant " << instant << " (" << phase << "): peer not recorded but not the memory "
          << "before the merge";
      EXPECT_FALSE(logged) << "instant " << instant << ": merge logged but not committed";
    }
    return phase;
  }

  // Restart on the crash image: the merge completes (again), or the peer is not fetched again;
  // either way tscd ends with the post-merge memory.
  void RestartAndFinish(int instant, bool recorded, const testing_support::ServingPeer& peer) {
    const size_t before = Announces(*bus_, 1);
    const int64_t requests_before = peer.requests();
    fs::remove(dir_ / "restart.log");
    ChildProcess dut(IdleRobot(1, state_, frames_), dir_ / "restart.log");
    ASSERT_TRUE(WaitNewAnnounce(*bus_, 1, before, seconds(60))) << dut.Log();
    if (recorded) {
      // The peer announces every 0.2 s; a memory not merged yet is asked for within one
      // announce and the exchange tick (0.1 s) after it.
      std::this_thread::sleep_for(milliseconds(800 * Slowdown()));
      EXPECT_EQ(peer.requests(), requests_before)
          << "instant " << instant << ": a merged peer was fetched again";
    } else {
      EXPECT_TRUE(WaitLog(dut, "merged the memory of robot 2", seconds(60)))
          << "instant " << instant << ": " << dut.Log();
    }
    dut.Signal(SIGTERM);
    ASSERT_EQ(dut.Wait(seconds(30)), 0) << dut.Log();
    EXPECT_EQ(DescribeDifferences(LoadKnowledge(state_ / "memory.db", 1), *post_), "")
        << "instant " << instant << ": after the restart";
  }

  std::unique_ptr<BusListener> bus_;  // started after the private-namespace check
  fs::path pre_dir_ = dir_ / "pre";
  fs::path state_ = dir_ / "state";
  std::optional<Knowledge> pre_, post_;  // set by LearnOurMemory, RunReferenceMerge
  double received_s_ = 0, merged_s_ = 0;
};

TEST_F(CrashDuringMergeTest,
       KillNineDuringAMergeLeavesThePreOrPostMergeMemoryAndTheMergeCompletes) {
  TSCD_REQUIRE_PRIVATE_NETNS();
  bus_ = std::make_unique<BusListener>("TSC_ANNOUNCE|TSC_EVENT_.*");
  const int instants = TotalInstants() - TotalInstants() * 3 / 5;
  const int peer_places = EnvInt("TSCD_KILL_PEER_PLACES", 200);
  ASSERT_NO_FATAL_FAILURE(LearnOurMemory());
  // The teammate's memory, served over the exchange protocol.
  const auto memory = PeerMemory(pre_->state.memory, 2, peer_places, 7);
  testing_support::ServingPeer peer(
      2, BuildSnapshot(memory.memory, memory.map, SnapshotHeader{2, 4242, 1, 1}, 60000),
      testing_support::kNamespaceBusUrl);
  ASSERT_NO_FATAL_FAILURE(RunReferenceMerge());

  // Instants: every other one uniform over [0, 1.2 x the reference's time to the merged log
  // line] after the first announce (the transfer, the merge, its commit and a little after;
  // the reference was timed in this run, so a sanitizer's slowdown is in it already). The
  // others are aimed at the merge and its commit from this run's own reception log line,
  // uniform over the first half of the reference's reception-to-merged time: timed from the
  // announce they all fell after the merge once, on a loaded machine whose reference run had
  // been slower than the runs after it.
  constexpr unsigned kSeed = 20261124;  // of the kill instants, printed to replay a failure
  std::printf("merge kill instants: seed %u\n", kSeed);
  std::mt19937 rng(kSeed);
  std::uniform_int_distribution<int> anywhere_ms(0, static_cast<int>(1200.0 * merged_s_));
  std::uniform_int_distribution<int> merging_ms(
      0, static_cast<int>(500.0 * (merged_s_ - received_s_)));
  std::map<std::string, int> phases;
  const auto start = Clock::now();
  for (int instant = 0; instant < instants; ++instant) {
    const bool from_reception = instant % 2 == 1;
    const milliseconds delay(from_reception ? merging_ms(rng) : anywhere_ms(rng));
    std::string log;
    ASSERT_NO_FATAL_FAILURE(KillDuringMerge(delay, from_reception, &log));
    bool recorded = false;
    ++phases[JudgeCrashImage(instant, log, &recorded)];
    ASSERT_NO_FATAL_FAILURE(RestartAndFinish(instant, recorded, peer));
    if (HasFailure()) break;  // one broken instant says it; the rest would repeat it
  }
  const double s = std::chrono::duration<double>(Clock::now() - start).count();
  std::string where;
  for (const auto& [phase, n] : phases) where += " " + phase + ": " + std::to_string(n) + ";";
  std::printf(
      "[ figures  ] merge: %d kill -9 instants over 0-%.2f s after the first announce (peer "
      "memory of %d places: received at %.2f s, merged and logged at %.2f s in the reference "
      "run);%s %zu -> %zu places; %.1f s\n",
      instants, 1.2 * merged_s_, peer_places, received_s_, merged_s_, where.c_str(),
      pre_->state.memory.places().size(), post_->state.memory.places().size(), s);
  EXPECT_GT(phases["merging or committing"] + phases["committed, not yet logged"], 0)
      << "no instant fell inside the merge";
}

// Issue 23: the bodies of a teammate's memory that tscd merged are kept in its store, so after a
// restart it fetches the teammate's next memory as its structure and the one body that changed,
// not whole (it kept them in RAM before, and a restarted robot fetched every peer whole).
TEST_F(CrashDuringMergeTest, ARestartedRobotFetchesOnlyWhatChangedOfAPeerItMergedBefore) {
  TSCD_REQUIRE_PRIVATE_NETNS();
  bus_ = std::make_unique<BusListener>("TSC_ANNOUNCE");
  ASSERT_NO_FATAL_FAILURE(LearnOurMemory());
  auto memory = PeerMemory(pre_->state.memory, 2, 40, 7);
  const MemorySnapshot v1 =
      BuildSnapshot(memory.memory, memory.map, SnapshotHeader{2, 4242, 1, 1}, 60000);
  CopyPreMergeStore(state_);
  {
    testing_support::ServingPeer peer(2, v1, testing_support::kNamespaceBusUrl);
    ChildProcess dut(IdleRobot(1, state_, frames_), dir_ / "first.log");
    ASSERT_TRUE(WaitLog(dut, "merged the memory of robot 2", seconds(60))) << dut.Log();
    dut.Signal(SIGTERM);
    ASSERT_EQ(dut.Wait(seconds(30)), 0) << dut.Log();
    EXPECT_EQ(peer.served().size(), static_cast<size_t>(v1.count()));  // nothing known: whole
  }
  // The teammate sees its place 17 again: that place's body changes, and the structure.
  DetectedPlace revisit;
  revisit.index = 41;
  revisit.descriptors = memory.memory.places()[17].mean.replicate(1, 2) * 1.25f;
  revisit.members = {4100, 4101};
  memory.memory.Update(17, revisit);
  const MemorySnapshot v2 =
      BuildSnapshot(memory.memory, memory.map, SnapshotHeader{2, 4242, 2, 2}, 60000);
  ASSERT_EQ(v2.places, v1.places);
  ASSERT_NE(v2.body_digests[17], v1.body_digests[17]);
  testing_support::ServingPeer peer(2, v2, testing_support::kNamespaceBusUrl);
  ChildProcess dut(IdleRobot(1, state_, frames_), dir_ / "second.log");
  // Received whole and checked (the merge may then find nothing new: logged at debug level).
  ASSERT_TRUE(WaitLog(dut, "received the memory of robot 2 (version 2", seconds(60))) << dut.Log();
  dut.Signal(SIGTERM);
  ASSERT_EQ(dut.Wait(seconds(30)), 0) << dut.Log();
  std::set<int32_t> wanted;
  for (int32_t i = 0; i < v2.structure_portions; ++i) wanted.insert(i);
  wanted.insert(v2.structure_portions + 17);
  EXPECT_EQ(peer.served(), wanted) << dut.Log();
}

}  // namespace
}  // namespace tsc
