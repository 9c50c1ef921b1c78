// Storage faults under a running tscd (a real process on real udpm:// LCM inside the test's
// private network namespace): its state directory is a small tmpfs the test mounts in a private
// mount namespace of its own, and fills mid-run. tscd must say so (log naming the file and the
// system's reason, `degraded` in its announces), keep recognising and learning from memory,
// retry, and once space returns commit everything it kept: nothing it announced is lost.

#include <gtest/gtest.h>
#include <sched.h>
#include <sys/mount.h>
#include <sys/wait.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <thread>

#include "store/store.h"
#include "test/daemon/bus_listener.h"
#include "test/support/child_process.h"
#include "test/support/memory_compare.h"
#include "test/support/temp_dir.h"

namespace tsc {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;
using std::chrono::seconds;
using testing_support::BusListener;
using testing_support::ChildProcess;

const std::string kTscd = std::string(TSCD_BIN_DIR) + "/tscd";

using Key = std::pair<int, int>;  // (robot, local)

/// What tscd announced: its learned places and map edges, and the events by kind.
struct Announced {
  std::set<Key> places;
  std::set<std::pair<Key, Key>> edges;
  std::map<std::string, int> kinds;
};

Announced Collect(BusListener& bus, size_t from = 0) {
  Announced out;
  bus.Inspect([&](const BusListener& b) {
    if (!b.events.count("TSC_EVENT_1")) return;
    const auto& ev = b.events.at("TSC_EVENT_1");
    for (size_t i = from; i < ev.size(); ++i) {
      const place_event_t& e = ev[i];
      ++out.kinds[e.event];
      if (e.event == "learned") out.places.insert({e.place.robot, e.place.local});
      if (e.event == "mapped" && e.has_from) {
        const Key a{e.from.robot, e.from.local}, c{e.place.robot, e.place.local};
        if (a != c) out.edges.insert({std::min(a, c), std::max(a, c)});
      }
    }
  });
  return out;
}

size_t EventCount(BusListener& bus) {
  size_t n = 0;
  bus.Inspect([&](const BusListener& b) {
    if (b.events.count("TSC_EVENT_1")) n = b.events.at("TSC_EVENT_1").size();
  });
  return n;
}

std::optional<announce_t> LastAnnounce(BusListener& bus) {
  std::optional<announce_t> last;
  bus.Inspect([&](const BusListener& b) {
    if (!b.announces.count("TSC_ANNOUNCE")) return;
    for (const announce_t& a : b.announces.at("TSC_ANNOUNCE")) {
      if (a.robot == 1) last = a;
    }
  });
  return last;
}

/// Moves the test process into a mount namespace of its own, so its mounts are seen by it and
/// its children only and vanish with them. Empty, or why not.
std::string PrivateMountNamespace() {
  if (::unshare(CLONE_NEWNS) != 0) return std::string("unshare(CLONE_NEWNS): ") + strerror(errno);
  if (::mount(nullptr, "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0) {
    return std::string("mount --make-rprivate /: ") + strerror(errno);
  }
  return "";
}

/// A tmpfs of `bytes` at `at`, in a private mount namespace. Empty, or why not.
std::string MountPrivateTmpfs(const fs::path& at, size_t bytes) {
  if (std::string why = PrivateMountNamespace(); !why.empty()) return why;
  fs::create_directories(at);
  const std::string options = "size=" + std::to_string(bytes) + ",mode=0700";
  if (::mount("tscd-test", at.c_str(), "tmpfs", 0, options.c_str()) != 0) {
    return std::string("mount -t tmpfs: ") + strerror(errno);
  }
  return "";
}

/// Runs a shell command line; its exit status and output.
std::pair<int, std::string> Shell(const std::string& command) {
  std::string out;
  std::FILE* p = ::popen((command + " 2>&1").c_str(), "r");
  if (p == nullptr) return {-1, "popen failed"};
  char buf[512];
  while (std::fgets(buf, sizeof buf, p) != nullptr) out += buf;
  const int status = ::pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

/// The ext4 image at `image` mounted at `at` through a loop device, remounted read-only by the
/// kernel on the first file system error (as a root file system usually is). Empty, or why not.
std::string MountExt4(const fs::path& image, const fs::path& at) {
  const auto [rc, out] =
      Shell("mount -o loop,errors=remount-ro " + image.string() + " " + at.string());
  return rc == 0 ? "" : "mount -o loop " + image.string() + ": " + out;
}

/// Writes zeros to `path` until the file system is full; the bytes written.
size_t FillUp(const fs::path& path) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) return 0;
  std::vector<char> block(4096, 0);
  size_t written = 0;
  while (std::fwrite(block.data(), 1, block.size(), f) == block.size()) {
    written += block.size();
    if (std::fflush(f) != 0) break;
  }
  std::fclose(f);
  return written;
}

// A real image sequence that comes back to where it started, looped: after the first lap the
// robot recognises its places again and again.
std::vector<std::string> LoopingRobot(const fs::path& state, std::vector<std::string> extra = {}) {
  std::vector<std::string> argv = {
      kTscd,
      "--robot",
      "1",
      "--state-dir",
      state.string(),
      "--set",
      "camera.source=folder",
      "--set",
      "camera.path=" + (fs::path(TSCD_DATA_DIR) / "rtabmap-loop").string(),
      "--set",
      "camera.loop=true",
      "--set",
      "camera.fps=0",
      "--set",
      "lcm.announce_period_s=0.2",
      "--set",
      "detection.tau_p=3"};
  argv.insert(argv.end(), extra.begin(), extra.end());
  return argv;
}

size_t Occurrences(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

/// Every place and map edge announced so far is in the database `db`, which holds the record
/// of at least `frames` base points.
void ExpectAnnouncedAreStored(BusListener& bus, const fs::path& db, int64_t frames) {
  const Announced all = Collect(bus);
  const auto stored = testing_support::LoadKnowledge(db, 1);
  std::set<Key> places;
  for (const LearnedPlace& p : stored.state.memory.places()) {
    places.insert({static_cast<int>(p.id.robot), static_cast<int>(p.id.local)});
  }
  for (const Key& p : all.places) {
    EXPECT_TRUE(places.count(p)) << "announced place " << p.first << ":" << p.second << " lost";
  }
  for (const auto& [a, c] : all.edges) {
    EXPECT_NE(stored.state.map.Find(
                  PlaceId{static_cast<uint32_t>(a.first), static_cast<uint32_t>(a.second)},
                  PlaceId{static_cast<uint32_t>(c.first), static_cast<uint32_t>(c.second)}),
              nullptr)
        << "announced edge lost";
  }
  EXPECT_GE(stored.state.pipeline.next_base, frames);  // every base point's record
}

/// Waits until the pipeline, degraded, has published a full recognition since event `from`.
bool RecognisesWhileDegraded(BusListener& bus, size_t from) {
  return bus.WaitFor(
      [&](const BusListener& b) {
        const auto& ev = b.events.at("TSC_EVENT_1");
        for (size_t i = from; i < ev.size(); ++i) {
          if (ev[i].event == "recognized" && !ev[i].partial) return true;
        }
        return false;
      },
      seconds(60));
}

/// Waits until robot 1's last announce says degraded (or not).
bool WaitStatus(BusListener& bus, bool degraded, seconds timeout) {
  return bus.WaitFor(
      [&](const BusListener& b) {
        if (!b.announces.count("TSC_ANNOUNCE")) return false;
        const auto& all = b.announces.at("TSC_ANNOUNCE");
        for (auto it = all.rbegin(); it != all.rend(); ++it) {
          if (it->robot != 1) continue;
          return (it->status.find("degraded: memory not persisted") != std::string::npos) ==
                 degraded;
        }
        return false;
      },
      timeout);
}

class StorageFaultTest : public ::testing::Test {
 protected:
  testing_support::TempDir temp_{"storage_fault_test"};
  fs::path dir_ = temp_.path();
};

TEST_F(StorageFaultTest, FullDiskIsReportedLearningGoesOnAndNothingIsLostOnceSpaceReturns) {
  TSCD_REQUIRE_PRIVATE_NETNS();
  const fs::path state = dir_ / "state";
  // Room enough that the space freed later holds what tscd kept meanwhile: under ASan the
  // frame queue drops most frames, the robot learns instead of recognising, and a 24 MiB
  // tmpfs once stayed degraded 28 s, kept 1794 results and was full again 22 ms after
  // committing them, before an announce could say it was not degraded.
  if (const std::string why = MountPrivateTmpfs(state, 96u << 20); !why.empty()) {
    GTEST_SKIP() << "cannot mount a private tmpfs for the state directory (" << why
                 << "); run as root or with CAP_SYS_ADMIN";
  }
  BusListener bus("TSC_ANNOUNCE|TSC_EVENT_.*");
  ChildProcess dut(LoopingRobot(state), dir_ / "tscd.log");
  ASSERT_TRUE(bus.WaitFor(
      [](const BusListener& b) {
        if (!b.announces.count("TSC_ANNOUNCE")) return false;
        const announce_t& a = b.announces.at("TSC_ANNOUNCE").back();
        return a.robot == 1 && a.places >= 2;
      },
      seconds(120)))
      << dut.Log();

  // The disk fills up mid-run.
  const size_t filled = FillUp(state / "filler");
  ASSERT_GT(filled, 0u);
  ASSERT_TRUE(WaitStatus(bus, true, seconds(60))) << "tscd did not notice the full disk\n"
                                                  << dut.Log();
  const auto degraded_at = Clock::now();
  const size_t events_at_fault = EventCount(bus);
  const int64_t frames_at_fault = LastAnnounce(bus)->frames;
  const std::string log = dut.Log();
  EXPECT_NE(log.find((state / "memory.db").string()), std::string::npos) << log;
  EXPECT_TRUE(log.find("database or disk is full") != std::string::npos ||
              log.find("No space left on device") != std::string::npos)
      << log;

  // Degraded, the pipeline goes on from memory: frames, detections, recognitions.
  ASSERT_TRUE(RecognisesWhileDegraded(bus, events_at_fault))
      << "no recognition while the disk was full\n"
      << dut.Log();
  std::this_thread::sleep_for(seconds(1));
  const auto during = Collect(bus, events_at_fault);
  const announce_t still = *LastAnnounce(bus);
  EXPECT_NE(still.status.find("degraded"), std::string::npos) << still.status;
  EXPECT_GT(still.frames, frames_at_fault);
  EXPECT_TRUE(dut.running());

  // Space returns: tscd commits what it kept, without a restart.
  fs::remove(state / "filler");
  ASSERT_TRUE(WaitStatus(bus, false, seconds(30))) << dut.Log();
  const double degraded_s = std::chrono::duration<double>(Clock::now() - degraded_at).count();
  EXPECT_NE(dut.Log().find("writable again"), std::string::npos) << dut.Log();
  EXPECT_GE(Occurrences(dut.Log(), "commit failed"), 2u) << "no retry\n" << dut.Log();
  std::this_thread::sleep_for(milliseconds(500));
  dut.Signal(SIGKILL);  // no final commit: what is stored was committed while running
  ASSERT_EQ(dut.Wait(seconds(10)), 128 + SIGKILL);
  std::this_thread::sleep_for(milliseconds(100));
  ExpectAnnouncedAreStored(bus, state / "memory.db", still.frames);
  const Announced all = Collect(bus);
  std::printf(
      "[ figures  ] full disk: %zu KiB filler; degraded %.1f s with %d detected, %d recognized, "
      "%d learned, %d mapped events; %zu places and %zu edges announced in all, all stored\n",
      filled / 1024, degraded_s, during.kinds.count("detected") ? during.kinds.at("detected") : 0,
      during.kinds.count("recognized") ? during.kinds.at("recognized") : 0,
      during.kinds.count("learned") ? during.kinds.at("learned") : 0,
      during.kinds.count("mapped") ? during.kinds.at("mapped") : 0, all.places.size(),
      all.edges.size());
  ::umount2(state.c_str(), MNT_DETACH);
}

// SIGTERM while the disk is full: tscd tries the store for daemon.stop_store_wait_s, spills
// what the database lacks into $RUNTIME_DIRECTORY (the full disk takes no spill), says NOT
// SAVED and exits 1. Once space returns the next start takes the spill in: every place and
// edge announced before the stop is in the database, with the record of every base point.
TEST_F(StorageFaultTest, StopOnAFullDiskSpillsAndTheNextStartTakesItIn) {
  TSCD_REQUIRE_PRIVATE_NETNS();
  const fs::path state = dir_ / "state";
  const fs::path run = dir_ / "run";
  fs::create_directories(run);
  if (const std::string why = MountPrivateTmpfs(state, 96u << 20); !why.empty()) {
    GTEST_SKIP() << "cannot mount a private tmpfs for the state directory (" << why
                 << "); run as root or with CAP_SYS_ADMIN";
  }
  ASSERT_EQ(::setenv("RUNTIME_DIRECTORY", run.c_str(), 1), 0);
  struct Unset {
    ~Unset() { ::unsetenv("RUNTIME_DIRECTORY"); }
  } unset;
  const std::vector<std::string> extra = {"--set", "daemon.stop_store_wait_s=1"};
  BusListener bus("TSC_ANNOUNCE|TSC_EVENT_.*");
  int64_t frames = 0;
  {
    ChildProcess dut(LoopingRobot(state, extra), dir_ / "first.log");
    ASSERT_TRUE(bus.WaitFor(
        [](const BusListener& b) {
          if (!b.announces.count("TSC_ANNOUNCE")) return false;
          const announce_t& a = b.announces.at("TSC_ANNOUNCE").back();
          return a.robot == 1 && a.places >= 2;
        },
        seconds(120)))
        << dut.Log();
    ASSERT_GT(FillUp(state / "filler"), 0u);
    ASSERT_TRUE(WaitStatus(bus, true, seconds(60))) << dut.Log();
    const size_t events_at_fault = EventCount(bus);
    ASSERT_TRUE(RecognisesWhileDegraded(bus, events_at_fault)) << dut.Log();
    dut.Signal(SIGTERM);
    EXPECT_EQ(dut.Wait(seconds(30)), 1) << dut.Log();
    const std::string log = dut.Log();
    EXPECT_NE(log.find("NOT SAVED"), std::string::npos) << log;
    EXPECT_NE(log.find(run.string()), std::string::npos) << log;
    std::this_thread::sleep_for(milliseconds(300));
    frames = LastAnnounce(bus)->frames;
  }
  size_t spills = 0, beside = 0;
  for (const auto& e : fs::directory_iterator(run)) {
    spills += e.path().filename().string().starts_with("memory.db.spill.");
  }
  for (const auto& e : fs::directory_iterator(state)) {
    beside += e.path().filename().string().starts_with("memory.db.spill.");
  }
  EXPECT_EQ(spills, 1u);
  EXPECT_EQ(beside, 0u) << "a partial spill left on the full disk";

  fs::remove(state / "filler");  // space returns; the next start takes the spill in
  {
    ChildProcess dut(LoopingRobot(state, extra), dir_ / "second.log");
    const auto deadline = Clock::now() + seconds(60);
    while (dut.Log().find("ready:") == std::string::npos && Clock::now() < deadline) {
      std::this_thread::sleep_for(milliseconds(50));
    }
    EXPECT_NE(dut.Log().find("took in"), std::string::npos) << dut.Log();
    dut.Signal(SIGKILL);  // what is stored now was stored at start
    ASSERT_EQ(dut.Wait(seconds(10)), 128 + SIGKILL);
  }
  EXPECT_TRUE(fs::is_empty(run));
  ExpectAnnouncedAreStored(bus, state / "memory.db", frames);
  ::umount2(state.c_str(), MNT_DETACH);
}

// The file system under the state directory fails mid-run and the kernel remounts it read-only
// (ext4, errors=remount-ro, on a loop device; the failure injected through ext4's own
// trigger_fs_error). tscd must say so, keep recognising, close the database so the file system
// can be repaired, and once it is mounted again take it back and commit what it kept.
TEST_F(StorageFaultTest, ReadOnlyFileSystemIsReportedAndTheStoreReturnsOnceRepaired) {
  TSCD_REQUIRE_PRIVATE_NETNS();
  const fs::path state = dir_ / "state";
  const fs::path image = dir_ / "state.ext4";
  fs::create_directories(state);
  if (const std::string why = PrivateMountNamespace(); !why.empty()) {
    GTEST_SKIP() << "no private mount namespace (" << why << "); run as root";
  }
  fs::resize_file((std::ofstream(image), image), 64u << 20);
  if (const auto [rc, out] = Shell("mkfs.ext4 -q -F -O ^has_journal " + image.string()); rc != 0) {
    GTEST_SKIP() << "cannot make an ext4 file system (e2fsprogs): " << out;
  }
  if (const std::string why = MountExt4(image, state); !why.empty()) {
    GTEST_SKIP() << "cannot mount a loop device (" << why << ")";
  }
  std::string source = Shell("findmnt -n -o SOURCE " + state.string()).second;
  source = source.substr(0, source.find('\n'));  // /dev/loopN
  const std::string device = fs::path(source).filename().string();
  const fs::path trigger = fs::path("/sys/fs/ext4") / device / "trigger_fs_error";
  if (!fs::exists(trigger)) {
    ::umount2(state.c_str(), MNT_DETACH);
    GTEST_SKIP() << "no " << trigger << " to make the file system fail";
  }

  BusListener bus("TSC_ANNOUNCE|TSC_EVENT_.*");
  // Few results kept while degraded, so the oldest base point records are dropped: the
  // learned memory must still come through whole.
  ChildProcess dut(LoopingRobot(state, {"--set", "daemon.max_pending_results=40"}),
                   dir_ / "tscd.log");
  ASSERT_TRUE(bus.WaitFor(
      [](const BusListener& b) {
        if (!b.announces.count("TSC_ANNOUNCE")) return false;
        const announce_t& a = b.announces.at("TSC_ANNOUNCE").back();
        return a.robot == 1 && a.places >= 2;
      },
      seconds(120)))
      << dut.Log();

  std::ofstream(trigger) << "1\n";  // ext4_error(): the kernel makes the file system read-only
  ASSERT_TRUE(WaitStatus(bus, true, seconds(60))) << "tscd did not notice\n" << dut.Log();
  const auto degraded_at = Clock::now();
  const size_t events_at_fault = EventCount(bus);
  ASSERT_TRUE(RecognisesWhileDegraded(bus, events_at_fault))
      << "no recognition while the file system was read-only\n"
      << dut.Log();
  const std::string log = dut.Log();
  EXPECT_NE(log.find((state / "memory.db").string()), std::string::npos) << log;
  EXPECT_TRUE(log.find("Read-only file system") != std::string::npos ||
              log.find("Input/output error") != std::string::npos)
      << log;
  EXPECT_NE(log.find("closing"), std::string::npos) << log;
  // tscd tries the store again while the file system stays read-only.
  std::this_thread::sleep_for(seconds(2));
  EXPECT_NE(dut.Log().find("store still unavailable"), std::string::npos) << dut.Log();
  EXPECT_NE(dut.Log().find("are dropped"), std::string::npos) << dut.Log();

  // Repair: unmount (tscd has closed the database; it opens it again only for a moment each
  // second), check the file system, mount it again.
  bool unmounted = false;
  for (int attempt = 0; attempt < 200 && !unmounted; ++attempt) {
    unmounted = ::umount2(state.c_str(), 0) == 0;
    if (!unmounted) std::this_thread::sleep_for(milliseconds(50));
  }
  ASSERT_TRUE(unmounted) << "tscd keeps the broken file system busy: " << strerror(errno);
  const auto [fsck_rc, fsck_out] = Shell("e2fsck -fy " + image.string());
  EXPECT_LE(fsck_rc, 1) << fsck_out;  // 1: errors corrected
  ASSERT_EQ(MountExt4(image, state), "");
  ASSERT_TRUE(WaitStatus(bus, false, seconds(30))) << dut.Log();
  const double degraded_s = std::chrono::duration<double>(Clock::now() - degraded_at).count();
  EXPECT_NE(dut.Log().find("writable again"), std::string::npos) << dut.Log();
  std::this_thread::sleep_for(milliseconds(500));
  const int64_t frames = LastAnnounce(bus)->frames;
  dut.Signal(SIGKILL);  // no final commit: what is stored was committed while running
  ASSERT_EQ(dut.Wait(seconds(10)), 128 + SIGKILL);
  std::this_thread::sleep_for(milliseconds(100));
  ExpectAnnouncedAreStored(bus, state / "memory.db", frames);
  const Announced during = Collect(bus, events_at_fault);
  std::printf(
      "[ figures  ] read-only file system: degraded %.1f s (until repaired and mounted again) "
      "with %d recognized events; e2fsck exit %d; %zu places announced in all, all stored\n",
      degraded_s, during.kinds.count("recognized") ? during.kinds.at("recognized") : 0, fsck_rc,
      Collect(bus).places.size());
  ::umount2(state.c_str(), MNT_DETACH);
}

}  // namespace
}  // namespace tsc
