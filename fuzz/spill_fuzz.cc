// Fuzz target: a damaged spill taken in at start. A tscd that stops while its store fails
// writes what it could not commit to a spill, a database of its own (Store::WriteSpill), and
// the next start takes it into the store (Store::ReplaySpill). Written once per process: a
// store holding robot 1's memory and a spill continuing it (one place more, a merged peer);
// each input is a list of edits to a fresh copy of the spill (fuzz/sqlite_edits.h), which is
// then taken into a fresh copy of the store as tscd does. What must hold: the spill is taken
// in, after which the store loads and retention runs over it without failing or changing what
// loads (the spill's history records are copied as they are), or it is refused with
// StoreError and the store holds exactly what it held (places, tree, map, peers:
// test/support/memory_compare.h); no crash.

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/memory/builtin_view_basis.h"
#include "core/pipeline/pipeline.h"
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

// The store and the spill every input starts from, written once, with the spill's tables and
// what the store holds.
struct Seed {
  Seed();
  tsc::fuzz::ScratchDir dir{"tscd-fuzz-spill"};
  fs::path store, spill, work_store, work_spill;
  std::vector<tsc::fuzz::SqlTable> tables;
  std::optional<tsc::testing_support::Knowledge> held;
};

Seed::Seed() {
  store = dir.path() / "store.db";
  spill = dir.path() / "spill.db";
  work_store = dir.path() / "work.db";
  work_spill = dir.path() / "work-spill.db";
  const int dim = tsc::BuiltinViewBasis()->input_dimension();
  const tsc::PipelineOptions options;
  // The same random places, learned in the same order: the spill's memory holds the store's
  // four and one more.
  const auto stored = tsc::testing_support::MakeRandomMemory(kRobot, 4, dim, 1, 4, options.memory);
  auto spilled = tsc::testing_support::MakeRandomMemory(kRobot, 5, dim, 1, 4, options.memory);
  {
    tsc::Store written = tsc::Store::Open(store);
    written.ReplaceKnowledge(stored.memory, stored.map);
  }
  // The spill continues with the robot's history since: its records, as tscd spills them.
  std::vector<tsc::FrameResult> results;
  const tsc::Pipeline pipeline = tsc::fuzz::RunHistory(
      options, tsc::StoredState{std::move(spilled.memory), std::move(spilled.map), {}},
      kHistoryBasePoints,
      [&](const tsc::FrameResult& r, const tsc::Pipeline&) { results.push_back(r); });
  tsc::Store::WriteSpill(spill, results, pipeline, tsc::PeerMerge{2, 3, 99, 1}, tsc::BaseIndex{0});
  tables = tsc::fuzz::TablesOf(spill);
  held = tsc::testing_support::LoadKnowledge(store, kRobot);
}

}  // namespace

TSC_FUZZ_INITIALIZE_SEED(Seed)

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const Seed& seed = tsc::fuzz::SeedOf<Seed>();
  fs::copy_file(seed.store, seed.work_store, fs::copy_options::overwrite_existing);
  fs::copy_file(seed.spill, seed.work_spill, fs::copy_options::overwrite_existing);
  tsc::fuzz::ApplyEdits(seed.work_spill, seed.tables, data, size);
  bool taken = false;
  {
    tsc::Store store = tsc::Store::OpenExisting(seed.work_store);
    try {
      (void)store.ReplaySpill(seed.work_spill, kRobot, tsc::PipelineOptions{}.memory);
      taken = true;
    } catch (const tsc::StoreError&) {
      // refused, as tscd refuses it: the spill is kept and said so
    }
  }
  std::optional<tsc::testing_support::Knowledge> after;
  try {
    after = tsc::testing_support::LoadKnowledge(seed.work_store, kRobot);
  } catch (const tsc::StoreError& e) {
    std::fprintf(stderr, "after %s spill: %s\n", taken ? "a taken" : "a refused", e.what());
  }
  tsc::fuzz::Require(after.has_value(), "the store loads after a spill was taken in or refused");
  if (taken) tsc::fuzz::RequireRetentionKeepsKnowledge(seed.work_store, kRobot);
  if (!taken) {
    const std::string changes = tsc::testing_support::DescribeDifferences(*seed.held, *after);
    if (!changes.empty()) std::fprintf(stderr, "%s\n", changes.c_str());
    tsc::fuzz::Require(changes.empty(), "a refused spill leaves the store as it was");
  }
  return 0;
}
