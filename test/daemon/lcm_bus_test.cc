#include "daemon/lcm_bus.h"

#include <gtest/gtest.h>

#include <stdexcept>

#include "tsc/announce_t.hpp"
#include "tsc/memory_request_t.hpp"

namespace tsc {
namespace {

announce_t SampleAnnounce() {
  announce_t a{};
  a.utime = 42;
  a.protocol = announce_t::PROTOCOL;
  a.robot = 3;
  a.memory_version = 7;
  a.status = "running";
  a.hmac_size = 0;
  return a;
}

// LCM's in-process provider: real LCM encode/dispatch without sockets (STYLE 2).
TEST(LcmBus, DeliversPublishedMessagesOnMemq) {
  LcmBus dut("memq://");
  std::vector<announce_t> got;
  dut.Subscribe("TSC_ANNOUNCE", [&](const std::string& channel, const uint8_t* d, size_t n) {
    EXPECT_EQ(channel, "TSC_ANNOUNCE");
    auto a = LcmBus::Decode<announce_t>(d, n);
    ASSERT_TRUE(a.has_value());
    got.push_back(*a);
  });
  ASSERT_TRUE(dut.Publish("TSC_ANNOUNCE", SampleAnnounce()));
  ASSERT_TRUE(dut.HandleReady());
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].robot, 3);
  EXPECT_EQ(got[0].memory_version, 7);
  EXPECT_EQ(got[0].status, "running");
}

TEST(LcmBus, DecodeRejectsTruncatedForeignAndPaddedBytes) {
  const std::vector<uint8_t> bytes = LcmBus::Encode(SampleAnnounce());
  ASSERT_TRUE(LcmBus::Decode<announce_t>(bytes.data(), bytes.size()).has_value());
  for (size_t cut : {size_t{0}, size_t{4}, size_t{8}, bytes.size() - 1}) {
    EXPECT_FALSE(LcmBus::Decode<announce_t>(bytes.data(), cut).has_value()) << cut;
  }
  std::vector<uint8_t> padded = bytes;
  padded.push_back(0);
  EXPECT_FALSE(LcmBus::Decode<announce_t>(padded.data(), padded.size()).has_value());
  // Another type's bytes fail on the fingerprint.
  memory_request_t r{};
  r.num_missing = 0;
  r.hmac_size = 0;
  const std::vector<uint8_t> other = LcmBus::Encode(r);
  EXPECT_FALSE(LcmBus::Decode<announce_t>(other.data(), other.size()).has_value());
  // A negative array length is refused, not allocated.
  memory_request_t bad{};
  bad.num_missing = 0;
  bad.hmac_size = 0;
  std::vector<uint8_t> forged = LcmBus::Encode(bad);
  // num_missing sits after the 8-byte hash, utime (8), requester (4), robot (4), version (8).
  forged[8 + 8 + 4 + 4 + 8] = 0xff;
  EXPECT_FALSE(LcmBus::Decode<memory_request_t>(forged.data(), forged.size()).has_value());
}

TEST(LcmBus, HandlerExceptionIsCountedAndTheChannelKeepsWorking) {
  LcmBus dut("memq://");
  int calls = 0;
  dut.Subscribe("X", [&](const std::string&, const uint8_t*, size_t) {
    ++calls;
    throw std::runtime_error("bug in a handler");
  });
  ASSERT_TRUE(dut.PublishRaw("X", {1, 2, 3}));
  ASSERT_TRUE(dut.PublishRaw("X", {4}));
  ASSERT_TRUE(dut.HandleReady());
  EXPECT_EQ(calls, 2);
  EXPECT_EQ(dut.handler_failures(), 2);
}

TEST(LcmBus, BadUrlThrowsNamingIt) {
  try {
    LcmBus dut("nonsense://x");
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("nonsense://x"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace tsc
