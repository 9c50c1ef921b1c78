#pragma once
// The robot's history in the database fuzz targets (fuzz_store, fuzz_spill). Their seeds hold
// it as a robot's store does: tscd's pipeline, continuing a memory, run over a synthetic stream
// of places (test/support/descriptor_stream.h) leaves base point, detected place and transition
// records, more than a megabyte of them, so that retention (Store::Maintain) has something to
// thin under its smallest budget. Over the damaged database, tscd's pipeline then goes on
// (its commits must load back) and retention runs (it must neither fail nor lose knowledge).

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/memory/builtin_view_basis.h"
#include "core/pipeline/pipeline.h"
#include "fuzz/fuzz_target.h"
#include "store/store.h"
#include "test/support/descriptor_stream.h"
#include "test/support/memory_compare.h"

namespace tsc::fuzz {

/// `options` but for detection, which closes the stream's short visits.
inline PipelineOptions HistoryOptions(PipelineOptions options) {
  options.detector = DetectorOptions{2, 2, 3};
  return options;
}

/// The stream of the history: four places, the same on every call.
inline testing_support::DescriptorStream HistoryStream() {
  testing_support::DescriptorStream stream(23, BuiltinViewBasis()->input_dimension());
  for (int c = 0; c < 4; ++c) stream.AddCluster();
  return stream;
}

/// Runs the pipeline of `options` (detection: HistoryOptions) from `state` over at least
/// `base_points` base points of the history's places visited in turn, then Finish;
/// `f(result, pipeline)` after each step, as tscd commits them. Returns the pipeline as it ends.
inline Pipeline RunHistory(const PipelineOptions& options, StoredState state, int base_points,
                           const std::function<void(const FrameResult&, const Pipeline&)>& f) {
  Pipeline pipeline(CameraIntrinsics::FromHorizontalFov(64, 48, 60), HistoryOptions(options),
                    std::move(state.memory), std::move(state.map), state.pipeline);
  testing_support::DescriptorStream stream = HistoryStream();
  for (int taken = 0, visit = 0; taken < base_points; ++visit) {
    for (const Descriptor& d : stream.Visit(visit % 4, 14)) {
      f(pipeline.ProcessDescriptor(d, IntensityStats{0.5, 0.05}), pipeline);
      ++taken;
    }
  }
  f(pipeline.Finish(), pipeline);
  return pipeline;
}

/// tscd going on where `store` stopped: `pipeline` (built on what it loaded, detection:
/// HistoryOptions) visits one of the history's places and the stream ends, each result
/// committed as it comes. When every commit went in, the store must load as `pipeline` holds
/// its memory and map; a commit may fail instead (StoreError: tscd keeps the results and tries
/// again), and then nothing more is asked. Returns what loaded, if the commits went in.
inline std::optional<testing_support::Knowledge> RequireCommitsLoadBack(
    const std::filesystem::path& path, uint32_t robot, Pipeline& pipeline) {
  {
    Store store = Store::OpenExisting(path);
    testing_support::DescriptorStream stream = HistoryStream();
    try {
      for (const Descriptor& d : stream.Visit(1, 14)) {
        store.Commit(pipeline.ProcessDescriptor(d, IntensityStats{0.5, 0.05}), pipeline);
      }
      store.Commit(pipeline.Finish(), pipeline);
    } catch (const StoreError&) {
      return std::nullopt;
    }
  }
  std::optional<testing_support::Knowledge> loaded;
  try {
    loaded = testing_support::LoadKnowledge(path, robot);
  } catch (const StoreError& e) {
    std::fprintf(stderr, "after the commits: %s\n", e.what());
  }
  Require(loaded.has_value(), "a store that took every commit loads");
  const testing_support::Knowledge held{
      StoredState{pipeline.memory(), pipeline.map(), pipeline.position()}, {}};
  const std::string changes = testing_support::DescribeDifferences(held, *loaded, false);
  if (!changes.empty()) std::fprintf(stderr, "%s\n", changes.c_str());
  Require(changes.empty(), "a store that took every commit loads as the pipeline holds it");
  return loaded;
}

/// Retention over the store `path` of `robot`, which loads, as tscd runs it: at the smallest
/// budget, step after step until it has nothing left to do. It must neither fail on a damaged
/// record of the history (that stopped it for good) nor change what Load returns: `before`,
/// where the caller has just loaded it.
inline void RequireRetentionKeepsKnowledge(
    const std::filesystem::path& path, uint32_t robot,
    std::optional<testing_support::Knowledge> before = std::nullopt) {
  if (!before) before = testing_support::LoadKnowledge(path, robot);
  {
    Store store = Store::OpenExisting(path);
    StoreOptions options;
    options.budget_mb = 1;
    options.maintenance_pages = 64;
    bool more = true;
    for (int step = 0; more; ++step) {
      Require(step < 1000, "retention ends");
      try {
        more = store.Maintain(options).more;
      } catch (const StoreError& e) {
        std::fprintf(stderr, "retention: %s\n", e.what());
        Require(false, "retention does not fail on a loadable store");
      }
    }
  }
  const std::string changes =
      testing_support::DescribeDifferences(*before, testing_support::LoadKnowledge(path, robot));
  if (!changes.empty()) std::fprintf(stderr, "%s\n", changes.c_str());
  Require(changes.empty(), "retention keeps what Load returns");
}

}  // namespace tsc::fuzz
