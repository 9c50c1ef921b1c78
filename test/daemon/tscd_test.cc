// tscd as a real process on real udpm:// LCM inside the test's private network namespace
// (test/support/in_netns), with real SQLite files: lifecycle, the channels it serves, bad input.
// kill -9 at random instants is crash_test, storage faults storage_fault_test.

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <thread>

#include "daemon/lcm_bus.h"
#include "store/store.h"
#include "test/daemon/bus_listener.h"
#include "test/daemon/fast_sim_robot.h"
#include "test/support/child_process.h"
#include "test/support/temp_dir.h"

namespace tsc {
namespace {

namespace fs = std::filesystem;
using std::chrono::milliseconds;
using std::chrono::seconds;
using testing_support::BusListener;
using testing_support::ChildProcess;
using testing_support::FastSimRobot;

const std::string kTscd = std::string(TSCD_BIN_DIR) + "/tscd";

class TscdTest : public ::testing::Test {
 protected:
  testing_support::TempDir temp_{"tscd_test"};
  fs::path dir_ = temp_.path();
};

TEST_F(TscdTest, BadConfigurationExits78NamingTheKey) {
  {
    ChildProcess dut({kTscd, "--set", "memory.tau_r=abc"}, dir_ / "a.log");
    EXPECT_EQ(dut.Wait(seconds(10)), 78);
    EXPECT_NE(dut.Log().find("memory.tau_r"), std::string::npos) << dut.Log();
  }
  const fs::path ini = dir_ / "broken.ini";
  std::ofstream(ini) << "[memory]\ntau_r = 1.0\nno_such_key = 3\n";
  ChildProcess dut({kTscd, "--config", ini.string()}, dir_ / "b.log");
  EXPECT_EQ(dut.Wait(seconds(10)), 78);
  EXPECT_NE(dut.Log().find("broken.ini"), std::string::npos) << dut.Log();
  EXPECT_NE(dut.Log().find("no_such_key"), std::string::npos) << dut.Log();
}

TEST_F(TscdTest, ServesEveryChannelRejectsGarbageReloadsAndStopsCleanly) {
  TSCD_REQUIRE_PRIVATE_NETNS();
  BusListener bus;
  const fs::path ini = dir_ / "tscd.ini";
  std::ofstream(ini) << "[daemon]\nlog_level = info\n";
  ChildProcess dut(FastSimRobot(dir_ / "state", {"--config", ini.string()}), dir_ / "tscd.log");

  ASSERT_TRUE(bus.WaitFor(
      [](const BusListener& b) {
        return b.events.count("TSC_EVENT_1") && b.portions.count("TSC_MEMORY_1") &&
               b.announces.count("TSC_ANNOUNCE") &&
               b.announces.at("TSC_ANNOUNCE").back().places >= 2;
      },
      seconds(60)))
      << dut.Log();

  // A request for the memory is answered with every portion of the current version.
  size_t before = 0;
  bus.Inspect([&](const BusListener& b) { before = b.portions.at("TSC_MEMORY_1").size(); });
  memory_request_t req{};
  req.utime = 1;
  req.requester = 9;
  req.robot = 1;
  req.version = 0;
  req.num_missing = 0;
  req.hmac_size = 0;
  bus.lcm().publish("TSC_REQUEST_1", &req);
  ASSERT_TRUE(bus.WaitFor(
      [&](const BusListener& b) { return b.portions.at("TSC_MEMORY_1").size() > before; },
      seconds(10)));

  // Garbage on a channel tscd reads: counted, logged, and tscd carries on.
  const std::vector<uint8_t> junk = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11};
  bus.lcm().publish("TSC_REQUEST_1", junk.data(), static_cast<unsigned>(junk.size()));
  bus.lcm().publish("TSC_ANNOUNCE", junk.data(), 3);
  ASSERT_TRUE(bus.WaitFor(
      [](const BusListener& b) {
        return b.announces.at("TSC_ANNOUNCE").back().messages_rejected >= 2;
      },
      seconds(10)))
      << dut.Log();
  EXPECT_NE(dut.Log().find("malformed"), std::string::npos);

