#include "tools/classify_command.h"

#include <boost/program_options.hpp>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "drivers/dataset/dataset.h"
#include "settings/settings.h"
#include "tools/classify.h"
#include "tools/command_line.h"
#include "tools/events_json.h"
#include "tools/plots.h"

namespace tsc {
namespace {

namespace fs = std::filesystem;
namespace po = boost::program_options;
using Clock = std::chrono::steady_clock;

constexpr const char* kClassifyHelp =
    R"(usage: tsc classify train DATASET... --model FILE [--features L] [options]
       tsc classify test DATASET... --model FILE [--model FILE]... [--tau T]
                         [--json FILE] [--plots DIR]
       tsc classify cv DATASET... [--features L[,L]...] [--folds K] [--tau T]
                       [--json FILE] [--plots DIR]

Supervised place classification of thesis chapter 2: bubble descriptors of the labelled
frames (groundtruth.csv; frames with an empty label are skipped) and a multi-class C-SVC
with an RBF kernel (libsvm, one-against-one, probability estimates). A frame is classified
as the most probable place when its probability is at least the confidence threshold tau,
otherwise it stays unclassified. Scores: the ImageCLEF score (+1 correct, -1 wrong,
0 unclassified), precision = correct / classified, recall = correct / frames, per place.

  train  descriptors of every DATASET with the feature set L (L1..L5 as in section 2.3,
         N_I = 300, 600, 100, 400, 700; L2+I etc. add intensity), grid search of C and
         gamma by K-fold cross-validation (gamma relative to gamma0 = 1 / median squared
         distance between descriptors), then the final model with probability estimates,
         written to FILE with the descriptor settings it needs.
  test   classifies every labelled frame of the DATASETs with each model: score at tau,
         per-place precision and recall, the confusion matrix and the sweep of tau over
         0..1; --plots DIR writes pr_curve.png (one curve per model, as figures 2.5 and
         2.6) and confusion-<model>.png.
  cv     for each feature set, grid search and K-fold cross-validated probabilities of the
         DATASETs themselves, scored as by test (one curve per feature set).

Descriptor settings other than the features come from --config / --set (bubble.*,
descriptor.*); a model remembers them, so test needs none.

Options)";

struct Common {
  std::vector<fs::path> datasets;
  std::optional<fs::path> json, plots;
  double tau = 0.5;
};

void WriteFile(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::trunc);
  out << text;
  out.close();
  if (!out) throw std::runtime_error(path.string() + ": cannot write");
}

void WritePng(const fs::path& path, const cv::Mat& img) {
  if (!cv::imwrite(path.string(), img)) throw std::runtime_error(path.string() + ": cannot write");
}

std::string Fixed(double v, int decimals) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

std::string DatasetList(const std::vector<fs::path>& datasets) {
  std::string s;
  for (const fs::path& d : datasets) s += (s.empty() ? "" : ", ") + d.string();
  return s;
}

std::string JsonPaths(const std::vector<fs::path>& datasets) {
  std::string s = "[";
  for (size_t i = 0; i < datasets.size(); ++i) s += (i ? "," : "") + JsonString(datasets[i]);
  return s + "]";
}

