// `tsc run`: the TSC pipeline over a dataset folder, committing every result to a store.

#include "tools/run_command.h"

#include <boost/program_options.hpp>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "core/median.h"
#include "core/memory/descriptor_space_mismatch.h"
#include "drivers/dataset/assumed_keyframes_check.h"
#include "drivers/dataset/dataset.h"
#include "settings/settings.h"
#include "store/store.h"
#include "tools/command_line.h"
#include "tools/eval.h"
#include "tools/events_json.h"
#include "tools/frame_view.h"
#include "tools/progress.h"

namespace tsc {
namespace {
namespace fs = std::filesystem;
namespace po = boost::program_options;

constexpr const char* kRunHelp =
    R"(usage: tsc run DATASET --db FILE [--config F] [--set section.key=value]...
               [--events FILE.jsonl] [--robot ID] [--no-progress]

Runs the TSC loop (bubble descriptor, reliability, place detection, recognition or learning,
mapping) over every frame of DATASET in natural name order and commits each result to the
SQLite store FILE. A store that already holds a memory is continued. Of a camera whose
frames lie closer than 0.1 m, every N-th frame is a base point (about 0.15 m apart).

DATASET is a folder of frames (*.jpg, *.jpeg, *.png, directly or in rgb/) with optional
depth/ (16-bit PNG, mm), camera.json ({"width","height","hfov_deg"} or fx,fy,cx,cy; default
60 degrees horizontal field of view), groundtruth.csv and revisits.csv (see README.md).

Events are written as JSON lines, one per event:
  {"frame":k,"event":"detected|recognized|learned|ambiguous|mapped|pruned",
   "detected_place":m,"place":"<robot>:<id>", ...}
where k is the base point index (0-based). Recognized, learned and ambiguous events carry the
cost g_N and its terms ("terms":{"distance","ratio","vote","agreement"}): why a place was
recognised or learned (towards a place the map joins to the previous one the cost may exceed
tau_r by memory.neighbour_margin). A detected place within tau_r whose agreement is below
memory.min_agreement is "ambiguous": it gets no place (memory.learn_disagreed = true learns it);
so is one whose cost is within memory.near_miss_margin above tau_r while memory.near_miss_vote
of its points vote for the nearest place and that place is nearer than another one
("near_miss":true; a margin of 0 learns it).

Options)";

struct RunCounts {
  int64_t frames = 0, good = 0, uninformative = 0, incoherent = 0;
  int64_t detected = 0, pruned = 0, learned = 0, recognized = 0, partial = 0, mapped = 0,
          ambiguous = 0;
  ProgressCounts progress() const { return {detected, learned, recognized}; }
  void Add(const FrameResult& r) {
    if (r.has_base) {
      ++frames;
      switch (r.base.status) {
        case BaseStatus::kGood:
          ++good;
          break;
        case BaseStatus::kUninformative:
          ++uninformative;
          break;
        case BaseStatus::kIncoherent:
          ++incoherent;
          break;
      }
    }
    for (const PlaceEvent& e : r.events) {
      switch (e.kind) {
        case EventKind::kDetected:
          ++detected;
          break;
        case EventKind::kPruned:
          ++pruned;
          break;
        case EventKind::kLearned:
          ++learned;
          break;
        case EventKind::kRecognized:
          ++(e.partial ? partial : recognized);
          break;
        case EventKind::kMapped:
          ++mapped;
          break;
        case EventKind::kAmbiguous:
          ++ambiguous;
          break;
      }
    }
  }
};

}  // namespace

