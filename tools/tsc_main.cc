// tsc — the offline tool: `tsc run` runs the TSC pipeline over a dataset folder into a store,
// `tsc eval` scores it against the dataset's ground truth, `tsc inspect` shows what a store
// learned, `tsc config` prints the configuration keys, `tsc sim` writes simulated datasets,
// `tsc merge` merges two robots' stores, `tsc classify` trains and tests the supervised place
// classifier of chapter 2.
// Exit codes (DESIGN §7.2): 0 ok, 1 runtime failure, 2 usage error, 78 configuration error.

#include <algorithm>
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
#include "drivers/dataset/assumed_keyframes_check.h"
#include "drivers/dataset/dataset.h"
#include "drivers/dataset/lens_response.h"
#include "settings/settings.h"
#include "store/store.h"
#include "tools/axis_sim_command.h"
#include "tools/basis_command.h"
#include "tools/classify_command.h"
#include "tools/command_line.h"
#include "tools/eval.h"
#include "tools/events_json.h"
#include "tools/frame_view.h"
#include "tools/inspect.h"
#include "tools/jaguar_commands.h"
#include "tools/merge_command.h"
#include "tools/plots.h"
#include "tools/progress.h"
#include "tools/sim_command.h"
#include "tools/soak_command.h"
#include "tools/team_command.h"

namespace tsc {
namespace {
namespace fs = std::filesystem;
namespace po = boost::program_options;

constexpr const char* kMainHelp =
    R"(usage: tsc <command> [options]

Topological spatial cognition, offline. Commands:
  run      run the TSC pipeline over a dataset folder, storing what it learns
  eval     run the pipeline on a fresh memory and score it against the ground truth
           (JSON figures, PR curve over tau_r, PNG plots)
  inspect  summarise a store; export its place memory and map as JSON, DOT or PNG
  config   print the configuration keys with units, ranges and values as an INI file
  sim      write a simulated dataset (frames and ground truth) from a generated world
  team     run N tscd robots in a private network namespace on the simulated world
  soak     soak and load: a team under packet loss and restarts for minutes; RSS, CPU,
           merges and message rates to soak.csv and soak.png; judges growth
  merge    merge two robots' stores (place memories and maps) into a new store
  basis    fit the principal basis member views are kept in, on datasets' descriptors
  axis-sim a simulated Axis PTZ camera (VAPIX MJPEG and PTZ over HTTP) on 127.0.0.1
  classify supervised place classification (chapter 2): train, test or cross-validate a
           multi-class SVM on labelled RGB-D datasets (ImageCLEF score, PR curve over tau)
  jaguar-sim  a simulated Jaguar motor board on 127.0.0.1 (V2 binary/UDP and ASCII/TCP)
  teleop   drive a robot from the keyboard (JAGUAR_CMD_<robot>, dead-man rule)

'tsc <command> --help' describes each command; 'tsc --version' prints the version.

Exit codes: 0 ok, 1 runtime failure (dataset, store, I/O), 2 usage error,
78 configuration error. Every error names the file, key or frame at fault.
)";

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

constexpr const char* kEvalHelp =
    R"(usage: tsc eval DATASET --json FILE [--plots DIR] [--sweep FROM:TO:STEP]
                [--config F] [--set section.key=value]...

Runs the TSC loop over every frame of DATASET on a fresh memory (nothing is stored) and
scores it with the rules of DESIGN section 7.1b against groundtruth.csv (place labels)
and/or revisits.csv (or, without it, RTAB-Map's groundtruth.bmp). Of a camera whose frames
lie closer than 0.1 m, every N-th frame is a base point (about 0.15 m apart) and only those
are run and scored. Each frame's descriptor is computed once; the pipeline is then replayed
at the configured memory.tau_r (the main figures) and at each tau_r of the sweep (the PR
curve; default 1.5:3.5:0.1, around the default 2.9; STEP 0 = no sweep).

--json FILE gets one JSON object: frames, base_points, detected_places, learned_places,
detection.{boundary_f1,precision,recall} (with labels), recognition.{precision,recall,
recall_at_full_precision,pr_curve:[[tau_r,precision,recall],...]} and, with poses,
recognition.{view_recall,view_recall_at_full_precision,view_pr_curve} (only places that
share a view, within 2 m and 45 degrees, with the place they match), loop_closure.{precision,
recall,recall_at_full_precision,pr_curve} (frame level: each frame of a recognised place
names its nearest member frame of that place; correct within 2 frames of a revisit in
revisits.csv, or with labels only within 2 frames of a frame of its label before its own
visit; unlabelled frames are not judged, loop_closure.not_judged), map.{edges,
edge_precision (with labels)}, timing.{descriptor_ms_median,frame_ms_median}, spacing.{metres,
basis,keyframes,assumed,stride,dataset_frames,tau_p,caution} (how far apart the base points
were taken and on what evidence), lens.{hfov_deg,views,tau_kappa,distance_unit,caution} (a
forward camera's tau_kappa and memory.distance_unit follow its lens; the defaults are for 58
degrees), config, sweep, and decisions: per detected place of the main run, its frames, label, decision (recognised
ones say whether they needed memory.neighbour_margin, "neighbour"), place, cost g_N with its
terms (and the recognition tried when it opened, "partial"), and whether it should have been
recognised and was correct: why a place was missed or taken for another.
--plots DIR writes timeline.png (detection timeline), pr_curve.png (place, view-overlap and
frame-level curves), memory_map.png (place memory tree and topological map, needs
Graphviz's `dot`) and, when the ground truth has poses, floor_plan.png.

Options)";

constexpr const char* kInspectHelp =
    R"(usage: tsc inspect --db FILE [--json] [--dot PATH] [--png PATH] [--robot ID]
                   [--config F] [--set section.key=value]...

Prints what a store holds: robot, base points (good / uninformative / incoherent), detected
places, learned places with their member counts, the depth of the place memory tree and the
size of the topological map. --json prints the same as one JSON object.

--dot and --png write ONE Graphviz graph with two clusters: "place memory" (the tree, root
on top, terminals = learned places) and "topological map" (places and their edges, labelled
with traversal counts). --png runs Graphviz's `dot` command (package graphviz).
The configuration only matters for how discriminants missing from the store are retrained.

Options)";

constexpr const char* kConfigHelp =
    R"(usage: tsc config [--config F] [--set section.key=value]...

Prints the configuration as a commented INI file: every key with its meaning, unit, valid
range and built-in default, set to the value F and the overrides give (the defaults without
them). 'tsc config > my.ini' starts a configuration file.

Options)";

