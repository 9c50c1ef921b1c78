// `tsc eval`: the pipeline on a fresh memory, scored against the dataset's ground truth.

#include "tools/eval_command.h"

#include <algorithm>
#include <boost/program_options.hpp>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "drivers/dataset/assumed_keyframes_check.h"
#include "drivers/dataset/dataset.h"
#include "settings/settings.h"
#include "tools/command_line.h"
#include "tools/eval.h"
#include "tools/plots.h"

namespace tsc {
namespace {
namespace fs = std::filesystem;
namespace po = boost::program_options;

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
places_per_label (the final memory's places over the labels they hold; null without labels),
detection.{boundary_f1,precision,recall} (with labels), recognition.{precision,recall,
recall_at_full_precision,pr_curve:[[tau_r,precision,recall],...],sweep_counts:[[tau_r,
recognitions,correct,should_be_recognized],...]} and, with poses,
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

}  // namespace

int RunEvalCommand(const std::vector<std::string>& args) {
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
  const po::variables_map vm = ParseCommandLine(args, desc, &pos);
  if (vm.count("help")) {
    std::cout << desc << "\n";
    return kExitOk;
  }
  const EvalOptions eval =
      vm.count("sweep") ? ParseSweep(vm["sweep"].as<std::string>()) : EvalOptions{};
  const Settings settings = SettingsWithRobotOption(vm);
  const fs::path dataset_dir = vm["dataset"].as<std::string>();
  const fs::path json_path = vm["json"].as<std::string>();
  std::ostringstream spacing;  // said after the summary line
  const Dataset opened = Dataset::Open(dataset_dir, DatasetOptionsOf(settings));
  const auto [dataset, options, frames_apart, stride, lens] =
      PrepareDataset(settings, opened, &spacing);
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
  if (r.truth.has_labels()) {
    std::printf(
        "  places per label %.2f (the final memory's %d places, each under the majority "
        "label of its frames)\n",
        r.main.places_per_label, r.main.learned_places);
  }
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

}  // namespace tsc
