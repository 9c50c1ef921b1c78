#include "store/store.h"

#include <gtest/gtest.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <iterator>
#include <optional>
#include <random>
#include <set>
#include <string>
#include <unordered_set>
#include <vector>

#include "core/memory/descriptor_space_mismatch.h"
#include "core/memory/unchanged_places.h"
#include "core/merge/consolidate.h"
#include "core/merge/merge_maps.h"
#include "test/support/descriptor_stream.h"
#include "test/support/memory_compare.h"
#include "test/support/sql.h"
#include "test/support/temp_dir.h"

namespace tsc {
namespace {

namespace fs = std::filesystem;
using testing_support::Sql;
using testing_support::SqlText;

constexpr int kDim = 7 * 100;
constexpr uint32_t kRobot = 3;

PipelineOptions Options() {
  PipelineOptions o;
  o.robot = kRobot;
  o.detector = DetectorOptions{2, 2, 3};
  o.memory.svm_vote = true;       // the discriminants table is filled and checked below
  o.memory.view_basis = nullptr;  // the descriptors here are synthetic, of kDim dimensions
  return o;
}

CameraIntrinsics Camera() { return CameraIntrinsics::FromHorizontalFov(64, 48, 60); }

/// The synthetic stream of these tests, in their dimension.
class Stream : public testing_support::DescriptorStream {
 public:
  explicit Stream(unsigned seed) : DescriptorStream(seed, kDim) {}
};

/// Counts of what a run committed.
struct Committed {
  int frames = 0;
  int transitions = 0;
  int learned = 0;
  int recognized = 0;
};

void Feed(Pipeline& pipeline, Store& store, const std::vector<Descriptor>& frames,
          Committed& committed) {
  for (const Descriptor& d : frames) {
    const FrameResult r = pipeline.ProcessDescriptor(d, IntensityStats{0.5, 0.05});
    store.Commit(r, pipeline);
    ++committed.frames;
    committed.transitions += static_cast<int>(r.transitions.size());
    for (const PlaceEvent& e : r.events) {
      committed.learned += e.kind == EventKind::kLearned;
      committed.recognized += e.kind == EventKind::kRecognized && !e.partial;
    }
  }
}

void Finish(Pipeline& pipeline, Store& store, Committed& committed) {
  const FrameResult r = pipeline.Finish();
  store.Commit(r, pipeline);
  committed.transitions += static_cast<int>(r.transitions.size());
  for (const PlaceEvent& e : r.events) {
    committed.learned += e.kind == EventKind::kLearned;
    committed.recognized += e.kind == EventKind::kRecognized && !e.partial;
  }
}

void ExpectSameMemory(const PlaceMemory& want, const PlaceMemory& got) {
  EXPECT_EQ(got.robot(), want.robot());
  EXPECT_EQ(got.next_local_id(), want.next_local_id());
  ASSERT_EQ(got.places().size(), want.places().size());
  for (size_t i = 0; i < want.places().size(); ++i) {
    SCOPED_TRACE("place " + std::to_string(i));
    const LearnedPlace& w = want.places()[i];
    const LearnedPlace& g = got.places()[i];
    EXPECT_EQ(g.id, w.id);
    EXPECT_EQ(g.mean, w.mean);
    EXPECT_EQ(g.member_count, w.member_count);
    EXPECT_EQ(g.samples, w.samples);
    EXPECT_EQ(g.detected, w.detected);
    EXPECT_EQ(g.members, w.members);
    EXPECT_EQ(g.sources, w.sources);
  }
  EXPECT_EQ(got.slink().pi(), want.slink().pi());
  EXPECT_EQ(got.slink().lambda(), want.slink().lambda());
  EXPECT_EQ(got.root(), want.root());
  EXPECT_EQ(got.leaf_order(), want.leaf_order());
  ASSERT_EQ(got.nodes().size(), want.nodes().size());
  for (size_t i = 0; i < want.nodes().size(); ++i) {
    SCOPED_TRACE("node " + std::to_string(i));
    const MemoryNode& w = want.nodes()[i];
    const MemoryNode& g = got.nodes()[i];
    EXPECT_EQ(g.parent, w.parent);
    EXPECT_EQ(g.children, w.children);
    EXPECT_EQ(g.place, w.place);
    EXPECT_EQ(g.height, w.height);
    EXPECT_EQ(g.first_leaf, w.first_leaf);
    EXPECT_EQ(g.end_leaf, w.end_leaf);
    EXPECT_EQ(g.set_key, w.set_key);
    const OneClassDiscriminant& wd = want.discriminants()[i];
    const OneClassDiscriminant& gd = got.discriminants()[i];
    EXPECT_EQ(gd.trained(), wd.trained());
    EXPECT_EQ(gd.support(), wd.support());
    EXPECT_EQ(gd.coef(), wd.coef());
    EXPECT_EQ(gd.rho(), wd.rho());
    EXPECT_EQ(gd.gamma(), wd.gamma());
  }
}

void ExpectSameMap(const TopologicalMap& want, const TopologicalMap& got) {
  EXPECT_EQ(got.places(), want.places());
  ASSERT_EQ(got.edges().size(), want.edges().size());
  for (const auto& [key, w] : want.edges()) {
    SCOPED_TRACE("edge " + w.a.ToString() + "-" + w.b.ToString());
    const MapEdge* g = got.Find(key.first, key.second);
    ASSERT_NE(g, nullptr);
    EXPECT_EQ(g->a, w.a);
    EXPECT_EQ(g->b, w.b);
    EXPECT_EQ(g->traversals, w.traversals);
    EXPECT_EQ(g->transitions, w.transitions);
  }
}

void ExpectSameState(const PipelineState& want, const PipelineState& got) {
  EXPECT_EQ(got.next_base, want.next_base);
  EXPECT_EQ(got.next_detected, want.next_detected);
  EXPECT_EQ(got.previous_place, want.previous_place);
  EXPECT_EQ(got.copies, want.copies);
}

class StoreTest : public ::testing::Test {
 protected:
  StoreTest() : temp_("tscd_store_test"), dir_(temp_.path()), path_(dir_ / "tscd.db") {}

  /// A pipeline continuing from what `store` holds.
  static Pipeline Continue(Store& store) {
    StoredState s = store.Load(kRobot, Options().memory);
    return Pipeline(Camera(), Options(), std::move(s.memory), std::move(s.map), s.pipeline);
  }

  /// A pipeline that saw `rooms` synthetic rooms in the order of `visits` (12 base points a
  /// visit), every result committed to `store`.
  static Pipeline LearnedRooms(Store& store, int rooms, std::initializer_list<int> visits) {
    Stream stream(5);
    for (int c = 0; c < rooms; ++c) stream.AddCluster();
    Pipeline pipeline = Continue(store);
    Committed committed;
    for (int c : visits) Feed(pipeline, store, stream.Visit(c, 12), committed);
    Finish(pipeline, store, committed);
    return pipeline;
  }

  /// Writes a store at path_ whose robot went through three rooms and the first again (rooms
  /// of `seed`), and returns the memory it learned.
  PlaceMemory WriteThreeRoomsAndARevisit(uint32_t seed) {
    Stream stream(seed);
    for (int c = 0; c < 3; ++c) stream.AddCluster();
    Committed committed;
    Store dut = Store::Open(path_);
    Pipeline pipeline = Continue(dut);
    for (int c : {0, 1, 2, 0}) Feed(pipeline, dut, stream.Visit(c, 14), committed);
    Finish(pipeline, dut, committed);
    return pipeline.memory();
  }

