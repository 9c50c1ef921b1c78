#pragma once
// The Jaguar V2 / tracked V4 binary protocol (drrobot "PMS5005"-style board over UDP; facts in
// /work/shared/jaguar-hal-facts.md §1): frame encoder and decoder, CRC-8/MAXIM, the system
// (ACK) and PWM commands, the 0x7B/0x7C/0x7D sensor frames, and encoder unwrapping.
// Pure computation: no sockets, no clocks.
//
// Frame: 5E 02 | dest | seq | type | LEN | LEN data bytes | CRC | 5E 0D  (LEN + 9 bytes);
// CRC-8/MAXIM over dest … last data byte; 16-bit values little-endian.

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace tsc::jaguar_v2 {

inline constexpr uint8_t kDestBoard = 0x01;  ///< frames the PC sends
inline constexpr uint8_t kDestPc = 0x00;     ///< frames the board sends
inline constexpr size_t kFrameOverhead = 9;  ///< start(2) dest seq type len crc end(2)

/// Frame types (the `type` byte).
enum class FrameType : uint8_t {
  kPositionSingle = 3,
  kPositionAll = 4,
  kPwmSingle = 5,
  kPwmAll = 6,
  kPid = 7,
  kCustomIo = 22,
  kVelocitySingle = 26,
  kVelocityAll = 27,
  kDisableChannel = 0x1E,
  kMotorSensor = 0x7B,     ///< board → PC: output PWM, ch0/ch1 encoders
  kCustomSensor = 0x7C,    ///< board → PC: analog (battery, thermistors), track encoders
  kStandardSensor = 0x7D,  ///< board → PC: board and motor power
  kSystem = 0xFF,          ///< data[0]: 1 ACK, 0 ping, 2 urgent, 3 skip
};

/// System command bytes (data of a kSystem frame).
enum class SystemCommand : uint8_t { kPing = 0, kAck = 1, kUrgent = 2, kSkip = 3 };

/// PWM values: 0 … 32767, 16384 = stop, 0x8000 (−32768) = leave the channel as it is.
inline constexpr int kPwmStop = 16384;
inline constexpr int kPwmMax = 32767;
inline constexpr int16_t kNoControl = INT16_MIN;

/// Six channels: ch0/ch1 flippers (arms), ch3 forward power, ch4 turn power (the board mixes),
/// ch2/ch5 unused.
using PwmChannels = std::array<int16_t, 6>;

/// The PWM frame that stops every driven channel (ch0, ch1, ch3, ch4 at 16384) and leaves the
/// unused ones alone — the worked all-stop frame of the facts file.
PwmChannels AllStop();

/// CRC-8/MAXIM (Dallas 1-Wire: reflected polynomial 0x8C, init 0, no final xor).
uint8_t Crc8Maxim(std::span<const uint8_t> bytes);

struct Frame {
  uint8_t dest = kDestBoard;
  uint8_t seq = 0;
  uint8_t type = 0;
  std::vector<uint8_t> data;  ///< at most 255 bytes
};

/// The bytes of `frame`. Throws std::invalid_argument when data exceeds 255 bytes.
std::vector<uint8_t> Encode(const Frame& frame);
/// System ACK to the board: 5E 02 01 00 FF 01 01 85 5E 0D.
std::vector<uint8_t> EncodeAck(uint8_t dest = kDestBoard);
/// PWM for all six channels (type 6, LEN 12).
std::vector<uint8_t> EncodePwmAll(const PwmChannels& pwm);

/// Why a datagram was not a frame.
enum class Reject { kTruncated, kBadStart, kBadDest, kBadLength, kBadEnd, kBadCrc };
const char* RejectName(Reject r);

/// Counts of what Decode() saw, by outcome.
struct DecodeCounters {
  int64_t frames = 0;
  std::array<int64_t, 6> rejected{};  ///< indexed by Reject
  int64_t total_rejected() const;
};

/// Decodes one datagram (one frame, as the board sends them) addressed to `expected_dest`.
/// Returns the frame, or counts the reason in `counters` and returns nullopt.
std::optional<Frame> Decode(std::span<const uint8_t> datagram, DecodeCounters& counters,
                            uint8_t expected_dest = kDestPc);
/// As Decode(), also reporting the reason.
std::optional<Frame> Decode(std::span<const uint8_t> datagram, Reject* reason,
                            uint8_t expected_dest = kDestPc);

/// 0x7B motor sensor frame (data offsets 0–33).
struct MotorSensor {
  std::array<uint16_t, 6> output_pwm{};
  uint16_t ch0_encoder = 0, ch0_velocity = 0;
  uint16_t ch1_encoder = 0, ch1_velocity = 0;
  uint8_t direction_bits = 0;
};
/// 0x7C custom sensor frame: analog inputs, IO byte and the track encoders on ch3/ch4.
struct CustomSensor {
  std::array<uint16_t, 8> analog{};  ///< AD0…AD7, 12-bit
  uint8_t io = 0;
  uint16_t ch3_encoder = 0, ch3_velocity = 0, ch3_direction = 0;
  uint16_t ch4_encoder = 0, ch4_velocity = 0, ch4_direction = 0;
  /// AD1: battery volts = AD/4095 · 34.498.
  double battery_volts() const;
  /// AD2…AD7 (10 kΩ thermistors) in °C, by the B-parameter equation (B = 3900 K, R25 = 10 kΩ,
  /// 10 kΩ pull-up to 3.3 V). The thermistor curve is not in the facts: an approximation.
  std::array<double, 6> temperatures_c() const;
};
/// 0x7D standard sensor frame: the two power rails.
struct StandardSensor {
  uint16_t board_power_raw = 0;  ///< offset 30
  uint16_t motor_power_raw = 0;  ///< offset 32
  double board_volts() const { return board_power_raw * 9.0 / 4095.0; }
  double motor_volts() const { return motor_power_raw * 34.498 / 4095.0; }
};

inline constexpr size_t kMotorSensorBytes = 33;
inline constexpr size_t kCustomSensorBytes = 29;
inline constexpr size_t kStandardSensorBytes = 34;

/// Parses a sensor frame's data; nullopt when it is shorter than the fields read.
std::optional<MotorSensor> ParseMotorSensor(std::span<const uint8_t> data);
std::optional<CustomSensor> ParseCustomSensor(std::span<const uint8_t> data);
std::optional<StandardSensor> ParseStandardSensor(std::span<const uint8_t> data);

/// The data of a sensor frame with these fields (the simulator's side; also round-trip tests).
std::vector<uint8_t> SerializeMotorSensor(const MotorSensor& s);
std::vector<uint8_t> SerializeCustomSensor(const CustomSensor& s);
std::vector<uint8_t> SerializeStandardSensor(const StandardSensor& s);

/// Turns a wrapping uint16 encoder position into an unbounded count: each step is taken as
/// the shortest signed difference, so it is right while the wheel moves less than 32767
/// counts between two readings.
class EncoderUnwrap {
 public:
  /// The unwrapped count; the first reading is the origin (count 0).
  int64_t Update(uint16_t raw);
  int64_t count() const { return count_; }
  void Reset() { started_ = false, count_ = 0; }

 private:
  bool started_ = false;
  uint16_t last_ = 0;
  int64_t count_ = 0;
};

}  // namespace tsc::jaguar_v2
