// The 4x4/V6 ASCII protocol: command lines, reply lines, and the TCP line splitter.

#include "drivers/motor/jaguar_ascii_protocol.h"

#include <gtest/gtest.h>

namespace tsc::jaguar_ascii {
namespace {

TEST(JaguarAsciiCommands, LinesAsTheBoardsExpectThem) {
  EXPECT_EQ(WheelPower(300, -300), "MMW !M 300 -300\r\n");
  EXPECT_EQ(WheelPower(5000, -5000), "MMW !M 1000 -1000\r\n");  // clamped
  EXPECT_EQ(Stop(), "MMW !M 0 0\r\n");
  EXPECT_EQ(EmergencyStop(), "MMW !EX\r\n");
  EXPECT_EQ(Release(), "MMW !MG\r\n");
  EXPECT_EQ(Ping(), "PING\r\n");
  EXPECT_EQ(FlipperMove(2, 1, 7600), "MM2 !PR 1 7600\r\n");
}

TEST(JaguarAsciiCommands, ParsedBackBySimulatorSide) {
  EXPECT_EQ(ParseCommand(WheelPower(250, -400)).kind, CommandLine::Kind::kWheelPower);
  EXPECT_EQ(ParseCommand(WheelPower(250, -400)).right, -400);
  EXPECT_EQ(ParseCommand(EmergencyStop()).kind, CommandLine::Kind::kEmergencyStop);
  EXPECT_EQ(ParseCommand(Release()).kind, CommandLine::Kind::kRelease);
  EXPECT_EQ(ParseCommand(Ping()).kind, CommandLine::Kind::kPing);
  const auto f = ParseCommand(FlipperMove(3, 2, -100));
  EXPECT_EQ(f.kind, CommandLine::Kind::kFlipper);
  EXPECT_EQ(f.board, 3);
  EXPECT_EQ(f.counts, -100);
  EXPECT_EQ(ParseCommand("SYS MMC 255").kind, CommandLine::Kind::kLights);
  for (const char* bad : {"MMW !M 1001 0", "MMW !M 1 2 3", "MMW !M x 0", "HELLO", ""}) {
    EXPECT_EQ(ParseCommand(bad).kind, CommandLine::Kind::kUnknown) << bad;
  }
}

TEST(JaguarAsciiReplies, MotorBoardKeys) {
  auto r = ParseReply("MM0 C=1234:-5678\r\n");
  ASSERT_EQ(r.kind, ReplyLine::Kind::kMotorBoard);
  EXPECT_EQ(r.motor.board, 0);
  EXPECT_EQ(r.motor.key, "C");
  EXPECT_EQ(r.motor.values, (std::vector<int64_t>{1234, -5678}));
  r = ParseReply("MM1 V=121:245:50");
  ASSERT_EQ(r.kind, ReplyLine::Kind::kMotorBoard);
  EXPECT_EQ(r.motor.board, 1);
  EXPECT_EQ(r.motor.values.size(), 3u);
  r = ParseReply("MM2 FF=17");
  ASSERT_EQ(r.kind, ReplyLine::Kind::kMotorBoard);
  EXPECT_EQ(FaultText(r.motor.values[0]), "over-heat,e-stop");
  EXPECT_EQ(FaultText(0), "");
  EXPECT_EQ(FaultText(0x22), "over-volt,fault bits 0x20");
  r = ParseReply("MM0 CR=-3:4");
  EXPECT_EQ(r.motor.key, "CR");
}

TEST(JaguarAsciiReplies, AcknowledgesAndImu) {
  auto r = ParseReply("MMW +");  // the answer to a command for both wheel boards
  ASSERT_EQ(r.kind, ReplyLine::Kind::kAcknowledge);
  EXPECT_EQ(r.ack.board, -1);
  EXPECT_TRUE(r.ack.accepted);
  r = ParseReply("MM1 -");
  ASSERT_EQ(r.kind, ReplyLine::Kind::kAcknowledge);
  EXPECT_EQ(r.ack.board, 1);
  EXPECT_FALSE(r.ack.accepted);
  r = ParseReply("+");
  ASSERT_EQ(r.kind, ReplyLine::Kind::kAcknowledge);
  EXPECT_TRUE(r.ack.accepted);
  r = ParseReply("#42,YAW,1.25,GYRO,1,2,3,ACC,0.1,0.2,9.8,COMP,4,5,6,EXTRA\r\n");
  ASSERT_EQ(r.kind, ReplyLine::Kind::kImu);
  EXPECT_EQ(r.imu.seq, 42);
  EXPECT_DOUBLE_EQ(r.imu.yaw, 1.25);
  EXPECT_DOUBLE_EQ(r.imu.gyro[2], 3);
  EXPECT_DOUBLE_EQ(r.imu.accel[2], 9.8);
  EXPECT_DOUBLE_EQ(r.imu.compass[0], 4);
}

TEST(JaguarAsciiReplies, MalformedAndForeignLines) {
  for (const char* bad : {"MM0 C=12?:4", "MM0 C=", "MM0 =3", "MMx C=1", "MM0 C",
                          "#1,YAW,nan,GYRO,1,2,3,ACC,1,2,3,COMP,1,2,3", "#1,YAW,1,GYRO,1,2"}) {
    EXPECT_EQ(ParseReply(bad).kind, ReplyLine::Kind::kMalformed) << bad;
  }
  EXPECT_EQ(ParseReply("$GPRMC,123519,A,4807.038,N").kind, ReplyLine::Kind::kOther);
  EXPECT_EQ(ParseReply("").kind, ReplyLine::Kind::kOther);
}

// Found by fuzz_jaguar_ascii_line (fuzz/regressions/fuzz_jaguar_ascii_line/empty-motor-key): a
// key of only blanks and a carriage return ("MM0\r=8") was taken as a motor report with an
// empty key.
// Found by review, confirmed by fuzz_jaguar_ascii_line under UBSan with
// fuzz/regressions/fuzz_jaguar_ascii_line/int64-*: encoder counts near the int64 limits
// overflowed the driver's sign flip of the mirrored side and the odometry's count difference.
TEST(JaguarAsciiReplies, ValuesBeyondThe32BitRegistersAreMalformed) {
  auto r = ParseReply("MM0 C=2147483647:-2147483648");
  ASSERT_EQ(r.kind, ReplyLine::Kind::kMotorBoard);
  EXPECT_EQ(r.motor.values, (std::vector<int64_t>{2147483647, -2147483648LL}));
  for (const char* bad : {"MM0 C=2147483648:0", "MM0 C=0:-2147483649",
                          "MM0 C=0:-9223372036854775808", "MM0 FF=99999999999999999999"}) {
    EXPECT_EQ(ParseReply(bad).kind, ReplyLine::Kind::kMalformed) << bad;
  }
}

TEST(JaguarAsciiReplies, KeyOfOnlyBlanksIsMalformed) {
  for (const char* bad : {"MM0\r=8", "MM1 \r =8", "MM0  =1:2"}) {
    EXPECT_EQ(ParseReply(bad).kind, ReplyLine::Kind::kMalformed) << bad;
  }
}

TEST(LineSplitter, SplitsAStreamInAnyChunking) {
  const std::string stream = "MM0 C=1:2\r\nMM0 V=1:2:3\r\n#1,YAW\r\n";
  for (size_t chunk : {1u, 3u, 7u, 100u}) {
    LineSplitter dut;
    std::vector<std::string> lines;
    for (size_t i = 0; i < stream.size(); i += chunk) {
      dut.Feed(std::string_view(stream).substr(i, chunk));
      while (auto l = dut.Next()) lines.push_back(*l);
    }
    EXPECT_EQ(lines, (std::vector<std::string>{"MM0 C=1:2", "MM0 V=1:2:3", "#1,YAW"})) << chunk;
  }
  LineSplitter dut(8);
  dut.Feed("0123456789abc");  // no end of line within 8 bytes: dropped
  EXPECT_FALSE(dut.Next());
  dut.Feed("\r\nok\r\n");
  EXPECT_EQ(dut.Next(), "ok");
  EXPECT_FALSE(dut.Next());
  EXPECT_EQ(dut.overlong(), 1);
}

// Found by fuzz_jaguar_ascii_line (fuzz/regressions/fuzz_jaguar_ascii_line/): the splitter
// dropped the first bytes of an overlong line once they outgrew the limit, then handed the
// rest of that line, when its "\n" came in a later read, to the driver as a line of its own —
// here a forged encoder report.
TEST(LineSplitter, OverlongLineCutAcrossReadsIsDroppedWholeAndCountedOnce) {
  LineSplitter dut(16);
  std::vector<std::string> lines;
  for (std::string_view read :
       {"MM0 V=1:2\r\nxxxxxxxxxxxx", "xxxxxxxxxxxx", "xxxMM0 C=999:", "1\r\nMM0 T=28:29\r\n"}) {
    dut.Feed(read);
    while (auto l = dut.Next()) lines.push_back(*l);
  }
  EXPECT_EQ(lines, (std::vector<std::string>{"MM0 V=1:2", "MM0 T=28:29"}));
  EXPECT_EQ(dut.overlong(), 1);
  // Cut anywhere, the same stream gives the same lines.
  const std::string stream =
      "MM0 V=1:2\r\n" + std::string(27, 'x') + "MM0 C=999:1\r\nMM0 T=28:29\r\n";
  for (size_t chunk = 1; chunk <= stream.size(); ++chunk) {
    LineSplitter cut(16);
    std::vector<std::string> got;
    for (size_t i = 0; i < stream.size(); i += chunk) {
      cut.Feed(std::string_view(stream).substr(i, chunk));
      while (auto l = cut.Next()) got.push_back(*l);
    }
    EXPECT_EQ(got, lines) << chunk;
    EXPECT_EQ(cut.overlong(), 1) << chunk;
  }
}

}  // namespace
}  // namespace tsc::jaguar_ascii
