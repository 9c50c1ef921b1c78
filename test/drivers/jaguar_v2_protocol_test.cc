// The V2/V4 binary protocol against the facts file's worked frames and its own round trips.

#include "drivers/motor/jaguar_v2_protocol.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace tsc::jaguar_v2 {
namespace {

std::vector<uint8_t> Bytes(std::initializer_list<int> v) {
  return std::vector<uint8_t>(v.begin(), v.end());
}

TEST(Crc8Maxim, CheckValueOfTheCatalogue) {
  const std::string s = "123456789";
  EXPECT_EQ(Crc8Maxim(std::span(reinterpret_cast<const uint8_t*>(s.data()), s.size())), 0xA1);
  EXPECT_EQ(Crc8Maxim({}), 0x00);
}

TEST(JaguarV2Frame, AckIsTheWorkedFrame) {
  EXPECT_EQ(EncodeAck(), Bytes({0x5E, 0x02, 0x01, 0x00, 0xFF, 0x01, 0x01, 0x85, 0x5E, 0x0D}));
}

TEST(JaguarV2Frame, AllStopIsTheWorkedFrame) {
  EXPECT_EQ(EncodePwmAll(AllStop()),
            Bytes({0x5E, 0x02, 0x01, 0x00, 0x06, 0x0C, 0x00, 0x40, 0x00, 0x40, 0x00,
                   0x80, 0x00, 0x40, 0x00, 0x40, 0x00, 0x80, 0x29, 0x5E, 0x0D}));
}

TEST(JaguarV2Frame, DecodesWhatItEncodes) {
  for (size_t len : {0u, 1u, 12u, 255u}) {
    Frame f{kDestPc, 7, 0x7C, std::vector<uint8_t>(len)};
    for (size_t i = 0; i < len; ++i) f.data[i] = static_cast<uint8_t>(i * 37 + 5);
    const auto bytes = Encode(f);
    ASSERT_EQ(bytes.size(), len + kFrameOverhead);
    DecodeCounters counters;
    const auto back = Decode(bytes, counters);
    ASSERT_TRUE(back.has_value()) << len;
    EXPECT_EQ(back->seq, 7);
    EXPECT_EQ(back->type, 0x7C);
    EXPECT_EQ(back->data, f.data);
    EXPECT_EQ(counters.frames, 1);
  }
  EXPECT_THROW(Encode(Frame{kDestPc, 0, 1, std::vector<uint8_t>(256)}), std::invalid_argument);
}

TEST(JaguarV2Frame, CorruptedFramesAreRejectedAndCounted) {
  const auto good = Encode({kDestPc, 0, static_cast<uint8_t>(FrameType::kStandardSensor),
                            SerializeStandardSensor({1000, 2000})});
  DecodeCounters counters;
  auto expect_reject = [&](std::vector<uint8_t> bytes, Reject why) {
    Reject got{};
    EXPECT_FALSE(Decode(bytes, &got).has_value());
    EXPECT_EQ(got, why) << RejectName(why) << " expected, got " << RejectName(got);
    EXPECT_FALSE(Decode(bytes, counters).has_value());
  };
  auto bad_crc = good;
  bad_crc[good.size() - 3] ^= 0x01;
  expect_reject(bad_crc, Reject::kBadCrc);
  auto bad_data = good;  // a flipped data bit is caught by the CRC too
  bad_data[10] ^= 0x80;
  expect_reject(bad_data, Reject::kBadCrc);
  std::vector<uint8_t> longer(good.begin(), good.end() - 3);  // LEN says fewer bytes than came
  longer.push_back(0x00);
  longer.insert(longer.end(), good.end() - 3, good.end());
  expect_reject(longer, Reject::kBadLength);
  auto bad_end = good;
  bad_end[bad_end.size() - 1] = 0x0A;
  expect_reject(bad_end, Reject::kBadEnd);
  expect_reject(std::vector<uint8_t>(good.begin(), good.end() - 1), Reject::kTruncated);
  expect_reject(std::vector<uint8_t>(good.begin(), good.begin() + 5), Reject::kTruncated);
  auto bad_start = good;
  bad_start[1] = 0x03;
  expect_reject(bad_start, Reject::kBadStart);
  expect_reject(EncodeAck(kDestBoard), Reject::kBadDest);  // the PC's own frame, echoed
  EXPECT_EQ(counters.frames, 0);
  EXPECT_EQ(counters.total_rejected(), 8);
  EXPECT_EQ(counters.rejected[static_cast<size_t>(Reject::kBadCrc)], 2);
  EXPECT_EQ(counters.rejected[static_cast<size_t>(Reject::kTruncated)], 2);
  EXPECT_TRUE(Decode(good, counters).has_value());
  EXPECT_EQ(counters.frames, 1);
}

// Builds the data of each sensor frame byte by byte at the facts file's offsets, so the parser
// is checked against the layout, not against its own serializer.
TEST(JaguarV2Sensors, MotorSensorFieldsAtTheirOffsets) {
  std::vector<uint8_t> d(33, 0);
  for (int i = 0; i < 6; ++i) d[2 * i] = static_cast<uint8_t>(i + 1), d[2 * i + 1] = 0x40;
  d[24] = 0x34, d[25] = 0x12;  // ch0 encoder 0x1234
  d[26] = 0x05;
  d[28] = 0xFF, d[29] = 0xFF;  // ch1 encoder 65535
  d[30] = 0x09;
  d[32] = 0b101;
  const auto s = ParseMotorSensor(d);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->output_pwm[0], 0x4001);
  EXPECT_EQ(s->output_pwm[5], 0x4006);
  EXPECT_EQ(s->ch0_encoder, 0x1234);
  EXPECT_EQ(s->ch0_velocity, 5);
  EXPECT_EQ(s->ch1_encoder, 65535);
  EXPECT_EQ(s->ch1_velocity, 9);
  EXPECT_EQ(s->direction_bits, 0b101);
  EXPECT_EQ(SerializeMotorSensor(*s), d);
  EXPECT_FALSE(ParseMotorSensor(std::span(d).first(32)));
}

