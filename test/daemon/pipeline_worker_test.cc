// The pipeline worker's hand-over to the event loop (issue 22): whatever the worker is doing,
// the loop's calls (the snapshot, asking for a fresh one, the inbox) return at once with what
// the worker last handed over, and a snapshot asked for comes back through the hook. The
// worker is held inside a merge by its own hook, so no timing decides a verdict.

#include "daemon/pipeline_worker.h"

#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <future>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "store/store.h"
#include "test/support/random_memory.h"
#include "test/support/sql.h"
#include "test/support/temp_dir.h"

namespace tsc {
namespace {

namespace fs = std::filesystem;
using testing_support::Sql;

// A camera that is never read: the worker only needs its intrinsics.
class UnreadCamera : public CameraSource {
 public:
  std::optional<CameraFrame> Next() override { return std::nullopt; }
  const CameraIntrinsics& intrinsics() const override { return intrinsics_; }
  std::string name() const override { return "unread"; }

 private:
  CameraIntrinsics intrinsics_ = CameraIntrinsics::FromHorizontalFov(64, 48, 60);
};

// A one-shot signal between threads; setting it again does nothing.
class Signal {
 public:
  void Set() {
    std::call_once(once_, [this] { promise_.set_value(); });
  }
  void Wait() { future_.wait(); }

 private:
  std::once_flag once_;
  std::promise<void> promise_;
  std::shared_future<void> future_ = promise_.get_future().share();
};

// Robot 2's memory of `places` random places as the loop hands it to the worker: published as
// a snapshot, every portion received (checked by the worker).
// `corrupt`: one value of a place changed after the digest was taken (as on a faulty link
// that keeps the datagram's framing).
MemorySnapshot PeerSnapshot(int places, int32_t robot) {
  const auto memory = testing_support::MakeRandomMemory(static_cast<uint32_t>(robot), places, 32,
                                                        static_cast<unsigned>(5 + robot));
  return BuildSnapshot(memory.memory, memory.map, SnapshotHeader{robot, 4242, 3, 1}, 60000);
}

SnapshotAssembler PeerMemory(int places, bool corrupt = false, int32_t robot = 2) {
  std::vector<memory_portion_v2_t> published = AllPortions(PeerSnapshot(places, robot));
  // A body other than the structure names (its digest fails on the worker).
  if (corrupt) published.back().places.front().mean.front() += 1.0f;
  SnapshotAssembler assembler(robot);
  for (const memory_portion_v2_t& p : published) assembler.Accept(p);
  if (!assembler.complete()) throw std::runtime_error("peer snapshot incomplete");
  return assembler;
}

// The same memory again from a receiver that kept its bodies: only the structure came.
SnapshotAssembler KnownPeerMemory(int places, int32_t robot = 2) {
  const MemorySnapshot snapshot = PeerSnapshot(places, robot);
  SnapshotAssembler assembler(robot,
                              std::make_shared<const KnownDigests>(snapshot.body_digests.begin(),
                                                                   snapshot.body_digests.end()));
  for (int32_t i = 0; i < snapshot.structure_portions; ++i) assembler.Accept(snapshot.Portion(i));
  if (!assembler.complete()) throw std::runtime_error("peer structure incomplete");
  return assembler;
}

class PipelineWorkerTest : public ::testing::Test {
 protected:
  PipelineWorkerTest()
      // The peer memories are random, of 32 dimensions: no view basis takes them.
      : settings_(
            LoadSettings(std::nullopt, {"robot.id=1", "camera.source=sim", "memory.view_basis=none",
                                        "daemon.state_dir=" + temp_.path().string()})) {}

  ~PipelineWorkerTest() override {
    release_merge_.Set();
    queue_.Close();
  }

  PipelineWorkerHooks Hooks() {
    return PipelineWorkerHooks{
        .events = [](std::vector<PlaceEvent>, int64_t) {},
        .merged =
            [this](std::vector<std::pair<PlaceId, PlaceId>>) {
              inside_merge_.Set();
              release_merge_.Wait();
            },
        .merge_failed =
            [this](int32_t robot) {
              failed_robot_ = robot;
              merge_failed_.Set();
            },
        .bodies_not_kept = [this](int32_t robot) { not_kept_robot_ = robot; },
        .snapshot_ready = [this] { snapshot_ready_.Set(); },
    };
  }

