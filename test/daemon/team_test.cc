// A team of three real tscd processes (started by `tsc team`) in the test's private network
// namespace: the test's own LCM client decodes every message on every channel; lcm-logger
// records the run and the Java types decode the log; a robot on a simulated base follows
// motor commands and its watchdog stops it.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <string>
#include <thread>

#include "store/store.h"
#include "test/daemon/bus_listener.h"
#include "test/support/child_process.h"
#include "test/support/json_number.h"
#include "test/support/temp_dir.h"
#include "test/support/tsc_command.h"

namespace tsc {
namespace {

namespace fs = std::filesystem;
using std::chrono::milliseconds;
using std::chrono::seconds;
using testing_support::BusListener;
using testing_support::ChildProcess;
using testing_support::JsonNumberAt;

const std::string kBin = TSCD_BIN_DIR;

using testing_support::ReadFile;

class TeamTest : public ::testing::Test {
 protected:
  testing_support::TempDir temp_{"team_test"};
  fs::path dir_ = temp_.path();
};

// Every place every robot learned itself, from the robots' stores.
std::set<PlaceId> OwnPlacesOfTheTeam(const fs::path& team, int robots) {
  std::set<PlaceId> own;
  for (int r = 1; r <= robots; ++r) {
    Store store = Store::Open(team / ("robot-" + std::to_string(r)) / "memory.db");
    for (const auto& [place, members] : store.LoadAssignments()) {
      if (place.robot == static_cast<uint32_t>(r)) own.insert(place);
    }
  }
  return own;
}

// The places robot `r` knows at the end: its memory's places and the sources they absorbed.
std::set<PlaceId> KnownPlaces(const fs::path& team, int r) {
  Store store = Store::Open(team / ("robot-" + std::to_string(r)) / "memory.db");
  const StoredState saved = store.Load(static_cast<uint32_t>(r), PipelineOptions{}.memory);
  std::set<PlaceId> known;
  for (const LearnedPlace& p : saved.memory.places()) {
    known.insert(p.id);
    known.insert(p.sources.begin(), p.sources.end());
  }
  return known;
}

TEST_F(TeamTest, ThreeRobotsLearnAndEveryMessageDecodes) {
  TSCD_REQUIRE_PRIVATE_NETNS();
  BusListener bus;
  const fs::path log = dir_ / "team.lcm";
  ChildProcess logger({TSCD_LCM_LOGGER, "-q", "-f", "--flush-interval=20",
                       std::string("--lcm-url=") + testing_support::kNamespaceBusUrl, log.string()},
                      dir_ / "logger.out");
  std::this_thread::sleep_for(milliseconds(300));
  ChildProcess team({kBin + "/tsc", "team",
                     "--robots",    "3",
                     "--world",     "7",
                     "--seconds",   "20",
                     "--fps",       "25",
                     "--netns",     "current",
                     "--out",       (dir_ / "team").string(),
                     "--set",       "sim.width=160",
                     "--set",       "sim.height=120",
                     "--set",       "lcm.memory_period_s=2"},
                    dir_ / "team.out");
  const auto status = team.Wait(seconds(120));
  ASSERT_EQ(status, 0) << team.Log();
  std::this_thread::sleep_for(milliseconds(300));
  logger.Signal(SIGINT);
  logger.Wait(seconds(10));

  bus.Inspect([](const BusListener& b) {
    EXPECT_TRUE(b.undecodable.empty());
    ASSERT_TRUE(b.announces.count("TSC_ANNOUNCE"));
    std::map<int, int> places;
    for (const announce_t& a : b.announces.at("TSC_ANNOUNCE")) places[a.robot] = a.places;
    for (int r = 1; r <= 3; ++r) {
      const std::string id = std::to_string(r);
      EXPECT_GE(places[r], 1) << "robot " << r << " learned nothing";
      EXPECT_TRUE(b.events.count("TSC_EVENT_" + id)) << id;
      ASSERT_TRUE(b.portions.count("TSC_MEMORY_" + id)) << id;
      const memory_portion_v2_t& last = b.portions.at("TSC_MEMORY_" + id).back();
      EXPECT_EQ(last.robot, r);
      EXPECT_GE(last.total_places, 1);
      EXPECT_GT(last.count, 0);
    }
  });
  const std::string summary = ReadFile(dir_ / "team" / "summary.json");
  for (int r = 1; r <= 3; ++r) {
    EXPECT_NE(summary.find("\"robot\":" + std::to_string(r)), std::string::npos) << summary;
    EXPECT_TRUE(fs::exists(dir_ / "team" / ("robot-" + std::to_string(r)) / "memory.db"));
  }
  EXPECT_NE(team.Log().find("recognised"), std::string::npos);

  // Chapter 4: every robot merged the others' memories (places of all three robots, kept as
  // places or as the sources of places that absorbed them), committed to its store.
  for (int r = 1; r <= 3; ++r) {
    Store store = Store::Open(dir_ / "team" / ("robot-" + std::to_string(r)) / "memory.db");
    const StoredState saved = store.Load(static_cast<uint32_t>(r), PipelineOptions{}.memory);
    std::set<uint32_t> robots;
    for (const LearnedPlace& p : saved.memory.places()) {
      robots.insert(p.id.robot);
      for (const PlaceId& s : p.sources) robots.insert(s.robot);
    }
    EXPECT_EQ(robots, (std::set<uint32_t>{1, 2, 3})) << "robot " << r;
    EXPECT_EQ(store.LoadPeers().size(), 2u) << "robot " << r;
  }

  // The Java types decode the captured log (what lcm-spy shows).
  ChildProcess dump({TSCD_JAVA, "-jar", TSCD_LOGDUMP_JAR, log.string()}, dir_ / "dump.txt");
  ASSERT_EQ(dump.Wait(seconds(120)), 0) << dump.Log().substr(0, 2000);
  const std::string text = dump.Log();
  for (const char* channel : {"TSC_ANNOUNCE", "TSC_EVENT_1", "TSC_EVENT_2", "TSC_EVENT_3",
                              "TSC_MEMORY_1", "TSC_MEMORY_2", "TSC_MEMORY_3"}) {
    EXPECT_NE(text.find(channel), std::string::npos) << channel;
  }
  EXPECT_NE(text.find("places[0].mean="), std::string::npos);
}

// For each PlaceId robot `r`'s final memory holds (a place's own id or a source it absorbed),
// how many of its places hold it: merging keeps one place per id (DESIGN 3.6, idempotent).
std::map<PlaceId, int> PlacesHoldingEachId(const fs::path& team, int r) {
  Store store = Store::Open(team / ("robot-" + std::to_string(r)) / "memory.db");
  const StoredState saved = store.Load(static_cast<uint32_t>(r), PipelineOptions{}.memory);
  std::map<PlaceId, int> count;
  for (const LearnedPlace& p : saved.memory.places()) {
    std::set<PlaceId> ids(p.sources.begin(), p.sources.end());
    ids.insert(p.id);
    for (const PlaceId& id : ids) ++count[id];
  }
  return count;
}

// Chapter 4 on a whole live run: the routes end, the exchange settles, and then what must hold
// whatever the run's timing: every robot knows every place any robot learned (as a place or as
// a source a place absorbed), each in exactly one of its places, and the team's memories are
// consistent (`tsc team` finds them knowing the same places). Which places get merged, and so
// merge precision and recall, depend on the order frames and memories happen to arrive in a
// live run; that quality is measured where it is deterministic, in the offline evaluation
// (`tsc team` summaries over fixed worlds, docs/results.md "Team merging"; DESIGN 7.1b's bar in
// DISABLED_MergeRecallBar), not asserted on one race here.
TEST_F(TeamTest, AfterTheRoutesEveryRobotKnowsEveryPlaceExactlyOnce) {
  TSCD_REQUIRE_PRIVATE_NETNS();
  ChildProcess team({kBin + "/tsc", "team",
                     "--robots",    "3",
                     "--world",     "7",
                     "--seconds",   "0",
                     "--settle",    "40",
                     "--fps",       "50",
                     "--netns",     "current",
                     "--out",       (dir_ / "team").string(),
                     "--set",       "sim.width=160",
                     "--set",       "sim.height=120",
                     "--set",       "lcm.memory_period_s=2"},
                    dir_ / "team.out");
  ASSERT_EQ(team.Wait(seconds(150)), 0) << team.Log();
  EXPECT_EQ(team.Log().find("still changing"), std::string::npos) << team.Log();
  const std::string summary = ReadFile(dir_ / "team" / "summary.json");
  EXPECT_NE(summary.find("\"consistent\":true"), std::string::npos) << summary;
  // The team map over the floor plan (issue 21, item 4).
  const fs::path team_map = dir_ / "team" / "team_map.png";
  EXPECT_TRUE(fs::exists(team_map) && fs::file_size(team_map) > 10000u) << team.Log();

  const std::set<PlaceId> own = OwnPlacesOfTheTeam(dir_ / "team", 3);
  ASSERT_GE(own.size(), 6u);
  for (int r = 1; r <= 3; ++r) {
    EXPECT_EQ(KnownPlaces(dir_ / "team", r), own) << "robot " << r;
    for (const auto& [id, places] : PlacesHoldingEachId(dir_ / "team", r)) {
      EXPECT_EQ(places, 1) << "robot " << r << " holds place " << id.ToString() << " in " << places
                           << " places";
    }
  }
  // Figures of this run, for the log (not asserted: see above).
  std::printf("merges %g, merge precision %g\n", JsonNumberAt(summary, "merges"),
              JsonNumberAt(summary, "precision"));
}

// DESIGN 7.1b merge recall >= 0.8 is NOT met: it counts pairs of same-label places of
// different robots, and a robot that learns a room or the corridor as several places caps it
// (a merge joins a place with one place of each other robot): forward camera, five worlds,
// at most 74 of 245 pairs can be merged; 30 were. With pan sweeps (config/sweep.ini, 160x120,
// fps 12) pair recall 0.46 at precision 0.88, place recall 0.69 (docs/results.md, "Team
// merging, session 15"). Run with --gtest_also_run_disabled_tests.
TEST_F(TeamTest, DISABLED_MergeRecallBar) {
  TSCD_REQUIRE_PRIVATE_NETNS();
  ChildProcess team({kBin + "/tsc", "team", "--robots", "3", "--world", "5", "--seconds", "0",
                     "--fps", "30", "--netns", "current", "--out", (dir_ / "team").string()},
                    dir_ / "team.out");
  ASSERT_EQ(team.Wait(seconds(300)), 0) << team.Log();
  const std::string summary = ReadFile(dir_ / "team" / "summary.json");
  EXPECT_GE(JsonNumberAt(summary, "recall"), 0.8) << summary;
  EXPECT_GE(JsonNumberAt(summary, "precision"), 0.95) << summary;
}

// With a team key every exchange message is signed: robots fetch each other's memories, and
// unsigned or forged messages from the test are dropped and counted.
TEST_F(TeamTest, SignedExchangeDeliversMemoriesAndDropsForgeries) {
  TSCD_REQUIRE_PRIVATE_NETNS();
  const fs::path key = dir_ / "team.key";
  std::ofstream(key) << "team secret\n";
  fs::permissions(key, fs::perms::owner_read | fs::perms::owner_write);
  BusListener bus;
  ChildProcess team({kBin + "/tsc", "team",
                     "--robots",    "2",
                     "--world",     "3",
                     "--seconds",   "14",
                     "--fps",       "25",
                     "--netns",     "current",
                     "--out",       (dir_ / "team").string(),
                     "--set",       "sim.width=160",
                     "--set",       "sim.height=120",
                     "--set",       "lcm.team_key_file=" + key.string(),
                     "--set",       "lcm.memory_period_s=2"},
                    dir_ / "team.out");
  ASSERT_TRUE(bus.WaitFor(
      [](const BusListener& b) {
        return b.announces.count("TSC_ANNOUNCE") && b.announces.at("TSC_ANNOUNCE").size() >= 4;
      },
      seconds(30)))
      << team.Log();
  // An unsigned announce, and a memory portion of robot 2 signed with the wrong key.
  announce_t fake{};
  fake.robot = 9;
  fake.memory_version = 1;
  fake.status = "forged";
  fake.hmac_size = 0;
  bus.lcm().publish("TSC_ANNOUNCE", &fake);
  memory_portion_v2_t forged{};
  bus.Inspect([&](const BusListener& b) {
    if (b.portions.count("TSC_MEMORY_2")) forged = b.portions.at("TSC_MEMORY_2").back();
  });
  forged.robot = 2;
  forged.version += 100;
  forged.hmac.assign(32, 0xAB);
  forged.hmac_size = 32;
  bus.lcm().publish("TSC_MEMORY_2", &forged);

  ASSERT_EQ(team.Wait(seconds(90)), 0) << team.Log();
  bus.Inspect([](const BusListener& b) {
    int64_t rejected = 0;
    for (const announce_t& a : b.announces.at("TSC_ANNOUNCE")) {
      if (a.robot == 9) continue;  // the test's own forgery
      EXPECT_EQ(a.hmac_size, 32) << "robot " << a.robot << " announced unsigned";
      if (a.robot == 1) rejected = std::max(rejected, a.messages_rejected);
    }
    EXPECT_GE(rejected, 2);
  });
  const std::string log1 = ReadFile(dir_ / "team" / "robot-1" / "tscd.log");
  const std::string log2 = ReadFile(dir_ / "team" / "robot-2" / "tscd.log");
  EXPECT_NE(log1.find("received the memory of robot 2"), std::string::npos) << log1;
  EXPECT_NE(log2.find("received the memory of robot 1"), std::string::npos) << log2;
  EXPECT_NE(log1.find("dropped an unsigned announce"), std::string::npos) << log1;
  EXPECT_NE(log1.find("dropped a forged memory portion"), std::string::npos) << log1;
}

// One lost datagram loses one portion: with 25 % of all UDP datagrams dropped in this namespace
// (nftables), small portions and many of them, every robot still completes the others' memories.
// Which datagrams are lost is a seeded hash of their first 16 payload bytes (LCM's magic and
// per-sender sequence number, then channel or fragment header), not `numgen random`: the same
// traffic loses the same datagrams, and the seed is printed (~23 % of 1000 test datagrams).
TEST_F(TeamTest, ExchangeCompletesUnderPacketLoss) {
  TSCD_REQUIRE_PRIVATE_NETNS();
  constexpr const char* kLossSeed = "0x12";
  std::printf("packet loss: jhash of the first 16 payload bytes, seed %s, 25 %%\n", kLossSeed);
  const int nft = std::system(
      (std::string("nft add table inet tscd_loss && nft add chain inet tscd_loss out "
                   "'{ type filter hook output priority 0; }' && nft add rule inet tscd_loss out "
                   "meta l4proto udp jhash @th,64,128 mod 100 seed ") +
       kLossSeed + " '<' 25 drop")
          .c_str());
  if (nft != 0) GTEST_SKIP() << "nftables cannot drop packets here (nft exit " << nft << ")";
  struct RemoveLoss {
    ~RemoveLoss() { (void)std::system("nft delete table inet tscd_loss"); }
  } remove_loss;

  ChildProcess team({kBin + "/tsc", "team",
                     "--robots",    "2",
                     "--world",     "4",
                     "--seconds",   "0",
                     "--settle",    "60",
                     "--fps",       "50",
                     "--netns",     "current",
                     "--out",       (dir_ / "team").string(),
                     "--set",       "sim.width=160",
                     "--set",       "sim.height=120",
                     "--set",       "lcm.portion_bytes=4096",
                     "--set",       "lcm.memory_period_s=2"},
                    dir_ / "team.out");
  ASSERT_EQ(team.Wait(seconds(180)), 0) << team.Log();
  // Every exchange completed: after the routes, each robot knows every place either learned,
  // as a lossless exchange leaves it.
  const std::set<PlaceId> own = OwnPlacesOfTheTeam(dir_ / "team", 2);
  ASSERT_GE(own.size(), 4u);
  for (int r = 1; r <= 2; ++r) EXPECT_EQ(KnownPlaces(dir_ / "team", r), own) << "robot " << r;
  for (int r = 1; r <= 2; ++r) {
    const std::string log = ReadFile(dir_ / "team" / ("robot-" + std::to_string(r)) / "tscd.log");
    const std::string other = std::to_string(3 - r);
    // A memory of several portions (places carry 8 samples each: > 4 KB per place).
    const size_t at = log.rfind("received the memory of robot " + other);
    ASSERT_NE(at, std::string::npos) << log;
    const std::string line = log.substr(at, log.find('\n', at) - at);
    const size_t comma = line.find(", ");
    ASSERT_NE(comma, std::string::npos) << line;
    EXPECT_GE(std::stoi(line.substr(comma + 2)), 2) << line;
  }
}

TEST_F(TeamTest, SimulatedBaseFollowsCommandsAndItsWatchdogStopsIt) {
  TSCD_REQUIRE_PRIVATE_NETNS();
  BusListener bus;
  ChildProcess dut({kBin + "/tscd", "--robot", "4", "--state-dir", (dir_ / "state").string(),
                    "--set", "sim.drive=commands", "--set", "sim.width=160", "--set",
                    "sim.height=120", "--set", "camera.fps=20"},
                   dir_ / "tscd.log");
  ASSERT_TRUE(bus.WaitFor([](const BusListener& b) { return b.received.count("JAGUAR_STATE_4"); },
                          seconds(30)))
      << dut.Log();
  // The listener keeps only tsc types; decode JAGUAR_STATE_4 with a typed subscription.
  struct StateSink {
    std::mutex m;
    std::vector<jaguar::motor_state_t> states;
    // The function form of subscribe: see BusListener.
    static void On(const lcm::ReceiveBuffer*, const std::string&, const jaguar::motor_state_t* s,
                   StateSink* self) {
      std::lock_guard lock(self->m);
      self->states.push_back(*s);
    }
  } sink;
  lcm::LCM own(testing_support::kNamespaceBusUrl);
  own.subscribeFunction("JAGUAR_STATE_4", &StateSink::On, &sink);
  auto pump = [&](milliseconds d) {
    const auto end = std::chrono::steady_clock::now() + d;
    while (std::chrono::steady_clock::now() < end) own.handleTimeout(20);
  };
  auto last = [&] {
    std::lock_guard lock(sink.m);
    return sink.states.empty() ? jaguar::motor_state_t{} : sink.states.back();
  };
  pump(milliseconds(300));
  const jaguar::motor_state_t start = last();
  ASSERT_TRUE(start.stopped);

  jaguar::motor_command_t cmd{};
  cmd.linear_mps = 0.5;
  cmd.angular_radps = 0.0;
  for (int i = 0; i < 10; ++i) {  // 1 s at 0.5 m/s, a command every 100 ms
    cmd.utime = i;
    cmd.sequence = i;
    own.publish("JAGUAR_CMD_4", &cmd);
    pump(milliseconds(100));
  }
  const jaguar::motor_state_t moving = last();
  EXPECT_FALSE(moving.stopped);
  const double moved = std::hypot(moving.x - start.x, moving.y - start.y);
  EXPECT_GT(moved, 0.3);
  EXPECT_LT(moved, 0.7);

  pump(milliseconds(900));  // no more commands: the watchdog stops the base within 0.5 s
  const jaguar::motor_state_t stopped = last();
  EXPECT_TRUE(stopped.stopped);
  EXPECT_EQ(stopped.fault, "watchdog");
  const double drift = std::hypot(stopped.x - moving.x, stopped.y - moving.y);
  EXPECT_LT(drift, 0.5 * 0.5 + 0.1);  // at most 0.5 s more at 0.5 m/s

  dut.Signal(SIGTERM);
  EXPECT_EQ(dut.Wait(seconds(20)), 0) << dut.Log();
}

}  // namespace
}  // namespace tsc
