#include "drivers/motor/jaguar_v2_protocol.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace tsc::jaguar_v2 {
namespace {

constexpr uint8_t kStart0 = 0x5E, kStart1 = 0x02, kEnd0 = 0x5E, kEnd1 = 0x0D;

uint16_t U16(std::span<const uint8_t> d, size_t at) {
  return static_cast<uint16_t>(d[at] | (d[at + 1] << 8));
}
void PutU16(std::vector<uint8_t>& d, size_t at, uint16_t v) {
  d[at] = static_cast<uint8_t>(v & 0xFF);
  d[at + 1] = static_cast<uint8_t>(v >> 8);
}

}  // namespace

PwmChannels AllStop() { return {kPwmStop, kPwmStop, kNoControl, kPwmStop, kPwmStop, kNoControl}; }

uint8_t Crc8Maxim(std::span<const uint8_t> bytes) {
  uint8_t crc = 0;
  for (uint8_t b : bytes) {
    crc ^= b;
    for (int i = 0; i < 8; ++i) {
      crc = (crc & 1) ? static_cast<uint8_t>((crc >> 1) ^ 0x8C) : static_cast<uint8_t>(crc >> 1);
    }
  }
  return crc;
}

std::vector<uint8_t> Encode(const Frame& frame) {
  if (frame.data.size() > 255) {
    throw std::invalid_argument("jaguar v2 frame: " + std::to_string(frame.data.size()) +
                                " data bytes, at most 255");
  }
  std::vector<uint8_t> out;
  out.reserve(frame.data.size() + kFrameOverhead);
  out.insert(out.end(), {kStart0, kStart1, frame.dest, frame.seq, frame.type,
                         static_cast<uint8_t>(frame.data.size())});
  out.insert(out.end(), frame.data.begin(), frame.data.end());
  out.push_back(Crc8Maxim(std::span(out).subspan(2)));
  out.insert(out.end(), {kEnd0, kEnd1});
  return out;
}

std::vector<uint8_t> EncodeAck(uint8_t dest) {
  return Encode({dest,
                 0,
                 static_cast<uint8_t>(FrameType::kSystem),
                 {static_cast<uint8_t>(SystemCommand::kAck)}});
}

std::vector<uint8_t> EncodePwmAll(const PwmChannels& pwm) {
  Frame f{kDestBoard, 0, static_cast<uint8_t>(FrameType::kPwmAll), std::vector<uint8_t>(12)};
  for (size_t i = 0; i < pwm.size(); ++i) PutU16(f.data, 2 * i, static_cast<uint16_t>(pwm[i]));
  return Encode(f);
}

const char* RejectName(Reject r) {
  switch (r) {
    case Reject::kTruncated:
      return "truncated";
    case Reject::kBadStart:
      return "bad start bytes";
    case Reject::kBadDest:
      return "wrong destination";
    case Reject::kBadLength:
      return "wrong length";
    case Reject::kBadEnd:
      return "bad end bytes";
    case Reject::kBadCrc:
      return "bad CRC";
  }
  return "?";
}

int64_t DecodeCounters::total_rejected() const {
  int64_t n = 0;
  for (int64_t r : rejected) n += r;
  return n;
}

std::optional<Frame> Decode(std::span<const uint8_t> d, Reject* reason, uint8_t expected_dest) {
  auto fail = [&](Reject r) -> std::optional<Frame> {
    if (reason != nullptr) *reason = r;
    return std::nullopt;
  };
  if (d.size() >= 2 && (d[0] != kStart0 || d[1] != kStart1)) return fail(Reject::kBadStart);
  if (d.size() < kFrameOverhead) return fail(Reject::kTruncated);
  const size_t len = d[5];
  // A datagram shorter than LEN says is cut off; a longer one disagrees with its LEN.
  if (d.size() < len + kFrameOverhead) return fail(Reject::kTruncated);
  if (d.size() > len + kFrameOverhead) return fail(Reject::kBadLength);
  if (d[len + 7] != kEnd0 || d[len + 8] != kEnd1) return fail(Reject::kBadEnd);
  if (Crc8Maxim(d.subspan(2, len + 4)) != d[len + 6]) return fail(Reject::kBadCrc);
  if (d[2] != expected_dest) return fail(Reject::kBadDest);
  return Frame{d[2], d[3], d[4], std::vector<uint8_t>(d.begin() + 6, d.begin() + 6 + len)};
}