  testing_support::TempDir temp_;
  fs::path dir_;
  fs::path path_;
};

TEST_F(StoreTest, LoadReturnsWhatWasCommitted) {
  Stream stream(17);
  for (int c = 0; c < 4; ++c) stream.AddCluster();
  Committed committed;
  std::optional<PlaceMemory> memory;
  std::optional<TopologicalMap> map;
  PipelineState state;
  {
    Store dut = Store::Open(path_);
    Pipeline pipeline = Continue(dut);
    for (int c : {0, 1, 2, 0, 3, 1}) Feed(pipeline, dut, stream.Visit(c, 14), committed);
    Finish(pipeline, dut, committed);
    memory = pipeline.memory();
    map = pipeline.map();
    state = pipeline.state();
  }
  // The stream exercised learning, recognition (Update) and mapping.
  EXPECT_GE(committed.learned, 3);
  EXPECT_GE(committed.recognized, 1);
  ASSERT_GE(memory->places().size(), 3u);
  EXPECT_GE(map->edges().size(), 2u);

  Store dut = Store::Open(path_);
  const StoredState loaded = dut.Load(kRobot, Options().memory);
  ExpectSameMemory(*memory, loaded.memory);
  ExpectSameMap(*map, loaded.map);
  ExpectSameState(state, loaded.pipeline);

  // The knowledge base of appendix D.2 beyond what the memory needs.
  EXPECT_EQ(Sql(path_, "SELECT COUNT(*) FROM base_points"), committed.frames);
  EXPECT_EQ(Sql(path_, "SELECT COUNT(*) FROM detected_places"),
            committed.learned + committed.recognized);
  EXPECT_EQ(Sql(path_, "SELECT COUNT(*) FROM detected_places WHERE place_robot IS NULL"), 0);
  EXPECT_EQ(Sql(path_, "SELECT COUNT(*) FROM transition_regions"), committed.transitions);
  EXPECT_EQ(Sql(path_, "SELECT COUNT(*) FROM transition_regions WHERE to_robot IS NULL"), 0);
  EXPECT_EQ(Sql(path_, "SELECT COUNT(*) FROM memory_nodes"),
            static_cast<int64_t>(memory->nodes().size()));
  EXPECT_EQ(Sql(path_, "SELECT COUNT(*) FROM map_places"),
            static_cast<int64_t>(map->places().size()));
  // One discriminant per distinct trained node set, none left over from older trees.
  std::set<uint64_t> keys;
  for (size_t i = 0; i < memory->nodes().size(); ++i) {
    if (memory->discriminants()[i].trained()) keys.insert(memory->nodes()[i].set_key);
  }
  EXPECT_EQ(Sql(path_, "SELECT COUNT(*) FROM discriminants"), static_cast<int64_t>(keys.size()));
  EXPECT_EQ(SqlText(path_, "PRAGMA journal_mode"), "wal");
}

// Edges to places recognised on a pruned passage (mapped events of no detected place) are
// committed and load back like every other edge.
TEST_F(StoreTest, EdgesThroughAPassageRecognisedOnTheWayLoadBack) {
  Stream stream(29);
  for (int c = 0; c < 3; ++c) stream.AddCluster();
  PipelineOptions options = Options();
  options.whereabouts_points = 2;
  Committed committed;
  std::optional<TopologicalMap> map;
  int passage_edges = 0;
  {
    Store dut = Store::Open(path_);
    StoredState s = dut.Load(kRobot, options.memory);
    Pipeline pipeline(Camera(), options, std::move(s.memory), std::move(s.map), s.pipeline);
    for (int c : {0, 1, 2, 1, 0}) Feed(pipeline, dut, stream.Visit(c, 14), committed);
    for (const Descriptor& d : stream.Visit(1, 4)) {  // 3 good points: pruned
      const FrameResult r = pipeline.ProcessDescriptor(d, IntensityStats{0.5, 0.05});
      for (const PlaceEvent& e : r.events) {
        passage_edges += e.kind == EventKind::kMapped && e.detected_place == 0;
      }
      dut.Commit(r, pipeline);
    }
    Feed(pipeline, dut, stream.Visit(2, 14), committed);
    Finish(pipeline, dut, committed);
    map = pipeline.map();
  }
  EXPECT_EQ(passage_edges, 1);
  EXPECT_EQ(map->Find(PlaceId{kRobot, 1}, PlaceId{kRobot, 3}), nullptr);  // 1 and 3 not joined
  Store dut = Store::Open(path_);
  ExpectSameMap(*map, dut.Load(kRobot, options.memory).map);
}

TEST_F(StoreTest, ReopenedDatabaseContinuesLearning) {
  Stream stream(23);
  for (int c = 0; c < 5; ++c) stream.AddCluster();
  Committed committed;
  uint32_t max_local_before = 0;
  size_t places_before = 0;
  int64_t detected_before = 0;
  {
    Store dut = Store::Open(path_);
    Pipeline pipeline = Continue(dut);
    for (int c : {0, 1, 2}) Feed(pipeline, dut, stream.Visit(c, 14), committed);
    Finish(pipeline, dut, committed);
    for (const LearnedPlace& p : pipeline.memory().places()) {
      max_local_before = std::max(max_local_before, p.id.local);
    }
    places_before = pipeline.memory().places().size();
    detected_before = Sql(path_, "SELECT MAX(idx) FROM detected_places");
  }
  ASSERT_GE(places_before, 2u);
  int recognized_before = committed.recognized;
  {
    Store dut = Store::Open(path_);
    Pipeline pipeline = Continue(dut);
    for (int c : {3, 0, 4}) Feed(pipeline, dut, stream.Visit(c, 14), committed);
    Finish(pipeline, dut, committed);
  }
  // The revisit of cluster 0 is recognised by the reloaded memory.
  EXPECT_GT(committed.recognized, recognized_before);

  Store dut = Store::Open(path_);
  const StoredState loaded = dut.Load(kRobot, Options().memory);
  const std::vector<LearnedPlace>& places = loaded.memory.places();
  ASSERT_GT(places.size(), places_before);
  std::set<PlaceId> ids;
  for (size_t i = 0; i < places.size(); ++i) {
    EXPECT_TRUE(ids.insert(places[i].id).second) << "duplicate " << places[i].id.ToString();
    EXPECT_EQ(places[i].id.robot, kRobot);
    if (i >= places_before) {
      EXPECT_GT(places[i].id.local, max_local_before);
    }
  }
  EXPECT_GT(loaded.memory.next_local_id(), places.back().id.local);
  // Base points 0..frames-1, each once; detected place indices continue.
  EXPECT_EQ(Sql(path_, "SELECT COUNT(*) FROM base_points"), committed.frames);
  EXPECT_EQ(Sql(path_, "SELECT COUNT(DISTINCT idx) FROM base_points"), committed.frames);
  EXPECT_EQ(Sql(path_, "SELECT MIN(idx) FROM base_points"), 0);
  EXPECT_EQ(Sql(path_, "SELECT MAX(idx) FROM base_points"), committed.frames - 1);
  EXPECT_EQ(loaded.pipeline.next_base, committed.frames);
  EXPECT_GT(Sql(path_, "SELECT MAX(idx) FROM detected_places"), detected_before);
  EXPECT_EQ(Sql(path_, "SELECT COUNT(*) FROM detected_places"),
            committed.learned + committed.recognized);
}

// A consolidation folds places and renumbers the rest (FrameResult::memory_replaced): the
// commit then writes the whole memory and map, as after a merge, and the folded place's row
// is gone; a commit that wrote only the changed places would keep it.
TEST_F(StoreTest, AReplacedMemoryIsWrittenWhole) {
  Store dut = Store::Open(path_);
  Pipeline pipeline = LearnedRooms(dut, 3, {0, 1, 2, 0});
  const size_t before = pipeline.memory().places().size();
  ASSERT_GE(before, 3u);
  Consolidation c = Consolidate(pipeline.memory(), {0, 1});
  TopologicalMap map = MergeMaps(pipeline.map(), TopologicalMap{}, c.memory);
  pipeline.AdoptMerged(std::move(c.memory), std::move(map));
  FrameResult replaced;
  replaced.has_base = false;
  replaced.memory_replaced = true;
  dut.Commit(replaced, pipeline);
  const StoredState loaded = dut.Load(kRobot, Options().memory);
  ASSERT_EQ(loaded.memory.places().size(), before - 1);
  ExpectSameMemory(pipeline.memory(), loaded.memory);
  ExpectSameMap(pipeline.map(), loaded.map);
}

// A replaced memory whose database held the memory before (a merge committed at once) writes
// only the places that changed: the rows of the others stay as they were (a row altered behind
// the store's back proves it), the folded place's row and the rows past the end go, and the
// memory loads back whole.
TEST_F(StoreTest, AReplacedMemoryWritesOnlyThePlacesItChanged) {
  Store dut = Store::Open(path_);
  Pipeline pipeline = LearnedRooms(dut, 4, {0, 1, 2, 3, 0});
  const std::vector<LearnedPlace> before = pipeline.memory().places();
  ASSERT_GE(before.size(), 4u);
  // The last two fold: every place before them keeps its position and row.
  const int last = static_cast<int>(before.size()) - 1;
  Consolidation c = Consolidate(pipeline.memory(), {last - 1, last});
  TopologicalMap map = MergeMaps(pipeline.map(), TopologicalMap{}, c.memory);
  const std::vector<char> unchanged = UnchangedPositions(before, c.memory.places());
  ASSERT_EQ(unchanged.size(), before.size() - 1);
  ASSERT_EQ(unchanged[0], 1) << "the first place is untouched by the fold";
  ASSERT_EQ(std::count(unchanged.begin(), unchanged.end(), 0), 1) << "the holder changed";
  pipeline.AdoptMerged(std::move(c.memory), std::move(map));
  Sql(path_, "UPDATE learned_places SET member_count = 999 WHERE position = 0");
  FrameResult replaced;
  replaced.has_base = false;
  replaced.memory_replaced = true;
  dut.CommitPending(std::span<const FrameResult>(&replaced, 1), pipeline, false, std::nullopt,
                    &unchanged);
  EXPECT_EQ(Sql(path_, "SELECT member_count FROM learned_places WHERE position = 0"), 999)
      << "an unchanged place was written again";
  EXPECT_EQ(Sql(path_, "SELECT COUNT(*) FROM learned_places"),
            static_cast<int64_t>(before.size() - 1));
  Sql(path_, "UPDATE learned_places SET member_count = " + std::to_string(before[0].member_count) +
                 " WHERE position = 0");
  const StoredState loaded = dut.Load(kRobot, Options().memory);
  ExpectSameMemory(pipeline.memory(), loaded.memory);
  ExpectSameMap(pipeline.map(), loaded.map);
  // Without the flags every place is written, the altered row included.
  Sql(path_, "UPDATE learned_places SET member_count = 999 WHERE position = 0");
  dut.Commit(replaced, pipeline);
  EXPECT_EQ(Sql(path_, "SELECT member_count FROM learned_places WHERE position = 0"),
            before[0].member_count);
}

// Copy evidence takes several laps to gather (core/pipeline/copy_evidence.h): a robot that
// restarts between them continues counting. It is written when a result says it changed (a
// commit is made for every base point; the evidence rarely changes).
TEST_F(StoreTest, CopyEvidenceIsKeptAcrossARestartWhenItChanged) {
  Store dut = Store::Open(path_);
  StoredState s = dut.Load(kRobot, Options().memory);
  PipelineState state = s.pipeline;
  state.copies = {{PlaceId{2, 5}, PlaceId{kRobot, 2}, 1, 17},  // in pair order
                  {PlaceId{kRobot, 1}, PlaceId{kRobot, 3}, 2, 40}};
  Pipeline pipeline(Camera(), Options(), std::move(s.memory), std::move(s.map), state);
  FrameResult unchanged;
  unchanged.has_base = false;
  dut.Commit(unchanged, pipeline);
  EXPECT_TRUE(dut.Load(kRobot, Options().memory).pipeline.copies.empty());
  FrameResult changed = unchanged;
  changed.copies_changed = true;
  dut.Commit(changed, pipeline);
  ExpectSameState(state, dut.Load(kRobot, Options().memory).pipeline);
  // A restarted pipeline holds it and writes it back as it was.
  Pipeline again = Continue(dut);
  EXPECT_EQ(again.state().copies, state.copies);
}

TEST_F(StoreTest, BrokenCopyEvidenceIsAClearError) {
  { Store::Open(path_); }
  Sql(path_, "INSERT INTO copy_evidence VALUES (1, 4, 1, 2, 1, 9)");  // pair out of order
  try {
    Store::Open(path_).Load(kRobot, Options().memory);
    FAIL() << "loaded a pair out of order";
  } catch (const StoreError& e) {
    EXPECT_NE(std::string(e.what()).find("copy_evidence"), std::string::npos) << e.what();
  }
  Sql(path_, "DELETE FROM copy_evidence");
  Sql(path_, "INSERT INTO copy_evidence VALUES (1, 2, 1, 4, 0, 9)");  // seen no time
  try {
    Store::Open(path_).Load(kRobot, Options().memory);
    FAIL() << "loaded a pair seen no time";
  } catch (const StoreError& e) {
    EXPECT_NE(std::string(e.what()).find("count"), std::string::npos) << e.what();
  }
}

TEST_F(StoreTest, RecommittingAResultIsHarmless) {
  Stream stream(5);
  stream.AddCluster();
  stream.AddCluster();
  Store dut = Store::Open(path_);
  Pipeline pipeline = Continue(dut);
  for (int c : {0, 1}) {
    for (const Descriptor& d : stream.Visit(c, 12)) {
      const FrameResult r = pipeline.ProcessDescriptor(d, IntensityStats{0.5, 0.05});
      dut.Commit(r, pipeline);
      dut.Commit(r, pipeline);
    }
  }
  const StoredState loaded = dut.Load(kRobot, Options().memory);
  ExpectSameMemory(pipeline.memory(), loaded.memory);
  ExpectSameMap(pipeline.map(), loaded.map);
}

TEST_F(StoreTest, NewDatabaseHasTheCurrentSchemaVersionAndAnEmptyMemory) {
  Store dut = Store::Open(path_);
  EXPECT_EQ(dut.schema_version(), 6);
  EXPECT_EQ(Store::kSchemaVersion, 6);
  EXPECT_EQ(dut.path(), path_);
  const StoredState loaded = dut.Load(kRobot, Options().memory);
  EXPECT_TRUE(loaded.memory.empty());
  EXPECT_EQ(loaded.memory.robot(), kRobot);
  EXPECT_TRUE(loaded.map.edges().empty());
  ExpectSameState(PipelineState{}, loaded.pipeline);
  // Reopening an up-to-date database changes nothing.
  Store again = Store::Open(path_);
  EXPECT_EQ(again.schema_version(), 6);
  EXPECT_EQ(Sql(path_, "SELECT COUNT(*) FROM schema_version"), 1);
}

// Reopening after a failure: a database that is not there is not made anew (a file system not
// mounted again yet); one that is there opens as with Open().
TEST_F(StoreTest, OpenExistingRefusesAMissingDatabaseAndCreatesNothing) {
  try {
    Store::OpenExisting(path_);
    FAIL() << "opened a database that does not exist";
  } catch (const StoreError& e) {
    EXPECT_TRUE(e.file_system());
    EXPECT_NE(std::string(e.what()).find(path_.string()), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(path_));
  { Store::Open(path_); }
  Store dut = Store::OpenExisting(path_);
  EXPECT_EQ(dut.schema_version(), Store::kSchemaVersion);
}

// A memory.db that is not a database (another file in its place, or its first page overwritten)
// is refused with what to do about it, and left byte for byte as it was.
TEST_F(StoreTest, OpenRefusesAFileThatIsNotADatabaseAndLeavesIt) {
  const std::string text(5000, 'x');
  {
    std::ofstream out(path_, std::ios::binary);
    out << text;
  }
  for (const bool existing : {true, false}) {
    try {
      if (existing) {
        Store::OpenExisting(path_);
      } else {
        Store::Open(path_);
      }
      FAIL() << "a file of 'x' was opened as a database";
    } catch (const StoreError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(path_.string()), std::string::npos) << what;
      EXPECT_NE(what.find("not a SQLite database"), std::string::npos) << what;
      EXPECT_NE(what.find("move it away"), std::string::npos) << what;
    }
    std::ifstream in(path_, std::ios::binary);
    const std::string after((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(after, text);
  }
}

TEST_F(StoreTest, OpenRefusesANewerSchemaVersion) {
  { Store::Open(path_); }
  Sql(path_, "UPDATE schema_version SET version = 7");
  try {
    Store::Open(path_);
    FAIL() << "a database of schema version 7 was opened";
  } catch (const StoreError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(path_.string()), std::string::npos) << what;
    EXPECT_NE(what.find("version 7"), std::string::npos) << what;
    EXPECT_NE(what.find("version 6"), std::string::npos) << what;
  }
}

// Tables without a recorded version (another program's database, or tscd's with its version
// row lost) are refused as they are: a migration from version 0 would try to create them.
TEST_F(StoreTest, OpenRefusesTablesWithoutASchemaVersion) {
  { Store::Open(path_); }
  Sql(path_, "DELETE FROM schema_version");
  for (const bool existing : {false, true}) {
    try {
      if (existing) {
        Store::OpenExisting(path_);
      } else {
        Store::Open(path_);
      }
      FAIL() << "a database without its schema version was opened";
    } catch (const StoreError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(path_.string()), std::string::npos) << what;
      EXPECT_NE(what.find("no schema version"), std::string::npos) << what;
      EXPECT_NE(what.find("learned_places"), std::string::npos) << what;
    }
  }
  EXPECT_EQ(Sql(path_, "SELECT COUNT(*) FROM schema_version"), 0);  // left as it was
}

// Every detected place that was recognised or learned is listed with the place it went to
// and its members; the revisit of cluster 0 goes to the same place as the first visit.
TEST_F(StoreTest, AssignmentsListDetectedPlacesWithTheirPlaceAndMembers) {
  Stream stream(31);
  for (int c = 0; c < 2; ++c) stream.AddCluster();
  Committed committed;
  Store dut = Store::Open(path_);
  Pipeline pipeline = Continue(dut);
  for (int c : {0, 1, 0}) Feed(pipeline, dut, stream.Visit(c, 14), committed);
  Finish(pipeline, dut, committed);
  const auto got = dut.LoadAssignments();
  ASSERT_GE(got.size(), 3u);
  std::set<BaseIndex> seen;
  for (const auto& [place, members] : got) {
    EXPECT_TRUE(pipeline.memory().Find(place).has_value()) << place.ToString();
    EXPECT_FALSE(members.empty());
    for (BaseIndex b : members) EXPECT_TRUE(seen.insert(b).second) << "base point twice: " << b;
  }
  EXPECT_EQ(got.front().first, got.back().first);  // the revisit was recognised
}

TEST_F(StoreTest, MigratesAVersionOneDatabaseKeepingItsKnowledge) {
  const PlaceMemory memory = WriteThreeRoomsAndARevisit(23);
  ASSERT_GE(memory.places().size(), 2u);
  // Turn it into what version 1 wrote: no sources column.
  Sql(path_, "ALTER TABLE learned_places DROP COLUMN sources");
  Sql(path_, "ALTER TABLE peers DROP COLUMN digest");
  Sql(path_, "DROP TABLE copy_evidence");
  Sql(path_, "DROP TABLE peer_bodies");
  Sql(path_, "UPDATE schema_version SET version = 1");
  Store dut = Store::Open(path_);
  EXPECT_EQ(dut.schema_version(), 6);
  EXPECT_TRUE(dut.LoadPeers().empty());
  const StoredState loaded = dut.Load(kRobot, Options().memory);
  ExpectSameMemory(memory, loaded.memory);
  for (const LearnedPlace& p : loaded.memory.places()) EXPECT_TRUE(p.sources.empty());
}

// The float32 layout of member views that schema versions 1-3 wrote (int32 rows, int32 cols,
// float32 column-major) as an SQL blob literal.
std::string Float32SamplesLiteral(const Eigen::MatrixXf& views) {
  std::vector<unsigned char> bytes(8 + static_cast<size_t>(views.size()) * 4);
  const auto put = [&bytes](size_t at, uint32_t word) {
    for (int b = 0; b < 4; ++b) bytes[at + b] = static_cast<unsigned char>(word >> (8 * b));
  };
  put(0, static_cast<uint32_t>(views.rows()));
  put(4, static_cast<uint32_t>(views.cols()));
  for (Eigen::Index k = 0; k < views.size(); ++k) {
    put(8 + static_cast<size_t>(k) * 4, std::bit_cast<uint32_t>(views.data()[k]));
  }
  std::string hex = "X'";
  for (unsigned char c : bytes) {
    constexpr char kDigits[] = "0123456789abcdef";
    hex += kDigits[c >> 4];
    hex += kDigits[c & 15];
  }
  return hex + "'";
}

// A store of schema version 3 holds member views as float32: they are read, and kept in 8 bits
// they are the views the memory had (decoded views encode to the same bits).
TEST_F(StoreTest, ReadsMemberViewsOfTheFloat32Layout) {
  const PlaceMemory memory = WriteThreeRoomsAndARevisit(37);
  ASSERT_GE(memory.places().size(), 2u);
  for (size_t i = 0; i < memory.places().size(); ++i) {
    Sql(path_, "UPDATE learned_places SET samples = " +
                   Float32SamplesLiteral(memory.places()[i].samples.Decoded()) +
                   " WHERE position = " + std::to_string(i));
  }
  Sql(path_, "DROP TABLE copy_evidence");
  Sql(path_, "DROP TABLE peer_bodies");
  Sql(path_, "UPDATE schema_version SET version = 3");
  EXPECT_EQ(Sql(path_,
                "SELECT COUNT(*) FROM learned_places WHERE substr(samples, 1, 4) = "
                "X'ffffffff'"),
            0);
  Store dut = Store::Open(path_);
  EXPECT_EQ(dut.schema_version(), 6);
  ExpectSameMemory(memory, dut.Load(kRobot, Options().memory).memory);
}

// Views that encoding could not have given are refused with the column named, not decoded.
TEST_F(StoreTest, RefusesMemberViewsThatAreNotAnEncoding) {
  Stream stream(41);
  stream.AddCluster();
  Committed committed;
  {
    Store dut = Store::Open(path_);
    Pipeline pipeline = Continue(dut);
    Feed(pipeline, dut, stream.Visit(0, 14), committed);
    Finish(pipeline, dut, committed);
  }
  ASSERT_GE(Sql(path_, "SELECT COUNT(*) FROM learned_places"), 1);
  // Marker, 1 x 1 view, shift 3, value 5: the largest value must lie in [2^14, 2^15).
  Sql(path_,
      "UPDATE learned_places SET samples = X'ffffffff0100000001000000030000000500' "
      "WHERE position = 0");
  Store dut = Store::Open(path_);
  try {
    dut.Load(kRobot, Options().memory);
    FAIL() << "loaded views that are not an encoding";
  } catch (const StoreError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("samples"), std::string::npos) << what;
    EXPECT_NE(what.find("not what encoding views gives"), std::string::npos) << what;
  }
}

TEST_F(StoreTest, ReplaceKnowledgeRoundTripsMergedPlacesAndMap) {
  Stream stream(29);
  for (int c = 0; c < 3; ++c) stream.AddCluster();
  Committed committed;
  Store dut = Store::Open(path_);
  EXPECT_EQ(dut.robot(), std::nullopt);
  {
    Pipeline pipeline = Continue(dut);
    for (int c : {0, 1, 2}) Feed(pipeline, dut, stream.Visit(c, 14), committed);
    Finish(pipeline, dut, committed);
  }
  EXPECT_EQ(dut.robot(), kRobot);
  StoredState state = dut.Load(kRobot, Options().memory);
  ASSERT_GE(state.memory.places().size(), 2u);
  std::vector<LearnedPlace> places = state.memory.places();
  places[0].sources = {PlaceId{7, 1}, PlaceId{7, 4}};
  const PlaceMemory merged = PlaceMemory::Restore(
      kRobot, Options().memory, places, state.memory.slink(), state.memory.next_local_id(), {});
  TopologicalMap map = state.map;
  map.RecordTransition(places[0].id, PlaceId{7, 9}, TransitionRegion{});
  dut.ReplaceKnowledge(merged, map, PeerMerge{7, 5, -42, 1000});
  dut.ReplaceKnowledge(merged, map, PeerMerge{7, 6, 99, 2000});  // the newer merge replaces it
  const auto peers = dut.LoadPeers();
  ASSERT_EQ(peers.size(), 1u);
  EXPECT_EQ(peers.at(7).version, 6);
  EXPECT_EQ(peers.at(7).digest, 99);
  EXPECT_EQ(peers.at(7).utime, 2000);
  const fs::path copy = dir_ / "copy.db";
  dut.CopyTo(copy);
  Store other = Store::Open(copy);
  const StoredState loaded = other.Load(kRobot, Options().memory);
  ExpectSameMemory(merged, loaded.memory);
  ExpectSameMap(map, loaded.map);
}

// The peer bodies the exchange keeps (issue 23): added, replaced by digest, dropped when the
// peer's next memory no longer names them, per robot, and there after a reopen.
TEST_F(StoreTest, PeerBodiesAreKeptByRobotAndDigestUntilNoLongerNamed) {
  using Body = std::pair<int64_t, std::vector<unsigned char>>;
  const auto bodies_of = [](const Store& store, uint32_t robot) {
    std::map<int64_t, std::vector<unsigned char>> got;
    store.ForEachPeerBody(robot, [&](int64_t digest, std::span<const unsigned char> bytes) {
      got.emplace(digest, std::vector<unsigned char>(bytes.begin(), bytes.end()));
    });
    return got;
  };
  {
    Store dut = Store::Open(path_);
    EXPECT_TRUE(dut.LoadPeerBodyDigests().empty());
    const std::vector<Body> seven{
        {-5, {1, 2, 3}}, {11, {4}}, {12, std::vector<unsigned char>(20000, 9)}};
    dut.AddPeerBodies(7, seven);
    dut.AddPeerBodies(8, std::vector<Body>{{11, {8, 8}}});
    dut.AddPeerBodies(7, std::vector<Body>{{11, {5, 6}}});  // the same digest: replaced
    EXPECT_EQ(dut.KeepOnlyPeerBodies(7, {-5, 11, 99}), (std::unordered_set<int64_t>{-5, 11}));
  }
  const Store dut = Store::Open(path_);
  const auto digests = dut.LoadPeerBodyDigests();
  ASSERT_EQ(digests.size(), 2u);
  EXPECT_EQ(digests.at(7), (std::vector<int64_t>{-5, 11}));
  EXPECT_EQ(digests.at(8), (std::vector<int64_t>{11}));
  const auto seven = bodies_of(dut, 7);
  ASSERT_EQ(seven.size(), 2u);
  EXPECT_EQ(seven.at(-5), (std::vector<unsigned char>{1, 2, 3}));
  EXPECT_EQ(seven.at(11), (std::vector<unsigned char>{5, 6}));
  EXPECT_EQ(bodies_of(dut, 8).at(11), (std::vector<unsigned char>{8, 8}));
  EXPECT_TRUE(bodies_of(dut, 9).empty());
}

/// A memory with learned places, recognitions, map edges and a peer's version, and base point
/// records far beyond `frames_at_least` x ~4 KiB. Returns the knowledge as Load() gives it.
testing_support::Knowledge FillBeyondABudget(const fs::path& path, int frames_at_least,
                                             Committed& committed) {
  Stream stream(41);
  for (int c = 0; c < 4; ++c) stream.AddCluster();
  {
    Store store = Store::Open(path);
    StoredState s = store.Load(kRobot, Options().memory);
    Pipeline pipeline(Camera(), Options(), std::move(s.memory), std::move(s.map), s.pipeline);
    const std::array<int, 6> route = {0, 1, 2, 0, 3, 1};
    for (size_t i = 0; committed.frames < frames_at_least; ++i) {
      Feed(pipeline, store, stream.Visit(route[i % route.size()], 14), committed);
    }
    Finish(pipeline, store, committed);
    store.ReplaceKnowledge(pipeline.memory(), pipeline.map(), PeerMerge{7, 5, -42, 1000});
  }
  return testing_support::LoadKnowledge(path, kRobot, Options().memory);
}

TEST_F(StoreTest, MaintainThinsOldBasePointsUnderTheBudgetAndKeepsTheKnowledge) {
  Committed committed;
  const testing_support::Knowledge before = FillBeyondABudget(path_, 1500, committed);
  ASSERT_GE(before.state.memory.places().size(), 3u);
  ASSERT_GE(before.state.map.edges().size(), 2u);
  ASSERT_EQ(before.peers.size(), 1u);
  const auto assignments = Store::Open(path_).LoadAssignments();
  const int64_t records = Sql(path_, "SELECT COUNT(*) FROM base_points");
  ASSERT_EQ(records, committed.frames);
  const uintmax_t bytes_before = fs::file_size(path_);  // closed: the WAL is folded in
  constexpr int64_t kBudgetMb = 2;
  constexpr uintmax_t kBudget = uintmax_t{kBudgetMb} << 20;
  ASSERT_GT(bytes_before, 2 * kBudget) << "the test needs a database well over the budget";

  StoreOptions options;
  options.budget_mb = kBudgetMb;
  options.maintenance_pages = 64;
  int steps = 0;
  {
    Store dut = Store::Open(path_);
    EXPECT_TRUE(dut.reclaims_space());
    for (MaintenanceStep step; steps == 0 || step.more; ++steps) {
      ASSERT_LT(steps, 1000) << "maintenance does not converge";
      step = dut.Maintain(options);
      // Bounded steps: neither part does more than maintenance_pages at once.
      EXPECT_LE(step.base_points_deleted, options.maintenance_pages);
      EXPECT_LE(step.detected_places_deleted, options.maintenance_pages);
      EXPECT_LE(step.pages_released, options.maintenance_pages);
    }
    EXPECT_GT(steps, 10);  // the work was spread over many small steps
    const MaintenanceStep idle = dut.Maintain(options);  // nothing left to do
    EXPECT_EQ(idle.base_points_deleted, 0);
    EXPECT_EQ(idle.pages_released, 0);
    EXPECT_FALSE(idle.more);
    EXPECT_LE(idle.bytes_used, static_cast<int64_t>(kBudget));
  }
  // The file itself shrank under the budget, with its newest base points kept, oldest gone.
  const uintmax_t bytes_after = fs::file_size(path_);
  EXPECT_LE(bytes_after, kBudget);
  EXPECT_LT(bytes_after, bytes_before / 2);
  const int64_t kept = Sql(path_, "SELECT COUNT(*) FROM base_points");
  EXPECT_GT(kept, 0);
  EXPECT_LT(kept, records / 2);
  EXPECT_EQ(Sql(path_, "SELECT MAX(idx) FROM base_points"), committed.frames - 1);
  EXPECT_EQ(Sql(path_, "SELECT MIN(idx) FROM base_points"), committed.frames - kept);
  EXPECT_EQ(Sql(path_, "PRAGMA freelist_count"), 0);
  EXPECT_EQ(SqlText(path_, "PRAGMA integrity_check"), "ok");

  // Every learned place (members, member views), the tree, every map edge, the pipeline's
  // position and the peer's version load back exactly.
  const testing_support::Knowledge after =
      testing_support::LoadKnowledge(path_, kRobot, Options().memory);
  EXPECT_TRUE(testing_support::Differences(before, after).empty())
      << testing_support::DescribeDifferences(before, after);
  ExpectSameState(before.state.pipeline, after.state.pipeline);
  // The history went with its base points: exactly the detected places none of whose base
  // points is kept, and the transition regions before them; the newer ones load back as they
  // were.
  Store dut = Store::Open(path_);
  const int64_t horizon = committed.frames - kept;
  std::vector<std::pair<PlaceId, std::vector<BaseIndex>>> newer;
  for (const auto& a : assignments) {
    if (a.second.back() >= horizon) newer.push_back(a);
  }
  EXPECT_LT(newer.size(), assignments.size());
  EXPECT_FALSE(newer.empty());
  EXPECT_EQ(dut.LoadAssignments(), newer);
  EXPECT_EQ(
      Sql(path_, "SELECT COUNT(*) FROM transition_regions WHERE last < " + std::to_string(horizon)),
      0);
  EXPECT_GT(Sql(path_, "SELECT COUNT(*) FROM transition_regions"), 0);

  // Learning continues where it stopped, recognising the places it kept.
  Pipeline pipeline = Continue(dut);
  Stream stream(41);
  for (int c = 0; c < 4; ++c) stream.AddCluster();
  Committed more;
  Feed(pipeline, dut, stream.Visit(2, 14), more);
  EXPECT_EQ(more.learned, 0);
  EXPECT_EQ(Sql(path_, "SELECT MAX(idx) FROM base_points"), committed.frames - 1 + more.frames);
}

// A detected place record that cannot be read (a damaged disk, a spill taken in) is history
// nothing can use any more: retention deletes it in its turn instead of failing every step
// on it, which stopped thinning for good and let the database grow past its budget. So does a
// transition region whose end is no number, which compared above every index and stayed.
TEST_F(StoreTest, MaintainThinsPastHistoryRecordsThatCannotBeRead) {
  Committed committed;
  const testing_support::Knowledge before = FillBeyondABudget(path_, 700, committed);
  const int64_t records = Sql(path_, "SELECT COUNT(*) FROM detected_places");
  ASSERT_GE(records, 4);
  Sql(path_,
      "UPDATE detected_places SET members = x'0102' WHERE idx = "
      "(SELECT MIN(idx) FROM detected_places)");
  Sql(path_,
      "UPDATE detected_places SET members = 7 WHERE idx = "
      "(SELECT idx FROM detected_places ORDER BY idx LIMIT 1 OFFSET 2)");
  ASSERT_GE(Sql(path_, "SELECT COUNT(*) FROM transition_regions"), 2);
  Sql(path_,
      "UPDATE transition_regions SET last = x'0102' WHERE id = "
      "(SELECT MIN(id) FROM transition_regions)");
  StoreOptions options;
  options.budget_mb = 1;
  options.maintenance_pages = 64;
  {
    Store dut = Store::Open(path_);
    int steps = 0;
    for (MaintenanceStep step; steps == 0 || step.more; ++steps) {
      ASSERT_LT(steps, 1000) << "maintenance does not converge";
      ASSERT_NO_THROW(step = dut.Maintain(options));
    }
    EXPECT_LE(dut.Maintain(options).bytes_used, int64_t{1} << 20);
    // Both damaged records went, being older than every base point kept.
    EXPECT_NO_THROW(dut.LoadAssignments());
  }
  EXPECT_LT(Sql(path_, "SELECT COUNT(*) FROM detected_places"), records - 2);
  EXPECT_EQ(Sql(path_, "SELECT COUNT(*) FROM transition_regions WHERE typeof(last) = 'blob'"), 0);
  EXPECT_EQ(testing_support::DescribeDifferences(
                before, testing_support::LoadKnowledge(path_, kRobot, Options().memory)),
            "");
}

TEST_F(StoreTest, MaintainWithoutABudgetKeepsEveryBasePoint) {
  Committed committed;
  FillBeyondABudget(path_, 300, committed);
  StoreOptions unlimited;
  unlimited.budget_mb = 0;
  Store dut = Store::Open(path_);
  const MaintenanceStep step = dut.Maintain(unlimited);
  EXPECT_EQ(step.base_points_deleted, 0);
  EXPECT_FALSE(step.more);
  EXPECT_EQ(Sql(path_, "SELECT COUNT(*) FROM base_points"), committed.frames);
  StoreOptions bad;
  bad.budget_mb = -1;
  EXPECT_THROW(dut.Maintain(bad), std::invalid_argument);
}

TEST_F(StoreTest, EnableIncrementalVacuumConvertsASmallOlderDatabase) {
  Committed committed;
  const testing_support::Knowledge before = FillBeyondABudget(path_, 100, committed);
  // What a store written before issue 23 is: auto_vacuum NONE.
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path_.c_str(), &db), SQLITE_OK);
    EXPECT_EQ(sqlite3_exec(db, "PRAGMA auto_vacuum=NONE; VACUUM", nullptr, nullptr, nullptr),
              SQLITE_OK)
        << sqlite3_errmsg(db);
    sqlite3_close(db);
  }
  ASSERT_EQ(Sql(path_, "PRAGMA auto_vacuum"), 0);
  Store dut = Store::Open(path_);
  EXPECT_FALSE(dut.reclaims_space());  // Open() rewrites nothing
  EXPECT_EQ(Sql(path_, "PRAGMA auto_vacuum"), 0);
  EXPECT_TRUE(dut.EnableIncrementalVacuum());
  EXPECT_TRUE(dut.reclaims_space());
  EXPECT_EQ(Sql(path_, "PRAGMA auto_vacuum"), 2);
  const testing_support::Knowledge after =
      testing_support::LoadKnowledge(path_, kRobot, Options().memory);
  EXPECT_TRUE(testing_support::Differences(before, after).empty())
      << testing_support::DescribeDifferences(before, after);
}

