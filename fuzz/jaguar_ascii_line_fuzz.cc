// Fuzz target: the byte stream a Jaguar 4x4/V6 board sends over TCP
// (drivers/motor/jaguar_ascii_protocol), cut into reads of sizes the input chooses
// (fuzz/chunked_input.h) and handled as JaguarAsciiBase::Receive does: each read fed to a
// LineSplitter, every whole line parsed as a reply, the encoder counts of `MM0 C=` run through
// the odometry with a mirrored side. The same lines are parsed as commands, as the simulator
// does. Properties: the splitter yields exactly the input's lines, whatever the reads, and
// drops and counts each overlong line once; parsed replies and commands re-serialize to lines
// that parse the same; nothing overflows.

#include <cmath>
#include <string>
#include <string_view>
#include <vector>

#include "drivers/motor/jaguar_ascii_protocol.h"
#include "drivers/motor/jaguar_drive.h"
#include "fuzz/chunked_input.h"
#include "fuzz/fuzz_target.h"

namespace ascii = tsc::jaguar_ascii;
using tsc::fuzz::Require;

namespace {

// Small, so the fuzzer reaches it; the driver's is 1024 (same code).
constexpr size_t kMaxLine = 64;

// The lines of `stream` the splitter must yield, and how many it must drop as overlong.
struct ExpectedLines {
  std::vector<std::string> lines;
  int64_t overlong = 0;
};
ExpectedLines Expected(std::string_view stream) {
  ExpectedLines e;
  size_t start = 0;
  for (size_t nl = stream.find('\n'); nl != std::string_view::npos;
       start = nl + 1, nl = stream.find('\n', start)) {
    std::string_view line = stream.substr(start, nl - start);
    if (line.size() > kMaxLine) {
      ++e.overlong;
      continue;
    }
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    e.lines.emplace_back(line);
  }
  if (stream.size() - start > kMaxLine) ++e.overlong;  // an unfinished line already too long
  return e;
}

std::string Join(const std::vector<int64_t>& values) {
  std::string s;
  for (size_t i = 0; i < values.size(); ++i) s += (i ? ":" : "") + std::to_string(values[i]);
  return s;
}

void CheckReply(const ascii::ReplyLine& r, tsc::DifferentialOdometry& odometry, int64_t t_us) {
  using Kind = ascii::ReplyLine::Kind;
  if (r.kind == Kind::kImu) {
    Require(std::isfinite(r.imu.yaw), "IMU yaw finite");
  } else if (r.kind == Kind::kMotorBoard) {
    const ascii::MotorBoardLine& m = r.motor;
    Require(m.board >= 0 && m.board <= 9 && !m.key.empty() && !m.values.empty(),
            "motor board line has a board, a key and values");
    // The same report written out again parses the same.
    const ascii::ReplyLine again = ascii::ParseReply("MM" + std::to_string(m.board) + " " + m.key +
                                                     "=" + Join(m.values) + "\r\n");
    Require(again.kind == Kind::kMotorBoard && again.motor.board == m.board &&
                again.motor.key == m.key && again.motor.values == m.values,
            "motor board line re-serializes");
    // As JaguarAsciiBase::Handle: encoder counts (right side mirrored) into the odometry, fault
    // bits into text.
    if (m.board == 0 && m.key == "C" && m.values.size() >= 2) {
      odometry.Update(m.values[0], -m.values[1], t_us);
      Require(std::isfinite(odometry.x()) && std::isfinite(odometry.y()) &&
                  std::isfinite(odometry.heading()),
              "odometry finite");
    }
    if (m.key == "FF") (void)ascii::FaultText(m.values[0]);
  }
}

void CheckCommand(const std::string& line) {
  using Kind = ascii::CommandLine::Kind;
  const ascii::CommandLine c = ascii::ParseCommand(line);
  if (c.kind == Kind::kWheelPower) {
    const ascii::CommandLine again = ascii::ParseCommand(ascii::WheelPower(c.left, c.right));
    Require(again.kind == Kind::kWheelPower && again.left == c.left && again.right == c.right,
            "wheel power command re-serializes");
  } else if (c.kind == Kind::kFlipper) {
    const ascii::CommandLine again =
        ascii::ParseCommand(ascii::FlipperMove(c.board, c.channel, c.counts));
    Require(again.kind == Kind::kFlipper && again.board == c.board && again.channel == c.channel &&
                again.counts == c.counts,
            "flipper command re-serializes");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const tsc::fuzz::ChunkedInput input = tsc::fuzz::SplitChunked(data, size);
  ascii::LineSplitter lines(kMaxLine);
  tsc::DifferentialOdometry odometry{tsc::JaguarOptions{}};
  std::vector<std::string> got;
  int64_t t_us = 0;
  input.ForEachRead([&](std::string_view read) {
    lines.Feed(read);
    t_us += 20000;
    while (auto line = lines.Next()) {
      Require(line->size() <= kMaxLine, "a yielded line is within the limit");
      CheckReply(ascii::ParseReply(*line), odometry, t_us);
      CheckCommand(*line);
      got.push_back(std::move(*line));
    }
  });
  const ExpectedLines expected = Expected(input.stream);
  Require(got == expected.lines, "the splitter yields the stream's lines, whatever the reads");
  Require(lines.overlong() == expected.overlong, "each overlong line is counted once");
  return 0;
}
