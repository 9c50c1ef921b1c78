// `tsc classify` on small simulated RGB-D data (thesis chapter 2, issue 7): one office world
// with nine labelled places (eight rooms and the corridor) walked along three routes: a day
// training pass, a night training pass and a night test pass (160x120, a short look-around
// per room). The experiments' shape at full size is in docs/results.md.

#include "tools/classify.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <string>

#include "drivers/world/dataset_writer.h"
#include "test/support/temp_dir.h"
#include "test/support/tsc_command.h"

namespace tsc {
namespace {
namespace fs = std::filesystem;
using testing_support::Quote;
using testing_support::ReadFile;
using testing_support::RunTsc;
using testing_support::TempDir;

constexpr std::uint32_t kWorldSeed = 4;  // office world with 4 rooms per side: 9 places

fs::path WritePass(const fs::path& dir, const char* name, std::uint32_t route_seed,
                   sim::LightingMode lighting, int max_frames) {
  sim::SimOptions o;
  o.world = sim::WorldKind::kOffice;
  o.seed = kWorldSeed;
  o.route_seed = route_seed;
  o.lighting = lighting;
  o.depth = true;
  o.png = true;
  o.render.width = 160;
  o.render.height = 120;
  o.route.dwell_frames = 16;
  o.route.scan_step_deg = 22.5;
  o.route.step_m = 0.45;  // a third of the travel frames of the default
  o.max_frames = max_frames;
  const fs::path out = dir / name;
  sim::WriteSimulatedDataset(out, o);
  return out;
}

// ctest runs every test in its own process: each test writes only the passes it uses.
class ClassifyTest : public ::testing::Test {
 protected:
  ClassifyTest() : dir_("classify_test") {}
  fs::path Day() { return WritePass(dir_.path(), "day", 21, sim::LightingMode::kDay, 0); }
  fs::path Night() { return WritePass(dir_.path(), "night", 22, sim::LightingMode::kDim, 0); }
  fs::path NightTest() { return WritePass(dir_.path(), "test", 23, sim::LightingMode::kDim, 0); }
  // The first 240 frames of the day pass: for the command line's plumbing.
  fs::path ShortDay() { return WritePass(dir_.path(), "short", 21, sim::LightingMode::kDay, 240); }

  // Trains on `train` with feature set `features` and scores it on `test`.
  static ClassifyRun TrainAndTest(const std::vector<fs::path>& train, const fs::path& test,
                                  const std::string& features) {
    PipelineOptions options;
    options.features = ClassifyFeatureSet(features);
    const LabelledDescriptors data = ToLabelledDescriptors(ReadLabelledFrames(train, options));
    // Fixed C and γ (near what the grid search picks at full size, docs/results.md): the grid
    // search itself is tested in place_classifier_test and through the command line below.
    const SvmParameters params{64.0, 2.0 * MedianGamma(data.descriptors)};
    const PlaceClassifier classifier = PlaceClassifier::Train(data, params);
    const LabelledFrames frames = ReadLabelledFrames({test}, options);
    Eigen::MatrixXd xi(classifier.num_places(), frames.size());
    for (int i = 0; i < frames.size(); ++i) {
      xi.col(i) = classifier.Probabilities(frames.descriptors.col(i));
    }
    ClassifyRun run = ScoreRun(features, classifier.places(), frames.labels, xi, 0.5);
    std::cout << features << " trained on " << train.size() << " pass(es): best ImageCLEF score "
              << run.best_imageclef << " of " << frames.size() << " frames (tau " << run.best_tau
              << "), at tau 0.5: " << run.score.imageclef << "\n";
    return run;
  }

  TempDir dir_;
};

// The two findings of chapter 2 the issue asks for, on one set of passes (one process).
TEST_F(ClassifyTest, VisionAndDepthBeatDepthOnlyAndDayNightTrainingBeatsDayOnly) {
  const fs::path day = Day(), night = Night(), test = NightTest();
  for (const fs::path& pass : {day, night, test}) {
    const LabelledFrames frames = ReadLabelledFrames({pass}, PipelineOptions{});
    EXPECT_EQ(ToLabelledDescriptors(frames).places.size(), 9u) << pass;
    EXPECT_GT(frames.unlabelled, 0) << pass;  // doorway frames are skipped
  }
  const int l3 = TrainAndTest({day, night}, test, "L3").best_imageclef;
  const int l4 = TrainAndTest({day, night}, test, "L4").best_imageclef;
  const int l5 = TrainAndTest({day, night}, test, "L5").best_imageclef;
  EXPECT_GT(l4, l3);
  EXPECT_GT(l5, l3);
  EXPECT_GT(l5, TrainAndTest({day}, test, "L5").best_imageclef);
}

TEST_F(ClassifyTest, AGridThatIsNotFromToStepIsAUsageError) {
  const fs::path day = ShortDay();
  const fs::path model = dir_.path() / "bad-grid.model";
  for (const std::string grid : {"--grid-c 1:7", "--grid-gamma 0:x:1", "--grid-c 1:7:3:4"}) {
    const auto r = RunTsc(dir_.path(), "classify train " + Quote(day.string()) + " --model " +
                                           Quote(model.string()) + " " + grid);
    EXPECT_EQ(r.code, 2) << grid << ": " << r.err;
    EXPECT_NE(r.err.find(grid.substr(0, grid.find(' '))), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(model)) << grid;
  }
}

TEST_F(ClassifyTest, TrainThenTestThroughTheCommandLine) {
  const fs::path day = ShortDay();
  const fs::path scratch = dir_.path() / "cli";
  fs::create_directories(scratch);
  const fs::path model = scratch / "day-L4.model";
  auto r = RunTsc(scratch, "classify train " + Quote(day.string()) + " --features L4 --model " +
                               Quote(model.string()) + " --grid-c 1:7:3 --grid-gamma 0:0:1" +
                               " --json " + Quote((scratch / "train.json").string()));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("chosen"), std::string::npos) << r.out;
  EXPECT_NE(ReadFile(scratch / "train.json").find("\"cv_accuracy\":"), std::string::npos);
  const ClassifierModel loaded = LoadModel(model);
  EXPECT_EQ(loaded.descriptor.features.ToString(), "L4-I");
  EXPECT_EQ(loaded.classifier.dim(), 400);