TEST_F(StoreTest, OpenRefusesAFileThatIsNotADatabase) {
  {
    std::FILE* f = std::fopen(path_.c_str(), "wb");
    ASSERT_NE(f, nullptr);
    const std::string junk(4096, 'x');
    std::fwrite(junk.data(), 1, junk.size(), f);
    std::fclose(f);
  }
  EXPECT_THROW(Store::Open(path_), StoreError);
}

TEST_F(StoreTest, LoadRefusesADatabaseOfAnotherRobot) {
  {
    Store dut = Store::Open(path_);
    dut.Load(kRobot, Options().memory);
  }
  Store dut = Store::Open(path_);
  try {
    dut.Load(kRobot + 1, Options().memory);
    FAIL() << "robot " << kRobot + 1 << " loaded the database of robot " << kRobot;
  } catch (const StoreError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(path_.string()), std::string::npos) << what;
    EXPECT_NE(what.find("robot " + std::to_string(kRobot)), std::string::npos) << what;
  }
}

// A store learned with other features than the configuration's (tscd started without the
// config/sweep.ini its memory was learned with) is no damaged store: Load says which space
// each holds, naming the file, and the store still loads under its own configuration.
TEST_F(StoreTest, LoadNamesAMemoryLearnedInAnotherDescriptorSpace) {
  {
    Store dut = Store::Open(path_);
    LearnedRooms(dut, 2, {0, 1});
  }
  ASSERT_GE(Sql(path_, "SELECT COUNT(*) FROM learned_places"), 1);
  Store dut = Store::Open(path_);
  const PlaceMemoryOptions builtin = PipelineOptions{}.memory;  // the builtin basis: 1200 in
  ASSERT_NE(builtin.view_basis, nullptr);
  try {
    dut.Load(kRobot, builtin);
    FAIL() << "places of " << kDim << " dimensions were loaded into the builtin basis";
  } catch (const DescriptorSpaceMismatch& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(path_.string()), std::string::npos) << what;
    EXPECT_NE(what.find("dimension 700"), std::string::npos) << what;
    EXPECT_NE(what.find("memory.view_basis = builtin takes 1200"), std::string::npos) << what;
  }
  EXPECT_GE(dut.Load(kRobot, Options().memory).memory.places().size(), 1u);
}