std::optional<Frame> Decode(std::span<const uint8_t> d, DecodeCounters& counters,
                            uint8_t expected_dest) {
  Reject reason{};
  auto frame = Decode(d, &reason, expected_dest);
  if (frame) {
    ++counters.frames;
  } else {
    ++counters.rejected[static_cast<size_t>(reason)];
  }
  return frame;
}

double CustomSensor::battery_volts() const { return analog[1] / 4095.0 * 34.498; }

std::array<double, 6> CustomSensor::temperatures_c() const {
  std::array<double, 6> t{};
  for (size_t i = 0; i < t.size(); ++i) {
    const double ad = std::clamp<double>(analog[i + 2], 1.0, 4094.0);
    const double r = 10000.0 * ad / (4095.0 - ad);  // thermistor below a 10 kΩ pull-up
    t[i] = 1.0 / (1.0 / 298.15 + std::log(r / 10000.0) / 3900.0) - 273.15;
  }
  return t;
}

std::optional<MotorSensor> ParseMotorSensor(std::span<const uint8_t> d) {
  if (d.size() < kMotorSensorBytes) return std::nullopt;
  MotorSensor s;
  for (size_t i = 0; i < 6; ++i) s.output_pwm[i] = U16(d, 2 * i);
  s.ch0_encoder = U16(d, 24);
  s.ch0_velocity = U16(d, 26);
  s.ch1_encoder = U16(d, 28);
  s.ch1_velocity = U16(d, 30);
  s.direction_bits = d[32];
  return s;
}

std::optional<CustomSensor> ParseCustomSensor(std::span<const uint8_t> d) {
  if (d.size() < kCustomSensorBytes) return std::nullopt;
  CustomSensor s;
  for (size_t i = 0; i < 8; ++i) s.analog[i] = U16(d, 2 * i);
  s.io = d[16];
  s.ch3_encoder = U16(d, 17);
  s.ch3_velocity = U16(d, 19);
  s.ch3_direction = U16(d, 21);
  s.ch4_encoder = U16(d, 23);
  s.ch4_velocity = U16(d, 25);
  s.ch4_direction = U16(d, 27);
  return s;
}

std::optional<StandardSensor> ParseStandardSensor(std::span<const uint8_t> d) {
  if (d.size() < kStandardSensorBytes) return std::nullopt;
  return StandardSensor{U16(d, 30), U16(d, 32)};
}

std::vector<uint8_t> SerializeMotorSensor(const MotorSensor& s) {
  std::vector<uint8_t> d(kMotorSensorBytes);
  for (size_t i = 0; i < 6; ++i) PutU16(d, 2 * i, s.output_pwm[i]);
  PutU16(d, 24, s.ch0_encoder);
  PutU16(d, 26, s.ch0_velocity);
  PutU16(d, 28, s.ch1_encoder);
  PutU16(d, 30, s.ch1_velocity);
  d[32] = s.direction_bits;
  return d;
}

std::vector<uint8_t> SerializeCustomSensor(const CustomSensor& s) {
  std::vector<uint8_t> d(kCustomSensorBytes);
  for (size_t i = 0; i < 8; ++i) PutU16(d, 2 * i, s.analog[i]);
  d[16] = s.io;
  PutU16(d, 17, s.ch3_encoder);
  PutU16(d, 19, s.ch3_velocity);
  PutU16(d, 21, s.ch3_direction);
  PutU16(d, 23, s.ch4_encoder);
  PutU16(d, 25, s.ch4_velocity);
  PutU16(d, 27, s.ch4_direction);
  return d;
}

std::vector<uint8_t> SerializeStandardSensor(const StandardSensor& s) {
  std::vector<uint8_t> d(kStandardSensorBytes);
  PutU16(d, 30, s.board_power_raw);
  PutU16(d, 32, s.motor_power_raw);
  return d;
}

int64_t EncoderUnwrap::Update(uint16_t raw) {
  if (!started_) {
    started_ = true;
    last_ = raw;
    return count_;
  }
  count_ += static_cast<int16_t>(static_cast<uint16_t>(raw - last_));
  last_ = raw;
  return count_;
}

}  // namespace tsc::jaguar_v2