  // Starts `dut` with merges never held, and has it merge robot 2's memory of `places`.
  void StartWithPeerMerged(PipelineWorker& dut, int places) {
    release_merge_.Set();
    dut.Start(join_);
    dut.Enqueue(PeerMemory(places));
    AwaitMerges(1);
  }

  // Returns once the worker has completed `merges` merges in all (merges never block here
  // once release_merge_ is set).
  void AwaitMerges(int64_t merges) const {
    while (counters_.merges_completed < merges) std::this_thread::yield();
  }

  testing_support::TempDir temp_{"pipeline_worker_test"};
  Settings settings_;
  UnreadCamera camera_;
  DaemonCounters counters_;
  FrameQueue<CameraFrame> queue_{4};
  JoinGate join_{false, {}, {}, JoinGate::Clock::now()};
  Signal inside_merge_, release_merge_, snapshot_ready_, merge_failed_;
  std::atomic<int32_t> failed_robot_{0};
  std::atomic<int32_t> not_kept_robot_{0};
};

TEST_F(PipelineWorkerTest, AnIdleWorkerAnswersARequestWithItsCurrentSnapshot) {
  PipelineWorker dut(settings_, camera_, SnapshotHeader{1, 99, 0, 0}, counters_, queue_, Hooks());
  const std::shared_ptr<const MemorySnapshot> first = dut.snapshot();
  ASSERT_NE(first, nullptr);
  EXPECT_EQ(first->version, 1);
  EXPECT_EQ(first->places, 0);
  dut.Start(join_);
  dut.RequestSnapshot();
  snapshot_ready_.Wait();
  EXPECT_EQ(dut.snapshot(), first);  // nothing changed: the same snapshot, not a rebuilt one
  queue_.Close();
  dut.Join();
}

TEST_F(PipelineWorkerTest, TheLoopGetsTheLastSnapshotWhileTheWorkerIsInsideAMerge) {
  PipelineWorker dut(settings_, camera_, SnapshotHeader{1, 99, 0, 0}, counters_, queue_, Hooks());
  const std::shared_ptr<const MemorySnapshot> before = dut.snapshot();
  dut.Start(join_);
  dut.Enqueue(PeerMemory(20));
  inside_merge_.Wait();  // the worker now waits in its merge until release_merge_

  // What the event loop does meanwhile returns: the snapshot handed over last, whole.
  EXPECT_EQ(counters_.memory_version, 2);  // the merge changed the memory …
  EXPECT_EQ(dut.snapshot(), before);       // … which no snapshot shows yet
  EXPECT_EQ(dut.snapshot()->places, 0);
  EXPECT_EQ(dut.inbox_size(), 0u);
  dut.RequestSnapshot();

  release_merge_.Set();
  snapshot_ready_.Wait();
  const std::shared_ptr<const MemorySnapshot> after = dut.snapshot();
  EXPECT_EQ(after->version, 2);
  EXPECT_EQ(after->places, 20);
  EXPECT_EQ(before->places, 0);  // the one handed over before stays as it was
  EXPECT_EQ(counters_.merges_completed, 1);
  queue_.Close();
  dut.Join();
}

TEST_F(PipelineWorkerTest, APeerMemoryFailingItsDigestIsDroppedOnTheWorkerAndFetchedAgain) {
  PipelineWorker dut(settings_, camera_, SnapshotHeader{1, 99, 0, 0}, counters_, queue_, Hooks());
  dut.Start(join_);
  dut.Enqueue(PeerMemory(20, /*corrupt=*/true));
  merge_failed_.Wait();
  EXPECT_EQ(failed_robot_, 2);  // the loop forgets it: fetched again at its next announce
  EXPECT_EQ(counters_.messages_rejected, 1);
  EXPECT_EQ(counters_.snapshots_received, 0);
  EXPECT_EQ(counters_.merges_completed, 0);
  EXPECT_EQ(counters_.memory_version, 1);
  queue_.Close();
  dut.Join();
}

// The bodies of `snapshot` at every place, as the worker serves them to the loop.
PipelineWorker::Bodies AllBodies(PipelineWorker& dut,
                                 const std::shared_ptr<const MemorySnapshot>& snapshot) {
  std::promise<PipelineWorker::Bodies> served;
  dut.RequestBodies(snapshot, PortionsBelow(snapshot->places),
                    [&](PipelineWorker::Bodies b) { served.set_value(std::move(b)); });
  return served.get_future().get();
}

// Each body as the snapshot named it (its digest): what a peer checks it by.
void ExpectNamedBodies(const MemorySnapshot& snapshot, const PipelineWorker::Bodies& bodies) {
  ASSERT_EQ(bodies.size(), static_cast<size_t>(snapshot.places));
  for (size_t i = 0; i < bodies.size(); ++i) {
    ASSERT_NE(bodies[i], nullptr) << i;
    EXPECT_EQ(BodyDigest(*bodies[i]), snapshot.body_digests[i]) << i;
  }
}

// The worker's snapshots hold no body (issue 23): it serves them from its memory, also once
// the thread has ended (the last broadcast at stop). A merge that replaced the memory withdraws
// the bodies of the snapshots built before it (none is served: a second copy of the memory
// otherwise), and the one built after serves its own.
TEST_F(PipelineWorkerTest, ASnapshotServesTheBodiesItNamedUntilAMergeReplacesTheMemory) {
  release_merge_.Set();
  PipelineWorker dut(settings_, camera_, SnapshotHeader{1, 99, 0, 0}, counters_, queue_, Hooks());
  dut.Start(join_);
  const auto current = [&](int64_t merges) {
    AwaitMerges(merges);
    dut.RequestSnapshot();
    while (dut.snapshot()->version != counters_.memory_version) std::this_thread::yield();
    return dut.snapshot();
  };
  dut.Enqueue(PeerMemory(20));
  const std::shared_ptr<const MemorySnapshot> two = current(1);
  ASSERT_EQ(two->places, 20);
  for (const auto& b : two->bodies) EXPECT_EQ(b, nullptr);
  const PipelineWorker::Bodies before = AllBodies(dut, two);
  ExpectNamedBodies(*two, before);

  dut.Enqueue(PeerMemory(12, false, 3));
  const std::shared_ptr<const MemorySnapshot> three = current(2);
  ASSERT_GT(three->places, 20);
  EXPECT_TRUE(AllBodies(dut, two).empty());
  ExpectNamedBodies(*three, AllBodies(dut, three));

  queue_.Close();
  dut.Join();
  EXPECT_TRUE(AllBodies(dut, two).empty());
  ExpectNamedBodies(*three, AllBodies(dut, three));
  // The bodies of the peer's last memory are in the store for its next exchange (issue 23).
  EXPECT_EQ(not_kept_robot_, 0);
  const auto kept = Store::Open(temp_.path() / "memory.db").LoadPeerBodyDigests();
  ASSERT_EQ(kept.size(), 2u);
  EXPECT_EQ(kept.at(2).size(), 20u);
  EXPECT_EQ(kept.at(3).size(), 12u);
}

// A teammate's memory merged before changes nothing when it comes again (in a settled team,
// most exchanges): the store records the peer's version and leaves the stored places as they
// are. It rewrote every one of them (1.5 s at 10⁴ places, tscd_footprint --peer-merged 1).
// The database itself counts the writes to the places: triggers added by the test.
TEST_F(PipelineWorkerTest, AMergeThatChangesNothingLeavesTheStoredPlacesAsTheyAre) {
  PipelineWorker dut(settings_, camera_, SnapshotHeader{1, 99, 0, 0}, counters_, queue_, Hooks());
  StartWithPeerMerged(dut, 20);
  const fs::path db = temp_.path() / "memory.db";
  ASSERT_EQ(Sql(db, "SELECT count(*) FROM learned_places"), 20);
  Sql(db, "CREATE TABLE probe(writes INTEGER)");
  Sql(db, "INSERT INTO probe VALUES(0)");
  for (const char* change : {"INSERT", "DELETE"}) {
    Sql(db, std::string("CREATE TRIGGER probe_") + change + " AFTER " + change +
                " ON learned_places BEGIN UPDATE probe SET writes = writes + 1; END");
  }
  ASSERT_FALSE(::testing::Test::HasFailure());  // the probe is in place
  const int64_t version = counters_.memory_version;
  dut.Enqueue(PeerMemory(20));  // the same memory again
  AwaitMerges(2);
  EXPECT_EQ(counters_.memory_version, version);  // the merge changed nothing
  queue_.Close();
  dut.Join();
  EXPECT_EQ(Sql(db, "SELECT writes FROM probe"), 0);
  EXPECT_EQ(Sql(db, "SELECT count(*) FROM learned_places"), 20);
  EXPECT_EQ(Sql(db, "SELECT last_merged_version FROM peers WHERE robot = 2"), 3);
  for (const char* drop :
       {"DROP TRIGGER probe_INSERT", "DROP TRIGGER probe_DELETE", "DROP TABLE probe"}) {
    Sql(db, drop);
  }
  ASSERT_FALSE(::testing::Test::HasFailure());
  EXPECT_EQ(Store::Open(db).Load(1, settings_.pipeline.memory).memory.places().size(), 20u);
}

// Issue 23: a teammate's memory that names only bodies kept from its last exchange, and that the
// merge leaves as ours is, is decided by the names the worker kept of those bodies: none is read
// from the store, where the test damaged every one (a read refuses them). Once a merge needs
// them, they are read, refused, and the memory is fetched again whole.
TEST_F(PipelineWorkerTest, ARepeatExchangeThatChangesNothingReadsNoKeptBody) {
  PipelineWorker dut(settings_, camera_, SnapshotHeader{1, 99, 0, 0}, counters_, queue_, Hooks());
  StartWithPeerMerged(dut, 20);
  const fs::path db = temp_.path() / "memory.db";
  ASSERT_EQ(Sql(db, "SELECT count(*) FROM peer_bodies WHERE robot = 2"), 20);
  Sql(db, "UPDATE peer_bodies SET body = X'00'");
  ASSERT_FALSE(::testing::Test::HasFailure());

  dut.Enqueue(KnownPeerMemory(20));
  // Merged, or refused (what reading a damaged body gives).
  while (counters_.merges_completed < 2 && counters_.messages_rejected == 0) {
    std::this_thread::yield();
  }
  EXPECT_EQ(counters_.merges_completed, 2);
  EXPECT_EQ(counters_.messages_rejected, 0);
  EXPECT_EQ(counters_.merges_failed, 0);
  EXPECT_EQ(not_kept_robot_, 0);

  // Robot 3's places, which robot 2 never held: robot 2's next memory is merged in full.
  dut.Enqueue(PeerMemory(12, false, 3));
  AwaitMerges(3);
  dut.Enqueue(KnownPeerMemory(20));
  merge_failed_.Wait();
  EXPECT_EQ(failed_robot_, 2);
  EXPECT_EQ(counters_.merges_failed, 1);
  queue_.Close();
  dut.Join();
  EXPECT_EQ(counters_.merges_completed, 3);
  EXPECT_EQ(Store::Open(db).Load(1, settings_.pipeline.memory).memory.places().size(), 32u);
}

// A kept body damaged in the store fails the exchange that reads it, which then fetches the
// memory whole; that whole memory must leave the store sound again, or every later exchange that
// reads the body fails in turn.
TEST_F(PipelineWorkerTest, AWholeFetchAfterADamagedKeptBodyKeepsItAfresh) {
  PipelineWorker dut(settings_, camera_, SnapshotHeader{1, 99, 0, 0}, counters_, queue_, Hooks());
  StartWithPeerMerged(dut, 20);
  dut.Enqueue(PeerMemory(12, false, 3));  // places robot 2 never held: its next merge reads
  AwaitMerges(2);
  const fs::path db = temp_.path() / "memory.db";
  const std::string sound = "SELECT count(*) FROM peer_bodies WHERE robot = 2 AND length(body) > 1";
  ASSERT_EQ(Sql(db, sound), 20);
  Sql(db,
      "UPDATE peer_bodies SET body = X'00' WHERE rowid = (SELECT min(rowid) FROM peer_bodies "
      "WHERE robot = 2)");
  ASSERT_EQ(Sql(db, sound), 19);

  dut.Enqueue(KnownPeerMemory(20));
  merge_failed_.Wait();
  EXPECT_EQ(failed_robot_, 2);
  dut.Enqueue(PeerMemory(20));  // fetched again whole
  AwaitMerges(3);
  queue_.Close();
  dut.Join();
  EXPECT_EQ(Sql(db, sound), 20);
  EXPECT_EQ(Sql(db, "SELECT count(*) FROM peer_bodies WHERE robot = 2"), 20);
}

}  // namespace
}  // namespace tsc