TEST_F(StoreTest, CommitRefusesAPipelineOfAnotherRobotAndRollsBack) {
  Store dut = Store::Open(path_);
  dut.Load(kRobot, Options().memory);
  PipelineOptions other = Options();
  other.robot = kRobot + 1;
  Pipeline pipeline(Camera(), other, PlaceMemory(other.robot, other.memory), TopologicalMap());
  Stream stream(3);
  stream.AddCluster();
  const FrameResult r =
      pipeline.ProcessDescriptor(stream.Visit(0, 1).front(), IntensityStats{0.5, 0.05});
  EXPECT_THROW(dut.Commit(r, pipeline), StoreError);
  EXPECT_EQ(Sql(path_, "SELECT COUNT(*) FROM base_points"), 0);
}

TEST_F(StoreTest, LoadNamesTableRowAndColumnOfACorruptBlob) {
  {
    Store dut = Store::Open(path_);
    LearnedRooms(dut, 2, {0, 1});
  }
  ASSERT_GE(Sql(path_, "SELECT COUNT(*) FROM learned_places"), 1);
  Sql(path_, "UPDATE learned_places SET mean = x'0102030405' WHERE position = 0");
  Store dut = Store::Open(path_);
  try {
    dut.Load(kRobot, Options().memory);
    FAIL() << "a corrupt mean was loaded";
  } catch (const StoreError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(path_.string()), std::string::npos) << what;
    EXPECT_NE(what.find("learned_places"), std::string::npos) << what;
    EXPECT_NE(what.find("position=0"), std::string::npos) << what;
    EXPECT_NE(what.find("mean"), std::string::npos) << what;
  }
}

