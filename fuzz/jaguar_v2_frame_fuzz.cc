// Fuzz target: one UDP datagram from a Jaguar V2/V4 board (drivers/motor/jaguar_v2_protocol),
// decoded as JaguarV2Base does, and as the simulator decodes the PC's frames. Properties: every
// datagram is counted once, as a frame or under one reject reason; a frame that decodes encodes
// back to the same bytes (Decode checks start, LEN, CRC and end, so the encoding is unique); a
// sensor frame's fields serialize back to the bytes they were read from; the driver's
// arithmetic on them (encoder unwrap, battery, thermistors) stays finite.

#include <algorithm>
#include <cmath>
#include <span>

#include "drivers/motor/jaguar_v2_protocol.h"
#include "fuzz/fuzz_target.h"

namespace v2 = tsc::jaguar_v2;
using tsc::fuzz::Require;

namespace {

// The bytes of `serialized` and `data` agree at the offsets [from, to).
bool SameBytes(const std::vector<uint8_t>& serialized, std::span<const uint8_t> data, size_t from,
               size_t to) {
  return to <= serialized.size() && to <= data.size() &&
         std::equal(serialized.begin() + from, serialized.begin() + to, data.begin() + from);
}

void CheckSensors(const v2::Frame& frame) {
  const std::span<const uint8_t> d(frame.data);
  switch (static_cast<v2::FrameType>(frame.type)) {
    case v2::FrameType::kMotorSensor:
      if (const auto s = v2::ParseMotorSensor(d)) {
        // Offsets 12-23 (motor currents) are not read: the rest must come back.
        const std::vector<uint8_t> back = v2::SerializeMotorSensor(*s);
        Require(SameBytes(back, d, 0, 12) && SameBytes(back, d, 24, v2::kMotorSensorBytes),
                "0x7B fields re-serialize");
      } else {
        Require(d.size() < v2::kMotorSensorBytes, "0x7B refused only when short");
      }
      break;
    case v2::FrameType::kCustomSensor:
      if (const auto s = v2::ParseCustomSensor(d)) {
        Require(SameBytes(v2::SerializeCustomSensor(*s), d, 0, v2::kCustomSensorBytes),
                "0x7C fields re-serialize");
        Require(std::isfinite(s->battery_volts()), "battery volts finite");
        for (double t : s->temperatures_c()) Require(std::isfinite(t), "temperature finite");
        // As JaguarV2Base: a track encoder unwrapped; from the ch4 reading to the ch3 one the
        // count moves by the shortest step, so it matches the raw position modulo 2^16.
        v2::EncoderUnwrap unwrap;
        unwrap.Update(s->ch4_encoder);
        const int64_t step = unwrap.Update(s->ch3_encoder);
        Require(step >= -32768 && step <= 32767, "encoder step within half a turn");
        Require(static_cast<uint16_t>(s->ch4_encoder + step) == s->ch3_encoder,
                "unwrapped count matches the raw position");
      } else {
        Require(d.size() < v2::kCustomSensorBytes, "0x7C refused only when short");
      }
      break;
    case v2::FrameType::kStandardSensor:
      if (const auto s = v2::ParseStandardSensor(d)) {
        Require(SameBytes(v2::SerializeStandardSensor(*s), d, 30, v2::kStandardSensorBytes),
                "0x7D power fields re-serialize");
        Require(std::isfinite(s->board_volts()) && std::isfinite(s->motor_volts()),
                "power rails finite");
      } else {
        Require(d.size() < v2::kStandardSensorBytes, "0x7D refused only when short");
      }
      break;
    default:
      break;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::span<const uint8_t> datagram(data, size);
  v2::DecodeCounters counters;
  int decoded = 0;
  // The driver takes frames to the PC, the simulator frames to the board.
  for (uint8_t dest : {v2::kDestPc, v2::kDestBoard}) {
    const auto frame = v2::Decode(datagram, counters, dest);
    if (!frame) continue;
    ++decoded;
    Require(frame->dest == dest, "decoded frame has the expected destination");
    Require(v2::Encode(*frame) == std::vector<uint8_t>(datagram.begin(), datagram.end()),
            "decoded frame encodes to the same bytes");
    CheckSensors(*frame);
  }
  Require(decoded <= 1, "a datagram is a frame for one destination at most");
  Require(counters.frames == decoded, "frame counter counts decoded frames");
  Require(counters.frames + counters.total_rejected() == 2, "each decode counted once");
  return 0;
}
