#pragma once
// The Jaguar 4x4 (2014) / V4 / V6 ASCII protocol over TCP (facts file §2): command lines the PC
// sends and the reply lines the boards send, each ending "\r\n", no checksum.
// Pure computation: no sockets, no clocks.

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace tsc::jaguar_ascii {

inline constexpr int kPowerMax = 1000;  ///< |wheel power| of `MMW !M L R`

/// `MMW !M <left> <right>\r\n`; powers are clamped to ±1000.
std::string WheelPower(int left, int right);
inline std::string Stop() { return "MMW !M 0 0\r\n"; }
inline std::string EmergencyStop() { return "MMW !EX\r\n"; }
inline std::string Release() { return "MMW !MG\r\n"; }
inline std::string Ping() { return "PING\r\n"; }
/// Flipper board `MM2` (front) / `MM3` (rear), channel 1|2, relative move in counts.
std::string FlipperMove(int board, int channel, int counts);

/// `MMx key=a:b:…` from motor board x (0 front wheels, 1 rear, 2 front flippers, 3 rear).
struct MotorBoardLine {
  int board = 0;
  std::string key;  ///< A, C, CR, P, S, T, V, FF, …
  /// Each within int32 (the boards' registers), so the driver's arithmetic on them (sign flips,
  /// count differences) cannot overflow; a line with a larger value is kMalformed.
  std::vector<int64_t> values;
};
/// `#seq,YAW,y,GYRO,gx,gy,gz,ACC,ax,ay,az,COMP,cx,cy,cz,...`
struct ImuLine {
  int64_t seq = 0;
  double yaw = 0.0;
  std::array<double, 3> gyro{}, accel{}, compass{};
};
/// `MMx +` / `MMx -` (or a bare `+`/`-`): the last command accepted or rejected.
struct Acknowledge {
  int board = -1;  ///< −1 when the line names none
  bool accepted = false;
};

/// Fault bits of the FF key.
inline constexpr int64_t kFaultOverheat = 0x01, kFaultOverVolt = 0x02, kFaultUnderVolt = 0x04,
                         kFaultShort = 0x08, kFaultEstop = 0x10;
/// "over-heat,e-stop" for the set bits ("" for none).
std::string FaultText(int64_t bits);

/// What one reply line is. Unknown kinds ($GPRMC, banners) are kOther; malformed lines of a
/// known kind are kMalformed (counted by the driver).
struct ReplyLine {
  enum class Kind { kMotorBoard, kImu, kAcknowledge, kOther, kMalformed };
  Kind kind = Kind::kOther;
  MotorBoardLine motor;
  ImuLine imu;
  Acknowledge ack;
};
/// Parses one line (without or with its trailing "\r\n").
ReplyLine ParseReply(std::string_view line);

/// A command line the board understands (the simulator's side).
struct CommandLine {
  enum class Kind { kWheelPower, kEmergencyStop, kRelease, kPing, kFlipper, kLights, kUnknown };
  Kind kind = Kind::kUnknown;
  int left = 0, right = 0;                 ///< kWheelPower
  int board = 0, channel = 0, counts = 0;  ///< kFlipper
};
CommandLine ParseCommand(std::string_view line);

/// Splits a TCP byte stream into lines: Feed() bytes, Next() whole lines without "\r\n".
/// A line longer than `max_line` bytes (with its "\r") is dropped whole and counted once (a
/// stream that lost its framing): once it outgrows the limit the splitter holds none of it and
/// skips to the next "\n", so no tail of it is ever taken for a line.
class LineSplitter {
 public:
  explicit LineSplitter(size_t max_line = 1024) : max_line_(max_line) {}
  void Feed(std::string_view bytes);
  std::optional<std::string> Next();
  int64_t overlong() const { return overlong_; }
  void Clear() { buffer_.clear(), skipping_ = false; }

 private:
  size_t max_line_;
  std::string buffer_;
  bool skipping_ = false;  // inside an overlong line already counted: drop up to its "\n"
  int64_t overlong_ = 0;
};

}  // namespace tsc::jaguar_ascii