po::variables_map Parse(const std::vector<std::string>& args, const po::options_description& desc,
                        const po::positional_options_description* positional = nullptr) {
  return ParseCommandLine(args, desc, positional);
}

Settings ConfigFrom(const po::variables_map& vm) {
  // --robot is robot.id, given last so it wins; checked like every other key.
  if (vm.count("robot"))
    return SettingsFromCommandLine(vm, {"robot.id=" + vm["robot"].as<std::string>()});
  return SettingsFromCommandLine(vm);
}

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

int Run(const std::vector<std::string>& args) {
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
  const po::variables_map vm = Parse(args, desc, &pos);
  if (vm.count("help")) {
    std::cout << desc << "\n";
    return kExitOk;
  }

  const Settings settings = ConfigFrom(vm);
  const fs::path dataset_dir = vm["dataset"].as<std::string>();
  const fs::path db_path = vm["db"].as<std::string>();
  std::ostringstream spacing;  // said after the summary line
  const auto [dataset, options, frames_apart, stride, lens] =
      PrepareDataset(settings, Dataset::Open(dataset_dir, DatasetOptionsOf(settings)), &spacing);
  AssumedKeyframesCheck keyframes_check(frames_apart, lens.lens);
  std::optional<std::string> keyframes_caution;
  if (options.features.NeedsDepth() && !dataset.has_depth()) {
    throw DatasetError(dataset_dir.string() + ": bubble.features = " + options.features.ToString() +
                       " needs depth, but the dataset has no depth/ folder");
  }

  std::ofstream events;
  if (vm.count("events")) {
    const fs::path events_path = vm["events"].as<std::string>();
    events.open(events_path, std::ios::trunc);
    if (!events) throw std::runtime_error(events_path.string() + ": cannot write events file");
  }

  Store store = Store::Open(db_path);
  StoredState stored = store.Load(options.robot, options.memory);
  const int64_t learned_before = static_cast<int64_t>(stored.memory.places().size());
  Pipeline pipeline(dataset.camera(), options, std::move(stored.memory), std::move(stored.map),
                    stored.pipeline);

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

EvalOptions ParseSweep(const std::string& text) {
  const FromToStep sweep = ParseFromToStep("--sweep", text, "1.5:3.5:0.1");
  EvalOptions e;
  e.sweep_from = sweep.from, e.sweep_to = sweep.to, e.sweep_step = sweep.step;
  try {
    e.Validate();
  } catch (const std::invalid_argument& ex) {
    throw UsageError("--sweep " + text + ": " + ex.what());
  }
  return e;
}

// "labels, revisits (groundtruth.bmp)": what the ground truth holds, for the summary line.
std::string TruthKinds(const GroundTruth& truth, const std::string& revisits_file) {
  std::string kinds = truth.has_labels() ? "labels" : "";
  if (truth.has_revisits()) {
    kinds += (kinds.empty() ? "" : ", ") + std::string("revisits");
    if (revisits_file != "revisits.csv") kinds += " (" + revisits_file + ")";
  }
  return kinds.empty() ? "none" : kinds;
}

int Eval(const std::vector<std::string>& args) {
  po::options_description desc(kEvalHelp);
  desc.add_options()("help,h", "show this help")(
      "dataset", po::value<std::string>()->required()->value_name("DATASET"),
      "dataset folder (also the first positional argument)")(
      "json", po::value<std::string>()->required()->value_name("FILE"),
      "write the figures as one JSON object to FILE")(
      "plots", po::value<std::string>()->value_name("DIR"), "write PNG plots into DIR")(
      "sweep", po::value<std::string>()->value_name("FROM:TO:STEP"),
      "tau_r values of the PR curve (default 1.5:3.5:0.1)");
  AddConfigOptions(desc);
  po::positional_options_description pos;
  pos.add("dataset", 1);
  const po::variables_map vm = Parse(args, desc, &pos);
  if (vm.count("help")) {
    std::cout << desc << "\n";
    return kExitOk;
  }
  const EvalOptions eval =
      vm.count("sweep") ? ParseSweep(vm["sweep"].as<std::string>()) : EvalOptions{};
  const Settings settings = ConfigFrom(vm);
  const fs::path dataset_dir = vm["dataset"].as<std::string>();
  const fs::path json_path = vm["json"].as<std::string>();
  std::ostringstream spacing;  // said after the summary line
  const Dataset opened = Dataset::Open(dataset_dir, DatasetOptionsOf(settings));
  const auto [dataset, options, frames_apart, stride, lens] =
      PrepareDataset(settings, opened, &spacing);
  if (options.features.NeedsDepth() && !dataset.has_depth()) {
    throw DatasetError(dataset_dir.string() + ": bubble.features = " + options.features.ToString() +
                       " needs depth, but the dataset has no depth/ folder");
  }
  EvalResult r = Evaluate(dataset, options, eval);
  const std::optional<std::string> keyframes_caution =
      AssumedKeyframesCaution(frames_apart, r.consecutive_chi2_median, lens.lens);
  r.spacing = EvalSpacing{frames_apart, stride, opened.size(),
                          keyframes_caution ? keyframes_caution : SpacingCaution(frames_apart)};
  r.lens = lens;
  {
    std::ofstream out(json_path, std::ios::trunc);
    if (!out) throw std::runtime_error(json_path.string() + ": cannot write JSON file");
    WriteEvalJson(out, r);
    out.close();
    if (!out) throw std::runtime_error(json_path.string() + ": write failed");
  }
  std::vector<fs::path> plots;
  if (vm.count("plots")) plots = WritePlots(r, dataset, vm["plots"].as<std::string>());

  const RecognitionScore& s = r.main.recognition;
  std::printf(
      "tsc eval: %d frames of %s (ground truth: %s)\n"
      "  base points      good %d, uninformative %d, incoherent %d (median chi2 to the "
      "previous %.4f, tau_kappa %g)\n"
      "  detected places  %zu, learned places %d, ambiguous (no place) %lld\n",
      r.frames, dataset_dir.c_str(), TruthKinds(r.truth, opened.revisits_file()).c_str(), r.good,
      r.uninformative, r.incoherent, r.consecutive_chi2_median, options.reliability.tau_kappa,
      r.main.detected.size(), r.main.learned_places,
      static_cast<long long>(std::count_if(r.main.detected.begin(), r.main.detected.end(),
                                           [](const EvalDetectedPlace& d) { return !d.place; })));
  std::cout << spacing.str();
  if (keyframes_caution) std::cout << "  caution         " << *keyframes_caution << "\n";
  if (r.boundaries) {
    std::printf("  boundaries       F1 %.3f (precision %.3f, recall %.3f; %d true, %d detected)\n",
                r.boundaries->f1, r.boundaries->precision, r.boundaries->recall,
                r.boundaries->true_boundaries, r.boundaries->detected_boundaries);
  }
  std::printf(
      "  recognition      tau_r %.2f: precision %.3f, recall %.3f (%d of %d correct, %d should "
      "be recognised)\n"
      "  PR sweep         %zu points, recall at full precision %.3f\n",
      r.main.tau_r, s.precision, s.recall, s.correct, s.recognitions, s.should_be_recognized,
      r.pr_curve.size(), r.recall_at_full_precision);
  if (r.truth.has_poses()) {
    std::printf(
        "  view overlap     recall %.3f (%d of %d sharing a view), at full precision %.3f\n",
        s.view_recall, s.view_correct, s.view_should_be_recognized,
        r.view_recall_at_full_precision);
  }
  if (r.truth.has_labels() || r.truth.has_revisits()) {
    const LoopClosureScore& c = r.main.loop_closure;
    std::printf(
        "  loop closure     frames: precision %.3f, recall %.3f (%d of %d correct, %d frames "
        "revisit), at full precision %.3f\n",
        c.precision, c.recall, c.correct, c.detections, c.frames_with_revisit,
        r.loop_closure_recall_at_full_precision);
  }
  std::printf("  map              %zu edges", r.main.map.edges().size());
  if (r.edges) std::printf(", edge precision %.3f", r.edges->precision);
  std::printf(
      "\n  median per frame %.2f ms descriptor, %.2f ms with the pipeline step\n"
      "  wrote            %s",
      r.descriptor_ms_median, r.frame_ms_median, json_path.c_str());
  for (const fs::path& p : plots) std::printf(", %s", p.c_str());
  std::printf("\n");
  return kExitOk;
}

int Inspect(const std::vector<std::string>& args) {
  po::options_description desc(kInspectHelp);
  desc.add_options()("help,h", "show this help")(
      "db", po::value<std::string>()->required()->value_name("FILE"), "SQLite store to read")(
      "json", "print the summary as one JSON object")(
      "dot", po::value<std::string>()->value_name("PATH"), "write the Graphviz DOT file")(
      "png", po::value<std::string>()->value_name("PATH"), "render the graph to PNG with `dot`")(
      "robot", po::value<std::string>()->value_name("ID"),
      "robot whose memory to read (default: the store's)");
  AddConfigOptions(desc);
  const po::variables_map vm = Parse(args, desc);
  if (vm.count("help")) {
    std::cout << desc << "\n";
    return kExitOk;
  }
  const PipelineOptions options = ConfigFrom(vm).pipeline;
  std::optional<uint32_t> robot;
  if (vm.count("robot")) robot = options.robot;
  const InspectedStore st = InspectStore(vm["db"].as<std::string>(), options.memory, robot);
  if (vm.count("json")) {
    PrintSummaryJson(std::cout, st.summary);
  } else {
    PrintSummary(std::cout, st.summary);
  }
  if (vm.count("dot") || vm.count("png")) {
    const std::string dot = ToDot(st.memory, st.map);
    if (vm.count("dot")) WriteTextFile(vm["dot"].as<std::string>(), dot);
    if (vm.count("png")) RenderPng(dot, vm["png"].as<std::string>());
  }
  return kExitOk;
}

int Config(const std::vector<std::string>& args) {
  po::options_description desc(kConfigHelp);
  desc.add_options()("help,h", "show this help");
  AddConfigOptions(desc);
  const po::variables_map vm = Parse(args, desc);
  if (vm.count("help")) {
    std::cout << desc << "\n";
    return kExitOk;
  }
  std::cout << DumpConfig(ConfigFrom(vm));
  return kExitOk;
}

int Main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << kMainHelp;
    return kExitUsage;
  }
  const std::string command = argv[1];
  if (command == "--help" || command == "-h" || command == "help") {
    std::cout << kMainHelp;
    return kExitOk;
  }
  if (command == "--version" || command == "version") {
    std::cout << "tsc " << TSCD_VERSION << "\n";
    return kExitOk;
  }
  using Command = int (*)(const std::vector<std::string>&);
  Command fn = nullptr;
  if (command == "run") fn = Run;
  if (command == "eval") fn = Eval;
  if (command == "inspect") fn = Inspect;
  if (command == "config") fn = Config;
  if (command == "sim") fn = RunSimCommand;
  if (command == "team") fn = RunTeamCommand;
  if (command == "soak") fn = RunSoakCommand;
  if (command == "merge") fn = RunMergeCommand;
  if (command == "basis") fn = RunBasisCommand;
  if (command == "axis-sim") fn = RunAxisSimCommand;
  if (command == "classify") fn = RunClassifyCommand;
  if (command == "jaguar-sim") fn = RunJaguarSimCommand;
  if (command == "teleop") fn = RunTeleopCommand;
  if (fn == nullptr) {
    std::cerr << "tsc: unknown command '" << command << "' (try 'tsc --help')\n";
    return kExitUsage;
  }
  const std::vector<std::string> args(argv + 2, argv + argc);
  return RunReportingErrors(command, [&] { return fn(args); });
}

}  // namespace
}  // namespace tsc

int main(int argc, char** argv) { return tsc::Main(argc, argv); }
