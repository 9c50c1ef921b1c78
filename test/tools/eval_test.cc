// tsc eval on real frames (../shared/data/rtabmap-loop, revisits only) and on a small
// synthetic dataset with labels and poses (boundaries, edge precision, floor plan).

#include "tools/eval.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <sstream>

#include "tools/plots.h"

namespace tsc {
namespace {
namespace fs = std::filesystem;

class EvalTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("tscd_eval_test_" + std::string(info->name()) + "_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Rooms a, b, c visited along a -> b -> c -> b -> a, 10 panning frames each, separated by
  // 3 dark frames (unlabelled transitions); poses along a line, rooms 5 m apart.
  fs::path MakeLabelledDataset() {
    const fs::path ds = dir_ / "rooms";
    fs::create_directories(ds);
    std::mt19937 rng(7);
    std::vector<cv::Mat> rooms;
    const cv::Scalar tint[3] = {{1.0, 1.0, 1.0}, {1.0, 0.8, 0.5}, {0.5, 0.8, 1.0}};  // BGR
    std::uniform_int_distribution<int> value(40, 215);
    for (int room = 0; room < 3; ++room) {
      cv::Mat scene(120, 400, CV_8UC3);
      for (int y = 0; y < scene.rows; y += 8) {
        for (int x = 0; x < scene.cols; x += 8) {
          const cv::Scalar& t = tint[room];
          scene(cv::Rect(x, y, 8, 8))
              .setTo(cv::Scalar(t[0] * value(rng), t[1] * value(rng), t[2] * value(rng)));
        }
      }
      rooms.push_back(scene);
    }
    std::ofstream gt(ds / "groundtruth.csv");
    gt << "frame,place,x,y,heading\n";
    int frame = 0;
    const auto write = [&](const cv::Mat& img, const std::string& label, double x) {
      ++frame;
      ASSERT_TRUE(cv::imwrite((ds / (std::to_string(frame) + ".png")).string(), img));
      gt << frame << "," << label << "," << x << "," << 0.1 * (frame % 4) << ",0\n";
    };
    const int route[] = {0, 1, 2, 1, 0};
    for (int v = 0; v < 5; ++v) {
      if (v > 0) {
        const double door = 2.5 * (route[v - 1] + route[v]) + 1.0;
        for (int t = 0; t < 3; ++t) {
          write(cv::Mat(120, 160, CV_8UC3, cv::Scalar(3, 3, 3)), "", door);
        }
      }
      const int room = route[v];
      for (int i = 0; i < 10; ++i) {
        write(rooms[static_cast<size_t>(room)](cv::Rect(2 * i, 0, 160, 120)).clone(),
              std::string(1, static_cast<char>('a' + room)), 5.0 * room + 0.2 * i);
      }
    }
    gt.close();
    return ds;
  }

  fs::path dir_;
};

void ExpectPng(const fs::path& p, int min_width, int min_height) {
  ASSERT_TRUE(fs::exists(p)) << p;
  EXPECT_GT(fs::file_size(p), 0u) << p;
  const cv::Mat img = cv::imread(p.string());
  ASSERT_FALSE(img.empty()) << p;
  EXPECT_GE(img.cols, min_width) << p;
  EXPECT_GE(img.rows, min_height) << p;
}

TEST_F(EvalTest, RtabmapLoopRecognisesWithFullPrecisionAndWritesPlots) {
  const fs::path folder = fs::path(TSCD_DATA_DIR) / "rtabmap-loop";
  if (!fs::exists(folder)) GTEST_SKIP() << folder << " is not present";
  const Dataset dataset = Dataset::Open(folder);
  const EvalResult r = Evaluate(dataset, PipelineOptions{}, EvalOptions{});

  EXPECT_EQ(r.frames, 84);
  EXPECT_EQ(r.good + r.uninformative + r.incoherent, 84);
  EXPECT_GE(r.main.learned_places, 3);
  EXPECT_DOUBLE_EQ(r.main.recognition.precision, 1.0);
  EXPECT_GT(r.main.recognition.recall, 0.0);
  EXPECT_GT(r.recall_at_full_precision, 0.0);
  EXPECT_FALSE(r.boundaries.has_value());  // no labels
  ASSERT_EQ(r.pr_curve.size(), 21u);       // 1.0:2.0:0.05
  for (size_t i = 1; i < r.pr_curve.size(); ++i) {
    EXPECT_LT(r.pr_curve[i - 1].tau_r, r.pr_curve[i].tau_r);
  }
  EXPECT_DOUBLE_EQ(r.pr_curve.front().tau_r, 1.0);
  EXPECT_DOUBLE_EQ(r.pr_curve.back().tau_r, 2.0);
  EXPECT_GT(r.descriptor_ms_median, 0.0);
  EXPECT_GE(r.frame_ms_median, r.descriptor_ms_median);

  std::ostringstream json;
  WriteEvalJson(json, r);
  const std::string text = json.str();
  for (const char* key :
       {"\"frames\":84", "\"detected_places\":", "\"learned_places\":", "\"recognition\":{",
        "\"precision\":1,", "\"recall\":", "\"recall_at_full_precision\":", "\"pr_curve\":[[1,",
        "\"map\":{", "\"edges\":", "\"timing\":{",
        "\"descriptor_ms_median\":", "\"frame_ms_median\":", "\"memory.tau_r\":1.3"}) {
    EXPECT_NE(text.find(key), std::string::npos) << key << " in " << text;
  }
  EXPECT_EQ(text.find("nan"), std::string::npos);
  EXPECT_EQ(text.find("\"detection\""), std::string::npos);  // no labels, no boundary F1

  const auto written = WritePlots(r, dataset, dir_ / "plots");
  EXPECT_EQ(written.size(), 3u);  // no poses: no floor plan
  ExpectPng(dir_ / "plots" / "timeline.png", 900, 250);
  ExpectPng(dir_ / "plots" / "pr_curve.png", 500, 500);
  ExpectPng(dir_ / "plots" / "memory_map.png", 100, 100);
  EXPECT_FALSE(fs::exists(dir_ / "plots" / "floor_plan.png"));
}

TEST_F(EvalTest, LabelledDatasetScoresBoundariesEdgesAndDrawsFloorPlan) {
  const Dataset dataset = Dataset::Open(MakeLabelledDataset());
  ASSERT_EQ(dataset.size(), 62);
  EvalOptions eval;
  eval.sweep_from = 1.0, eval.sweep_to = 1.6, eval.sweep_step = 0.2;
  const EvalResult r = Evaluate(dataset, PipelineOptions{}, eval);

  ASSERT_TRUE(r.boundaries.has_value());
  EXPECT_EQ(r.boundaries->true_boundaries, 4);
  EXPECT_EQ(r.boundaries->tolerance, 3);
  EXPECT_GT(r.boundaries->f1, 0.5)
      << "detected " << r.boundaries->detected_boundaries << ", matched " << r.boundaries->matched;
  EXPECT_DOUBLE_EQ(r.main.recognition.precision, 1.0);
  ASSERT_TRUE(r.edges.has_value());
  EXPECT_EQ(r.edges->edges, static_cast<int>(r.main.map.edges().size()));
  ASSERT_EQ(r.pr_curve.size(), 4u);
  EXPECT_DOUBLE_EQ(r.pr_curve[3].tau_r, 1.6);

  std::ostringstream json;
  WriteEvalJson(json, r);
  for (const char* key : {"\"detection\":{\"boundary_f1\":", "\"edge_precision\":"}) {
    EXPECT_NE(json.str().find(key), std::string::npos) << key << " in " << json.str();
  }
  const auto written = WritePlots(r, dataset, dir_ / "plots");
  EXPECT_EQ(written.size(), 4u);
  ExpectPng(dir_ / "plots" / "floor_plan.png", 500, 200);
  ExpectPng(dir_ / "plots" / "timeline.png", 900, 250);
}

TEST(EvalOptions, SweepValuesAreInclusiveAndValidated) {
  EvalOptions e;
  const std::vector<double> v = e.SweepValues();
  ASSERT_EQ(v.size(), 21u);
  EXPECT_DOUBLE_EQ(v[6], 1.3);
  e.sweep_step = 0;
  EXPECT_TRUE(e.SweepValues().empty());
  e.sweep_from = 2.0, e.sweep_to = 1.0;
  EXPECT_THROW(e.Validate(), std::invalid_argument);
}

}  // namespace
}  // namespace tsc