  r = RunTsc(scratch, "classify test " + Quote(day.string()) + " --model " + Quote(model.string()) +
                          " --tau 0.4 --json " + Quote((scratch / "test.json").string()) +
                          " --plots " + Quote((scratch / "plots").string()));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("ImageCLEF score"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("confusion"), std::string::npos) << r.out;
  const std::string json = ReadFile(scratch / "test.json");
  for (const char* key : {"\"imageclef\":", "\"confusion\":", "\"pr_curve\":", "\"places\":",
                          "\"classify_ms_median\":"}) {
    EXPECT_NE(json.find(key), std::string::npos) << key << " in " << json;
  }
  EXPECT_GT(fs::file_size(scratch / "plots" / "pr_curve.png"), 1000u);
  EXPECT_GT(fs::file_size(scratch / "plots" / "confusion-day-L4.png"), 1000u);
}

TEST_F(ClassifyTest, CrossValidationScoresEveryFeatureSetAsked) {
  const fs::path day = ShortDay();
  const fs::path scratch = dir_.path() / "cv";
  fs::create_directories(scratch);
  const auto r = RunTsc(scratch, "classify cv " + Quote(day.string()) +
                                     " --features L1,L3 --c 8 --gamma 10000 --json " +
                                     Quote((scratch / "cv.json").string()) + " --plots " +
                                     Quote((scratch / "plots").string()));
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string json = ReadFile(scratch / "cv.json");
  EXPECT_NE(json.find("\"features\":\"L1-I\""), std::string::npos) << json;
  EXPECT_NE(json.find("\"features\":\"L3-I\""), std::string::npos) << json;
  EXPECT_TRUE(fs::exists(scratch / "plots" / "confusion-L3.png"));
}

TEST_F(ClassifyTest, BadInputGetsAClearErrorNamingTheFileOrOption) {
  const fs::path day = ShortDay();
  const fs::path scratch = dir_.path() / "bad";
  fs::create_directories(scratch);
  // A dataset without ground truth.
  fs::create_directories(scratch / "nolabels");
  fs::copy_file(day / "000001.png", scratch / "nolabels" / "000001.png");
  auto r = RunTsc(scratch, "classify train " + Quote((scratch / "nolabels").string()) +
                               " --model " + Quote((scratch / "m").string()));
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("nolabels: no groundtruth.csv"), std::string::npos) << r.err;
  // Depth features without depth/.
  fs::create_directories(scratch / "nodepth");
  fs::copy_file(day / "000001.png", scratch / "nodepth" / "000001.png");
  std::ofstream(scratch / "nodepth" / "groundtruth.csv") << "frame,place\n1,room1\n";
  r = RunTsc(scratch, "classify train " + Quote((scratch / "nodepth").string()) +
                          " --features L3 --model " + Quote((scratch / "m").string()));
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("no depth/ folder"), std::string::npos) << r.err;
  // A corrupt model names the file and line.
  std::ofstream(scratch / "bad.model") << "tsc-classify-model 1\nbubble.nonsense = 3\n";
  r = RunTsc(scratch, "classify test " + Quote(day.string()) + " --model " +
                          Quote((scratch / "bad.model").string()));
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("bad.model:2:"), std::string::npos) << r.err;
  // Usage errors.
  EXPECT_EQ(RunTsc(scratch, "classify fit " + Quote(day.string())).code, 2);
  EXPECT_EQ(RunTsc(scratch, "classify train " + Quote(day.string())).code, 2);  // no --model
  EXPECT_EQ(RunTsc(scratch, "classify cv " + Quote(day.string()) + " --features L9").code, 2);
  EXPECT_EQ(RunTsc(scratch, "classify test " + Quote(day.string()) + " --model x --tau 2").code, 2);
}

TEST(ClassifyHelpTest, HelpDescribesTheModesAndExitsZero) {
  TempDir scratch("classify_help");
  const auto r = RunTsc(scratch.path(), "classify --help");
  EXPECT_EQ(r.code, 0) << r.err;
  for (const char* word : {"usage: tsc classify train", "ImageCLEF", "--tau", "--features"}) {
    EXPECT_NE(r.out.find(word), std::string::npos) << word;
  }
  EXPECT_NE(RunTsc(scratch.path(), "--help").out.find("classify"), std::string::npos);
}

}  // namespace
}  // namespace tsc
