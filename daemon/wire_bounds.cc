#include "daemon/wire_bounds.h"

#include <cstring>

#include "jaguar/motor_command_t.hpp"
#include "jaguar/motor_state_t.hpp"
#include "tsc/announce_t.hpp"
#include "tsc/memory_portion_v2_t.hpp"
#include "tsc/memory_request_t.hpp"
#include "tsc/place_event_t.hpp"
#include "tsc/stats_t.hpp"

namespace tsc {
namespace {

// Walks an LCM encoding (big-endian fixed-size fields, int32 length + bytes + NUL strings,
// arrays without a header of their own) field by field. Any failure sticks.
class WireWalker {
 public:
  WireWalker(const uint8_t* data, size_t size) : data_(data), left_(size) {}

  bool ok() const { return ok_; }

  void Skip(size_t bytes) {
    if (!ok_ || bytes > left_) {
      ok_ = false;
      return;
    }
    data_ += bytes;
    left_ -= bytes;
  }
  /// A length field (int16 or int32, big endian); -1 after a failure.
  int64_t Length(size_t bytes) {
    if (!ok_ || bytes > left_) {
      ok_ = false;
      return -1;
    }
    int64_t v = 0;
    for (size_t i = 0; i < bytes; ++i) v = (v << 8) | data_[i];
    if (bytes == 2) v = static_cast<int16_t>(v);
    if (bytes == 4) v = static_cast<int32_t>(v);
    Skip(bytes);
    return v;
  }
  /// Checks a claimed element count against the bytes left; false (and failed) if it cannot
  /// be there.
  bool Fits(int64_t count) {
    if (!ok_ || count < 0 || static_cast<uint64_t>(count) > left_) ok_ = false;
    return ok_;
  }
  void Array(int64_t count, size_t element_bytes) {
    if (Fits(count)) Skip(static_cast<size_t>(count) * element_bytes);
  }
  /// An int32 length (counting the terminating NUL) and the bytes. LCM's encoder writes
  /// strlen + 1 bytes, so a NUL before the last byte, or none at the end, is forged: decoded,
  /// such a string would not encode back to the same bytes.
  void String() {
    const int64_t length = Length(4);
    if (length < 1 || !Fits(length)) {
      ok_ = false;
      return;
    }
    const auto n = static_cast<size_t>(length);
    if (data_[n - 1] != 0 || std::memchr(data_, 0, n - 1) != nullptr) ok_ = false;
    Skip(n);
  }
  void Hmac() { Array(Length(2), 1); }  // int16 hmac_size, byte hmac[hmac_size]

 private:
  const uint8_t* data_;
  size_t left_;
  bool ok_ = true;
};

constexpr size_t kHash = 8;
constexpr size_t kPlaceRef = 4 + 4;

void LearnedPlace(WireWalker& w) {
  w.Skip(kPlaceRef + 8);  // id, member_count
  const int64_t dims = w.Length(4);
  w.Array(dims, 4);  // mean
  const int64_t samples = w.Length(4);
  const int64_t view_dims = w.Length(4);  // samples[num_samples][view_dims]
  w.Skip(2);                              // view_shift
  if (w.Fits(samples) && view_dims > 0) {
    if (samples * view_dims > INT32_MAX) w.Fits(-1);  // more values than any message can hold
    w.Array(samples * view_dims, 2);
  }
  w.Array(w.Length(4), kPlaceRef);  // sources
}

void MemoryNode(WireWalker& w) {
  w.Skip(4 + 4 + 4 + 8);  // index, parent, place, height
  w.Array(w.Length(4), 4);
}

}  // namespace

template <>
bool ArrayLengthsFit<announce_t>(const uint8_t* data, size_t size) {
  WireWalker w(data, size);
  // utime … portions, structure_portions, view_basis, places … queue_fill
  w.Skip(kHash + 8 + 2 + 4 + 8 + 8 + 8 + 8 + 4 + 4 + 8 + 4 + 4 + 4 + 8 + 8 + 8 + 4);
  w.String();  // status
  w.Hmac();
  return w.ok();
}

template <>
bool ArrayLengthsFit<memory_request_t>(const uint8_t* data, size_t size) {
  WireWalker w(data, size);
  w.Skip(kHash + 8 + 4 + 4 + 8);
  w.Array(w.Length(4), 4);  // missing
  w.Hmac();
  return w.ok();
}

template <>
bool ArrayLengthsFit<memory_portion_v2_t>(const uint8_t* data, size_t size) {
  WireWalker w(data, size);
  // utime … count, structure_portions, digest … next_local, view_basis
  w.Skip(kHash + 8 + 4 + 8 + 8 + 4 + 4 + 4 + 8 + 4 + 4 + 4 + 4 + 4 + 8);
  w.Array(w.Length(4), kPlaceRef + 8 + 4 + 8);  // entries: id, digest, slink_pi, slink_lambda
  const int64_t places = w.Length(4);
  if (w.Fits(places))
    for (int64_t i = 0; i < places && w.ok(); ++i) LearnedPlace(w);
  const int64_t nodes = w.Length(4);
  if (w.Fits(nodes))
    for (int64_t i = 0; i < nodes && w.ok(); ++i) MemoryNode(w);
  w.Array(w.Length(4), 2 * kPlaceRef + 8);  // edges
  w.Hmac();
  return w.ok();
}

template <>
bool ArrayLengthsFit<place_event_t>(const uint8_t* data, size_t size) {
  WireWalker w(data, size);
  w.Skip(kHash + 8 + 4 + 8);
  w.String();  // event
  return w.ok();
}

template <>
bool ArrayLengthsFit<stats_t>(const uint8_t* data, size_t size) {
  WireWalker w(data, size);
  // utime … publish_failures (16 fields), then the six queue sizes.
  w.Skip(kHash + 8 + 4 + 8 + 8 + 8 + 8 + 4 + 4 + 8 * 8 + 4 * 6);
  const int64_t channels = w.Length(2);
  if (w.Fits(channels))
    for (int64_t i = 0; i < channels && w.ok(); ++i) w.String();
  for (int column = 0; column < 4; ++column) w.Array(channels, 8);  // sent … received_bytes
  return w.ok();
}

template <>
bool ArrayLengthsFit<jaguar::motor_command_t>(const uint8_t*, size_t) {
  return true;  // no arrays, no strings
}

template <>
bool ArrayLengthsFit<jaguar::motor_state_t>(const uint8_t* data, size_t size) {
  WireWalker w(data, size);
  w.Skip(kHash + 8 + 8 * 5 + 8 + 8 + 8);
  w.Array(w.Length(2), 8);  // temperatures_c
  w.Skip(1 + 1);
  w.String();  // fault
  return w.ok();
}

}  // namespace tsc