TEST_F(StoreTest, LoadRejectsBlobsOfTheWrongShape) {
  {
    Store dut = Store::Open(path_);
    LearnedRooms(dut, 2, {0, 1});
  }
  struct Case {
    const char* sql;
    const char* table;
  };
  const Case cases[] = {
      // samples claim more columns than the blob holds
      {"UPDATE learned_places SET samples = x'BC020000FFFFFF7F' WHERE position = 0",
       "learned_places"},
      {"UPDATE learned_places SET members = x'010203' WHERE position = 0", "learned_places"},
      {"UPDATE learned_places SET mean = 'text' WHERE position = 0", "learned_places"},
      {"UPDATE discriminants SET n_sv = n_sv + 1", "discriminants"},
      {"UPDATE map_edges SET transitions = x'0000000000000000'", "map_edges"},
      {"UPDATE meta SET value = x'00' WHERE key = 'slink'", "meta"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.sql);
    const fs::path copy = dir_ / "copy.db";
    fs::remove(copy);
    {
      Store original = Store::Open(path_);  // checkpoints the WAL on close
    }
    fs::copy_file(path_, copy);
    Sql(copy, c.sql);
    Store dut = Store::Open(copy);
    try {
      dut.Load(kRobot, Options().memory);
      ADD_FAILURE() << "loaded";
    } catch (const StoreError& e) {
      EXPECT_NE(std::string(e.what()).find(c.table), std::string::npos) << e.what();
    }
  }
}

