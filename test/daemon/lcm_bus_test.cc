#include "daemon/lcm_bus.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>
#include <stdexcept>

#include "jaguar/motor_state_t.hpp"
#include "tsc/announce_t.hpp"
#include "tsc/memory_portion_v2_t.hpp"
#include "tsc/memory_request_t.hpp"

// The largest single allocation this test binary made since the last reset: how the tests
// below see that a forged length is refused before the decoder sizes a vector from it.
namespace {
std::atomic<size_t> largest_allocation{0};
}  // namespace

// Not inlined, so GCC does not pair the malloc and free inside with new and delete
// (-Wmismatched-new-delete).
[[gnu::noinline]] void* operator new(size_t size) {
  size_t seen = largest_allocation.load();
  while (size > seen && !largest_allocation.compare_exchange_weak(seen, size)) {
  }
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
[[gnu::noinline]] void operator delete(void* p) noexcept { std::free(p); }
[[gnu::noinline]] void operator delete(void* p, size_t) noexcept { std::free(p); }

namespace tsc {
namespace {

int32_t GetInt32(const std::vector<uint8_t>& bytes, size_t at) {
  uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v = (v << 8) | bytes.at(at + i);
  return static_cast<int32_t>(v);
}

void PutInt32(std::vector<uint8_t>& bytes, size_t at, int32_t value) {
  for (int i = 0; i < 4; ++i)
    bytes.at(at + i) = static_cast<uint8_t>(static_cast<uint32_t>(value) >> (24 - 8 * i));
}

// A portion holding one place entry, one place of `dims` dimensions and one sample, one node
// with one child.
memory_portion_v2_t SamplePortion(int32_t dims) {
  memory_portion_v2_t p{};
  p.robot = 2;
  p.count = 1;
  p.entries = {place_entry_t{}};
  p.num_entries = 1;
  learned_place_v2_t place{};
  place.id.robot = 2;
  place.dims = dims;
  place.mean.assign(static_cast<size_t>(dims), 0.5f);
  place.num_samples = 1;
  place.view_dims = dims;
  place.samples.assign(1, std::vector<int16_t>(static_cast<size_t>(dims), 16384));
  place.num_sources = 0;
  p.places = {place};
  p.num_places = 1;
  memory_node_t node{};
  node.num_children = 1;
  node.children = {0};
  p.nodes = {node};
  p.num_nodes = 1;
  p.num_edges = 0;
  p.hmac_size = 0;
  return p;
}

// Offsets in the encoding of SamplePortion: after the 8-byte hash come 68 bytes of fixed
// fields, then num_entries and an entry of 28 bytes, then num_places; a place has 16 bytes
// before dims.
constexpr size_t kNumEntries = 8 + 76;
constexpr size_t kNumPlaces = kNumEntries + 4 + 28;
constexpr size_t kDims = kNumPlaces + 4 + 16;

// Decodes forged bytes and checks they are refused without a large allocation.
template <typename T>
void ExpectRefusedCheaply(const std::vector<uint8_t>& forged, const char* what) {
  largest_allocation = 0;
  EXPECT_FALSE(LcmBus::Decode<T>(forged.data(), forged.size()).has_value()) << what;
  EXPECT_LT(largest_allocation.load(), size_t{1} << 16) << what;
}

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

TEST(LcmBus, DecodeRoundTripsEveryArrayShape) {
  for (int32_t dims : {0, 1, 7}) {
    memory_portion_v2_t p = SamplePortion(dims);
    p.places[0].num_sources = 2;
    p.places[0].sources.resize(2);
    const std::vector<uint8_t> bytes = LcmBus::Encode(p);
    const auto back = LcmBus::Decode<memory_portion_v2_t>(bytes.data(), bytes.size());
    ASSERT_TRUE(back.has_value()) << dims;
    EXPECT_EQ(back->places.at(0).samples.at(0).size(), static_cast<size_t>(dims));
    EXPECT_EQ(back->nodes.at(0).children, std::vector<int32_t>{0});
  }
  jaguar::motor_state_t s{};
  s.num_temperatures = 3;
  s.temperatures_c = {20.0, 21.0, 22.0};
  s.fault = "link lost";
  const std::vector<uint8_t> bytes = LcmBus::Encode(s);
  const auto back = LcmBus::Decode<jaguar::motor_state_t>(bytes.data(), bytes.size());
  ASSERT_TRUE(back.has_value());
  EXPECT_EQ(back->fault, "link lost");
}

// Regression (fuzz/lcm_decode): lcm-gen's decoders resize a vector to the claimed length
// before checking the bytes exist, so a ~100-byte datagram claiming 2^31 elements allocated
// gigabytes (ASan: allocation-size-too-big).
TEST(LcmBus, ForgedHugeArrayLengthIsRefusedBeforeAllocating) {
  const std::vector<uint8_t> good = LcmBus::Encode(SamplePortion(3));
  ASSERT_TRUE(LcmBus::Decode<memory_portion_v2_t>(good.data(), good.size()).has_value());
  // Field offsets in `good`: mean holds 3 floats, then view_shift (int16) and samples one
  // row of 3 int16.
  const size_t num_samples = kDims + 4 + 12;
  const size_t view_dims = num_samples + 4;
  const size_t num_sources = view_dims + 4 + 2 + 6;
  const size_t num_nodes = num_sources + 4;
  const size_t num_children = num_nodes + 4 + 20;
  const size_t num_edges = num_children + 4 + 4;
  struct Field {
    size_t at;
    int32_t value;  // in `good`, to check the offset
    const char* what;
  };
  for (const auto& [at, value, what] : std::vector<Field>{{kNumEntries, 1, "num_entries"},
                                                          {kNumPlaces, 1, "num_places"},
                                                          {kDims, 3, "dims"},
                                                          {num_samples, 1, "num_samples"},
                                                          {view_dims, 3, "view_dims"},
                                                          {num_sources, 0, "num_sources"},
                                                          {num_nodes, 1, "num_nodes"},
                                                          {num_children, 1, "num_children"},
                                                          {num_edges, 0, "num_edges"}}) {
    ASSERT_EQ(GetInt32(good, at), value) << "offset of " << what;
    std::vector<uint8_t> forged = good;
    PutInt32(forged, at, INT32_MAX);
    ExpectRefusedCheaply<memory_portion_v2_t>(forged, what);
  }
  // Rows of zero values take no bytes: 2^31 empty sample rows would still be 48 GB of vectors.
  std::vector<uint8_t> empty_rows = LcmBus::Encode(SamplePortion(0));
  ASSERT_EQ(GetInt32(empty_rows, kDims + 4), 1) << "offset of num_samples";
  PutInt32(empty_rows, kDims + 4, INT32_MAX);
  ExpectRefusedCheaply<memory_portion_v2_t>(empty_rows, "num_samples of empty rows");

  memory_request_t r{};
  r.num_missing = 1;
  r.missing = {4};
  r.hmac_size = 0;
  std::vector<uint8_t> request = LcmBus::Encode(r);
  ASSERT_EQ(GetInt32(request, 8 + 8 + 4 + 4 + 8), 1) << "offset of num_missing";
  PutInt32(request, 8 + 8 + 4 + 4 + 8, INT32_MAX);
  ExpectRefusedCheaply<memory_request_t>(request, "num_missing");

  std::vector<uint8_t> announce = LcmBus::Encode(SampleAnnounce());
  // The status string's length follows 102 bytes of fixed fields.
  ASSERT_EQ(GetInt32(announce, 8 + 102), 8) << "offset of the length of \"running\"";
  PutInt32(announce, 8 + 102, INT32_MAX);
  ExpectRefusedCheaply<announce_t>(announce, "status length");
  PutInt32(announce, 8 + 102, 0);  // an LCM string always counts its NUL
  ExpectRefusedCheaply<announce_t>(announce, "status length 0");
}

// Regression (fuzz_lcm_place_event_t, fuzz_lcm_announce_t): a string whose bytes hold a NUL
// before the end decoded to a std::string that encodes to other bytes (LCM writes strlen + 1)
// and with trailing garbage (getEncodedSize counts size() + 1).
TEST(LcmBus, StringWithANulInsideIsRefusedAndEncodeStaysConsistent) {
  std::vector<uint8_t> bytes = LcmBus::Encode(SampleAnnounce());
  ASSERT_EQ(GetInt32(bytes, 8 + 102), 8);  // "running" and its NUL
  bytes.at(8 + 106 + 3) = 0;               // "run\0ing"
  EXPECT_FALSE(LcmBus::Decode<announce_t>(bytes.data(), bytes.size()).has_value());
  bytes.at(8 + 106 + 3) = 'n';
  bytes.at(8 + 106 + 7) = 'x';  // no terminating NUL
  EXPECT_FALSE(LcmBus::Decode<announce_t>(bytes.data(), bytes.size()).has_value());

  announce_t a = SampleAnnounce();
  a.status = std::string("run\0ing", 7);
  const std::vector<uint8_t> encoded = LcmBus::Encode(a);
  const auto back = LcmBus::Decode<announce_t>(encoded.data(), encoded.size());
  ASSERT_TRUE(back.has_value()) << "Encode must give bytes Decode takes";
  EXPECT_EQ(back->status, "run");
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