  // SIGHUP reloads the file: a new log level is applied, a pipeline key waits for a restart.
  std::ofstream(ini) << "[daemon]\nlog_level = debug\n[memory]\ntau_r = 1.1\n";
  dut.Signal(SIGHUP);
  std::this_thread::sleep_for(milliseconds(500));
  EXPECT_TRUE(dut.running());
  EXPECT_NE(dut.Log().find("reload: daemon.log_level = debug"), std::string::npos) << dut.Log();
  EXPECT_NE(dut.Log().find("memory.tau_r changed"), std::string::npos) << dut.Log();

  dut.Signal(SIGTERM);
  EXPECT_EQ(dut.Wait(seconds(20)), 0) << dut.Log();
  EXPECT_NE(dut.Log().find("stopped:"), std::string::npos);

  bus.Inspect([](const BusListener& b) {
    for (const auto& [channel, n] : b.undecodable) {
      // Only the test's own junk may fail to decode.
      EXPECT_TRUE(channel == "TSC_REQUEST_1" || channel == "TSC_ANNOUNCE") << channel;
      EXPECT_EQ(n, 1) << channel;
    }
    for (const place_event_t& e : b.events.at("TSC_EVENT_1")) {
      EXPECT_EQ(e.robot, 1);
      EXPECT_TRUE(e.event == "detected" || e.event == "recognized" || e.event == "learned" ||
                  e.event == "mapped" || e.event == "pruned")
          << e.event;
    }
  });
  // What it learned is in its store.
  Store store = Store::Open(dir_ / "state" / "memory.db");
  EXPECT_GE(store.Load(1, PlaceMemoryOptions{}).memory.places().size(), 2u);
}

TEST_F(TscdTest, UnwritableStateDirectoryIsReportedAndTheDaemonKeepsRunning) {
  TSCD_REQUIRE_PRIVATE_NETNS();
  BusListener bus;
  std::ofstream(dir_ / "a-file") << "not a folder\n";
  ChildProcess dut(FastSimRobot(dir_ / "a-file" / "state"), dir_ / "tscd.log");
  ASSERT_TRUE(bus.WaitFor(
      [](const BusListener& b) {
        return b.announces.count("TSC_ANNOUNCE") &&
               b.announces.at("TSC_ANNOUNCE").back().places >= 1;
      },
      seconds(60)))
      << dut.Log();
  bus.Inspect([](const BusListener& b) {
    EXPECT_NE(b.announces.at("TSC_ANNOUNCE").back().status.find("degraded: memory not persisted"),
              std::string::npos);
  });
  EXPECT_NE(dut.Log().find("memory is not persisted"), std::string::npos) << dut.Log();
  EXPECT_NE(dut.Log().find("a-file"), std::string::npos) << dut.Log();
  dut.Signal(SIGTERM);
  EXPECT_EQ(dut.Wait(seconds(20)), 0) << dut.Log();
}

// A folder camera with a truncated JPEG, then the folder disappears mid-run.
TEST_F(TscdTest, TruncatedFrameAndVanishingCameraAreLoggedAndSurvived) {
  TSCD_REQUIRE_PRIVATE_NETNS();
  const fs::path frames = dir_ / "frames";
  fs::create_directories(frames);
  const fs::path source = fs::path(TSCD_DATA_DIR) / "rtabmap-loop";
  std::vector<fs::path> images;
  for (const auto& e : fs::directory_iterator(source)) {
    if (e.path().extension() == ".jpg") images.push_back(e.path());
  }
  std::sort(images.begin(), images.end());
  ASSERT_GE(images.size(), 12u);
  for (int i = 0; i < 12; ++i) {
    fs::copy_file(images[static_cast<size_t>(i)],
                  frames / images[static_cast<size_t>(i)].filename());
  }
  const fs::path cut = frames / images[5].filename();
  fs::resize_file(cut, fs::file_size(cut) / 2);

  BusListener bus;
  ChildProcess dut(
      {kTscd, "--robot", "1", "--state-dir", (dir_ / "state").string(), "--set",
       "camera.source=folder", "--set", "camera.path=" + frames.string(), "--set", "camera.fps=20",
       "--set", "camera.loop=true", "--set", "lcm.announce_period_s=0.2"},
      dir_ / "tscd.log");
  ASSERT_TRUE(bus.WaitFor(
      [](const BusListener& b) {
        return b.announces.count("TSC_ANNOUNCE") &&
               b.announces.at("TSC_ANNOUNCE").back().frames >= 15;
      },
      seconds(60)))
      << dut.Log();
  EXPECT_NE(dut.Log().find(cut.filename().string()), std::string::npos) << dut.Log();

  fs::remove_all(frames);  // the camera goes away
  std::this_thread::sleep_for(seconds(2));
  int64_t frames_then = 0;
  bus.Inspect(
      [&](const BusListener& b) { frames_then = b.announces.at("TSC_ANNOUNCE").back().frames; });
  const size_t announces_then = [&] {
    size_t n = 0;
    bus.Inspect([&](const BusListener& b) { n = b.announces.at("TSC_ANNOUNCE").size(); });
    return n;
  }();
  std::this_thread::sleep_for(seconds(1));
  EXPECT_TRUE(dut.running()) << dut.Log();
  bus.Inspect([&](const BusListener& b) {
    EXPECT_GT(b.announces.at("TSC_ANNOUNCE").size(), announces_then);      // still announcing
    EXPECT_EQ(b.announces.at("TSC_ANNOUNCE").back().frames, frames_then);  // no new frames
  });
  EXPECT_NE(dut.Log().find("camera:"), std::string::npos) << dut.Log();
  dut.Signal(SIGTERM);
  EXPECT_EQ(dut.Wait(seconds(20)), 0) << dut.Log();
}

// systemd's notify protocol over a real AF_UNIX datagram socket, as Type=notify sees it.
TEST_F(TscdTest, TellsSystemdReadyWatchdogAndStopping) {
  TSCD_REQUIRE_PRIVATE_NETNS();
  const fs::path sock_path = dir_ / "notify.sock";
  const int sock = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  ASSERT_GE(sock, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  ASSERT_LT(sock_path.string().size(), sizeof(addr.sun_path));
  std::strcpy(addr.sun_path, sock_path.c_str());
  ASSERT_EQ(::bind(sock, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)), 0);
  timeval tv{0, 200000};
  ::setsockopt(sock, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof(tv));

  ::setenv("NOTIFY_SOCKET", sock_path.c_str(), 1);
  ::setenv("WATCHDOG_USEC", "400000", 1);  // pet every 0.2 s
  ChildProcess dut(FastSimRobot(dir_ / "state"), dir_ / "tscd.log");
  ::unsetenv("NOTIFY_SOCKET");
  ::unsetenv("WATCHDOG_USEC");

  std::string seen;
  auto collect = [&](std::chrono::milliseconds d) {
    const auto end = std::chrono::steady_clock::now() + d;
    char buf[4096];
    while (std::chrono::steady_clock::now() < end) {
      const ssize_t n = ::recv(sock, buf, sizeof buf, 0);
      if (n > 0) seen += std::string(buf, static_cast<size_t>(n)) + "\n";
    }
  };
  collect(seconds(3));
  EXPECT_NE(seen.find("READY=1"), std::string::npos) << seen;
  EXPECT_NE(seen.find("STATUS=frames"), std::string::npos) << seen;
  EXPECT_NE(seen.find("WATCHDOG=1"), std::string::npos) << seen;
  dut.Signal(SIGTERM);
  collect(seconds(2));
  EXPECT_EQ(dut.Wait(seconds(20)), 0) << dut.Log();
  EXPECT_NE(seen.find("STOPPING=1"), std::string::npos) << seen;
  ::close(sock);
}

}  // namespace
}  // namespace tsc