// tscd keeps results while its store fails and commits them together once it works: the one
// transaction must leave exactly what committing each result at its time would have left.
TEST_F(StoreTest, KeptResultsCommittedTogetherEqualResultsCommittedOneByOne) {
  Stream stream(41);
  for (int c = 0; c < 4; ++c) stream.AddCluster();
  std::vector<Descriptor> frames;
  for (int c : {0, 1, 2, 0, 3, 1}) {
    for (Descriptor& d : stream.Visit(c, 14)) frames.push_back(std::move(d));
  }
  const fs::path one_by_one = dir_ / "one_by_one.db";
  const fs::path together = dir_ / "together.db";
  const fs::path rewritten = dir_ / "rewritten.db";
  {
    Store a = Store::Open(one_by_one);
    Store b = Store::Open(together);
    Store c = Store::Open(rewritten);
    Pipeline pipeline = Continue(a);
    std::vector<FrameResult> kept_b, kept_c;
    for (size_t i = 0; i < frames.size(); ++i) {
      FrameResult r = pipeline.ProcessDescriptor(frames[i], IntensityStats{0.5, 0.05});
      a.Commit(r, pipeline);
      // b: the first third committed at once, the rest kept until the end; c: everything
      // kept, and written with the whole memory (as after dropped results).
      if (i < frames.size() / 3) {
        b.Commit(r, pipeline);
      } else {
        kept_b.push_back(r);
      }
      kept_c.push_back(std::move(r));
    }
    FrameResult last = pipeline.Finish();
    a.Commit(last, pipeline);
    kept_b.push_back(last);
    kept_c.push_back(std::move(last));
    b.CommitPending(kept_b, pipeline, false, std::nullopt);
    c.CommitPending(kept_c, pipeline, true, std::nullopt);
    ASSERT_GE(pipeline.memory().places().size(), 3u);
  }
  const auto expected = testing_support::LoadKnowledge(one_by_one, kRobot, Options().memory);
  EXPECT_EQ(testing_support::DescribeDifferences(
                expected, testing_support::LoadKnowledge(together, kRobot, Options().memory)),
            "");
  EXPECT_EQ(testing_support::DescribeDifferences(
                expected, testing_support::LoadKnowledge(rewritten, kRobot, Options().memory)),
            "");
  for (const char* table : {"base_points", "detected_places", "transition_regions"}) {
    const std::string count = std::string("SELECT COUNT(*) FROM ") + table;
    EXPECT_EQ(Sql(together, count), Sql(one_by_one, count)) << table;
    EXPECT_EQ(Sql(rewritten, count), Sql(one_by_one, count)) << table;
  }
}

