// Runs the real `tsc` binary (build/bin/tsc) as a subprocess and checks its contract
// (DESIGN §7.2): exit codes 0/1/2/78 and error messages that name the file or key at fault.

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <sstream>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "test/support/image_bombs.h"
#include "test/support/temp_dir.h"
#include "test/support/tsc_command.h"

namespace tsc {
namespace {
namespace fs = std::filesystem;

using Outcome = testing_support::TscOutcome;
using testing_support::Quote;
using testing_support::ReadFile;

class TscCliTest : public ::testing::Test {
 protected:
  /// Runs `tsc ARGS` (already quoted) with stdout and stderr captured.
  Outcome Tsc(const std::string& args) { return testing_support::RunTsc(dir_, args); }

  /// `n` frames of a slowly panning textured scene, as a dataset folder.
  fs::path MakeDataset(int n) {
    const fs::path ds = dir_ / "dataset";
    fs::create_directories(ds);
    std::mt19937 rng(42);
    std::uniform_int_distribution<int> value(40, 215);
    cv::Mat scene(120, 400, CV_8UC3);
    for (int y = 0; y < scene.rows; y += 4) {
      for (int x = 0; x < scene.cols; x += 4) {
        const cv::Vec3b c(static_cast<uint8_t>(value(rng)), static_cast<uint8_t>(value(rng)),
                          static_cast<uint8_t>(value(rng)));
        scene(cv::Rect(x, y, 4, 4)).setTo(cv::Scalar(c[0], c[1], c[2]));
      }
    }
    for (int i = 0; i < n; ++i) {
      const cv::Mat frame = scene(cv::Rect(2 * i, 0, 160, 120)).clone();
      EXPECT_TRUE(cv::imwrite((ds / (std::to_string(i + 1) + ".png")).string(), frame));
    }
    return ds;
  }

