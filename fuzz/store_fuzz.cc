// Fuzz target: a damaged database, loaded as tscd loads it at start. A real store (robot 1's
// learned places in tscd's default view basis, their tree and discriminants, the map, a merged
// peer and that peer's place bodies, then the history of a run: base points, detected places,
// transitions) is written once per process; each input is a list of
// edits to a fresh copy of it (fuzz/sqlite_edits.h). Then the database is opened and loaded as
// tscd's worker does (Load, the peers, the peer bodies, each decoded against its digest), the
// pipeline is built on what was loaded and its first snapshot taken, and `tsc inspect`'s
// assignments are read; then the pipeline goes on (a visit, each result committed) and
// retention runs at its smallest budget. What must hold: the store loads or throws StoreError;
// the pipeline is built or refuses the memory with std::invalid_argument; a store that took
// every commit loads as the pipeline holds its memory; retention over a store that loads never
// fails and leaves what loads unchanged; no crash, no unbounded allocation.

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/memory/builtin_view_basis.h"
#include "core/pipeline/pipeline.h"
#include "daemon/memory_snapshot.h"
#include "fuzz/fuzz_target.h"
#include "fuzz/scratch_dir.h"
#include "fuzz/sqlite_edits.h"
#include "fuzz/store_history.h"
#include "store/store.h"
#include "test/support/memory_compare.h"
#include "test/support/random_memory.h"

namespace {

namespace fs = std::filesystem;

constexpr uint32_t kRobot = 1;           // tscd's default options' robot (PipelineOptions)
constexpr int kHistoryBasePoints = 300;  // ~1.4 MiB of 1200-dimension descriptors

// The database every input edits, written once, and its tables.
struct Seed {
  Seed();
  tsc::fuzz::ScratchDir dir{"tscd-fuzz-store"};
  fs::path db, work;
  std::vector<tsc::fuzz::SqlTable> tables;
};

Seed::Seed() {
  db = dir.path() / "seed.db";
  work = dir.path() / "work.db";
  const int dim = tsc::BuiltinViewBasis()->input_dimension();
  const tsc::PipelineOptions options;
  const auto ours = tsc::testing_support::MakeRandomMemory(kRobot, 6, dim, 1, 4, options.memory);
  const auto peer = tsc::testing_support::MakeRandomMemory(2, 3, dim, 2, 4, options.memory);
  const tsc::MemorySnapshot snap =
      tsc::BuildSnapshot(peer.memory, peer.map, tsc::SnapshotHeader{2, 7, 1, 0}, 60000);
  std::vector<std::pair<int64_t, std::vector<unsigned char>>> bodies;
  for (const tsc::memory_portion_v2_t& p : tsc::AllPortions(snap)) {
    for (const tsc::learned_place_v2_t& body : p.places) {
      const std::vector<uint8_t> bytes = tsc::EncodeBody(body);
      bodies.emplace_back(tsc::BodyDigest(body),
                          std::vector<unsigned char>(bytes.begin(), bytes.end()));
    }
  }
  {
    tsc::Store store = tsc::Store::Open(db);
    store.ReplaceKnowledge(ours.memory, ours.map, tsc::PeerMerge{2, 1, snap.digest, 1});
    store.AddPeerBodies(2, bodies);
    // The robot's history since: base points, detected places, transitions, committed as tscd
    // commits them (over 1 MiB, so that retention's smallest budget thins it).
    tsc::fuzz::RunHistory(
        options, store.Load(kRobot, options.memory), kHistoryBasePoints,
        [&](const tsc::FrameResult& r, const tsc::Pipeline& p) { store.Commit(r, p); });
  }
  tables = tsc::fuzz::TablesOf(db);
}

}  // namespace

TSC_FUZZ_INITIALIZE_SEED(Seed)

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const Seed& seed = tsc::fuzz::SeedOf<Seed>();
  fs::copy_file(seed.db, seed.work, fs::copy_options::overwrite_existing);
  tsc::fuzz::ApplyEdits(seed.work, seed.tables, data, size);
  std::optional<tsc::StoredState> loaded;
  try {
    tsc::Store store = tsc::Store::OpenExisting(seed.work);
    loaded.emplace(store.Load(kRobot, tsc::PipelineOptions{}.memory));
    (void)store.LoadPeers();
    for (const auto& [robot, digests] : store.LoadPeerBodyDigests()) {
      store.ForEachPeerBody(robot, [](int64_t digest, std::span<const unsigned char> bytes) {
        (void)tsc::DecodeBody(bytes, digest);
      });
    }
  } catch (const tsc::StoreError&) {
    return 0;  // the documented way to fail: tscd says so and runs without its store
  }
  try {
    (void)tsc::Store::OpenExisting(seed.work).LoadAssignments();
  } catch (const tsc::StoreError&) {
    // a damaged history record: `tsc team` says which, tscd never reads them
  }
  std::optional<tsc::Pipeline> pipeline;
  try {
    pipeline.emplace(tsc::CameraIntrinsics::FromHorizontalFov(64, 48, 60),
                     tsc::fuzz::HistoryOptions(tsc::PipelineOptions{}), std::move(loaded->memory),
                     std::move(loaded->map), loaded->pipeline);
    (void)tsc::BuildSnapshot(pipeline->memory(), pipeline->map(),
                             tsc::SnapshotHeader{kRobot, 1, 1, 0}, 60000);
  } catch (const std::invalid_argument&) {
    return 0;  // a memory the pipeline cannot take: refused with its reason
  }
  std::optional<tsc::testing_support::Knowledge> committed =
      tsc::fuzz::RequireCommitsLoadBack(seed.work, kRobot, *pipeline);
  tsc::fuzz::RequireRetentionKeepsKnowledge(seed.work, kRobot, std::move(committed));
  return 0;
}