// What Store::Open(path) throws when run as user nobody (in a child process, all its user ids
// changed: SQLite's errno depends on them), or "" when it opens.
std::string OpenErrorAsNobody(const fs::path& path) {
  int out[2];
  if (::pipe(out) != 0) return "pipe failed";
  const pid_t child = ::fork();
  if (child == 0) {
    ::close(out[0]);
    std::string what;
    if (::setresgid(65534, 65534, 65534) != 0 || ::setresuid(65534, 65534, 65534) != 0) {
      what = "cannot become nobody";
    } else {
      try {
        Store::Open(path);
      } catch (const StoreError& e) {
        what = e.what();
      }
    }
    const ssize_t n = ::write(out[1], what.data(), what.size());
    ::_exit(n == static_cast<ssize_t>(what.size()) ? 0 : 1);
  }
  ::close(out[1]);
  std::string what;
  char buf[512];
  for (ssize_t n; (n = ::read(out[0], buf, sizeof buf)) > 0;)
    what.append(buf, static_cast<size_t>(n));
  ::close(out[0]);
  int status = 0;
  ::waitpid(child, &status, 0);
  return what;
}

// A state folder tscd may not write: the error says so ("Permission denied"), not "No such
// file or directory" (SQLite keeps the errno of its read-only fallback open), for a new
// database and for one made before the folder was locked ("attempt to write a readonly
// database" without a reason before).
TEST_F(StoreTest, OpenInAFolderThatCannotBeWrittenSaysPermissionDenied) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to run the open as another user";
  const fs::path locked = dir_ / "locked";
  const fs::path existing = dir_ / "existing";
  fs::create_directories(locked);
  fs::create_directories(existing);
  Store::Open(existing / "memory.db");  // closed again: no -wal, no -shm
  ASSERT_FALSE(fs::exists(existing / "memory.db-wal"));
  const auto read_only = fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                         fs::perms::others_read | fs::perms::others_exec;
  fs::permissions(dir_, read_only);
  fs::permissions(locked, read_only);
  fs::permissions(existing, read_only);
  fs::permissions(existing / "memory.db", fs::perms::all);  // the file itself may be written
  for (const fs::path& folder : {locked, existing}) {
    SCOPED_TRACE(folder.string());
    const std::string what = OpenErrorAsNobody(folder / "memory.db");
    EXPECT_NE(what.find("Permission denied"), std::string::npos) << what;
    EXPECT_EQ(what.find("No such file"), std::string::npos) << what;
    EXPECT_NE(what.find((folder / "memory.db").string()), std::string::npos) << what;
  }
}