ClassifierOptions GridOptions(const po::variables_map& vm) {
  ClassifierOptions o;
  if (vm.count("grid-c")) {
    const FromToStep g =
        ParseFromToStep("--grid-c", vm["grid-c"].as<std::string>(), "-1:9:2 (log2)");
    o.log2_c_from = g.from, o.log2_c_to = g.to, o.log2_c_step = g.step;
  }
  if (vm.count("grid-gamma")) {
    const FromToStep g =
        ParseFromToStep("--grid-gamma", vm["grid-gamma"].as<std::string>(), "-3:3:1.5 (log2)");
    o.log2_gamma_from = g.from, o.log2_gamma_to = g.to, o.log2_gamma_step = g.step;
  }
  o.folds = vm["folds"].as<int>();
  const long long seed = vm["seed"].as<long long>();
  if (seed < 0 || seed > 4294967295LL) throw UsageError("--seed must be in [0, 4294967295]");
  o.seed = static_cast<uint32_t>(seed);
  try {
    o.Validate();
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  return o;
}

// C and γ from --c/--gamma (both or neither), else nullopt (grid search).
std::optional<SvmParameters> FixedParameters(const po::variables_map& vm) {
  if (vm.count("c") != vm.count("gamma")) throw UsageError("--c and --gamma go together");
  if (!vm.count("c")) return std::nullopt;
  SvmParameters p{vm["c"].as<double>(), vm["gamma"].as<double>()};
  try {
    p.Validate();
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  return p;
}

// Grid search (or the fixed parameters), printed as a table of accuracies.
SvmParameters ChooseParameters(const LabelledDescriptors& data, const po::variables_map& vm,
                               const ClassifierOptions& grid_options, std::ostringstream& json,
                               double* seconds) {
  const Clock::time_point t0 = Clock::now();
  if (const std::optional<SvmParameters> fixed = FixedParameters(vm)) {
    std::printf("  parameters       C = %g, gamma = %g (given)\n", fixed->c, fixed->gamma);
    json << "\"grid\":null,\"c\":" << JsonNumber(fixed->c)
         << ",\"gamma\":" << JsonNumber(fixed->gamma) << ",\"cv_accuracy\":null";
    *seconds = 0.0;
    return *fixed;
  }
  const GridSearchResult grid = GridSearch(data, grid_options);
  *seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  std::printf("  grid search      %d-fold cross-validated accuracy, gamma0 = %.4g (%.1f s)\n",
              grid_options.folds, grid.gamma0, *seconds);
  const std::vector<double> cs = grid_options.CValues();
  std::printf("    gamma/gamma0 \\ C");
  for (double c : cs) std::printf(" %7g", c);
  std::printf("\n");
  size_t i = 0;
  for (double scale : grid_options.GammaScales()) {
    std::printf("    %-17.4g", scale);
    for (size_t j = 0; j < cs.size(); ++j, ++i) std::printf(" %7.3f", grid.points[i].accuracy);
    std::printf("\n");
  }
  std::printf("  chosen           C = %g, gamma = %.4g (gamma0 x %.3g), accuracy %.3f\n",
              grid.best.c, grid.best.gamma, grid.best.gamma / grid.gamma0, grid.best_accuracy);
  json << "\"grid\":{\"folds\":" << grid_options.folds << ",\"gamma0\":" << JsonNumber(grid.gamma0)
       << ",\"points\":[";
  for (size_t k = 0; k < grid.points.size(); ++k) {
    json << (k ? "," : "") << "[" << JsonNumber(grid.points[k].c) << ","
         << JsonNumber(grid.points[k].gamma) << "," << JsonNumber(grid.points[k].accuracy) << "]";
  }
  json << "]},\"c\":" << JsonNumber(grid.best.c) << ",\"gamma\":" << JsonNumber(grid.best.gamma)
       << ",\"cv_accuracy\":" << JsonNumber(grid.best_accuracy);
  return grid.best;
}

void AddCommonOptions(po::options_description& desc) {
  desc.add_options()("help,h", "show this help")(
      "tau", po::value<double>()->default_value(0.5, "0.5")->value_name("T"),
      "confidence threshold in [0, 1] (test, cv)")(
      "json", po::value<std::string>()->value_name("FILE"), "write the figures as JSON to FILE")(
      "plots", po::value<std::string>()->value_name("DIR"), "write PNG plots into DIR (test, cv)")(
      "model", po::value<std::vector<std::string>>()->composing()->value_name("FILE"),
      "model file to write (train) or read (test; repeatable)")(
      "features", po::value<std::string>()->value_name("L"),
      "feature set: L1..L5 (train, default L5); comma-separated list (cv, default L1,L2,L3,L4,L5)")(
      "c", po::value<double>()->value_name("C"), "SVM C: skip the grid search (with --gamma)")(
      "gamma", po::value<double>()->value_name("G"), "RBF gamma: skip the grid search (with --c)")(
      "folds", po::value<int>()->default_value(5)->value_name("K"), "cross-validation folds")(
      "grid-c", po::value<std::string>()->value_name("FROM:TO:STEP"),
      "log2 C of the grid (default -1:9:2)")("grid-gamma",
                                             po::value<std::string>()->value_name("FROM:TO:STEP"),
                                             "log2 gamma/gamma0 of the grid (default -3:3:1.5)")(
      "seed", po::value<long long>()->default_value(1)->value_name("N"),
      "seed of the folds and of libsvm's probability fit");
  AddConfigOptions(desc, "configuration file for bubble.* and descriptor.* (INI)");
}

FeatureSet Features(const std::string& name) {
  try {
    return ClassifyFeatureSet(name);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--features: ") + e.what());
  }
}

int Train(const po::variables_map& vm, const Common& common) {
  const std::vector<std::string> models =
      vm.count("model") ? vm["model"].as<std::vector<std::string>>() : std::vector<std::string>{};
  if (models.size() != 1) throw UsageError("train needs exactly one --model FILE to write");
  PipelineOptions options = SettingsFromCommandLine(vm).pipeline;
  options.features = Features(vm.count("features") ? vm["features"].as<std::string>() : "L5");
  const ClassifierOptions grid_options = GridOptions(vm);

  const LabelledFrames frames = ReadLabelledFrames(common.datasets, options);
  const LabelledDescriptors data = ToLabelledDescriptors(frames);
  std::printf(
      "tsc classify train: %s, %d labelled frames of %zu places (%d unlabelled skipped)\n"
      "  datasets         %s\n  descriptors      dimension %ld, median %.2f ms per frame\n",
      options.features.ToString().c_str(), frames.size(), data.places.size(), frames.unlabelled,
      DatasetList(common.datasets).c_str(), static_cast<long>(data.descriptors.rows()),
      MedianOf(frames.descriptor_ms));
  std::ostringstream json;
  json << "{\"datasets\":" << JsonPaths(common.datasets)
       << ",\"features\":" << JsonString(options.features.ToString())
       << ",\"frames\":" << frames.size() << ",\"unlabelled\":" << frames.unlabelled
       << ",\"descriptor_ms_median\":" << JsonNumber(MedianOf(frames.descriptor_ms)) << ",";
  double grid_seconds = 0.0;
  const SvmParameters params = ChooseParameters(data, vm, grid_options, json, &grid_seconds);
  const Clock::time_point t0 = Clock::now();
  const ClassifierModel model{options, PlaceClassifier::Train(data, params, grid_options.seed)};
  const double train_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  SaveModel(models.front(), model);
  std::printf(
      "  training         %.2f s (final model with probability estimates), %d support "
      "vectors\n  wrote            %s\n",
      train_seconds, model.classifier.num_support_vectors(), models.front().c_str());
  json << ",\"grid_seconds\":" << JsonNumber(grid_seconds)
       << ",\"train_seconds\":" << JsonNumber(train_seconds)
       << ",\"support_vectors\":" << model.classifier.num_support_vectors() << ",\"places\":[";
  for (size_t p = 0; p < data.places.size(); ++p) {
    json << (p ? "," : "") << JsonString(data.places[p]);
  }
  json << "]}\n";
  if (common.json) WriteFile(*common.json, json.str());
  return kExitOk;
}

void Report(const Common& common, const std::vector<ClassifyRun>& runs, const char* what) {
  for (const ClassifyRun& r : runs) std::printf("%s", FormatRun(r).c_str());
  if (common.json) {
    std::string text = "{\"command\":" + JsonString(what) +
                       ",\"datasets\":" + JsonPaths(common.datasets) + ",\"runs\":[";
    for (size_t i = 0; i < runs.size(); ++i) text += (i ? "," : "") + RunToJson(runs[i]);
    WriteFile(*common.json, text + "]}\n");
  }
  if (common.plots) {
    std::error_code ec;
    fs::create_directories(*common.plots, ec);
    if (ec) throw std::runtime_error(common.plots->string() + ": cannot create: " + ec.message());
    std::vector<NamedTauCurve> curves;
    for (const ClassifyRun& r : runs) {
      curves.push_back({r.name, r.curve});
      WritePng(*common.plots / ("confusion-" + r.name + ".png"),
               DrawConfusionMatrix(r.score.confusion, r.places,
                                   r.name + " (" + r.features + "), tau " + Fixed(r.tau, 2) +
                                       ": ImageCLEF score " + std::to_string(r.score.imageclef)));
    }
    WritePng(*common.plots / "pr_curve.png",
             DrawTauPrCurves(curves, std::string("place classification (") + what +
                                         "): precision-recall over tau"));
  }
}

int Test(const po::variables_map& vm, const Common& common) {
  const std::vector<std::string> models =
      vm.count("model") ? vm["model"].as<std::vector<std::string>>() : std::vector<std::string>{};
  if (models.empty()) throw UsageError("test needs at least one --model FILE");
  if (vm.count("features") || vm.count("c") || vm.count("gamma")) {
    throw UsageError("test takes the features and parameters from the model");
  }
  // Descriptors once per descriptor setting (models of the same features share them).
  std::map<std::string, LabelledFrames> cache;
  std::vector<ClassifyRun> runs;
  for (const std::string& file : models) {
    const ClassifierModel model = LoadModel(file);
    const Settings settings{model.descriptor, DaemonOptions{}};
    std::string key;
    for (const ConfigKey& k : ConfigTable()) {
      if (k.key.rfind("bubble.", 0) == 0 || k.key.rfind("descriptor.", 0) == 0) {
        key += k.key + "=" + k.get(settings) + "\n";
      }
    }
    auto it = cache.find(key);
    if (it == cache.end()) {
      it = cache.emplace(key, ReadLabelledFrames(common.datasets, model.descriptor)).first;
    }
    const LabelledFrames& frames = it->second;
    if (frames.descriptors.rows() != model.classifier.dim()) {
      throw std::runtime_error(file + ": the model expects descriptors of dimension " +
                               std::to_string(model.classifier.dim()) + ", its settings give " +
                               std::to_string(frames.descriptors.rows()));
    }
    Eigen::MatrixXd xi(model.classifier.num_places(), frames.size());
    std::vector<double> classify_ms;
    for (int i = 0; i < frames.size(); ++i) {
      const Clock::time_point t0 = Clock::now();
      xi.col(i) = model.classifier.Probabilities(frames.descriptors.col(i));
      classify_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    }
    ClassifyRun run = ScoreRun(fs::path(file).stem().string(), model.classifier.places(),
                               frames.labels, xi, common.tau);
    run.features = model.descriptor.features.ToString();
    run.descriptor_ms_median = MedianOf(frames.descriptor_ms);
    run.classify_ms_median = MedianOf(classify_ms);
    runs.push_back(std::move(run));
  }
  std::printf("tsc classify test: %s\n", DatasetList(common.datasets).c_str());
  Report(common, runs, "test");
  return kExitOk;
}

int CrossValidate(const po::variables_map& vm, const Common& common) {
  if (vm.count("model")) throw UsageError("cv writes no model; use train");
  const PipelineOptions base = SettingsFromCommandLine(vm).pipeline;
  const ClassifierOptions grid_options = GridOptions(vm);
  std::vector<std::string> names;
  std::stringstream list(vm.count("features") ? vm["features"].as<std::string>()
                                              : std::string("L1,L2,L3,L4,L5"));
  for (std::string name; std::getline(list, name, ',');) names.push_back(name);
  std::printf("tsc classify cv: %s\n", DatasetList(common.datasets).c_str());
  std::vector<ClassifyRun> runs;
  for (const std::string& name : names) {
    PipelineOptions options = base;
    options.features = Features(name);
    const LabelledFrames frames = ReadLabelledFrames(common.datasets, options);
    const LabelledDescriptors data = ToLabelledDescriptors(frames);
    std::printf("%s: %d labelled frames of %zu places\n", options.features.ToString().c_str(),
                frames.size(), data.places.size());
    std::ostringstream unused;
    double seconds = 0.0;
    const SvmParameters params = ChooseParameters(data, vm, grid_options, unused, &seconds);
    const Eigen::MatrixXd xi =
        CrossValidatedProbabilities(data, params, grid_options.folds, grid_options.seed);
    ClassifyRun run = ScoreRun(name, data.places, frames.labels, xi, common.tau);
    run.features = options.features.ToString();
    run.descriptor_ms_median = MedianOf(frames.descriptor_ms);
    run.classify_ms_median = -1.0;  // not timed: the folds' models differ
    runs.push_back(std::move(run));
  }
  Report(common, runs, "cv");
  return kExitOk;
}

int Classify(const std::vector<std::string>& args) {
  po::options_description desc(kClassifyHelp);
  AddCommonOptions(desc);
  po::options_description hidden;
  hidden.add_options()("positional", po::value<std::vector<std::string>>(), "MODE DATASET...");
  po::options_description all;
  all.add(desc).add(hidden);
  po::positional_options_description positional;
  positional.add("positional", -1);
  const po::variables_map vm = ParseCommandLine(args, all, &positional);
  if (vm.count("help")) {
    std::cout << desc << "\n";
    return kExitOk;
  }
  const std::vector<std::string> words = vm.count("positional")
                                             ? vm["positional"].as<std::vector<std::string>>()
                                             : std::vector<std::string>{};
  if (words.empty()) throw UsageError("expected train, test or cv");
  const std::string mode = words.front();
  if (mode != "train" && mode != "test" && mode != "cv") {
    throw UsageError("unknown mode '" + mode + "' (train, test or cv)");
  }
  Common common;
  for (size_t i = 1; i < words.size(); ++i) common.datasets.emplace_back(words[i]);
  if (common.datasets.empty()) throw UsageError(mode + " needs at least one DATASET");
  common.tau = vm["tau"].as<double>();
  if (!(common.tau >= 0.0 && common.tau <= 1.0)) throw UsageError("--tau must be in [0, 1]");
  if (vm.count("json")) common.json = vm["json"].as<std::string>();
  if (vm.count("plots")) common.plots = vm["plots"].as<std::string>();
  if (mode == "train") return Train(vm, common);
  if (mode == "test") return Test(vm, common);
  return CrossValidate(vm, common);
}

}  // namespace

int RunClassifyCommand(const std::vector<std::string>& args) {
  return RunReportingErrors("classify", [&] { return Classify(args); });
}

}  // namespace tsc
