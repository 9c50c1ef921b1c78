#pragma once
// The team's shared secret and the HMAC-SHA256 every exchange message carries (DESIGN §4):
// a message is signed over its LCM encoding with an empty hmac field; a receiver recomputes
// the tag and compares it in constant time. The key file must be readable by its owner only.

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace tsc {

class TeamKeyError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

using HmacTag = std::array<uint8_t, 32>;

class TeamKey {
 public:
  /// Reads the key file: refused (TeamKeyError naming the file and why) when it cannot be
  /// read, is empty, or is readable or writable by group or others (mode must be 0600 or
  /// 0400). Surrounding whitespace is not part of the key.
  static TeamKey Load(const std::filesystem::path& file);
  /// A key from bytes (tests). Precondition: not empty.
  explicit TeamKey(std::string secret);

  /// HMAC-SHA256 of `bytes`.
  HmacTag Sign(const std::vector<uint8_t>& bytes) const;
  /// Constant-time comparison of `tag` with the HMAC of `bytes`.
  bool Verify(const std::vector<uint8_t>& bytes, const uint8_t* tag, size_t tag_size) const;

 private:
  std::string secret_;
};

/// Signs an exchange message in place: hmac over its encoding with hmac_size = 0.
template <typename Message, typename Encoder>
void SignMessage(const TeamKey& key, Message& msg, Encoder encode) {
  msg.hmac_size = 0;
  msg.hmac.clear();
  const HmacTag tag = key.Sign(encode(msg));
  msg.hmac.assign(tag.begin(), tag.end());
  msg.hmac_size = static_cast<int16_t>(tag.size());
}

/// Checks an exchange message's tag; the message is unchanged afterwards.
template <typename Message, typename Encoder>
bool VerifyMessage(const TeamKey& key, const Message& msg, Encoder encode) {
  if (msg.hmac_size != 32 || msg.hmac.size() != 32) return false;
  Message unsigned_copy = msg;
  unsigned_copy.hmac_size = 0;
  unsigned_copy.hmac.clear();
  return key.Verify(encode(unsigned_copy), msg.hmac.data(), msg.hmac.size());
}

}  // namespace tsc