// A tscd stopping while its store fails spills what it holds (Store::WriteSpill); the next
// start takes the spill in (ReplaySpill): the database is then exactly what committing every
// result at its time would have made.
TEST_F(StoreTest, ASpillTakenInEqualsResultsCommittedOneByOne) {
  Stream stream(47);
  for (int c = 0; c < 4; ++c) stream.AddCluster();
  std::vector<Descriptor> frames;
  for (int c : {0, 1, 2, 0, 3, 1}) {
    for (Descriptor& d : stream.Visit(c, 14)) frames.push_back(std::move(d));
  }
  const fs::path one_by_one = dir_ / "one_by_one.db";
  const fs::path spill = dir_ / "memory.db.spill.1";
  const fs::path never_loaded = dir_ / "never_loaded.db";
  const fs::path never_loaded_spill = dir_ / "memory.db.spill.2";
  BaseIndex continues = 0;
  {
    Store a = Store::Open(one_by_one);
    Store b = Store::Open(path_);
    Pipeline pipeline = Continue(a);
    std::vector<FrameResult> kept, all;
    for (size_t i = 0; i < frames.size(); ++i) {
      FrameResult r = pipeline.ProcessDescriptor(frames[i], IntensityStats{0.5, 0.05});
      a.Commit(r, pipeline);
      all.push_back(r);
      if (i < frames.size() / 3) {  // the store works for a third of the run, then fails
        b.Commit(r, pipeline);
        continues = pipeline.state().next_base;
      } else {
        kept.push_back(std::move(r));
      }
    }
    FrameResult last = pipeline.Finish();
    a.Commit(last, pipeline);
    all.push_back(last);
    kept.push_back(std::move(last));
    Store::WriteSpill(spill, kept, pipeline, std::nullopt, continues);
    Store::WriteSpill(never_loaded_spill, all, pipeline, std::nullopt, std::nullopt);
    ASSERT_GE(pipeline.memory().places().size(), 3u);
  }
  EXPECT_FALSE(fs::exists(spill.string() + ".partial"));
  const auto expected = testing_support::LoadKnowledge(one_by_one, kRobot, Options().memory);

  // A spill of a writer that never loaded a database goes only into an empty one.
  {
    Store dut = Store::Open(path_);
    EXPECT_THROW(dut.ReplaySpill(never_loaded_spill, kRobot, Options().memory), StoreError);
    // Nor into another robot's.
    Store other = Store::Open(dir_ / "other.db");
    other.Load(kRobot + 1, Options().memory);
    EXPECT_THROW(other.ReplaySpill(spill, kRobot + 1, Options().memory), StoreError);
  }
  {
    Store dut = Store::Open(path_);
    const SpillReplay r = dut.ReplaySpill(spill, kRobot, Options().memory);
    EXPECT_EQ(r.next_base, static_cast<BaseIndex>(frames.size()));
    EXPECT_EQ(r.places, expected.state.memory.places().size());
    EXPECT_EQ(r.base_points, static_cast<int64_t>(frames.size()) - continues);
  }
  EXPECT_EQ(testing_support::DescribeDifferences(
                expected, testing_support::LoadKnowledge(path_, kRobot, Options().memory)),
            "");
  for (const char* table : {"base_points", "detected_places", "transition_regions"}) {
    const std::string count = std::string("SELECT COUNT(*) FROM ") + table;
    EXPECT_EQ(Sql(path_, count), Sql(one_by_one, count)) << table;
  }
  // Taken in, the same spill is refused again (the database is past it) and changes nothing.
  {
    Store dut = Store::Open(path_);
    dut.Load(kRobot, Options().memory);
    EXPECT_THROW(dut.ReplaySpill(never_loaded_spill, kRobot, Options().memory), StoreError);
  }
  {
    Store dut = Store::Open(never_loaded);
    dut.ReplaySpill(never_loaded_spill, kRobot, Options().memory);
  }
  EXPECT_EQ(testing_support::DescribeDifferences(
                expected, testing_support::LoadKnowledge(never_loaded, kRobot, Options().memory)),
            "");
  EXPECT_EQ(Sql(never_loaded, "SELECT COUNT(*) FROM base_points"),
            Sql(one_by_one, "SELECT COUNT(*) FROM base_points"));
}

// A spill whose peers row is damaged is refused, the store left as it was: copied row by row,
// the row went in and the next start could not read the store's peers (fuzz_spill).
TEST_F(StoreTest, ASpillWithADamagedPeerIsRefusedAndTheStoreKept) {
  Stream stream(48);
  stream.AddCluster();
  const fs::path spill = dir_ / "memory.db.spill.1";
  {
    Store dut = Store::Open(path_);
    Pipeline pipeline = Continue(dut);
    for (Descriptor& d : stream.Visit(0, 14)) {
      dut.Commit(pipeline.ProcessDescriptor(d, IntensityStats{0.5, 0.05}), pipeline);
    }
    Store::WriteSpill(spill, {}, pipeline, PeerMerge{2, 3, 99, 1}, pipeline.state().next_base);
  }
  const auto before = testing_support::LoadKnowledge(path_, kRobot, Options().memory);
  Sql(spill, "UPDATE peers SET merged_at_utime = x'00ff'");
  {
    Store dut = Store::Open(path_);
    try {
      dut.ReplaySpill(spill, kRobot, Options().memory);
      FAIL() << "a spill with a damaged peers row was taken in";
    } catch (const StoreError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(spill.string()), std::string::npos) << what;
      EXPECT_NE(what.find("merged_at_utime"), std::string::npos) << what;
    }
  }
  EXPECT_EQ(testing_support::DescribeDifferences(
                before, testing_support::LoadKnowledge(path_, kRobot, Options().memory)),
            "");
  EXPECT_TRUE(fs::exists(spill));
}

// The crash tests' comparison sees one bit of one mean, one traversal and one merged version.
TEST_F(StoreTest, StructuralComparisonNamesTheSmallestDifference) {
  WriteThreeRoomsAndARevisit(43);
  const auto a = testing_support::LoadKnowledge(path_, kRobot, Options().memory);
  ASSERT_GE(a.state.memory.places().size(), 2u);
  EXPECT_EQ(testing_support::DescribeDifferences(
                a, testing_support::LoadKnowledge(path_, kRobot, Options().memory)),
            "");

  std::vector<LearnedPlace> places = a.state.memory.places();
  places[1].mean[5] = std::nextafter(places[1].mean[5], 1.0f);
  testing_support::Knowledge b{
      StoredState{PlaceMemory::Restore(kRobot, Options().memory, places, a.state.memory.slink(),
                                       a.state.memory.next_local_id(), {}),
                  a.state.map, a.state.pipeline},
      a.peers};
  const std::string d = testing_support::DescribeDifferences(a, b);
  EXPECT_NE(d.find("place at position 1"), std::string::npos) << d;
  EXPECT_NE(d.find("mean differs"), std::string::npos) << d;

  testing_support::Knowledge c{
      StoredState{PlaceMemory::Restore(kRobot, Options().memory, a.state.memory.places(),
                                       a.state.memory.slink(), a.state.memory.next_local_id(), {}),
                  a.state.map, a.state.pipeline},
      a.peers};
  ASSERT_FALSE(c.state.map.edges().empty());
  const MapEdge& e = c.state.map.edges().begin()->second;
  c.state.map.RecordTransition(e.a, e.b, TransitionRegion{1, 2});
  c.peers[7] = PeerMerge{7, 3, 4, 5};
  const std::string f = testing_support::DescribeDifferences(a, c);
  EXPECT_NE(f.find("traversals differ"), std::string::npos) << f;
  EXPECT_NE(f.find("peer 7 merged only in the second"), std::string::npos) << f;
}

}  // namespace
}  // namespace tsc
