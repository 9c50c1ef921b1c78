#pragma once
// The store's blobs (internal to tscd::store): little-endian raw arrays of arithmetic values
// with explicit length checks, so a database moves between machines and a cut or forged cell
// is refused with its size rather than read past.

#include <algorithm>
#include <bit>
#include <cstring>
#include <span>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace tsc::store_internal {

template <typename T>
concept Arithmetic = std::is_arithmetic_v<T> && !std::is_same_v<T, bool>;

using Bytes = std::vector<unsigned char>;

/// Copies `count` values between native and little-endian byte order (the conversion is its
/// own inverse, so one function serves both directions).
template <Arithmetic T>
void CopyLittleEndian(const unsigned char* src, unsigned char* dst, size_t count) {
  static_assert(std::endian::native == std::endian::little ||
                std::endian::native == std::endian::big);
  if constexpr (std::endian::native == std::endian::little) {
    if (count > 0) std::memcpy(dst, src, count * sizeof(T));
  } else {
    for (size_t i = 0; i < count; ++i) {
      std::reverse_copy(src + i * sizeof(T), src + (i + 1) * sizeof(T), dst + i * sizeof(T));
    }
  }
}

class BlobWriter {
 public:
  template <Arithmetic T>
  BlobWriter& Put(std::span<const T> values) {
    const size_t at = bytes_.size();
    bytes_.resize(at + values.size_bytes());
    CopyLittleEndian<T>(reinterpret_cast<const unsigned char*>(values.data()), bytes_.data() + at,
                        values.size());
    return *this;
  }
  template <Arithmetic T>
  BlobWriter& PutOne(T value) {
    return Put(std::span<const T>(&value, 1));
  }
  Bytes Finish() { return std::move(bytes_); }

 private:
  Bytes bytes_;
};

/// A blob that does not decode; the caller adds table, row and column.
class BlobError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class BlobReader {
 public:
  explicit BlobReader(std::span<const unsigned char> bytes) : bytes_(bytes) {}

  size_t remaining() const { return bytes_.size() - pos_; }

  template <Arithmetic T>
  void TakeInto(T* out, size_t count) {
    if (count > remaining() / sizeof(T)) {
      throw BlobError("blob of " + std::to_string(bytes_.size()) +
                      " bytes is too short: " + std::to_string(count) + " values of " +
                      std::to_string(sizeof(T)) + " bytes wanted at byte " + std::to_string(pos_));
    }
    CopyLittleEndian<T>(bytes_.data() + pos_, reinterpret_cast<unsigned char*>(out), count);
    pos_ += count * sizeof(T);
  }
  template <Arithmetic T>
  std::vector<T> Take(size_t count) {
    if (count > remaining() / sizeof(T)) {
      TakeInto<T>(nullptr, count);  // throws with the standard message
    }
    std::vector<T> out(count);
    TakeInto(out.data(), count);
    return out;
  }
  template <Arithmetic T>
  T TakeOne() {
    T value{};
    TakeInto(&value, 1);
    return value;
  }
  /// Everything left, which must be a whole number of values.
  template <Arithmetic T>
  std::vector<T> TakeRest() {
    if (remaining() % sizeof(T) != 0) {
      throw BlobError("blob of " + std::to_string(bytes_.size()) +
                      " bytes is not a whole number of " + std::to_string(sizeof(T)) +
                      "-byte values");
    }
    return Take<T>(remaining() / sizeof(T));
  }
  void ExpectEnd() const {
    if (remaining() != 0) {
      throw BlobError("blob of " + std::to_string(bytes_.size()) + " bytes has " +
                      std::to_string(remaining()) + " trailing bytes");
    }
  }

 private:
  std::span<const unsigned char> bytes_;
  size_t pos_ = 0;
};

template <Arithmetic T>
Bytes EncodeArray(std::span<const T> values) {
  return BlobWriter().Put(values).Finish();
}

}  // namespace tsc::store_internal
