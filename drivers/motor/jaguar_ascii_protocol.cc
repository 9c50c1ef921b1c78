#include "drivers/motor/jaguar_ascii_protocol.h"

#include <algorithm>
#include <charconv>
#include <cmath>

namespace tsc::jaguar_ascii {
namespace {

std::string_view Trim(std::string_view s) {
  while (!s.empty() && (s.back() == '\r' || s.back() == '\n' || s.back() == ' '))
    s.remove_suffix(1);
  while (!s.empty() && s.front() == ' ') s.remove_prefix(1);
  return s;
}

std::vector<std::string_view> Split(std::string_view s, char sep) {
  std::vector<std::string_view> out;
  size_t start = 0;
  while (true) {
    const size_t at = s.find(sep, start);
    out.push_back(
        s.substr(start, at == std::string_view::npos ? std::string_view::npos : at - start));
    if (at == std::string_view::npos) return out;
    start = at + 1;
  }
}

template <typename T>
bool ParseNumber(std::string_view s, T& out) {
  s = Trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const auto r = std::from_chars(s.data(), s.data() + s.size(), out);
  return r.ec == std::errc{} && r.ptr == s.data() + s.size() && !s.empty();
}

bool ParseReal(std::string_view s, double& out) {
  if (!ParseNumber(s, out)) return false;
  return std::isfinite(out);
}

}  // namespace

std::string WheelPower(int left, int right) {
  left = std::clamp(left, -kPowerMax, kPowerMax);
  right = std::clamp(right, -kPowerMax, kPowerMax);
  return "MMW !M " + std::to_string(left) + " " + std::to_string(right) + "\r\n";
}

std::string FlipperMove(int board, int channel, int counts) {
  return "MM" + std::to_string(board) + " !PR " + std::to_string(channel) + " " +
         std::to_string(counts) + "\r\n";
}

std::string FaultText(int64_t bits) {
  static const std::pair<int64_t, const char*> kNames[] = {{kFaultOverheat, "over-heat"},
                                                           {kFaultOverVolt, "over-volt"},
                                                           {kFaultUnderVolt, "under-volt"},
                                                           {kFaultShort, "short"},
                                                           {kFaultEstop, "e-stop"}};
  std::string s;
  for (const auto& [bit, name] : kNames) {
    if (bits & bit) s += (s.empty() ? "" : ",") + std::string(name);
  }
  const int64_t known = 0x1F;
  if (bits & ~known)
    s += (s.empty() ? "" : ",") + std::string("fault bits 0x") + [&] {
      char buf[24];
      auto r = std::to_chars(buf, buf + sizeof buf, bits & ~known, 16);
      return std::string(buf, r.ptr);
    }();
  return s;
}

ReplyLine ParseReply(std::string_view raw) {
  const std::string_view line = Trim(raw);
  ReplyLine out;
  auto malformed = [&] {
    out.kind = ReplyLine::Kind::kMalformed;
    return out;
  };
  if (line == "+" || line == "-") {
    out.kind = ReplyLine::Kind::kAcknowledge;
    out.ack.accepted = line == "+";
    return out;
  }
  if (line.starts_with("#")) {
    const auto f = Split(line.substr(1), ',');
    // seq, YAW, y, GYRO, gx, gy, gz, ACC, ax, ay, az, COMP, cx, cy, cz
    if (f.size() < 15 || Trim(f[1]) != "YAW" || Trim(f[3]) != "GYRO" || Trim(f[7]) != "ACC" ||
        Trim(f[11]) != "COMP") {
      return malformed();
    }
    ImuLine& imu = out.imu;
    bool ok = ParseNumber(f[0], imu.seq) && ParseReal(f[2], imu.yaw);
    for (size_t i = 0; i < 3; ++i) {
      ok = ok && ParseReal(f[4 + i], imu.gyro[i]) && ParseReal(f[8 + i], imu.accel[i]) &&
           ParseReal(f[12 + i], imu.compass[i]);
    }
    if (!ok) return malformed();
    out.kind = ReplyLine::Kind::kImu;
    return out;
  }
  if (line == "MMW +" || line == "MMW -") {  // a command to both wheel boards answered
    out.kind = ReplyLine::Kind::kAcknowledge;
    out.ack = {-1, line.back() == '+'};
    return out;
  }
  if (line.starts_with("MM") && line.size() >= 3) {
    int board = 0;
    if (!ParseNumber(line.substr(2, 1), board)) return malformed();
    const std::string_view rest = Trim(line.substr(3));
    if (rest == "+" || rest == "-") {
      out.kind = ReplyLine::Kind::kAcknowledge;
      out.ack = {board, rest == "+"};
      return out;
    }
    const size_t eq = rest.find('=');
    if (eq == std::string_view::npos) return malformed();
    const std::string_view key = Trim(rest.substr(0, eq));
    if (key.empty()) return malformed();  // "MM0 =1", "MM0\r=1"
    out.motor.board = board;
    out.motor.key = std::string(key);
    for (std::string_view v : Split(rest.substr(eq + 1), ':')) {
      int32_t n = 0;  // the boards' registers are 32-bit: a larger value is no report of theirs
      if (!ParseNumber(v, n)) return malformed();
      out.motor.values.push_back(n);
    }
    out.kind = ReplyLine::Kind::kMotorBoard;
    return out;
  }
  return out;  // kOther: GPS, banners, echoes
}

CommandLine ParseCommand(std::string_view raw) {
  const std::string_view line = Trim(raw);
  CommandLine out;
  if (line == "PING") {
    out.kind = CommandLine::Kind::kPing;
  } else if (line == "MMW !EX") {
    out.kind = CommandLine::Kind::kEmergencyStop;
  } else if (line == "MMW !MG") {
    out.kind = CommandLine::Kind::kRelease;
  } else if (line.starts_with("MMW !M ")) {
    const auto f = Split(line.substr(7), ' ');
    if (f.size() == 2 && ParseNumber(f[0], out.left) && ParseNumber(f[1], out.right) &&
        std::abs(out.left) <= kPowerMax && std::abs(out.right) <= kPowerMax) {
      out.kind = CommandLine::Kind::kWheelPower;
    }
  } else if (line.starts_with("SYS MMC ")) {
    out.kind = CommandLine::Kind::kLights;
  } else if (line.size() > 8 && line.starts_with("MM") && line.substr(3, 5) == " !PR ") {
    const auto f = Split(line.substr(8), ' ');
    if (ParseNumber(line.substr(2, 1), out.board) && f.size() == 2 &&
        ParseNumber(f[0], out.channel) && ParseNumber(f[1], out.counts)) {
      out.kind = CommandLine::Kind::kFlipper;
    }
  }
  return out;
}

void LineSplitter::Feed(std::string_view bytes) { buffer_.append(bytes); }

std::optional<std::string> LineSplitter::Next() {
  while (true) {
    const size_t nl = buffer_.find('\n');
    if (skipping_) {
      if (nl == std::string::npos) {
        buffer_.clear();
        return std::nullopt;
      }
      buffer_.erase(0, nl + 1);  // the end of the overlong line
      skipping_ = false;
      continue;
    }
    if (nl == std::string::npos) {
      if (buffer_.size() > max_line_) {  // no end in sight: drop it, and the rest up to its end
        buffer_.clear();
        skipping_ = true;
        ++overlong_;
      }
      return std::nullopt;
    }
    std::string line = buffer_.substr(0, nl);
    buffer_.erase(0, nl + 1);
    if (line.size() > max_line_) {
      ++overlong_;
      continue;
    }
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return line;
  }
}

}  // namespace tsc::jaguar_ascii
