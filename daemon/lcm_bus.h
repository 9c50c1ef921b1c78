#pragma once
// The one adapter between tscd and LCM (STYLE 2): owns the lcm_t, exposes its file descriptor
// for the event loop, publishes generated types and hands raw payloads to subscribers, which
// decode them with Decode<T>() so a malformed message is a counted value, never an exception
// inside LCM's C callback.

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "daemon/wire_bounds.h"

namespace tsc {

class LcmBus {
 public:
  /// Raw payload of one received message.
  using Handler = std::function<void(const std::string& channel, const uint8_t* data, size_t size)>;

  /// Opens the provider `url` (udpm://..., memq://). Throws std::runtime_error naming the URL
  /// when LCM cannot start (no multicast route, bad URL).
  explicit LcmBus(const std::string& url);
  ~LcmBus();
  LcmBus(const LcmBus&) = delete;
  LcmBus& operator=(const LcmBus&) = delete;

  /// Readable when messages wait; the event loop calls HandleReady() then.
  int fd() const;
  /// Dispatches the messages waiting now without blocking. Returns false on an LCM error.
  bool HandleReady();
  /// Blocks up to `timeout_ms` for one message (tests and tools without an event loop).
  bool HandleTimeout(int timeout_ms);

  /// Subscribes to a channel (a POSIX regular expression, as LCM takes it). Exceptions the
  /// handler throws are caught, logged by the caller's `on_error`, and counted.
  void Subscribe(const std::string& channel_regex, Handler handler);

  /// Publishes encoded bytes. Returns false when LCM refused them (too large, socket error).
  bool PublishRaw(const std::string& channel, const std::vector<uint8_t>& bytes);

  template <typename T>
  bool Publish(const std::string& channel, const T& msg) {
    return PublishRaw(channel, Encode(msg));
  }

  /// Exceptions thrown by handlers, so a bug in a handler cannot silently stop a channel.
  int64_t handler_failures() const { return handler_failures_; }

  const std::string& url() const { return url_; }

 private:
  struct Subscription;
  static void Dispatch(const void* rbuf, const char* channel, void* user);

  std::string url_;
  void* lcm_ = nullptr;  // lcm_t*, kept opaque so the header needs no LCM include
  std::vector<std::unique_ptr<Subscription>> subscriptions_;
  int64_t handler_failures_ = 0;

 public:
  /// The encoding of a generated type (empty if the type cannot encode it).
  template <typename T>
  static std::vector<uint8_t> Encode(const T& msg) {
    std::vector<uint8_t> out(static_cast<size_t>(msg.getEncodedSize()));
    // encode() writes strlen + 1 bytes per string while getEncodedSize() counts size() + 1:
    // a string holding a NUL would leave trailing bytes that receivers refuse.
    const int n = msg.encode(out.data(), 0, static_cast<int>(out.size()));
    out.resize(n < 0 ? 0 : static_cast<size_t>(n));
    return out;
  }
  /// Decodes a generated type; nullopt when the bytes are not exactly one valid T (wrong
  /// fingerprint, truncated, trailing bytes, an array or string length that is negative or
  /// larger than the bytes left, a string with a NUL inside or none at its end).
  // lcm-gen's decoders size a vector from its length field before checking the bytes are
  // there: ArrayLengthsFit refuses forged lengths first, so a datagram cannot make us allocate
  // more than a small multiple of its size; what it misses is still caught below.
  template <typename T>
  static std::optional<T> Decode(const uint8_t* data, size_t size) {
    if (size > static_cast<size_t>(INT32_MAX)) return std::nullopt;
    if (!ArrayLengthsFit<T>(data, size)) return std::nullopt;
    try {
      T msg;
      const int n = msg.decode(data, 0, static_cast<int>(size));
      if (n < 0 || static_cast<size_t>(n) != size) return std::nullopt;
      return msg;
    } catch (const std::exception&) {
      return std::nullopt;
    }
  }
};

}  // namespace tsc