int RunPipelineCommand(const std::vector<std::string>& args) {
  po::options_description desc(kRunHelp);
  desc.add_options()("help,h", "show this help")(
      "dataset", po::value<std::string>()->required()->value_name("DATASET"),
      "dataset folder (also the first positional argument)")(
      "db", po::value<std::string>()->required()->value_name("FILE"),
      "SQLite store to create or continue")("events",
                                            po::value<std::string>()->value_name("FILE.jsonl"),
                                            "write the events as JSON lines to this file")(
      "robot", po::value<std::string>()->value_name("ID"), "robot id (same as --set robot.id=ID)")(
      "no-progress", "no progress bar (it is shown only when stderr is a terminal anyway)");
  AddConfigOptions(desc);
  po::positional_options_description pos;
  pos.add("dataset", 1);
  const po::variables_map vm = ParseCommandLine(args, desc, &pos);
  if (vm.count("help")) {
    std::cout << desc << "\n";
    return kExitOk;
  }

  const Settings settings = SettingsWithRobotOption(vm);
  const fs::path dataset_dir = vm["dataset"].as<std::string>();
  const fs::path db_path = vm["db"].as<std::string>();
  std::ostringstream spacing;  // said after the summary line
  const auto [dataset, options, frames_apart, stride, lens] =
      PrepareDataset(settings, Dataset::Open(dataset_dir, DatasetOptionsOf(settings)), &spacing);
  AssumedKeyframesCheck keyframes_check(frames_apart, lens.lens);
  std::optional<std::string> keyframes_caution;

  std::ofstream events;
  if (vm.count("events")) {
    const fs::path events_path = vm["events"].as<std::string>();
    events.open(events_path, std::ios::trunc);
    if (!events) throw std::runtime_error(events_path.string() + ": cannot write events file");
  }

  Store store = Store::Open(db_path);
  // Restored on daemon.merge_threads, as tscd loads the same store.
  StoredState stored = store.Load(options.robot, options.memory, settings.daemon.MergeThreads());
  const int64_t learned_before = static_cast<int64_t>(stored.memory.places().size());
  Pipeline pipeline(dataset.camera(), options, std::move(stored.memory), std::move(stored.map),
                    stored.pipeline);
  try {
    pipeline.RequireMemoryOfTheseFeatures();
  } catch (const DescriptorSpaceMismatch& e) {
    throw DescriptorSpaceMismatch(db_path.string() + ": " + e.what());
  }

  RunCounts counts;
  std::vector<double> pipeline_ms, total_ms;
  pipeline_ms.reserve(static_cast<size_t>(dataset.size()));
  total_ms.reserve(static_cast<size_t>(dataset.size()));
  ProgressBar progress(dataset.size(), stderr, vm.count("no-progress") > 0);
  using Clock = std::chrono::steady_clock;
  const auto ms = [](Clock::duration d) {
    return std::chrono::duration<double, std::milli>(d).count();
  };
  const auto emit = [&](const FrameResult& result, const std::string& where) {
    try {
      store.Commit(result, pipeline);
    } catch (const StoreError& e) {
      throw StoreError(where + ": " + e.what());
    }
    if (events.is_open()) {
      WriteEvents(events, result);
      if (!events) throw std::runtime_error(vm["events"].as<std::string>() + ": write failed");
    }
    counts.Add(result);
  };

  for (int i = 0; i < dataset.size(); ++i) {
    const Clock::time_point t0 = Clock::now();
    const std::string where =
        "frame " + std::to_string(i + 1) + " (" + dataset.image_path(i).string() + ")";
    const std::vector<Observation> views = LoadFrame(dataset, i);
    const Clock::time_point t1 = Clock::now();
    FrameResult result;
    try {
      result = pipeline.Process(views);
    } catch (const std::exception& e) {
      throw std::runtime_error(where + ": " + e.what());
    }
    if (std::optional<std::string> c = keyframes_check.Add(result.base.descriptor)) {
      keyframes_caution = std::move(c);
    }
    pipeline_ms.push_back(ms(Clock::now() - t1));
    emit(result, where);
    total_ms.push_back(ms(Clock::now() - t0));
    progress.Update(i + 1, counts.progress());
  }
  emit(pipeline.Finish(), "end of " + dataset_dir.string());
  progress.Finish();
  if (events.is_open()) events.close();

  const int64_t learned_now = static_cast<int64_t>(pipeline.memory().places().size());
  std::printf(
      "tsc run: %lld frames of %s into %s\n"
      "  base points      %lld (good %lld, uninformative %lld, incoherent %lld)\n"
      "  detected places  %lld (and %lld pruned)\n"
      "  learned places   %lld new, %lld in memory (tree depth %d)\n"
      "  recognitions     %lld (and %lld on partial places; %lld ambiguous places left)\n"
      "  map              %zu places, %zu edges (%lld transitions mapped)\n"
      "  median per frame %.2f ms pipeline, %.2f ms with decoding and commit\n",
      static_cast<long long>(counts.frames), dataset_dir.c_str(), db_path.c_str(),
      static_cast<long long>(counts.frames), static_cast<long long>(counts.good),
      static_cast<long long>(counts.uninformative), static_cast<long long>(counts.incoherent),
      static_cast<long long>(counts.detected), static_cast<long long>(counts.pruned),
      static_cast<long long>(learned_now - learned_before), static_cast<long long>(learned_now),
      pipeline.memory().empty() ? 0 : pipeline.memory().Depth(),
      static_cast<long long>(counts.recognized), static_cast<long long>(counts.partial),
      static_cast<long long>(counts.ambiguous), pipeline.map().places().size(),
      pipeline.map().edges().size(), static_cast<long long>(counts.mapped), Median(pipeline_ms),
      Median(total_ms));
  std::cout << spacing.str();
  if (keyframes_caution) std::cout << "  caution         " << *keyframes_caution << "\n";
  return kExitOk;
}

}  // namespace tsc
