// `tsc merge` end to end: two robots' stores from `tsc sim` + `tsc run`, merged by the real
// binary, the result read back with Store; exit codes of DESIGN §7.2.

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include "store/store.h"
#include "test/support/temp_dir.h"
#include "test/support/tsc_command.h"

namespace tsc {
namespace {
namespace fs = std::filesystem;

using Outcome = testing_support::TscOutcome;
using testing_support::ReadFile;

class MergeCliTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing_support::TempDir("tscd_merge_cli_test");
    const fs::path d = dir_->path();
    ASSERT_EQ(Tsc("sim --out " + (d / "sim").string() +
                  " --seed 3 --robots 2 --size 160x120 --max-frames 300")
                  .code,
              0);
    for (int r : {1, 2}) {
      const Outcome run = Tsc("run " + (d / "sim" / "robots" / std::to_string(r)).string() +
                              " --no-progress --robot " + std::to_string(r) + " --db " +
                              (d / (std::to_string(r) + ".db")).string());
      ASSERT_EQ(run.code, 0) << run.err;
    }
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }

  /// Runs `tsc ARGS` (paths without spaces) with stdout and stderr captured.
  static Outcome Tsc(const std::string& args) {
    return testing_support::RunTsc(dir_->path(), args);
  }

  static fs::path Path(const std::string& name) { return dir_->path() / name; }
  static StoredState Load(const std::string& name, uint32_t robot) {
    return Store::Open(Path(name)).Load(robot, PipelineOptions{}.memory);
  }

  static testing_support::TempDir* dir_;
};

testing_support::TempDir* MergeCliTest::dir_ = nullptr;

TEST_F(MergeCliTest, MergesTwoRobotsAndIsIdempotent) {
  const Outcome merge = Tsc("merge " + Path("1.db").string() + " " + Path("2.db").string() +
                            " --out " + Path("c.db").string());
  ASSERT_EQ(merge.code, 0) << merge.err;
  EXPECT_NE(merge.out.find("case"), std::string::npos) << merge.out;
  EXPECT_NE(merge.out.find("absorbed"), std::string::npos) << merge.out;

  const StoredState a = Load("1.db", 1), b = Load("2.db", 2), c = Load("c.db", 1);
  EXPECT_EQ(c.memory.robot(), 1u);
  // Every place of both robots is in C, as a place or as the source of one.
  std::set<PlaceId> held;
  size_t absorbed = 0;
  for (const LearnedPlace& p : c.memory.places()) {
    held.insert(p.id);
    held.insert(p.sources.begin(), p.sources.end());
    absorbed += p.sources.size();
    for (const PlaceId& s : p.sources) EXPECT_FALSE(c.map.places().contains(s)) << s.ToString();
  }
  for (const StoredState* s : {&a, &b}) {
    for (const LearnedPlace& p : s->memory.places()) EXPECT_TRUE(held.contains(p.id));
  }
  EXPECT_EQ(c.memory.places().size() + absorbed,
            a.memory.places().size() + b.memory.places().size());
  EXPECT_EQ(c.map.places().size(), c.memory.places().size());
  // A's stream comes along.
  EXPECT_EQ(c.pipeline.next_base, a.pipeline.next_base);

  // Merging B again changes nothing.
  const Outcome again = Tsc("merge " + Path("c.db").string() + " " + Path("2.db").string() +
                            " --out " + Path("d.db").string());
  ASSERT_EQ(again.code, 0) << again.err;
  EXPECT_NE(again.out.find("nothing-new"), std::string::npos) << again.out;
  const StoredState d = Load("d.db", 1);
  ASSERT_EQ(d.memory.places().size(), c.memory.places().size());
  for (size_t i = 0; i < d.memory.places().size(); ++i) {
    EXPECT_EQ(d.memory.places()[i].id, c.memory.places()[i].id);
    EXPECT_EQ(d.memory.places()[i].mean, c.memory.places()[i].mean);
    EXPECT_EQ(d.memory.places()[i].sources, c.memory.places()[i].sources);
  }
  EXPECT_EQ(d.map.edges().size(), c.map.edges().size());

  // The DOT colours places by robot.
  const Outcome dot =
      Tsc("inspect --db " + Path("c.db").string() + " --dot " + Path("c.dot").string());
  ASSERT_EQ(dot.code, 0) << dot.err;
  const std::string text = ReadFile(Path("c.dot"));
  EXPECT_NE(text.find("#9ecae1"), std::string::npos);  // robot 1
  // Robot 2's places appear in its own colour, or in the merged colour once absorbed.
  if (absorbed < b.memory.places().size()) {
    EXPECT_NE(text.find("#a1d99b"), std::string::npos);  // robot 2
  }
  if (absorbed > 0) {
    EXPECT_NE(text.find("#fd8d3c"), std::string::npos);  // merged
  }
}

TEST_F(MergeCliTest, ExistingOutputNeedsForce) {
  const std::string args = "merge " + Path("1.db").string() + " " + Path("2.db").string() +
                           " --out " + Path("e.db").string();
  ASSERT_EQ(Tsc(args).code, 0);
  const Outcome refused = Tsc(args);
  EXPECT_EQ(refused.code, 1);
  EXPECT_NE(refused.err.find("e.db"), std::string::npos) << refused.err;
  EXPECT_EQ(Tsc(args + " --force").code, 0);
}

TEST_F(MergeCliTest, ErrorsUseTheExitCodesOfTheContract) {
  const std::string a = Path("1.db").string(), b = Path("2.db").string();
  const Outcome same = Tsc("merge " + a + " " + a + " --out " + Path("x.db").string());
  EXPECT_EQ(same.code, 1);
  EXPECT_NE(same.err.find("robot 1"), std::string::npos) << same.err;
  const Outcome missing =
      Tsc("merge " + a + " " + Path("none.db").string() + " --out " + Path("y.db").string());
  EXPECT_EQ(missing.code, 1);
  EXPECT_NE(missing.err.find("none.db"), std::string::npos) << missing.err;
  EXPECT_FALSE(fs::exists(Path("none.db")));
  EXPECT_EQ(Tsc("merge " + a + " --out " + Path("z.db").string()).code, 2);
  EXPECT_EQ(Tsc("merge " + a + " " + b).code, 2);
  const Outcome config =
      Tsc("merge " + a + " " + b + " --out " + Path("w.db").string() + " --set memory.tau_r=-1");
  EXPECT_EQ(config.code, 78);
  EXPECT_NE(config.err.find("memory.tau_r"), std::string::npos) << config.err;
  EXPECT_EQ(Tsc("merge --help").code, 0);
}

}  // namespace
}  // namespace tsc
