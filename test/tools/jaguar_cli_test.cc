// `tsc jaguar-sim` and `tsc teleop` as a user runs them: bad command lines exit 2 naming the
// option, and the simulator's pose file holds the start pose it was given.

#include <gtest/gtest.h>

#include <filesystem>

#include "test/support/temp_dir.h"
#include "test/support/tsc_command.h"

namespace tsc {
namespace {

using testing_support::Quote;
using testing_support::ReadFile;
using testing_support::RunTsc;

class JaguarCliTest : public ::testing::Test {
 protected:
  testing_support::TempDir temp_{"jaguar_cli_test"};
  std::filesystem::path dir_ = temp_.path();
};

TEST_F(JaguarCliTest, BadArgumentsExit2NamingTheOption) {
  auto r = RunTsc(dir_, "jaguar-sim --start 1,2");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--start '1,2'"), std::string::npos) << r.err;
  r = RunTsc(dir_, "jaguar-sim --start 1,x,0");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("'x' is not a number"), std::string::npos) << r.err;
  r = RunTsc(dir_, "jaguar-sim --drop 1.5");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("drop fraction"), std::string::npos) << r.err;
  r = RunTsc(dir_, "jaguar-sim --world 1 --start 0,0,0");
  EXPECT_EQ(r.code, 2);
  r = RunTsc(dir_, "jaguar-sim --silence 3");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--silence"), std::string::npos) << r.err;
  r = RunTsc(dir_, "teleop");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("robot"), std::string::npos) << r.err;
  r = RunTsc(dir_, "teleop --robot 1 --hold-s 0");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--hold-s"), std::string::npos) << r.err;
  // Checked before LCM opens it (which would blame a missing multicast route).
  r = RunTsc(dir_, "teleop --robot 1 --lcm-url udpm://239.255.76.67:99999");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--lcm-url"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("port '99999'"), std::string::npos) << r.err;
}

TEST_F(JaguarCliTest, PoseFileHoldsTheStartPoseAndPortsAreAnnounced) {
  const auto pose = dir_ / "pose.txt";
  const auto r = RunTsc(
      dir_, "jaguar-sim --seconds 0.3 --start 1.5,-2,0.25 --pose-file " + Quote(pose.string()));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(ReadFile(pose), "1.500000 -2.000000 0.250000\n");
  EXPECT_FALSE(std::filesystem::exists(pose.string() + ".tmp"));
  EXPECT_NE(r.out.find("jaguar-sim: udp 127.0.0.1:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("stopped"), std::string::npos) << r.out;
  EXPECT_EQ(RunTsc(dir_, "jaguar-sim --help").code, 0);
  EXPECT_EQ(RunTsc(dir_, "teleop --help").code, 0);
}

}  // namespace
}  // namespace tsc