TEST(JaguarV2Sensors, CustomSensorBatteryTemperaturesAndTrackEncoders) {
  std::vector<uint8_t> d(29, 0);
  d[2] = 0xFF, d[3] = 0x0F;  // AD1 = 4095: full scale, 34.498 V
  for (int i = 2; i < 8; ++i) d[2 * i] = 0x00, d[2 * i + 1] = 0x08;  // AD2..7 = 2048: ~25 °C
  d[16] = 0x80;
  d[17] = 0x10, d[18] = 0x27;  // ch3 encoder 10000
  d[19] = 0x64;                // ch3 velocity 100
  d[21] = 0x01;
  d[23] = 0xF0, d[24] = 0xD8;  // ch4 encoder 55536
  d[25] = 0x32;
  d[27] = 0x00;
  const auto s = ParseCustomSensor(d);
  ASSERT_TRUE(s);
  EXPECT_NEAR(s->battery_volts(), 34.498, 1e-9);
  for (double t : s->temperatures_c()) EXPECT_NEAR(t, 25.0, 0.1);
  EXPECT_EQ(s->io, 0x80);
  EXPECT_EQ(s->ch3_encoder, 10000);
  EXPECT_EQ(s->ch3_velocity, 100);
  EXPECT_EQ(s->ch3_direction, 1);
  EXPECT_EQ(s->ch4_encoder, 55536);
  EXPECT_EQ(s->ch4_velocity, 50);
  EXPECT_EQ(SerializeCustomSensor(*s), d);
  EXPECT_FALSE(ParseCustomSensor(std::span(d).first(28)));
}

TEST(JaguarV2Sensors, StandardSensorPowerRails) {
  std::vector<uint8_t> d(34, 0);
  d[30] = 0xFF, d[31] = 0x0F;  // board power full scale: 9 V
  d[32] = 0x00, d[33] = 0x08;  // motor power 2048
  const auto s = ParseStandardSensor(d);
  ASSERT_TRUE(s);
  EXPECT_NEAR(s->board_volts(), 9.0, 1e-9);
  EXPECT_NEAR(s->motor_volts(), 2048 * 34.498 / 4095, 1e-9);
  EXPECT_FALSE(ParseStandardSensor(std::span(d).first(33)));
}

TEST(EncoderUnwrap, CountsAcrossTheWrapBothWays) {
  EncoderUnwrap dut;
  EXPECT_EQ(dut.Update(65500), 0);  // origin
  EXPECT_EQ(dut.Update(65535), 35);
  EXPECT_EQ(dut.Update(20), 56);     // wrapped forward
  EXPECT_EQ(dut.Update(65526), 26);  // and back
  int64_t expected = 26;
  uint16_t raw = 65526;
  for (int i = 0; i < 1000; ++i) {  // 3 wraps forward in steps of 200
    raw = static_cast<uint16_t>(raw + 200);
    expected += 200;
    EXPECT_EQ(dut.Update(raw), expected);
  }
  dut.Reset();
  EXPECT_EQ(dut.Update(5), 0);
}

}  // namespace
}  // namespace tsc::jaguar_v2