  testing_support::TempDir temp_{"tscd_cli_test"};
  fs::path dir_ = temp_.path();
};

TEST_F(TscCliTest, HelpExitsZero) {
  for (const char* args :
       {"--help", "run --help", "eval --help", "inspect --help", "config --help"}) {
    const Outcome o = Tsc(args);
    EXPECT_EQ(o.code, 0) << args << ": " << o.err;
    EXPECT_NE(o.out.find("usage: tsc"), std::string::npos) << args;
  }
}

TEST_F(TscCliTest, VersionPrintsTheProjectVersion) {
  const Outcome o = Tsc("--version");
  EXPECT_EQ(o.code, 0) << o.err;
  EXPECT_EQ(o.out, "tsc " TSCD_VERSION "\n");
}

TEST_F(TscCliTest, NoCommandIsAUsageError) {
  EXPECT_EQ(Tsc("").code, 2);
  EXPECT_EQ(Tsc("frobnicate").code, 2);
}

TEST_F(TscCliTest, MissingDatasetFolderExits1NamingIt) {
  const fs::path missing = dir_ / "no_such_dataset";
  const Outcome o =
      Tsc("run " + Quote(missing.string()) + " --db " + Quote((dir_ / "x.db").string()));
  EXPECT_EQ(o.code, 1) << o.err;
  EXPECT_EQ(o.err.rfind("tsc: ", 0), 0u) << o.err;
  EXPECT_NE(o.err.find(missing.string()), std::string::npos) << o.err;
}

TEST_F(TscCliTest, EmptyFolderExits1NamingIt) {
  const fs::path empty = dir_ / "empty";
  fs::create_directories(empty);
  const Outcome o =
      Tsc("run " + Quote(empty.string()) + " --db " + Quote((dir_ / "x.db").string()));
  EXPECT_EQ(o.code, 1) << o.err;
  EXPECT_NE(o.err.find(empty.string()), std::string::npos) << o.err;
}

TEST_F(TscCliTest, ZeroSizeImageExits1NamingIt) {
  const fs::path ds = MakeDataset(3);
  std::ofstream(ds / "4.png").close();
  const Outcome o = Tsc("run " + Quote(ds.string()) + " --db " + Quote((dir_ / "x.db").string()));
  EXPECT_EQ(o.code, 1) << o.err;
  EXPECT_NE(o.err.find("4.png"), std::string::npos) << o.err;
}

// `tsc ARGS...` run directly (no shell between), stdout and stderr to files in `dir`; returns
// the exit code (-1 when killed) and the child's own peak resident set (wait4), kB.
std::pair<int, long> RunTscMeasured(const fs::path& dir, const std::vector<std::string>& args) {
  std::vector<std::string> argv = {std::string(TSCD_BIN_DIR) + "/tsc"};
  argv.insert(argv.end(), args.begin(), args.end());
  std::fflush(nullptr);  // or the child's freopen writes what this process had buffered
  const pid_t pid = fork();
  if (pid == 0) {
    const std::string out = (dir / "stdout.txt").string(), err = (dir / "stderr.txt").string();
    if (!std::freopen(out.c_str(), "w", stdout) || !std::freopen(err.c_str(), "w", stderr)) {
      _exit(127);
    }
    std::vector<char*> raw;
    for (std::string& a : argv) raw.push_back(a.data());
    raw.push_back(nullptr);
    execv(raw[0], raw.data());
    _exit(127);
  }
  int status = 0;
  rusage usage{};
  if (pid < 0 || wait4(pid, &status, 0, &usage) != pid) return {-1, -1};
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, usage.ru_maxrss};
}

// Issue 18: `tsc run` on a folder holding a decompression bomb (the 1.1 MB PNG of zeros that
// claims 20000x20000, or a JPEG claiming 20512x35225) exits 1 naming the file and the size
// its header claims, and never comes near decoding it: its peak RSS stays under 150 MB (it
// was 1.25 GB for the PNG before).
TEST_F(TscCliTest, RunOnADecompressionBombExits1NamingFileAndClaimedSize) {
  for (const auto& [name, bytes, claim] :
       {std::tuple{std::string("1.png"), testing_support::ZeroPngBomb(20000, 20000),
                   std::string("20000x20000")},
        std::tuple{std::string("1.jpg"), testing_support::ForgedJpegBomb(),
                   std::string("20512x35225")}}) {
    const fs::path ds = dir_ / ("bomb-" + claim);
    fs::create_directories(ds);
    testing_support::WriteBytes(ds / name, bytes);
    const auto [code, peak_kb] =
        RunTscMeasured(dir_, {"run", ds.string(), "--db", (dir_ / (claim + ".db")).string()});
    const std::string err = ReadFile(dir_ / "stderr.txt");
    EXPECT_EQ(code, 1) << err;
    EXPECT_NE(err.find((ds / name).string()), std::string::npos) << err;
    EXPECT_NE(err.find("claims " + claim + " pixels"), std::string::npos) << err;
    std::printf("tsc run on the %s bomb: exit %d, peak RSS %ld kB\n", claim.c_str(), code, peak_kb);
    EXPECT_GT(peak_kb, 0);
    EXPECT_LT(peak_kb, 150 * 1024);
  }
}

TEST_F(TscCliTest, UnknownOptionExits2) {
  const Outcome o = Tsc("run --frobnicate " + Quote(dir_.string()));
  EXPECT_EQ(o.code, 2) << o.err;
  EXPECT_NE(o.err.find("frobnicate"), std::string::npos) << o.err;
  EXPECT_EQ(Tsc("run " + Quote(dir_.string())).code, 2);  // --db missing
}

TEST_F(TscCliTest, BadConfigKeyExits78NamingFileAndKey) {
  const fs::path ds = MakeDataset(2);
  const fs::path ini = dir_ / "bad.ini";
  std::ofstream(ini) << "[detection]\ntau_bogus = 3\n";
  const Outcome o = Tsc("run " + Quote(ds.string()) + " --db " + Quote((dir_ / "x.db").string()) +
                        " --config " + Quote(ini.string()));
  EXPECT_EQ(o.code, 78) << o.err;
  EXPECT_NE(o.err.find("bad.ini"), std::string::npos) << o.err;
  EXPECT_NE(o.err.find("detection.tau_bogus"), std::string::npos) << o.err;
  EXPECT_FALSE(fs::exists(dir_ / "x.db"));  // nothing created before the configuration is good

  const Outcome range = Tsc("config --set memory.tau_h=3");
  EXPECT_EQ(range.code, 78) << range.err;
  EXPECT_NE(range.err.find("memory.tau_h"), std::string::npos) << range.err;
}

TEST_F(TscCliTest, RunThenInspect) {
  const fs::path ds = MakeDataset(12);
  const fs::path db = dir_ / "run.db", events = dir_ / "events.jsonl";
  const Outcome run = Tsc("run " + Quote(ds.string()) + " --db " + Quote(db.string()) +
                          " --events " + Quote(events.string()));
  ASSERT_EQ(run.code, 0) << run.err;
  EXPECT_NE(run.out.find("12 frames"), std::string::npos) << run.out;
  EXPECT_TRUE(run.err.empty()) << run.err;  // no progress bar: stderr is not a terminal

  const std::string lines = ReadFile(events);
  EXPECT_NE(lines.find("\"event\":\"learned\""), std::string::npos) << lines;
  std::istringstream in(lines);
  for (std::string line; std::getline(in, line);) {
    EXPECT_EQ(line.rfind("{\"frame\":", 0), 0u) << line;
    EXPECT_EQ(line.back(), '}') << line;
  }

  const Outcome inspect = Tsc("inspect --json --db " + Quote(db.string()));
  ASSERT_EQ(inspect.code, 0) << inspect.err;
  const std::string& json = inspect.out;
  ASSERT_FALSE(json.empty());
  EXPECT_EQ(json.front(), '{') << json;
  EXPECT_EQ(json[json.find_last_not_of(" \n")], '}') << json;
  const size_t at = json.find("\"learned_places\":");
  ASSERT_NE(at, std::string::npos) << json;
  EXPECT_GE(std::atoi(json.c_str() + at + 17), 1) << json;
  EXPECT_NE(json.find("\"base_points\":12"), std::string::npos) << json;
  EXPECT_NE(json.find("\"base_points_seen\":12"), std::string::npos) << json;

  const fs::path dot = dir_ / "memory.dot";
  const Outcome text = Tsc("inspect --db " + Quote(db.string()) + " --dot " + Quote(dot.string()));
  ASSERT_EQ(text.code, 0) << text.err;
  EXPECT_NE(text.out.find("learned places"), std::string::npos) << text.out;
  EXPECT_NE(ReadFile(dot).find("digraph"), std::string::npos);
  // The store may be named without --db, as `tsc run` takes its dataset.
  const Outcome positional = Tsc("inspect " + Quote(db.string()));
  ASSERT_EQ(positional.code, 0) << positional.err;
  EXPECT_EQ(positional.out, text.out);
  EXPECT_EQ(Tsc("inspect " + Quote(db.string()) + " --db " + Quote(db.string())).code, 2);

  // Running again continues the same store.
  const Outcome again = Tsc("run " + Quote(ds.string()) + " --db " + Quote(db.string()));
  ASSERT_EQ(again.code, 0) << again.err;
  const Outcome after = Tsc("inspect --json --db " + Quote(db.string()));
  EXPECT_NE(after.out.find("\"base_points\":24"), std::string::npos) << after.out;
}

// A store learned with other features (as with config/sweep.ini: L2+I, views as descriptors)
// is inspected whatever the configuration, in its own space, and the summary says so; `tsc
// run` under the defaults refuses to continue it with a configuration error naming the store
// (it used to refuse every frame), and continues it under its own configuration.
TEST_F(TscCliTest, AStoreLearnedWithOtherFeaturesIsInspectedAndContinuedOnlyUnderThem) {
  const fs::path ds = MakeDataset(12);
  const fs::path db = dir_ / "l2.db";
  const std::string own = " --set bubble.features=L2+I --set memory.view_basis=none";
  ASSERT_EQ(Tsc("run " + Quote(ds.string()) + " --db " + Quote(db.string()) + own).code, 0);

  const Outcome inspect = Tsc("inspect " + Quote(db.string()));
  ASSERT_EQ(inspect.code, 0) << inspect.err;
  EXPECT_NE(inspect.out.find("descriptors      dimension 700, member views as descriptors (not "
                             "the configuration's"),
            std::string::npos)
      << inspect.out;
  const Outcome json = Tsc("inspect --json " + Quote(db.string()) + own);
  ASSERT_EQ(json.code, 0) << json.err;
  EXPECT_NE(json.out.find("\"descriptor_dimension\":700,\"view_basis\":\"none\","
                          "\"configuration_fits\":true"),
            std::string::npos)
      << json.out;

  const Outcome refused = Tsc("run " + Quote(ds.string()) + " --db " + Quote(db.string()));
  EXPECT_EQ(refused.code, 78) << refused.err;
  EXPECT_NE(refused.err.find(db.string()), std::string::npos) << refused.err;
  EXPECT_NE(refused.err.find("dimension 700"), std::string::npos) << refused.err;
  const Outcome again = Tsc("run " + Quote(ds.string()) + " --db " + Quote(db.string()) + own);
  ASSERT_EQ(again.code, 0) << again.err;
  EXPECT_NE(Tsc("inspect --json " + Quote(db.string())).out.find("\"base_points\":24"),
            std::string::npos);
}

TEST_F(TscCliTest, InspectMissingStoreExits1NamingIt) {
  const fs::path db = dir_ / "absent.db";
  const Outcome o = Tsc("inspect --db " + Quote(db.string()));
  EXPECT_EQ(o.code, 1) << o.err;
  EXPECT_NE(o.err.find("absent.db"), std::string::npos) << o.err;
  EXPECT_FALSE(fs::exists(db));
}

TEST_F(TscCliTest, StoreOfAnotherRobotExits1) {
  const fs::path ds = MakeDataset(3);
  const fs::path db = dir_ / "r.db";
  ASSERT_EQ(Tsc("run " + Quote(ds.string()) + " --db " + Quote(db.string()) + " --robot 3").code,
            0);
  const Outcome o = Tsc("run " + Quote(ds.string()) + " --db " + Quote(db.string()) + " --robot 4");
  EXPECT_EQ(o.code, 1) << o.err;
  EXPECT_NE(o.err.find("r.db"), std::string::npos) << o.err;
}

// Features that need depth on a dataset without depth/: both commands refuse before anything
// is written (no store, no JSON).
TEST_F(TscCliTest, FeaturesThatNeedDepthWithoutDepthExit1BeforeWriting) {
  const fs::path ds = MakeDataset(3);
  const fs::path db = dir_ / "depth.db", json = dir_ / "depth.json";
  const std::string features = " --set bubble.features=L5+I";
  for (const std::string& command :
       {"run " + Quote(ds.string()) + " --db " + Quote(db.string()) + features,
        "eval " + Quote(ds.string()) + " --json " + Quote(json.string()) + features}) {
    const Outcome o = Tsc(command);
    EXPECT_EQ(o.code, 1) << command << ": " << o.err;
    EXPECT_NE(o.err.find("needs depth, but the dataset has no depth/ folder"), std::string::npos)
        << o.err;
  }
  EXPECT_FALSE(fs::exists(db));
  EXPECT_FALSE(fs::exists(json));
}

TEST_F(TscCliTest, EvalMissingDatasetExits1NamingIt) {
  const fs::path missing = dir_ / "no_such_dataset";
  const Outcome o =
      Tsc("eval " + Quote(missing.string()) + " --json " + Quote((dir_ / "e.json").string()));
  EXPECT_EQ(o.code, 1) << o.err;
  EXPECT_EQ(o.err.rfind("tsc: ", 0), 0u) << o.err;
  EXPECT_NE(o.err.find(missing.string()), std::string::npos) << o.err;
}

TEST_F(TscCliTest, EvalBadOptionExits2) {
  const fs::path ds = MakeDataset(2);
  const std::string json = " --json " + Quote((dir_ / "e.json").string());
  const Outcome unknown = Tsc("eval --frobnicate " + Quote(ds.string()) + json);
  EXPECT_EQ(unknown.code, 2) << unknown.err;
  EXPECT_NE(unknown.err.find("frobnicate"), std::string::npos) << unknown.err;
  EXPECT_EQ(Tsc("eval " + Quote(ds.string())).code, 2);  // --json missing
  const Outcome sweep = Tsc("eval " + Quote(ds.string()) + json + " --sweep 1.0:x:0.1");
  EXPECT_EQ(sweep.code, 2) << sweep.err;
  EXPECT_NE(sweep.err.find("--sweep"), std::string::npos) << sweep.err;
}

TEST_F(TscCliTest, EvalWritesJsonAndPlots) {
  const fs::path ds = MakeDataset(12);
  const fs::path json = dir_ / "e.json", plots = dir_ / "plots";
  const Outcome o = Tsc("eval " + Quote(ds.string()) + " --json " + Quote(json.string()) +
                        " --plots " + Quote(plots.string()) + " --sweep 1.0:1.5:0.25");
  ASSERT_EQ(o.code, 0) << o.err;
  EXPECT_NE(o.out.find("tsc eval: 12 frames"), std::string::npos) << o.out;
  EXPECT_NE(o.out.find("(ground truth: none)"), std::string::npos) << o.out;
  const std::string text = ReadFile(json);
  EXPECT_NE(text.find("\"frames\":12"), std::string::npos) << text;
  EXPECT_NE(text.find("\"pr_curve\":[[1,"), std::string::npos) << text;
  EXPECT_TRUE(fs::exists(plots / "timeline.png"));
  EXPECT_TRUE(fs::exists(plots / "pr_curve.png"));
}

// Revisits read from RTAB-Map's bitmap are scored, and the summary says where they came from.
TEST_F(TscCliTest, EvalNamesAGroundTruthBitmap) {
  const fs::path ds = MakeDataset(12);
  cv::Mat truth(12, 12, CV_8UC1, cv::Scalar(0));
  for (int i = 6; i < 12; ++i) truth.at<uint8_t>(i, i - 6) = 255;  // a second pass
  ASSERT_TRUE(cv::imwrite((ds / "groundtruth.bmp").string(), truth));
  const fs::path json = dir_ / "e.json";
  const Outcome o = Tsc("eval " + Quote(ds.string()) + " --json " + Quote(json.string()));
  ASSERT_EQ(o.code, 0) << o.err;
  EXPECT_NE(o.out.find("(ground truth: revisits (groundtruth.bmp))"), std::string::npos) << o.out;
  EXPECT_NE(ReadFile(json).find("\"frames_with_revisit\":6"), std::string::npos);
}

}  // namespace
}  // namespace tsc
